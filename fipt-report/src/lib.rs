//! # fipt-report
//!
//! What a finished `fipt run` looks like, for people who look before they read:
//! * `report/sheet_<split>.png`: a contact sheet per split, one row per view (up to
//!   [`Options::views`]): input | re-render | error | kd | σ | metallic | emission, and under
//!   it, when the scene has ground truth, a row with the true kd | σ | metallic | emission
//!   under their columns;
//! * `report.html`: a static page (opens from disk, no server, no network) with per view a
//!   slider between the input and the re-render, the error map, the material maps beside the
//!   ground truth, the lights with their power, the metrics and the per-stage timings, and the
//!   speed/accuracy plot when the folder has one (`sweep.png`).
//!
//! The page checks itself when it loads: it sets `data-images` (images on the page),
//! `data-images-bad` (images that did not decode) and `data-errors` (script and load errors)
//! on `<body>`, which a headless browser's DOM dump reads.
mod font;
mod html;
pub mod photo;
mod sheet;

use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::image::Image;
use std::path::{Path, PathBuf};

pub use html::{esc, write_html};

/// A relighting strip: the PNGs `pictures` (one view under several lights) side by side.
pub fn write_strip(pictures: &[PathBuf], path: &Path) -> Result<()> {
    let imgs: Vec<Option<image::RgbImage>> = pictures
        .iter()
        .map(|p| image::open(p).ok().map(|i| i.to_rgb8()))
        .collect();
    let Some(first) = imgs.iter().flatten().next() else {
        return Err(ReportError::Io {
            path: path.to_path_buf(),
            message: "no picture to put in the strip".into(),
        });
    };
    let (w, h) = first.dimensions();
    let n = imgs.len() as u32;
    // Each column is named by the folder of its light set (`<set>/preview/<picture>`).
    let columns: Vec<String> = pictures
        .iter()
        .map(|p| {
            let dir = p.parent().filter(|d| d.ends_with("preview"));
            (dir.map_or(p.parent(), |d| d.parent()))
                .and_then(|d| d.file_name())
                .map_or(String::new(), |d| d.to_string_lossy().into_owned())
        })
        .collect();
    let labels = sheet::Labels {
        columns: &columns,
        rows: &[],
    };
    sheet::tile(&[imgs], n, w, h, &labels, path)
}

/// Errors of report writing.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(transparent)]
    Core(#[from] fipt_core::CoreError),
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
}

pub type Result<T, E = ReportError> = std::result::Result<T, E>;

/// Report settings.
#[derive(Clone, Debug)]
pub struct Options {
    /// Views per split shown (the first ones).
    pub views: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options { views: 4 }
    }
}

/// The material maps of the sheet and the page: name in `views/`, ground-truth kind, label.
pub const MAPS: [(&str, GtKind, &str); 4] = [
    ("kd", GtKind::DiffCol, "kd"),
    ("roughness", GtKind::Roughness, "σ"),
    ("metallic", GtKind::Metallic, "metallic"),
    ("emission", GtKind::Emit, "emission"),
];

/// One view of a split as the report shows it (paths relative to the run folder).
#[derive(Clone, Debug)]
pub struct ViewPictures {
    pub split: String,
    pub index: usize,
    /// Picture size in pixels.
    pub width: usize,
    pub height: usize,
    pub input: String,
    pub render: Option<String>,
    pub error: Option<String>,
    /// Per map of [`MAPS`]: the recovered picture and the ground truth's.
    pub maps: Vec<(Option<String>, Option<String>)>,
    /// sRGB PSNR of the re-render against the input.
    pub psnr: Option<f64>,
    /// kd at the ends of the range of each light the views do not pin (picture, caption).
    pub light_ends: Vec<(String, String)>,
}

/// The file stem (in `views/<split>/`, and `preview/` for its PNG) of view `k`'s kd map with
/// light `light` at the `end` ("lower" or "upper") of its range.
pub fn light_end_stem(k: usize, light: usize, end: &str) -> String {
    format!("{k:03}_kd_light{light}_{end}")
}

/// Pixels whose kd changes by more than this share are counted as changed.
const CHANGED: f32 = 0.1;

/// How much of the view kd changes between `kd` and `moved`: the share of its pixels whose
/// luminance changes by more than [`CHANGED`], and their median factor.
fn change(kd: &Image, moved: &Image) -> String {
    use fipt_core::color::luminance;
    let ratios: Vec<f32> = kd
        .data
        .iter()
        .zip(&moved.data)
        .filter(|(a, _)| luminance(**a) > 1e-4)
        .map(|(a, b)| luminance(*b) / luminance(*a))
        .collect();
    let mut changed: Vec<f32> = ratios
        .iter()
        .copied()
        .filter(|r| (r - 1.0).abs() > CHANGED)
        .collect();
    if changed.is_empty() {
        return "no pixel changes by 10 %".into();
    }
    let share = 100.0 * changed.len() as f64 / ratios.len() as f64;
    let digits = usize::from(share < 1.0);
    let median = fipt_core::image::median(&mut changed);
    format!("{share:.digits$} % of the pixels change by more than 10 %, median ×{median:.2}")
}

