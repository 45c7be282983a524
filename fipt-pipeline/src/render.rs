//! Path-traced views (`fipt render`) of a recovered scene (a `fipt run` output folder) or of a
//! mesh with given materials, from any cameras, optionally relit by a lights file.
use crate::bail;
use crate::error::{Context, Result, RunError};
use crate::observe::{bar, Stage};
use crate::recovered::RunOutput;
use fipt_core::camera::Camera;
use fipt_core::dataset::{read_cam_list, read_transforms, MESH_NAMES};
use fipt_core::image::ExrPrecision;
use fipt_core::materials::SceneMaterials;
use fipt_core::reflectance::ReflectanceModel;
use fipt_geom::Mesh;
use fipt_shading::edit::EditedSurfaces;
use fipt_shading::lights::{EmitterPolicy, LightsFile};
use fipt_shading::relight::apply_lights;
use fipt_shading::render::{render_aovs, RenderConfig};
use fipt_shading::scene::{Scene, SurfaceModel, TableSurfaces};
use fipt_shading::scene_edits::{apply_edits, EditsFile, OBJECT_PART};
use fipt_synth::write_view;
use std::path::{Path, PathBuf};

/// `fipt render`: what to render, from which cameras, under which lights and edits.
#[derive(Clone, Debug)]
pub struct RenderRequest {
    /// A `fipt run` output folder (the recovered scene), a `.glb` of `fipt export`, or, with
    /// `materials`, a scene folder holding scene.obj (or .ply/.glb/.gltf) or a mesh file.
    pub source: PathBuf,
    /// Per-face materials (scene_gt.json or a scene_parts.json table) for a mesh.
    pub materials: Option<PathBuf>,
    /// The scene folder of a run output, when the path in its report.json does not resolve.
    pub scene: Option<PathBuf>,
    /// Cameras: transforms.json (Mitsuba convention) or cam.txt (with K_list.txt beside it).
    pub cameras: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// Image size when the cameras file has none (default for a run: its scene's).
    pub size: Option<(usize, usize)>,
    pub spp: u32,
    pub max_bounces: u32,
    pub seed: u64,
    /// Render only these view indices (default: all).
    pub views: Option<Vec<usize>>,
    /// The reflectance model (default: the run's; `fipt` for `materials`).
    pub brdf: Option<ReflectanceModel>,
    /// Lights files to add; several render each view under each into OUT/<file stem>/ and tile
    /// them into OUT/strip_{k:03}.png.
    pub lights: Vec<PathBuf>,
    /// The scene's own emitters (overrides the lights file's `emitters`).
    pub emitters: Option<EmitterPolicy>,
    /// Material edits and inserted objects (edits.json), applied before the lights.
    pub edits: Option<PathBuf>,
    /// Reference images to compare with (writes `metrics.json` into each output folder).
    pub reference: Option<PathBuf>,
    /// Denoise the path-traced views, keeping the raw ones beside them
    /// (`{k:03}_render_raw.exr`; for --materials, which writes a scene's split, only the
    /// denoised `Image/`). None: on, except for --materials (ground truth stays raw).
    pub denoise: Option<bool>,
}

/// What `fipt render` wrote.
#[derive(Debug, Default)]
pub struct RenderSummary {
    /// Per lights set: the folder and, with a reference, the sRGB PSNR per view.
    pub outputs: Vec<(PathBuf, Vec<(usize, f64)>)>,
    /// The relighting strips (several lights sets).
    pub strips: Vec<PathBuf>,
}

