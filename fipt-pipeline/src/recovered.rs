//! A `fipt run` output folder opened as a recovered scene: its scene, reflectance model,
//! material field and emitters, and the surfaces the path tracer renders from them (the
//! re-render of `fipt run`, `fipt render` and `fipt export` share them).
use crate::bail;
use crate::error::{Context, Result};
use fipt_core::dataset::{Dataset, View};
use fipt_core::emitter::Emitter;
use fipt_core::field::MaterialField;
use fipt_core::fsutil::read_json;
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::{Geometry, Mesh};
use fipt_shading::field_surfaces::FieldSurfaces;
use fipt_shading::records::HitPoint;
use std::path::{Path, PathBuf};

/// At most this many extra points spread over the mesh to cache the field where no view
/// looked (1.5 M: a few seconds of field queries on 2 cores).
pub const MAX_FILL_POINTS: usize = 1_500_000;

/// The cache cell of the recovered surfaces: twice the median pixel footprint of the views.
pub fn cache_cell(footprint: Option<f32>) -> f32 {
    footprint.unwrap_or(0.01) * 2.0
}

/// The surfaces of a recovered scene: the field cached on the voxels the `views` see (and
/// the rest of the mesh), the emitters' radiance per triangle.
pub fn surfaces(
    geometry: &Geometry,
    views: &[View],
    field: &dyn MaterialField,
    emitters: &[Emitter],
    model: ReflectanceModel,
) -> Result<FieldSurfaces> {
    // One view's primary records at a time (80 bytes a pixel; every view's at once held
    // 5 GiB at 200 views of 640 × 480): the footprint samples and the hit points, in view order
    // ([`fipt_shading::records::median_footprint`] on all of them gives the same median).
    let (mut foot, mut pts) = (vec![], vec![]);
    for v in views {
        let records = fipt_shading::records::primary_records(geometry, v);
        fipt_shading::records::footprint_samples(v, &records, &mut foot);
        pts.extend(records.iter().flatten().map(|r| (r.hit.p, r.hit.tri)));
    }
    cached(geometry, field, emitters, model, &pts, foot)
}

/// The field cached on the voxels of `pts` (and the rest of the mesh), the cell from the
/// median of the footprint samples `foot`.
fn cached(
    geometry: &Geometry,
    field: &dyn MaterialField,
    emitters: &[Emitter],
    model: ReflectanceModel,
    pts: &[(glam::Vec3, u32)],
    foot: Vec<f32>,
) -> Result<FieldSurfaces> {
    let footprint = fipt_shading::records::median(foot);
    Ok(FieldSurfaces::build_covering(
        field,
        &geometry.mesh,
        emitters,
        pts,
        cache_cell(footprint),
        MAX_FILL_POINTS,
    )?
    .with_model(model))
}

/// Every view of a scene traced once for both readers of a recovered scene in `fipt render`
/// and `fipt export`: [`crate::seen::SeenField`] over the training views and the surfaces'
/// cache over all of them (each traced them on its own before: the training views twice).
pub struct TracedViews {
    /// Per view (the training split's first), each pixel's primary hit.
    hits: Vec<Vec<Option<HitPoint>>>,
    train: usize,
    /// Footprints of every training pixel (the `observed` maps' cell) and of a sample of every
    /// view's (the cache's cell), as [`crate::seen::SeenField::with_footprint`] and [`surfaces`]
    /// take them.
    train_foot: Vec<f32>,
    cache_foot: Vec<f32>,
}

impl TracedViews {
    /// Traces every split of `ds`, the training split first.
    pub fn trace(geometry: &Geometry, ds: &Dataset) -> Self {
        use fipt_shading::records::{
            footprint_samples, points_of, primary_records, push_footprints,
        };
        let train = ds.train().views.len();
        let mut t = TracedViews {
            hits: vec![],
            train,
            train_foot: vec![],
            cache_foot: vec![],
        };
        let views = ds.splits.iter().flat_map(|s| s.views.iter());
        for (k, v) in views.enumerate() {
            let records = primary_records(geometry, v);
            footprint_samples(v, &records, &mut t.cache_foot);
            if k < train {
                push_footprints(v, &records, &mut t.train_foot);
            }
            t.hits.push(points_of(&records));
        }
        t
    }

