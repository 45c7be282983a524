//! `fipt degrade`: a capture-like copy of a scene with ground truth: the real layout, poses
//! off by a known amount, pixel noise, 8-bit photos at one exposure or each view's own, JPEG,
//! and a denser mesh warped smoothly by millimetres (a scan). What was done to each view is
//! written to `DST/degrade.json` (the gains, the pose offsets, the warp), which no stage reads:
//! it is for scoring (`fipt eval SRC OUT --cameras-from SRC`) and for tests.
use crate::bail;
use crate::error::{Context, Result};
use crate::observe::Stage;
use fipt_core::camera::Camera;
use fipt_core::capture::{LdrFormat, Response};
use fipt_core::color::{luminance, Rgb};
use fipt_core::dataset::{image_file_name, write_cam_list, write_transforms, Dataset, Split};
use fipt_core::image::{BadPixelPolicy, ExrPrecision, Image};
use fipt_core::rng::Pcg32;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The file a copy's record goes to.
pub const RECORD_FILE: &str = "degrade.json";

/// Middle grey: what a camera's metering maps the median luminance to.
pub const METERED_GREY: f32 = 0.18;

/// How the copy is exposed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LdrMode {
    /// Linear HDR values, as the source.
    None,
    /// 8-bit through sRGB, one exposure for all views (the training views' median luminance
    /// to middle grey): the lights clip.
    Fixed,
    /// 8-bit through sRGB, each view's own exposure (its median luminance to middle grey).
    Auto,
}

/// What a camera's auto-exposure meters on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Meter {
    /// The median luminance to middle grey ([`METERED_GREY`]).
    Median,
    /// The brightest pixels (the 99.5th percentile of luminance) to 0.9: a view with a light
    /// in it is exposed for the light and its surfaces come out dark.
    Lights,
}

impl Meter {
    /// The gain that maps luminances `l` to the metered value (1 for a black set).
    fn gain(self, l: &mut [f32]) -> f32 {
        let m = match self {
            Meter::Median => fipt_core::image::median(l),
            Meter::Lights if l.is_empty() => 0.0,
            Meter::Lights => {
                let k = ((l.len() as f64 * 0.995) as usize).min(l.len().saturating_sub(1));
                l.select_nth_unstable_by(k, f32::total_cmp).1.to_owned()
            }
        };
        let target = match self {
            Meter::Median => METERED_GREY,
            Meter::Lights => 0.9,
        };
        if m > 0.0 {
            target / m
        } else {
            1.0
        }
    }
}

/// A camera's tone curve, as `fipt degrade --tone` names it: `srgb`, `gamma:G`, `scurve:A`
/// (sRGB, then a contrast S-curve of strength A about stored 0.5, as phones do) or `filmic`
/// (sRGB, then lifted shadows and a rolled-off shoulder). Returned as the response a
/// `capture.json` would state (a table of 257 linear values for the last two).
pub fn tone_curve(name: &str) -> std::result::Result<Response, String> {
    let (kind, arg) = name
        .split_once(':')
        .map_or((name, None), |(k, a)| (k, Some(a)));
    let number = |what: &str| -> std::result::Result<f32, String> {
        arg.and_then(|a| a.parse::<f32>().ok())
            .filter(|x| x.is_finite() && (0.2..=5.0).contains(x))
            .ok_or_else(|| format!("--tone {name}: give {what} in [0.2, 5] (e.g. {kind}:1.5)"))
    };
    let over_srgb = |stored: &dyn Fn(f64) -> f64| -> Response {
        // The inverse of stored(t) (t the sRGB value) by bisection, at 257 stored values.
        let t_of = |s: f64| {
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if stored(mid) < s {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            0.5 * (lo + hi)
        };
        Response::Table(
            (0..=256)
                .map(|k| fipt_core::color::srgb_eotf(t_of(k as f64 / 256.0) as f32))
                .collect(),
        )
    };
    match kind {
        "srgb" if arg.is_none() => Ok(Response::Srgb),
        "gamma" => Ok(Response::Gamma(number("a gamma")?)),
        "scurve" => {
            let a = number("a strength")? as f64;
            Ok(over_srgb(&|t: f64| {
                t.powf(a) / (t.powf(a) + (1.0 - t).powf(a))
            }))
        }
        "filmic" if arg.is_none() => Ok(over_srgb(&|t: f64| {
            let s = t.powf(1.4) / (t.powf(1.4) + 0.55 * (1.0 - t).powf(1.4));
            s.clamp(0.0, 1.0)
        })),
        _ => Err(format!(
            "--tone {name}: give srgb, gamma:G, scurve:A or filmic"
        )),
    }
}

/// The copy's file format of the views.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ViewFormat {
    Exr,
    Png,
    Jpg,
}