/// Reads cameras from FIPT's transforms.json (Mitsuba convention) or cam.txt + K_list.txt, or
/// from a capture's: a nerfstudio transforms.json, a COLMAP model folder (or a scene folder
/// holding one, or a nerfstudio file). Cameras that carry their size keep it (`--size` is
/// then not used, and a warning says so).
pub fn read_cameras(path: &Path, size: Option<(usize, usize)>) -> Result<Vec<Camera>> {
    let capture = |c: fipt_core::capture_layout::CaptureCameras| -> Vec<Camera> {
        c.views.into_iter().map(|v| v.camera).collect()
    };
    let cams = if path.is_dir() {
        let model = if fipt_core::colmap::is_model(path) {
            Some(path.to_path_buf())
        } else {
            fipt_core::colmap::find_model(path)
        };
        match model {
            Some(m) => capture(fipt_core::colmap::read_model(path, &m)?),
            None if path.join("transforms.json").is_file() => {
                return read_cameras(&path.join("transforms.json"), size)
            }
            None => bail!(
                "{}: a folder without cameras: give a transforms.json, a cam.txt (with K_list.txt beside it), or a COLMAP model folder",
                path.display()
            ),
        }
    } else if !path.is_file() {
        bail!("{}: no such cameras file", path.display());
    } else if path.extension().is_some_and(|e| e == "json") {
        if fipt_core::nerfstudio::looks_like_nerfstudio(path)?.is_some() {
            capture(fipt_core::nerfstudio::read(path)?)
        } else {
            read_transforms(path, size)?
        }
    } else {
        return read_cam_txt(path, size);
    };
    if let (Some((w, h)), Some(c)) = (size, cams.first()) {
        if (c.width, c.height) != (w, h) {
            crate::note!(
                "warning: --size {w} {h} is not used: {} gives the cameras' size, {}x{}",
                path.display(),
                c.width,
                c.height
            );
        }
    }
    Ok(cams)
}

/// cam.txt + K_list.txt beside it, at `size`.
fn read_cam_txt(path: &Path, size: Option<(usize, usize)>) -> Result<Vec<Camera>> {
    let k = path.with_file_name("K_list.txt");
    let Some((w, h)) = size else {
        bail!(
            "{}: cam.txt cameras carry no image size; pass --size W H",
            path.display()
        );
    };
    if !k.is_file() {
        bail!(
            "{}: cam.txt cameras need K_list.txt beside them (not found: {})",
            path.display(),
            k.display()
        );
    }
    Ok(read_cam_list(path, &k, w, h)?)
}

/// The mesh of `source`: the file itself, or the first of [`MESH_NAMES`] in the folder.
pub fn mesh_of(source: &Path) -> Result<PathBuf> {
    if !source.is_dir() {
        return Ok(source.to_path_buf());
    }
    MESH_NAMES
        .iter()
        .map(|n| source.join(n))
        .find(|p| p.is_file())
        .with_context(|| format!("{}: no mesh ({})", source.display(), MESH_NAMES.join(", ")))
}

/// Renders what `a` asks for. Its output folder may not be, or lie inside, a run folder (only
/// `fipt run` writes there) nor, for a recovered scene, a scene folder (a mesh rendered with
/// --materials writes a scene's split in the dataset layout).
pub fn render_request(a: &RenderRequest, components: &crate::Components) -> Result<RenderSummary> {
    use fipt_core::lock::{refuse_owned_output, Owner};
    let refused: &[Owner] = if a.materials.is_some() {
        &[Owner::Run]
    } else {
        &[Owner::Run, Owner::Scene]
    };
    refuse_owned_output(&a.out, "render", refused)?;
    check_sizes(a)?;
    if let Some(w) = fipt_core::lock::already_holds(&a.out, "render") {
        crate::note!("warning: {w}");
    }
    render_unchecked(a, components)
}

/// The ranges of a render's options (the product with the cameras is checked in
/// `render_all`).
fn check_sizes(a: &RenderRequest) -> Result<()> {
    use fipt_core::range::check;
    check_spp(a.spp)?;
    check("--max-bounces", a.max_bounces, 0, 64).map_err(RunError::invalid)?;
    if let Some((w, h)) = a.size {
        check("--size W", w, 1, 16_384).map_err(RunError::invalid)?;
        check("--size H", h, 1, 16_384).map_err(RunError::invalid)?;
    }
    Ok(())
}

/// `--spp` within 1..=[`MAX_SPP`].
pub fn check_spp(spp: u32) -> Result<()> {
    fipt_core::range::check("--spp", spp, 1, MAX_SPP).map_err(RunError::invalid)?;
    Ok(())
}