    /// `inner` filled where no training pixel saw a surface (see [`crate::seen`]).
    pub fn seen<'a>(
        &self,
        inner: &'a dyn MaterialField,
        mesh: &Mesh,
    ) -> Result<crate::seen::SeenField<'a>> {
        let footprint = fipt_shading::records::median(self.train_foot.clone());
        crate::seen::SeenField::with_footprint(inner, mesh, &self.hits[..self.train], footprint)
    }

    /// The surfaces of the recovered scene ([`surfaces`] of every view), the hits dropped.
    pub fn into_surfaces(
        self,
        geometry: &Geometry,
        field: &dyn MaterialField,
        emitters: &[Emitter],
        model: ReflectanceModel,
    ) -> Result<FieldSurfaces> {
        let mut pts = vec![];
        for view in self.hits {
            pts.extend(view.into_iter().flatten().map(|h| (h.p, h.tri())));
        }
        cached(geometry, field, emitters, model, &pts, self.cache_foot)
    }
}

/// A finished `fipt run` output folder.
pub struct RunOutput {
    pub dir: PathBuf,
    pub report: serde_json::Value,
    /// The scene folder the run read.
    pub scene: PathBuf,
    pub model: ReflectanceModel,
    pub method: String,
    pub emitters: Vec<Emitter>,
}

pub use fipt_capture::scene::{open_options_of, run_open_options};

fn not_a_run(dir: &Path, why: &str) -> crate::error::RunError {
    if fipt_core::lock::Owner::of(dir) == Some(fipt_core::lock::Owner::Scene) {
        return crate::err!(
            "{}: a scene folder, not a finished `fipt run` output folder: give the folder a run wrote (`fipt run {} --out RUN`, then RUN)",
            dir.display(),
            dir.display()
        );
    }
    crate::err!(
        "{}: not a finished `fipt run` output folder ({why}); run `fipt run <scene> --out {}` first",
        dir.display(),
        dir.display()
    )
}

impl RunOutput {
    /// Whether `dir` looks like a run output (has `report.json`).
    pub fn is_run_output(dir: &Path) -> bool {
        dir.join("report.json").is_file()
    }

    /// Opens a run output folder; `scene` overrides the scene folder the report names.
    pub fn open(dir: &Path, scene: Option<&Path>) -> Result<RunOutput> {
        if !dir.is_dir() {
            bail!("{}: no such folder", dir.display());
        }
        let report: serde_json::Value = read_json(&dir.join("report.json"))
            .map_err(|_| not_a_run(dir, "no readable report.json"))?;
        match report["status"].as_str() {
            None | Some("complete") => {}
            Some(status) => bail!(
                "{}: the run in this folder did not finish (status `{status}`{}); run it again",
                dir.display(),
                report["error"]
                    .as_str()
                    .map_or(String::new(), |e| format!(": {e}"))
            ),
        }
        let emitters: Vec<Emitter> = read_json(&dir.join("emitters.json"))
            .map_err(|_| not_a_run(dir, "no readable emitters.json"))?;
        let named = report["scene"]
            .as_str()
            .map(PathBuf::from)
            .ok_or_else(|| not_a_run(dir, "report.json names no scene"))?;
        let scene = scene.map(Path::to_path_buf).unwrap_or(named);
        if !scene.is_dir() {
            bail!(
                "{}: the scene of the run ({}) is not a folder from here; pass it with --scene",
                dir.display(),
                scene.display()
            );
        }
        let model = match report["settings"]["model"]["brdf"].as_str() {
            None => ReflectanceModel::Fipt,
            Some(name) => name.parse::<ReflectanceModel>().map_err(|e| {
                crate::err!(
                    "{}: the run was made under reflectance model `{name}`: {e}; use the binary that registers it (as the run did)",
                    dir.display()
                )
            })?,
        };
        let method = report["settings"]["pipeline"]["method"]
            .as_str()
            .unwrap_or(crate::names::FIPT_METHOD)
            .to_string();
        Ok(RunOutput {
            dir: dir.to_path_buf(),
            report,
            scene,
            model,
            method,
            emitters,
        })
    }

    /// The folder of the final material field: `report.json`'s `field_dir` (the folder of the
    /// file the method stored its field in, with the training round's manifest); for runs
    /// made before the report said so, `train{r}` after the r refinement rounds the report
    /// lists (`fit.rounds`; top-level `rounds` before FIPT was a method). None: the method
    /// stored no field there (a folder may hold an earlier run's rounds beside it).
    pub fn field_dir(&self) -> Option<PathBuf> {
        if let Some(rel) = self.report["field_dir"].as_str() {
            return Some(self.dir.join(rel));
        }
        let (fit, old) = (&self.report["fit"]["rounds"], &self.report["rounds"]);
        let rounds = fit.as_array().or(old.as_array())?.len();
        Some(crate::trained::train_dir(&self.dir, rounds as u32))
    }