/// The copy's layout: the source's, or one of a capture's (the training views only, no
/// ground truth).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CopyLayout {
    /// The source's layout, with its splits and ground truth.
    Same,
    /// FIPT's real layout: `cam.txt`, `K_list.txt`, `Image/`.
    Real,
    /// A COLMAP text model in `sparse/0/`, views in `images/`.
    ColmapText,
    /// A COLMAP binary model in `sparse/0/`, views in `images/`.
    ColmapBinary,
    /// A nerfstudio `transforms.json` (OpenGL poses), views in `images/`.
    Nerfstudio,
}

impl CopyLayout {
    /// A layout of the training views alone (every one but `Same`).
    pub fn captures_only(self) -> bool {
        self != CopyLayout::Same
    }
}

/// What `fipt degrade` does.
#[derive(Clone, Debug, Serialize)]
pub struct DegradeRequest {
    pub source: PathBuf,
    pub out: PathBuf,
    /// The copy's layout.
    pub layout: CopyLayout,
    /// The lens the copy's views are seen through, resampled from the source's views (the
    /// focal length lengthened so that every pixel stays inside the source's view): a lens
    /// for the COLMAP and nerfstudio layouts, or the pinhole (undistorted copies of a lensed
    /// source). None keeps the source's cameras.
    pub lens: Option<fipt_core::distortion::Distortion>,
    /// Leave out every ground-truth folder, `scene_gt.json` and `scene_parts.json`.
    pub drop_gt: bool,
    /// Each camera moved by this many millimetres in a random direction…
    pub pose_mm: f32,
    /// …and turned by this many degrees about a random axis.
    pub pose_deg: f32,
    /// Multiplicative Gaussian noise per pixel and channel (0.03 = 3 %).
    pub pixel_noise: f32,
    pub ldr: LdrMode,
    /// The camera's tone curve for LDR copies ([`tone_curve`]); recorded as the true response.
    pub tone: Response,
    /// What auto-exposure (and the fixed exposure) meters on.
    pub meter: Meter,
    pub format: ViewFormat,
    pub jpeg_quality: u8,
    /// Each view enlarged this many times (every pixel an N×N block; the intrinsics
    /// multiplied): photos larger than the method needs, for `fipt run --downscale N`, which
    /// gives the views back exactly (from PNG and EXR views).
    pub upscale: usize,
    /// Write each JPEG view's exposure into its EXIF, as a camera does (time = gain / 100 s
    /// at ISO 100 and f/2: the relative exposures are the gains).
    pub exif: bool,
    /// Subdivision levels of the mesh (every triangle into 4^K).
    pub subdivide: u32,
    /// Largest displacement of the smooth mesh warp, millimetres.
    pub warp_mm: f32,
    /// A scanner's ripple on top: largest displacement in millimetres (0: none)…
    pub ripple_mm: f32,
    /// …and its wavelength in centimetres; the mesh is first refined to edges of a sixth of it.
    pub ripple_cm: f32,
    pub seed: u64,
}