pub use crate::run_config::MAX_SPP;

/// The most paths one render may trace (spp × pixels × views × lights sets): about 14 hours
/// at the 2 M paths/s of 2 cores.
pub const MAX_PATHS: f64 = 1e11;

/// [`render_request`] into a folder the caller holds (`fipt eval` renders into its run's
/// `eval/` under the run's lock).
pub fn render_unchecked(
    a: &RenderRequest,
    components: &crate::Components,
) -> Result<RenderSummary> {
    let size = a.size;
    if let Some(table) = &a.materials {
        let st = Stage::start("load");
        let mesh = Mesh::load(&mesh_of(&a.source)?)?;
        let materials = SceneMaterials::read_any(table)?;
        let mut surfaces = TableSurfaces::new(materials, &mesh, table)?;
        surfaces.model = a.brdf.unwrap_or(ReflectanceModel::Fipt);
        let cams = read_cameras(&a.cameras, size)?;
        // All emitting triangles form emitter 0.
        let lit: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| surfaces.emission(t).max_element() > 0.0)
            .collect();
        st.done();
        return render_all(a, &mesh, &surfaces, &[lit], &cams, Layout::Dataset);
    }
    if a.source.is_file()
        && a.source
            .extension()
            .is_some_and(|e| e == "glb" || e == "gltf")
    {
        // A scene exported by `fipt export --format glb` (or any metallic-roughness glTF).
        let st = Stage::start("load");
        let (mesh, surfaces) = fipt_export::load::load_glb(&a.source)?;
        let cams = read_cameras(&a.cameras, size)?;
        let lit: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| surfaces.emission(t).max_element() > 0.0)
            .collect();
        st.done();
        return render_all(a, &mesh, &surfaces, &[lit], &cams, Layout::Flat);
    }
    if !RunOutput::is_run_output(&a.source) {
        bail!(
            "{}: not a `fipt run` output folder (no report.json); render a recovered scene from one, or a mesh with --materials",
            a.source.display()
        );
    }
    let st = Stage::start("load");
    let run = RunOutput::open(&a.source, a.scene.as_deref())?;
    let (ds, geometry) = run.open_scene()?;
    let trained = run.field(components)?;
    let traced = crate::recovered::TracedViews::trace(&geometry, &ds);
    let field = traced.seen(trained.as_ref(), &geometry.mesh)?;
    let cams = read_cameras(&a.cameras, size.or(Some((ds.width, ds.height))))?;
    let model = a.brdf.unwrap_or(run.model);
    let surfaces = traced.into_surfaces(&geometry, &field, &run.emitters, model)?;
    let groups: Vec<Vec<u32>> = run.emitters.iter().map(|e| e.triangles.clone()).collect();
    st.done();
    let summary = render_all(a, &geometry.mesh, &surfaces, &groups, &cams, Layout::Flat)?;
    exact_maps(a, &run, &field, &geometry, &cams)?;
    Ok(summary)
}

/// The material maps of a run's recovered scene at the render's cameras, queried from the
/// field at each pixel's primary hit as the run's own maps are (the path tracer shades from a
/// cache of the field over the mesh, which blurs a texture's edges: 0.9 dB of kd on
/// `studio-mitsuba`'s val views). Only for the scene as recovered: no edits, no added lights,
/// the scene's emitters kept.
fn exact_maps(
    a: &RenderRequest,
    run: &RunOutput,
    field: &dyn fipt_core::field::MaterialField,
    geometry: &fipt_geom::Geometry,
    cams: &[Camera],
) -> Result<()> {
    let as_recovered = a.edits.is_none()
        && a.lights.is_empty()
        && matches!(a.emitters, None | Some(EmitterPolicy::Keep));
    if !as_recovered {
        return Ok(());
    }
    let st = Stage::start("maps");
    let ks = requested_views(a, cams.len())?;
    let views: Vec<fipt_core::dataset::View> = ks
        .iter()
        .map(|&k| fipt_core::dataset::View {
            index: k,
            camera: cams[k].clone(),
            image: PathBuf::new(),
            mask: None,
        })
        .collect();
    let mut emission = std::collections::HashMap::new();
    for e in &run.emitters {
        for (t, l) in e.triangles.iter().zip(&e.radiance) {
            emission.insert(*t, glam::Vec3::from(*l));
        }
    }
    crate::maps::export_views(
        field,
        geometry,
        &views,
        None,
        Some(&emission),
        None,
        1.0,
        &a.out,
    )?;
    st.done();
    Ok(())
}

