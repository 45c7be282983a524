//! The material-fitter contract: a method that turns the observations of a scene into a
//! [`MaterialField`] (and, when it estimates them, the emitters). `fipt run` chooses one by name
//! (`[pipeline] method`), FIPT's own bake → train → refine rounds included; the maps, emitters,
//! re-renders, report and evaluation after it are the same for every method.
use crate::dataset::{Dataset, View};
use crate::emitter::{Emitter, EmitterExtractor};
use crate::error::Result;
use crate::field::MaterialField;
use crate::image::Image;
use crate::reflectance::ReflectanceModel;
use crate::shading::{Progress, RayQuery, ShadingBaker, ShadingRefiner, Shard, ViewShadings};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The run's other components, for a method that composes them (FIPT's rounds bake, refine and
/// find the emitters through these); a method that needs none of them ignores them.
#[derive(Clone, Copy)]
pub struct FitParts<'a> {
    /// `[pipeline] baker`, built from its settings (also handed over, for the bake's cache).
    pub baker: &'a dyn ShadingBaker,
    pub bake_settings: &'a serde_json::Value,
    /// `[pipeline] refiner` and its settings.
    pub refiner: &'a dyn ShadingRefiner,
    pub refine_settings: &'a serde_json::Value,
    /// `[pipeline] extractor`.
    pub extractor: &'a dyn EmitterExtractor,
    /// `[pipeline] trainer`: builds the trainer from settings; `train_settings` are the
    /// configured ones (a method may change them for a round and build another trainer).
    pub trainer: MakeTrainer<'a>,
    pub train_settings: &'a serde_json::Value,
}

/// Builds the run's field trainer from its settings.
pub type MakeTrainer<'a> =
    &'a (dyn Fn(&serde_json::Value) -> Result<Box<dyn crate::trainer::FieldTrainer>> + Sync);

/// Reports a stage of the method's own as done: its name and when it began (its time and peak
/// memory then go in `report.json`'s `stages`).
pub type StageDone<'a> = &'a (dyn Fn(&'static str, Instant) + Sync);

/// The run around a fit: its folder and what the user asked of it.
pub struct FitRun<'a> {
    /// The run's output folder (the method's own folder, [`FitInputs::dir`], is inside it).
    pub out: &'a Path,
    /// `--force`: recompute what an earlier run of the folder left, rather than reuse it.
    pub force: bool,
    /// The views this process computes of a sharded stage ([`Shard::ALL`]: every view).
    pub shard: Shard,
    /// Where the method reports its stages; None: the fit is one stage, `fit`.
    pub stage_done: Option<StageDone<'a>>,
    /// A stage the user asked the method to stop before (`fipt run --stop-before refine`:
    /// FIPT's refinement, for a job array to compute it); None: run to the end.
    pub stop_before: Option<&'a str>,
}

impl<'a> FitRun<'a> {
    /// A plain run in `out`: reuse allowed, every view, one stage, no scene, no stop.
    pub fn new(out: &'a Path) -> Self {
        FitRun {
            out,
            force: false,
            shard: Shard::ALL,
            stage_done: None,
            stop_before: None,
        }
    }
}

/// What the host knows of the scene beyond the training views, for a method that reads more
/// than its inputs' views and images (FIPT's rounds: the ground truth for its closure figures,
/// the part maps for its regions, the key its stages' caches share with the run).
#[derive(Clone, Copy)]
pub struct FitScene<'a> {
    /// The scene's dataset: every split, the image size, the ground truth when it has one. Its
    /// training split's views are [`FitInputs::views`].
    pub dataset: &'a Dataset,
    /// What caches of the fit key on: the inputs' fingerprint and how the views were decoded
    /// (exposures, a fitted response, restored lights, shifts onto the mesh).
    pub cache_key: &'a str,
    /// The views' working scale: [`FitInputs::images`] hold the views / `exposure`; radiance
    /// results are multiplied by it where they are written.
    pub exposure: f32,
    /// Per training view and pixel, true where the material loss leaves the pixel out
    /// (clipped, but not on a light: its radiance is only bounded below); empty: none.
    pub left_out: &'a [Vec<bool>],
    /// Per training view and pixel, true where the view's mask leaves the pixel out (people,
    /// screens); empty: no masks.
    pub masked: &'a [Vec<bool>],
}

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
    /// The scene around the views, when the host has it (`fipt run` always does).
    pub scene: Option<FitScene<'a>>,
    /// A folder of the fitter's own (checkpoints, resume); it exists.
    pub dir: &'a Path,
    /// The run's baker, refiner and extractor; None outside a run (a test of the method alone).
    pub parts: Option<FitParts<'a>>,
    /// The run around the fit.
    pub run: FitRun<'a>,
}

/// What a fitter returns.
pub struct Fitted {
    pub field: Box<dyn MaterialField>,
    /// The emitters, when the method estimates them; None: the run's emitter extractor finds
    /// them from the field's emission mask.
    pub emitters: Option<Vec<Emitter>>,
    /// Anything the method reports (steps, losses, timings): `report.json`'s `fit`.
    pub report: serde_json::Value,
    /// What the method modelled and skipped, and why (an object merged into `report.json`'s
    /// `modeled`); None: "fitted by method `name`".
    pub modeled: Option<serde_json::Value>,
    /// An id of the fitted field (e.g. its checkpoint's fingerprint): re-renders an earlier
    /// run of the folder made from the same id are reused. None: always re-rendered.
    pub id: Option<String>,
    /// The file the field is stored in, when the method writes one (`fipt run`'s summary).
    pub field_file: Option<PathBuf>,
}

impl Fitted {
    /// A fitted field with its emitters (None: the run's extractor finds them) and report.
    pub fn new(
        field: Box<dyn MaterialField>,
        emitters: Option<Vec<Emitter>>,
        report: serde_json::Value,
    ) -> Self {
        Fitted {
            field,
            emitters,
            report,
            modeled: None,
            id: None,
            field_file: None,
        }
    }
}

/// Which of the run's [`FitParts`] a method builds its fit from; the run lists their settings in
/// `report.json` as used. The baker of a method that [`MaterialFitter::needs_shadings`], and
/// the extractor of one that returns no emitters, are used by the run itself and count anyway.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PartsUsed {
    pub baker: bool,
    pub refiner: bool,
    pub trainer: bool,
    pub extractor: bool,
}

impl PartsUsed {
    /// None of them (a method that works alone).
    pub const NONE: PartsUsed = PartsUsed {
        baker: false,
        refiner: false,
        trainer: false,
        extractor: false,
    };
    /// All four (FIPT's rounds).
    pub const ALL: PartsUsed = PartsUsed {
        baker: true,
        refiner: true,
        trainer: true,
        extractor: true,
    };
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
    /// Which of [`FitInputs::parts`] it composes (none unless it says so).
    fn parts_used(&self) -> PartsUsed {
        PartsUsed::NONE
    }
    /// Fits the field; `progress(done, total)` as the work goes.
    fn fit(&self, inputs: &FitInputs, progress: Progress) -> Result<Fitted>;
}