/// What was done to one view.
#[derive(Clone, Debug, Serialize)]
pub struct ViewRecord {
    pub split: String,
    pub index: usize,
    /// The factor the radiance was multiplied by before the response (1 for HDR).
    pub gain: f32,
    /// Share of the view's pixels that clipped.
    pub clipped_share: f64,
    pub offset_mm: [f32; 3],
    pub turn_deg: f32,
}

/// `degrade.json`.
#[derive(Clone, Debug, Serialize)]
pub struct DegradeRecord {
    pub fipt_version: &'static str,
    pub request: DegradeRequest,
    pub triangles: usize,
    /// With a ripple (the mesh refined): per file face of the source's mesh, the index of its
    /// first triangle in the copy's (one more entry at the end). `fipt eval --ceiling` reads it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub face_starts: Option<Vec<u32>>,
    pub views: Vec<ViewRecord>,
    /// The copy's views are at 1/gain of the source's radiance (for `ldr = fixed`, one gain).
    pub note: String,
}

/// Checks the request before any work.
fn validate(a: &DegradeRequest) -> Result<()> {
    let finite_in = |v: f32, lo: f32, hi: f32| v.is_finite() && (lo..=hi).contains(&v);
    if !finite_in(a.pose_mm, 0.0, 1000.0) || !finite_in(a.pose_deg, 0.0, 45.0) {
        bail!(
            "--pose-noise {},{}: give millimetres in [0, 1000] and degrees in [0, 45]",
            a.pose_mm,
            a.pose_deg
        );
    }
    if !finite_in(a.pixel_noise, 0.0, 1.0) {
        bail!(
            "--pixel-noise {}: give a relative standard deviation in [0, 1] (0.03 = 3 %)",
            a.pixel_noise
        );
    }
    if !finite_in(a.warp_mm, 0.0, 1000.0) {
        bail!("--mesh-warp {}: give millimetres in [0, 1000]", a.warp_mm);
    }
    if !finite_in(a.ripple_mm, 0.0, 100.0) || !finite_in(a.ripple_cm, 0.0, 1000.0) {
        bail!(
            "--mesh-ripple {},{}: give millimetres in [0, 100] and centimetres in [0, 1000]",
            a.ripple_mm,
            a.ripple_cm
        );
    }
    if a.ripple_mm > 0.0 && a.ripple_cm < 1.0 {
        bail!(
            "--mesh-ripple {},{}: a wavelength under 1 cm needs edges under 1.7 mm; give at least 1 cm",
            a.ripple_mm,
            a.ripple_cm
        );
    }
    if a.subdivide > 4 {
        bail!(
            "--subdivide {}: at most 4 (256 triangles per triangle)",
            a.subdivide
        );
    }
    if !(1..=100).contains(&a.jpeg_quality) {
        bail!("--jpeg-quality {}: give 1 to 100", a.jpeg_quality);
    }
    if a.lens.is_some_and(|l| !l.is_none())
        && !matches!(
            a.layout,
            CopyLayout::ColmapText | CopyLayout::ColmapBinary | CopyLayout::Nerfstudio
        )
    {
        bail!("--lens: a lens model is written by the COLMAP and nerfstudio layouts only; pass --layout colmap-text, colmap-binary or nerfstudio");
    }
    if !(1..=32).contains(&a.upscale) {
        bail!("--upscale {}: give 1 to 32", a.upscale);
    }
    if a.upscale > 1 && !a.layout.captures_only() && !a.drop_gt {
        bail!("--upscale: the ground truth stays at the source's size; pass --drop-gt or a capture layout (--layout real, …)");
    }
    if a.ldr == LdrMode::None && (a.tone != Response::Srgb || a.meter != Meter::Median) {
        bail!("--tone and --meter shape 8-bit photos; pass --ldr fixed or --ldr auto");
    }
    if a.exif && a.format != ViewFormat::Jpg {
        bail!("--exif: EXIF is written into JPEG views; pass --format jpg");
    }
    if a.ldr == LdrMode::None && a.format != ViewFormat::Exr {
        bail!("--format {:?}: PNG and JPEG hold 8-bit values; pass --ldr fixed or --ldr auto (or --format exr)", a.format);
    }
    let src = a
        .source
        .canonicalize()
        .with_context(|| format!("{}: no such folder", a.source.display()))?;
    // Resolved whether or not it exists yet: a copy made inside its source would be a
    // folder of the source scene.
    let out = fipt_core::lock::resolved(&a.out)?;
    if out.starts_with(&src) || src.starts_with(&out) {
        bail!(
            "{}: the copy must go to a folder outside the source {} (and not hold it)",
            a.out.display(),
            a.source.display()
        );
    }
    if a.out.is_dir()
        && !a.out.join(RECORD_FILE).is_file()
        && std::fs::read_dir(&a.out)?.next().is_some()
    {
        bail!(
            "{}: a folder that is not empty and was not made by `fipt degrade`; choose a new one",
            a.out.display()
        );
    }
    Ok(())
}