/// Where the views go: the dataset layout (`Image/` and ground-truth folders) or
/// `{k:03}_render.exr` with the material maps beside it.
#[derive(Clone, Copy, PartialEq)]
enum Layout {
    Dataset,
    Flat,
}

/// The views `a` asks for (all of the `n` cameras without `views`): each in range, none twice
/// (a view listed twice would be traced twice into one file).
fn requested_views(a: &RenderRequest, n: usize) -> Result<Vec<usize>> {
    let Some(views) = a.views.clone() else {
        return Ok((0..n).collect());
    };
    if let Some(&bad) = views.iter().find(|&&k| k >= n) {
        bail!(
            "view {bad} requested but {} has {n} cameras (views are numbered from 0)",
            a.cameras.display()
        );
    }
    let mut seen = std::collections::BTreeSet::new();
    if let Some(&twice) = views.iter().find(|&&k| !seen.insert(k)) {
        bail!("view {twice} is listed twice in the requested views: list each view once");
    }
    Ok(views)
}

/// Every lights set of `a` (none: the scene as it is), checked before anything renders.
fn render_all<S: SurfaceModel>(
    a: &RenderRequest,
    mesh: &Mesh,
    surfaces: &S,
    emitters: &[Vec<u32>],
    cams: &[Camera],
    layout: Layout,
) -> Result<RenderSummary> {
    let views = requested_views(a, cams.len())?;
    let sets: Vec<Option<&Path>> = if a.lights.is_empty() {
        vec![None]
    } else {
        a.lights.iter().map(|p| Some(p.as_path())).collect()
    };
    let px = |k: &usize| (cams[*k].width * cams[*k].height) as f64;
    fipt_core::range::product(
        "the paths of this render",
        &[
            ("spp", a.spp as f64),
            ("pixels of the views", views.iter().map(px).sum()),
            ("lights sets", sets.len() as f64),
        ],
        MAX_PATHS,
        "paths",
    )
    .map_err(RunError::invalid)?;
    let mut scenes = Vec::new();
    for l in &sets {
        scenes.push(build_scene(a, mesh.clone(), surfaces, emitters, cams, *l)?);
    }
    let mut summary = RenderSummary::default();
    let names = set_folders(&sets);
    for ((l, scene), name) in sets.iter().zip(&scenes).zip(&names) {
        let out = match l {
            Some(_) if sets.len() > 1 => a.out.join(name),
            _ => a.out.clone(),
        };
        let psnr = render_views(a, scene, cams, &views, &out, layout)?;
        summary.outputs.push((out, psnr));
    }
    if sets.len() > 1 {
        for &k in &views {
            let pics: Vec<PathBuf> = summary
                .outputs
                .iter()
                .map(|(o, _)| match layout {
                    Layout::Flat => o.join(format!("preview/{k:03}_render.png")),
                    Layout::Dataset => o.join(format!("preview/{k:03}.png")),
                })
                .collect();
            let strip = a.out.join(format!("strip_{k:03}.png"));
            fipt_report::write_strip(&pics, &strip)?;
            summary.strips.push(strip);
        }
    }
    Ok(summary)
}

/// The folder of each lights file of a relighting: its file name without the extension,
/// with `-2`, `-3`, … after a name an earlier file took (`a/light.json` and `b/light.json`
/// wrote into one folder, the second over the first).
fn set_folders(sets: &[Option<&Path>]) -> Vec<String> {
    let mut taken: Vec<String> = vec![];
    for l in sets {
        let stem = l
            .and_then(|p| p.file_stem())
            .map_or("lights".into(), |s| s.to_string_lossy().to_string());
        let mut name = stem.clone();
        let mut n = 1;
        while taken.contains(&name) {
            n += 1;
            name = format!("{stem}-{n}");
        }
        taken.push(name);
    }
    taken
}