    /// Loads the recovered material field through the trainer that trained it (its round's
    /// manifest names it; `components` must have it): runs of a method that stores its field
    /// in a trainer's round folder (FIPT's do).
    pub fn field(&self, components: &crate::Components) -> Result<Box<dyn MaterialField>> {
        let Some(dir) = self
            .field_dir()
            .filter(|d| d.join("manifest.json").is_file())
        else {
            bail!(
                "{}: method `{}` stored no material field that can be reloaded (report.json names no `field_dir` holding a training round's manifest.json)",
                self.dir.display(),
                self.method
            );
        };
        if let Some(why) = crate::trained::field_changed(&dir) {
            bail!(
                "{why}: run `fipt run` on {} again (it trains that round again and redoes what follows)",
                self.dir.display()
            );
        }
        let manifest: crate::trained::TrainManifest =
            fipt_core::fsutil::read_json(&dir.join("manifest.json"))
                .with_context(|| format!("reading the training round in {}", dir.display()))?;
        let trainer = (components.trainer(&manifest.trainer, &manifest.config))
            .with_context(|| format!("the trainer of {}", dir.display()))?;
        trainer
            .load(&dir)
            .with_context(|| format!("loading the material field from {}", dir.display()))
    }

    /// How the run read its scene (`[capture] downscale`).
    pub fn open_options(&self) -> fipt_core::capture_layout::OpenOptions {
        open_options_of(&self.report)
    }

    /// The scene's dataset and geometry; warns when its inputs changed since the run.
    pub fn open_scene(&self) -> Result<(Dataset, Geometry)> {
        let ds = Dataset::open_with(&self.scene, self.open_options())
            .with_context(|| format!("opening scene {}", self.scene.display()))?;
        let here = crate::scene::inputs_hash(&ds)?;
        if let Some(there) = self.report["inputs_hash"].as_str() {
            if there != here {
                crate::note!(
                    "warning: {} changed since the run in {} (inputs fingerprint {there} → {here})",
                    self.scene.display(),
                    self.dir.display()
                );
            }
        }
        let mesh = Mesh::load(&ds.mesh).context("loading the scene mesh")?;
        Ok((ds, Geometry::new(mesh)))
    }
}

/// `fipt export`: which run, in which format, where.
#[derive(Clone, Debug)]
pub struct ExportRequest {
    /// A `fipt run` output folder.
    pub run: PathBuf,
    /// The scene folder, when the path in the run's report.json does not resolve.
    pub scene: Option<PathBuf>,
    pub format: fipt_export::Format,
    /// Output folder.
    pub out: PathBuf,
    /// World size of a texel (default: the re-render's material cache cell).
    pub texel: Option<f32>,
    /// Largest atlas edge in texels.
    pub max_atlas: u32,
    /// Per-vertex materials instead of a texture atlas (glb only).
    pub per_vertex: bool,
}

/// Writes the recovered scene of a run for other tools (glTF, Mitsuba 3, OBJ + MTL).
pub fn export_run(
    a: &ExportRequest,
    components: &crate::Components,
) -> Result<fipt_export::ExportSummary> {
    use fipt_core::lock::{refuse_owned_output, Owner};
    refuse_owned_output(&a.out, "export", &[Owner::Run, Owner::Scene])?;
    if let Some(w) = fipt_core::lock::already_holds(&a.out, "export") {
        crate::note!("warning: {w}");
    }
    let checked = fipt_export::ExportOptions {
        texel_size: a.texel.unwrap_or(0.01),
        max_atlas: a.max_atlas,
        per_vertex: a.per_vertex,
    };
    checked
        .validate()
        .map_err(crate::error::RunError::invalid)?;
    crate::memory::check_bytes(
        "the export's texture atlas (--max-atlas²)",
        checked.atlas_bytes(),
    )?;
    let st = crate::observe::Stage::start("load");
    let run = RunOutput::open(&a.run, a.scene.as_deref())?;
    let (ds, geometry) = run.open_scene()?;
    let trained = run.field(components)?;
    let traced = TracedViews::trace(&geometry, &ds);
    let field = traced.seen(trained.as_ref(), &geometry.mesh)?;
    let surfaces = traced.into_surfaces(&geometry, &field, &run.emitters, run.model)?;
    st.done();
    let opts = fipt_export::ExportOptions {
        texel_size: a.texel.unwrap_or(surfaces.cell()),
        max_atlas: a.max_atlas,
        per_vertex: a.per_vertex,
    };
    let st = crate::observe::Stage::start("export");
    let sum = fipt_export::export(
        &geometry.mesh,
        &surfaces,
        &run.emitters,
        a.format,
        &a.out,
        &opts,
    )?;
    st.done();
    Ok(sum)
}