/// Makes the copy; returns its record (also written to `DST/degrade.json`).
pub fn degrade(a: &DegradeRequest) -> Result<DegradeRecord> {
    validate(a)?;
    fipt_core::lock::output_folder(&a.out)?;
    let ds = Dataset::open(&a.source)
        .with_context(|| format!("opening scene {}", a.source.display()))?;
    // The mesh first: a refused ripple leaves an earlier copy where it was.
    let mesh = crate::degrade_mesh::prepare_mesh(a, &ds)?;
    if a.out.join(RECORD_FILE).is_file() {
        std::fs::remove_dir_all(&a.out)
            .with_context(|| format!("replacing {}", a.out.display()))?;
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let (triangles, face_starts) = crate::degrade_mesh::write_mesh(a, &ds, mesh)?;
    let splits: Vec<&Split> = if a.layout.captures_only() {
        vec![ds.train()]
    } else {
        ds.splits.iter().collect()
    };
    let fixed_gain = match a.ldr {
        LdrMode::Fixed => Some(a.meter.gain(&mut split_luminance(&ds, ds.train())?)),
        _ => None,
    };
    let mut views = vec![];
    for s in splits {
        let st = Stage::start(&format!("degrade {}", s.name));
        let dir = if a.layout.captures_only() {
            a.out.clone()
        } else {
            a.out.join(&s.name)
        };
        let cams: Vec<(Camera, [f32; 3], f32)> = s
            .views
            .iter()
            .map(|v| moved(a, &s.name, v.index, &v.camera))
            .collect();
        // The lens: rays leave the copy's cameras through it, from the source's true poses.
        let lensed: Vec<Camera> = s
            .views
            .iter()
            .map(|v| {
                let l = a
                    .lens
                    .map_or_else(|| v.camera.clone(), |lens| with_lens(&v.camera, lens));
                Camera {
                    distortion: l.distortion,
                    fx: l.fx,
                    fy: l.fy,
                    ..v.camera.clone()
                }
            })
            .collect();
        let cameras: Vec<Camera> = cams
            .iter()
            .zip(&lensed)
            .map(|(c, l)| Camera {
                distortion: l.distortion,
                fx: l.fx,
                fy: l.fy,
                ..c.0.clone()
            })
            .map(|c| c.upscaled(a.upscale))
            .collect();
        let images_dir = write_cameras(a, &dir, &cameras)?;
        let recs: Vec<Result<ViewRecord>> = s
            .views
            .par_iter()
            .zip(&cams)
            .zip(&lensed)
            .map(|((v, (_, offset_mm, turn_deg)), lens_cam)| {
                let img = ds.load_image(v, BadPixelPolicy::Clamp)?.0;
                let img = if a.lens.is_none() {
                    img
                } else {
                    resample(&img, &v.camera, lens_cam)
                };
                let img = upscaled(&img, a.upscale);
                let (gain, clipped_share) =
                    write_view(a, &s.name, v.index, img, fixed_gain, &images_dir)?;
                Ok(ViewRecord {
                    split: s.name.clone(),
                    index: v.index,
                    gain,
                    clipped_share,
                    offset_mm: *offset_mm,
                    turn_deg: *turn_deg,
                })
            })
            .collect();
        for r in recs {
            views.push(r?);
        }
        if !a.layout.captures_only() && !a.drop_gt {
            copy_gt(s, &dir)?;
        }
        st.done();
    }
    if !a.drop_gt && !a.layout.captures_only() && a.subdivide == 0 && face_starts.is_none() {
        for f in ["scene_gt.json", "scene_parts.json"] {
            if ds.root.join(f).is_file() {
                std::fs::copy(ds.root.join(f), a.out.join(f))?;
            }
        }
    }
    let note = note_of(a.ldr, fixed_gain);
    let record = DegradeRecord {
        fipt_version: env!("CARGO_PKG_VERSION"),
        request: a.clone(),
        triangles,
        face_starts,
        views,
        note,
    };
    fipt_core::fsutil::write_json_atomic(&a.out.join(RECORD_FILE), &record)?;
    Ok(record)
}

/// Writes the copy's camera files in its layout; returns the folder its views go to.
fn write_cameras(a: &DegradeRequest, dir: &Path, cameras: &[Camera]) -> Result<PathBuf> {
    let name = |k: usize| format!("images/{}", image_file_name(k));
    let ext = match a.format {
        ViewFormat::Exr => "exr",
        ViewFormat::Png => "png",
        ViewFormat::Jpg => "jpg",
    };
    let named: Vec<(String, Camera)> = cameras
        .iter()
        .enumerate()
        .map(|(k, c)| {
            (
                Path::new(&name(k))
                    .with_extension(ext)
                    .to_string_lossy()
                    .into_owned(),
                c.clone(),
            )
        })
        .collect();
    match a.layout {
        CopyLayout::Same => {
            write_transforms(&dir.join("transforms.json"), cameras)?;
            Ok(dir.join("Image"))
        }
        CopyLayout::Real => {
            write_cam_list(&dir.join("cam.txt"), &dir.join("K_list.txt"), cameras)?;
            Ok(dir.join("Image"))
        }
        CopyLayout::ColmapText | CopyLayout::ColmapBinary => {
            // COLMAP names images relative to images/.
            let in_images: Vec<(String, Camera)> = named
                .iter()
                .map(|(n, c)| (n.trim_start_matches("images/").to_string(), c.clone()))
                .collect();
            let model = dir.join("sparse/0");
            std::fs::create_dir_all(&model)?;
            fipt_core::colmap::write_model(&model, &in_images, a.layout == CopyLayout::ColmapText)?;
            Ok(dir.join("images"))
        }
        CopyLayout::Nerfstudio => {
            let frames: Vec<(String, Camera, Option<String>)> =
                named.into_iter().map(|(n, c)| (n, c, None)).collect();
            fipt_core::nerfstudio::write(&dir.join("transforms.json"), &frames)?;
            Ok(dir.join("images"))
        }
    }
}

/// `cam` seen through `lens`, its focal length lengthened so that every pixel's ray stays
/// inside `cam`'s own view (the copy's views are resampled from the source's).
fn with_lens(cam: &Camera, lens: fipt_core::distortion::Distortion) -> Camera {
    if lens == cam.distortion {
        return cam.clone();
    }
    // In camera space (the pose left out), so that cameras of one intrinsics get one focal.
    let cam = &Camera {
        rotation: glam::Mat3::IDENTITY,
        origin: Vec3::ZERO,
        ..cam.clone()
    };
    let mut c = cam.clone();
    c.distortion = lens;
    let (w, h) = (cam.width as f32, cam.height as f32);
    for _ in 0..20 {
        // How far past the source's frame the border pixels' rays land (1: on its edge).
        let mut reach = 0.0f32;
        for i in 0..=64 {
            let t = i as f32 / 64.0;
            for (u, v) in [(t * w, 0.0), (t * w, h), (0.0, t * h), (w, t * h)] {
                let (_, d) = c.ray(u, v);
                let r = cam.project(cam.origin + d).map_or(4.0, |p| {
                    ((p.x - cam.cx).abs() / cam.cx.max(w - cam.cx))
                        .max((p.y - cam.cy).abs() / cam.cy.max(h - cam.cy))
                });
                reach = reach.max(r);
            }
        }
        if reach <= 1.0 + 1e-4 {
            break;
        }
        c.fx *= reach;
        c.fy *= reach;
    }
    c
}

/// `img` with every pixel an `n`×`n` block.
fn upscaled(img: &Image, n: usize) -> Image {
    if n <= 1 {
        return img.clone();
    }
    let mut out = Image::new(img.width * n, img.height * n);
    for (k, p) in out.data.iter_mut().enumerate() {
        let (x, y) = (k % (img.width * n) / n, k / (img.width * n) / n);
        *p = img.data[y * img.width + x];
    }
    out
}

/// The image `lens_cam` sees, bilinearly resampled from `img` taken by `src` (same pose).
fn resample(img: &Image, src: &Camera, lens_cam: &Camera) -> Image {
    let (w, h) = (img.width, img.height);
    let at = |x: i64, y: i64| {
        img.data[(y.clamp(0, h as i64 - 1) as usize) * w + x.clamp(0, w as i64 - 1) as usize]
    };
    let mut out = Image::new(w, h);
    for j in 0..h {
        for i in 0..w {
            let (_, d) = lens_cam.pixel_center_ray(i, j);
            let Some(p) = src.project(src.origin + d) else {
                continue;
            };
            let (x, y) = (p.x - 0.5, p.y - 0.5);
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            out.data[j * w + i] = (at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx) * (1.0 - fy)
                + (at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx) * fy;
        }
    }
    out
}

/// `degrade.json`'s note: how the copy's stored values relate to the source's radiance.
fn note_of(ldr: LdrMode, fixed_gain: Option<f32>) -> String {
    match ldr {
        LdrMode::None => "HDR: the views are the source's radiance (with the noise)".into(),
        LdrMode::Fixed => format!("8-bit at one exposure: stored = tone(min(1, {:.4e} × radiance)), tone = request.tone", fixed_gain.unwrap_or(1.0)),
        LdrMode::Auto => "8-bit at each view's exposure: stored = tone(min(1, gain × radiance)), tone = request.tone, gain per view below".into(),
    }
}

/// A split's luminances (every 7th pixel of every view), checked not all black.
fn split_luminance(ds: &Dataset, s: &Split) -> Result<Vec<f32>> {
    let mut l: Vec<f32> = vec![];
    for v in &s.views {
        let img = ds.load_image(v, BadPixelPolicy::Clamp)?.0;
        l.extend(img.data.iter().step_by(7).map(|&p| luminance(p)));
    }
    let m = fipt_core::image::median(&mut l.clone());
    if !(m > 0.0) {
        bail!(
            "{}: the median training pixel is black; an exposure cannot be metered",
            ds.root.display()
        );
    }
    Ok(l)
}

/// The camera of view `k` of `split`, moved and turned as asked: (camera, offset in mm, turn
/// in degrees).
fn moved(a: &DegradeRequest, split: &str, k: usize, cam: &Camera) -> (Camera, [f32; 3], f32) {
    if a.pose_mm == 0.0 && a.pose_deg == 0.0 {
        return (cam.clone(), [0.0; 3], 0.0);
    }
    let mut rng = Pcg32::from_keys(&[
        a.seed,
        0x9053,
        split.len() as u64,
        split.as_bytes()[0] as u64,
        k as u64,
    ]);
    let offset = unit_vector(&mut rng) * (a.pose_mm / 1000.0);
    let turn = Mat3::from_axis_angle(unit_vector(&mut rng), a.pose_deg.to_radians());
    (
        cam.moved(offset, turn),
        (offset * 1000.0).to_array(),
        a.pose_deg,
    )
}

fn unit_vector(rng: &mut Pcg32) -> Vec3 {
    loop {
        let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE;
        if (1e-4..=1.0).contains(&v.length_squared()) {
            return v.normalize();
        }
    }
}

/// A standard normal sample (Box–Muller).
fn gauss(rng: &mut Pcg32) -> f32 {
    let u1 = rng.next_f32().max(1e-7);
    let u2 = rng.next_f32();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}

/// Noise, exposure, response and format for one view; returns its gain and clipped share.
fn write_view(
    a: &DegradeRequest,
    split: &str,
    k: usize,
    mut img: Image,
    fixed_gain: Option<f32>,
    dir: &Path,
) -> Result<(f32, f64)> {
    if a.pixel_noise > 0.0 {
        let mut rng = Pcg32::from_keys(&[a.seed, 0x6e01, split.as_bytes()[0] as u64, k as u64]);
        for p in &mut img.data {
            let n = Rgb::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng));
            *p = (*p * (Rgb::ONE + n * a.pixel_noise)).max(Rgb::ZERO);
        }
    }
    let name = image_file_name(k);
    if a.ldr == LdrMode::None {
        img.write_exr(&dir.join(&name), ExrPrecision::F32)?;
        return Ok((1.0, 0.0));
    }
    let gain = match fixed_gain {
        Some(g) => g,
        None => a
            .meter
            .gain(&mut img.data.iter().map(|&p| luminance(p)).collect::<Vec<_>>()),
    };
    let r = &a.tone;
    let clipped = img
        .data
        .iter()
        .filter(|p| p.max_element() * gain >= 1.0)
        .count();
    let stored = Image {
        width: img.width,
        height: img.height,
        data: img
            .data
            .iter()
            .map(|&p| Rgb::from_array((p * gain).to_array().map(|v| r.to_stored(v))))
            .collect(),
    };
    match a.format {
        ViewFormat::Png => fipt_core::capture::write_ldr(
            &dir.join(&name).with_extension("png"),
            &stored,
            LdrFormat::Png,
        )?,
        ViewFormat::Jpg => {
            let path = dir.join(&name).with_extension("jpg");
            fipt_core::capture::write_ldr(&path, &stored, LdrFormat::Jpeg(a.jpeg_quality))?;
            if a.exif {
                write_exif(&path, gain)?;
            }
        }
        ViewFormat::Exr => {
            // 8-bit steps, decoded back to linear: an LDR photo in an EXR.
            let q = |v: f32| r.to_linear(fipt_core::capture::quantise8(v) as f32 / 255.0);
            let lin = Image {
                data: stored
                    .data
                    .iter()
                    .map(|p| Rgb::from_array(p.to_array().map(q)))
                    .collect(),
                ..stored
            };
            lin.write_exr(&dir.join(&name), ExrPrecision::F32)?;
        }
    }
    Ok((gain, clipped as f64 / img.data.len().max(1) as f64))
}

/// Rewrites the JPEG at `path` with the EXIF a camera would give a view of `gain`.
fn write_exif(path: &Path, gain: f32) -> Result<()> {
    let exp = fipt_core::exif::ExifExposure {
        exposure_time: Some(gain / 100.0),
        f_number: Some(2.0),
        iso: Some(100.0),
        camera: Some("fipt degrade".into()),
    };
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let with = fipt_core::exif::jpeg_with_exif(&bytes, &exp)
        .map_err(|e| crate::err!("{}: {e}", path.display()))?;
    fipt_core::fsutil::write_bytes_atomic(path, &with)?;
    Ok(())
}

/// Copies a split's ground-truth folders as they are (at the source's cameras).
fn copy_gt(s: &Split, dir: &Path) -> Result<()> {
    for kind in &s.gt {
        let to = dir.join(kind.folder());
        std::fs::create_dir_all(&to)?;
        for v in &s.views {
            let from = s.gt_path(*kind, v.index);
            std::fs::copy(&from, to.join(kind.file_name(v.index)))
                .with_context(|| format!("copying {}", from.display()))?;
        }
    }
    Ok(())
}