/// The scene of one lights set: edits and inserted objects first, then the lights.
fn build_scene<'s, S: SurfaceModel>(
    a: &RenderRequest,
    mut mesh: Mesh,
    surfaces: &'s S,
    emitters: &[Vec<u32>],
    cams: &[Camera],
    lights: Option<&Path>,
) -> Result<Scene<EditedSurfaces<&'s S>>> {
    let mut edited = EditedSurfaces::new(surfaces, &mesh);
    if let Some(p) = &a.edits {
        let file = EditsFile::read(p)?;
        let done = apply_edits(&mut mesh, &mut edited, &file, p, cams)?;
        crate::note!(
            "edits: {} material edits ({} triangles), {} objects ({} triangles)",
            done.selected.len(),
            done.selected.iter().sum::<usize>(),
            done.object_triangles.len(),
            done.object_triangles.iter().sum::<usize>()
        );
    }
    let default = a.emitters.unwrap_or(EmitterPolicy::Keep);
    let mut file = match lights {
        Some(p) => LightsFile::read(p)?,
        None => LightsFile::default(),
    };
    let origins: Vec<glam::Vec3> = cams.iter().map(|c| c.origin).collect();
    file.check_cameras(lights.unwrap_or(Path::new("lights")), &origins)?;
    let b = mesh.bounds();
    let away = file.outside(b.min, b.max);
    if !away.is_empty() {
        crate::note!(
            "warning: {}: lights {away:?} lie outside the scene's mesh (bounds {:.2?} – {:.2?}): in a closed room they light nothing the cameras see",
            lights.unwrap_or(Path::new("lights")).display(),
            b.min.to_array(),
            b.max.to_array()
        );
    }
    if a.emitters.is_some() {
        file.emitters = a.emitters;
    }
    let lights_path = lights.unwrap_or(Path::new("--emitters"));
    let deltas = apply_lights(
        &mut mesh,
        &mut edited,
        &file,
        lights_path,
        default,
        emitters,
    )?;
    let mut scene = Scene::new(mesh, edited);
    scene.delta_lights = deltas;
    if !scene.has_light() {
        crate::note!(
            "warning: nothing emits (no emitter kept, no light added): renders will be black"
        );
    }
    Ok(scene)
}