/// View `k`'s pictures of kd at the ends of the unpinned lights' ranges in `maps_dir`, with
/// captions from the run's `report` (the light's end and chosen value; how much of the view
/// changes and by how much).
fn light_end_pictures(
    run: &Path,
    maps_dir: &Path,
    k: usize,
    report: &serde_json::Value,
) -> Result<Vec<(String, String)>> {
    let estimates = report["capture"]["clipped_lights"]["estimates"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let kd_exr = maps_dir.join(format!("{k:03}_kd.exr"));
    let open = estimates.iter().any(|x| x["pinned"] == false);
    if !open || !kd_exr.is_file() {
        return Ok(vec![]);
    }
    let kd = Image::read_exr(&kd_exr)?;
    let mut out = vec![];
    for (e, x) in estimates.iter().enumerate() {
        for (end, at) in [("lower", 0), ("upper", 1)] {
            let stem = light_end_stem(k, e, end);
            let png = maps_dir.join(format!("preview/{stem}.png"));
            let exr = maps_dir.join(format!("{stem}.exr"));
            if !png.is_file() || !exr.is_file() {
                continue;
            }
            let change = change(&kd, &Image::read_exr(&exr)?);
            let levels = x["range"][at].as_f64().unwrap_or(f64::NAN);
            let caption = format!(
                "kd if clipped light {e} were at the {end} end of its range ({levels:.1} clip levels; chosen {:.1}): {change}",
                x["levels"].as_f64().unwrap_or(f64::NAN)
            );
            out.push((rel(run, &png), caption));
        }
    }
    Ok(out)
}

/// The error heat map of a re-render: |Δ| of the displayed (sRGB) values, mean over channels,
/// ×4, on a black → red → yellow → white ramp.
pub fn error_map(render: &Image, input: &Image) -> Image {
    let disp = |v: f32| fipt_core::color::srgb_oetf(v.clamp(0.0, 1.0));
    let data = render
        .data
        .iter()
        .zip(&input.data)
        .map(|(a, b)| {
            let e = (0..3).map(|c| (disp(a[c]) - disp(b[c])).abs()).sum::<f32>() / 3.0;
            let t = (4.0 * e).clamp(0.0, 1.0) * 3.0;
            // Linear values so that the PNG's sRGB encoding shows the ramp.
            let lin = |v: f32| fipt_core::color::srgb_eotf(v.clamp(0.0, 1.0));
            glam::Vec3::new(lin(t), lin(t - 1.0), lin(t - 2.0))
        })
        .collect();
    Image {
        width: render.width,
        height: render.height,
        data,
    }
}

fn rel(run: &Path, p: &Path) -> String {
    p.strip_prefix(run)
        .unwrap_or(p)
        .to_string_lossy()
        .replace('\\', "/")
}

/// The views of `split` a report of `n` views per split shows: the first ones with a
/// re-render (a run re-renders and maps a share of many training views, `[render]
/// train_pixels`), else the first ones with maps (the re-render switched off), else the first.
pub fn shown_views<'a>(
    run: &Path,
    split: &'a fipt_core::dataset::Split,
    n: usize,
) -> Vec<&'a fipt_core::dataset::View> {
    let maps_dir = run.join("views").join(&split.name);
    let has = |v: &fipt_core::dataset::View, map: &str| {
        maps_dir.join(format!("{:03}_{map}.exr", v.index)).is_file()
    };
    let with =
        |map: &str| -> Vec<_> { split.views.iter().filter(|v| has(v, map)).take(n).collect() };
    for map in ["render", "kd"] {
        let shown = with(map);
        if !shown.is_empty() {
            return shown;
        }
    }
    split.views.iter().take(n).collect()
}

