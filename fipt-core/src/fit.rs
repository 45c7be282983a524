//! The material-fitter contract: a method that turns the observations of a scene into a
//! [`MaterialField`] (and, when it estimates them, the emitters), in place of FIPT's
//! bake → train → refine rounds. `fipt run` chooses one by name (`[pipeline] method`); the maps,
//! emitters, re-renders, report and evaluation after it are the same for every method.
use crate::dataset::View;
use crate::emitter::Emitter;
use crate::error::Result;
use crate::field::MaterialField;
use crate::image::Image;
use crate::reflectance::ReflectanceModel;
use crate::shading::{Progress, RayQuery, ViewShadings};
use glam::Vec3;
use std::path::Path;

/// What a fitter works from.
pub struct FitInputs<'a> {
    pub geometry: &'a dyn RayQuery,
    /// Mesh vertex positions and triangles (the triangle indices of emitters index `triangles`).
    pub positions: &'a [Vec3],
    pub triangles: &'a [[u32; 3]],
    /// The training views and their HDR images, in the same order.
    pub views: &'a [View],
    pub images: &'a [Image],
    /// The initial bake's shadings of `views`, when [`MaterialFitter::needs_shadings`].
    pub shadings: Option<&'a [ViewShadings]>,
    /// Per training view and pixel, the scene's part id (`IndexMA/`, else the semantic class of
    /// `segmentation/`; negative: none), when the scene has them and
    /// [`MaterialFitter::wants_segments`]; an empty vector for a view without a map.
    pub segments: Option<&'a [Vec<i64>]>,
    /// The run's reflectance model (`[model] brdf`).
    pub model: ReflectanceModel,
    /// A folder of the fitter's own (checkpoints, resume); it exists.
    pub dir: &'a Path,
}

/// What a fitter returns.
pub struct Fitted {
    pub field: Box<dyn MaterialField>,
    /// The emitters, when the method estimates them; None: the run's emitter extractor finds
    /// them from the field's emission mask.
    pub emitters: Option<Vec<Emitter>>,
    /// Anything the method reports (steps, losses, timings), written to `report.json`.
    pub report: serde_json::Value,
}

/// A method that fits a material field to the training views.
pub trait MaterialFitter {
    /// A short name for reports.
    fn name(&self) -> &str;
    /// Whether the run should bake the initial shadings for it ([`FitInputs::shadings`]).
    fn needs_shadings(&self) -> bool;
    /// Whether the run should load the scene's part or class ids ([`FitInputs::segments`]).
    fn wants_segments(&self) -> bool {
        false
    }
    /// Fits the field; `progress(done, total)` as the work goes.
    fn fit(&self, inputs: &FitInputs, progress: Progress) -> Result<Fitted>;
}