fn render_views<S: SurfaceModel>(
    a: &RenderRequest,
    scene: &Scene<S>,
    cams: &[Camera],
    views: &[usize],
    out: &Path,
    layout: Layout,
) -> Result<Vec<(usize, f64)>> {
    // Given materials render a scene's ground truth: roulette as late as `fipt synth`'s.
    let base = if a.materials.is_some() {
        RenderConfig::ground_truth(a.spp)
    } else {
        RenderConfig::default()
    };
    let cfg = RenderConfig {
        spp: a.spp,
        max_bounces: a.max_bounces,
        seed: a.seed,
        ..base
    };
    let total: u64 = views
        .iter()
        .map(|&k| (cams[k].width * cams[k].height) as u64)
        .sum();
    let pb = bar(total, "render");
    let st = Stage::start("render");
    let (mut rays, mut nonfinite, mut traced) = (0u64, 0u64, 0f64);
    let reference = a.reference.as_deref().map(reference_dir).transpose()?;
    let mut rows = Vec::new();
    let mut raw_rows = Vec::new();
    let denoise = a.denoise.unwrap_or(layout == Layout::Flat);
    let dn = fipt_shading::denoise::DenoiseConfig {
        passes: if denoise { 5 } else { 0 },
        ..Default::default()
    };
    for &k in views {
        let tick = |n: usize| pb.inc(n as u64);
        let (img, raw, stats) =
            fipt_shading::denoise::render_denoised(scene, &cams[k], &cfg, k as u64, &dn, &tick);
        if let Some(dir) = &reference {
            rows.push((k, compare(dir, k, &img)?));
            if denoise {
                raw_rows.push((k, compare(dir, k, &raw)?));
            }
        }
        if denoise && layout == Layout::Flat {
            raw.write_exr(
                &out.join(format!("{k:03}_render_raw.exr")),
                ExrPrecision::F32,
            )?;
            raw.write_png(&out.join(format!("preview/{k:03}_render_raw.png")), 1.0)?;
        } else {
            // An older render's raw file would pass for this one's.
            let _ = std::fs::remove_file(out.join(format!("{k:03}_render_raw.exr")));
        }
        rays += stats.rays;
        nonfinite += stats.nonfinite;
        traced += stats.seconds;
        let aovs = render_aovs(scene, &cams[k]);
        match layout {
            Layout::Dataset => {
                let parts = aovs.part.iter().filter(|&&p| p < OBJECT_PART).max();
                let semantic: Vec<u32> = (0..=parts.copied().unwrap_or(0)).collect();
                write_view(out, k, &img, &aovs, &semantic)?
            }
            Layout::Flat => write_flat(out, k, &img, &aovs)?,
        }
    }
    pb.finish_and_clear();
    let secs = st.done();
    crate::note!(
        "{} views, {:.2} Mrays/s traced ({:.1} s of path tracing), {:.2} Mrays/s over the {secs:.1} s of the stage{}",
        views.len(),
        rays as f64 / traced.max(1e-9) / 1e6,
        traced,
        rays as f64 / secs / 1e6,
        if nonfinite > 0 {
            format!(", {nonfinite} non-finite samples dropped")
        } else {
            String::new()
        }
    );
    if reference.is_some() {
        write_metrics(out, &rows, &raw_rows)?;
    }
    Ok(rows)
}

fn reference_dir(p: &Path) -> Result<PathBuf> {
    let dir = if p.join("Image").is_dir() {
        p.join("Image")
    } else {
        p.to_path_buf()
    };
    if !dir.is_dir() {
        bail!(
            "{}: --reference must be a folder of {{k:03}}_0001.exr images",
            p.display()
        );
    }
    let (exr, photos) = count_images(&dir);
    if exr == 0 && photos > 0 {
        bail!(
            "{}: --reference compares linear HDR images ({{k:03}}_0001.exr, or another render's {{k:03}}_render.exr), and this folder holds {photos} 8-bit photo(s) and no EXR. A photo's exposure and tone curve are unknown here: score a run of photos with `fipt eval SRC RUN --cameras-from SRC --fit-scales on` against a scene with HDR ground truth",
            dir.display()
        );
    }
    Ok(dir)
}

/// The EXR files and the 8-bit photos (`capture::is_ldr_file`'s JPEG, PNG) directly in `dir`.
fn count_images(dir: &Path) -> (usize, usize) {
    let paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    let exr = (paths.iter())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")))
        .count();
    let photos = (paths.iter())
        .filter(|p| fipt_core::capture::is_ldr_file(p))
        .count();
    (exr, photos)
}

/// sRGB PSNR of a rendered view against the reference image of the same index.
fn compare(dir: &Path, k: usize, img: &fipt_core::image::Image) -> Result<f64> {
    let mut path = dir.join(fipt_core::dataset::image_file_name(k));
    if !path.is_file() {
        // Another `fipt render`'s output.
        path = dir.join(format!("{k:03}_render.exr"));
    }
    let r = fipt_core::image::Image::read_exr(&path)
        .with_context(|| format!("reading the reference image of view {k}"))?;
    if (r.width, r.height) != (img.width, img.height) {
        bail!(
            "{}: {}x{} but the camera renders {}x{}",
            path.display(),
            r.width,
            r.height,
            img.width,
            img.height
        );
    }
    Ok(fipt_core::metrics::srgb_psnr(&img.data, &r.data, None).unwrap_or(f64::NAN))
}