/// Writes the pictures of the report (inputs, error maps, ground truth as PNG under
/// `report/`) and returns what each view shows.
pub fn write_pictures(run: &Path, ds: &Dataset, opts: &Options) -> Result<Vec<ViewPictures>> {
    let mut out = Vec::new();
    let pics = run.join("report");
    // Pictures at the run's working exposure (views far from the canonical one are shown as
    // the pipeline saw them).
    let report = std::fs::read_to_string(run.join("report.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .unwrap_or_default();
    let exposure = report["exposure_scale"].as_f64().unwrap_or(1.0) as f32;
    let normalised = |mut i: Image| {
        if exposure != 1.0 {
            for p in &mut i.data {
                *p /= exposure;
            }
        }
        i
    };
    let mut photo = photo::PhotoModel::of(run);
    // The inputs are shown at the working exposure: so is their clip level.
    photo.clip /= exposure;
    for split in &ds.splits {
        let maps_dir = run.join("views").join(&split.name);
        for v in shown_views(run, split, opts.views) {
            let k = v.index;
            let input = normalised(ds.load_image(v, fipt_core::image::BadPixelPolicy::Clamp)?.0);
            let input_png = pics.join(format!("inputs/{}_{k:03}.png", split.name));
            input.write_png(&input_png, 1.0)?;
            let render_exr = maps_dir.join(format!("{k:03}_render.exr"));
            let (render, error, psnr) = if render_exr.is_file() {
                let r = normalised(Image::read_exr(&render_exr)?);
                if (r.width, r.height) != (input.width, input.height) {
                    return Err(ReportError::Core(fipt_core::CoreError::invalid(
                        &render_exr,
                        format!(
                            "{}×{} pixels but the view is {}×{}: not this scene's re-render (`fipt run` writes it again)",
                            r.width, r.height, input.width, input.height
                        ),
                    )));
                }
                let known = if split.name == "train" {
                    ds.view_exposure(v.index)
                } else {
                    1.0
                };
                let view = (split.name.as_str(), k, known);
                compare(run, &pics, &maps_dir, &photo, view, &r, &input)?
            } else {
                (None, None, None)
            };
            let mut maps = Vec::new();
            for (name, kind, _) in MAPS {
                let png = maps_dir.join(format!("preview/{k:03}_{name}.png"));
                let exr = maps_dir.join(format!("{k:03}_{name}.exr"));
                if !png.is_file() && exr.is_file() {
                    // A deleted preview is drawn again from its map.
                    let img = Image::read_exr(&exr)?;
                    let img = if name == "emission" {
                        normalised(img)
                    } else {
                        img
                    };
                    img.write_png(&png, 1.0)?;
                }
                let mine = png.is_file().then(|| rel(run, &png));
                let gt = match ds.load_gt(split, kind, k)? {
                    Some(img) => {
                        let p = pics.join(format!("gt/{}_{k:03}_{name}.png", split.name));
                        img.write_png(&p, 1.0)?;
                        Some(rel(run, &p))
                    }
                    None => None,
                };
                maps.push((mine, gt));
            }
            out.push(ViewPictures {
                split: split.name.clone(),
                index: k,
                width: input.width,
                height: input.height,
                input: rel(run, &input_png),
                render,
                error,
                maps,
                psnr,
                light_ends: light_end_pictures(run, &maps_dir, k, &report)?,
            });
        }
    }
    Ok(out)
}

/// The re-render `r` of view (split, k, known exposure) against its `input`: the picture the
/// slider shows, the error map, the PSNR. LDR views: the render as the camera would have
/// taken it ([`photo::PhotoModel`]), the photo's clipped pixels blue and not scored.
fn compare(
    run: &Path,
    pics: &Path,
    maps_dir: &Path,
    photo: &photo::PhotoModel,
    (split, k, known): (&str, usize, f32),
    r: &Image,
    input: &Image,
) -> Result<(Option<String>, Option<String>, Option<f64>)> {
    let e = pics.join(format!("error/{split}_{k:03}.png"));
    if !photo.ldr {
        error_map(r, input).write_png(&e, 1.0)?;
        let p = fipt_core::metrics::srgb_psnr(&r.data, &input.data, None);
        let png = maps_dir.join(format!("preview/{k:03}_render.png"));
        return Ok((Some(rel(run, &png)), Some(rel(run, &e)), p));
    }
    // Like with like: the render at the view's exposure, through the camera, clipped.
    let gain = (split == "train")
        .then(|| {
            photo
                .train_gains
                .as_ref()
                .and_then(|g| g.get(k))
                .map(|g| g * known)
        })
        .flatten();
    let shown = photo.as_photo(r, input, gain);
    let mut err = error_map(&shown.image, input);
    for (p, c) in err.data.iter_mut().zip(&shown.clipped) {
        if *c {
            *p = glam::Vec3::new(0.0, 0.05, 0.6);
        }
    }
    err.write_png(&e, 1.0)?;
    let keep: Vec<bool> = shown.clipped.iter().map(|c| !c).collect();
    let p = fipt_core::metrics::srgb_psnr(&shown.image.data, &input.data, Some(&keep));
    let png = pics.join(format!("as_photo/{split}_{k:03}.png"));
    shown.image.write_png(&png, 1.0)?;
    Ok((Some(rel(run, &png)), Some(rel(run, &e)), p))
}

/// Writes every picture, the contact sheets and `report.html` of the run folder `run` of
/// scene `ds`; returns the files written.
pub fn write_report(run: &Path, ds: &Dataset, opts: &Options) -> Result<Vec<PathBuf>> {
    let views = write_pictures(run, ds, opts)?;
    let mut files = Vec::new();
    for split in &ds.splits {
        let rows: Vec<&ViewPictures> = views.iter().filter(|v| v.split == split.name).collect();
        if rows.is_empty() {
            continue;
        }
        let p = run.join(format!("report/sheet_{}.png", split.name));
        sheet::write_sheet(run, &rows, &p)?;
        files.push(p);
    }
    let splits: Vec<(String, usize)> = ds
        .splits
        .iter()
        .map(|s| (s.name.clone(), s.views.len()))
        .collect();
    files.push(write_html(run, &views, &splits)?);
    Ok(files)
}