fn write_metrics(out: &Path, rows: &[(usize, f64)], raw: &[(usize, f64)]) -> Result<()> {
    let table = |rows: &[(usize, f64)]| serde_json::json!({ "mean": mean_psnr(rows), "views": rows.iter().map(|(k, p)| serde_json::json!({"view": k, "srgb_psnr": p})).collect::<Vec<_>>() });
    let mut json = serde_json::json!({ "render_psnr": table(rows) });
    if !raw.is_empty() {
        json["render_raw_psnr"] = table(raw);
    }
    fipt_core::fsutil::write_json_atomic(&out.join("metrics.json"), &json)?;
    Ok(())
}

/// The mean of the views' PSNRs.
pub fn mean_psnr(rows: &[(usize, f64)]) -> f64 {
    rows.iter().map(|r| r.1).sum::<f64>() / rows.len().max(1) as f64
}

/// `{k:03}_render.exr` and the maps of the rendered surfaces, with PNG previews.
fn write_flat(
    dir: &Path,
    k: usize,
    img: &fipt_core::image::Image,
    aovs: &fipt_shading::render::Aovs,
) -> Result<()> {
    let maps = [
        ("render", img, ExrPrecision::F32),
        ("kd", &aovs.kd, ExrPrecision::F16),
        ("ks", &aovs.ks, ExrPrecision::F16),
        ("roughness", &aovs.roughness, ExrPrecision::F16),
        ("metallic", &aovs.metallic, ExrPrecision::F16),
        ("emission", &aovs.emission, ExrPrecision::F32),
    ];
    for (name, m, prec) in maps {
        m.write_exr(&dir.join(format!("{k:03}_{name}.exr")), prec)?;
        m.write_png(&dir.join("preview").join(format!("{k:03}_{name}.png")), 1.0)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lights files of one name (`a/light.json`, `b/light.json`, the same file twice) each
    /// get a folder of their own.
    #[test]
    fn lights_files_of_one_name_get_folders_of_their_own() {
        let (a, b, c) = (
            Path::new("a/light.json"),
            Path::new("b/light.json"),
            Path::new("c/dusk.json"),
        );
        let names = set_folders(&[Some(a), Some(b), Some(c), Some(a)]);
        assert_eq!(names, ["light", "light-2", "dusk", "light-3"]);
    }

    /// `--views`: all cameras without it; a view out of range or listed twice is refused,
    /// naming it.
    #[test]
    fn requested_views_are_in_range_and_listed_once() {
        let ask = |views: Option<Vec<usize>>| RenderRequest {
            source: PathBuf::from("run"),
            materials: None,
            scene: None,
            cameras: PathBuf::from("cams/transforms.json"),
            out: PathBuf::from("out"),
            size: None,
            spp: 1,
            max_bounces: 1,
            seed: 0,
            views,
            brdf: None,
            lights: vec![],
            emitters: None,
            edits: None,
            reference: None,
            denoise: None,
        };
        assert_eq!(requested_views(&ask(None), 3).unwrap(), [0, 1, 2]);
        assert_eq!(requested_views(&ask(Some(vec![2, 0])), 3).unwrap(), [2, 0]);
        let twice = requested_views(&ask(Some(vec![0, 1, 0])), 3).unwrap_err();
        assert!(
            twice.to_string().contains("view 0 is listed twice"),
            "{twice}"
        );
        let far = requested_views(&ask(Some(vec![3])), 3).unwrap_err();
        assert!(
            far.to_string().contains("view 3 requested") && far.to_string().contains("3 cameras"),
            "{far}"
        );
    }

    /// `--reference` on a folder of JPEGs says why it cannot compare, and what to run instead.
    #[test]
    fn a_reference_folder_of_photos_is_refused_with_the_way_to_score_them() {
        let dir = std::env::temp_dir().join(format!("fipt-ref-photos-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("Image")).unwrap();
        std::fs::write(dir.join("Image/000_0001.jpg"), b"jpeg").unwrap();
        let e = reference_dir(&dir).unwrap_err().to_string();
        assert!(
            e.contains("1 8-bit photo") && e.contains("--cameras-from"),
            "{e}"
        );
        std::fs::write(dir.join("Image/000_0001.exr"), b"exr").unwrap();
        assert_eq!(reference_dir(&dir).unwrap(), dir.join("Image"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
