//! `fipt degrade SRC --out DST`: fipt-pipeline's capture simulator, with its options parsed.
use anyhow::{bail, Result};
use fipt_capture::degrade::{degrade, CopyLayout, DegradeRequest, LdrMode, Meter, ViewFormat};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder to copy (any layout; ground truth is kept unless --drop-gt or --layout real).
    source: PathBuf,
    /// The copy's folder (new, or one `fipt degrade` made: it is replaced).
    #[arg(long)]
    out: PathBuf,
    /// `same`: the source's layout. The training views only (no ground truth), as captures
    /// are stored: `real` (cam.txt + K_list.txt + Image/), `colmap-text` or `colmap-binary`
    /// (sparse/0/ + images/), `nerfstudio` (transforms.json + images/).
    #[arg(long, value_enum, default_value = "same")]
    layout: LayoutArg,
    /// The lens the copy's views are seen through: `opencv:K1[,K2,P1,P2,K3]` or
    /// `fisheye:K1[,K2,K3,K4]` (COLMAP and nerfstudio layouts), or `pinhole` (undistorted
    /// copies of a lensed source); the views are resampled from the source's and the focal
    /// length lengthened to stay inside them.
    #[arg(long, value_name = "MODEL:COEFFS")]
    lens: Option<fipt_core::distortion::Distortion>,
    /// Leave out the ground-truth maps and the part tables.
    #[arg(long)]
    drop_gt: bool,
    /// Pose error: MM,DEG (each camera moved by MM millimetres and turned by DEG degrees, in
    /// random directions).
    #[arg(long, value_name = "MM,DEG", default_value = "0,0")]
    pose_noise: String,
    /// Multiplicative Gaussian pixel noise (0.03 = 3 %).
    #[arg(long, default_value_t = 0.0)]
    pixel_noise: f32,
    /// 8-bit sRGB photos: `fixed` (one exposure: the median to middle grey, the lights clip)
    /// or `auto` (each view metered alone); `none` keeps HDR.
    #[arg(long, value_enum, default_value = "none")]
    ldr: LdrArg,
    /// The camera's tone curve of the 8-bit photos: `srgb`, `gamma:G`, `scurve:A` (sRGB then
    /// a contrast S-curve, as phones do) or `filmic` (sRGB, lifted shadows, a rolled-off
    /// shoulder); degrade.json records it as the true response.
    #[arg(long, default_value = "srgb", value_parser = parse_tone)]
    tone: fipt_core::capture::Response,
    /// What the exposure meters on: `median` (to middle grey) or `lights` (the brightest
    /// 0.5 % to 0.9: views with a light in them come out dark).
    #[arg(long, value_enum, default_value = "median")]
    meter: MeterArg,
    /// File format of the views (png and jpg need --ldr).
    #[arg(long, value_enum, default_value = "exr")]
    format: FormatArg,
    #[arg(long, default_value_t = 90)]
    jpeg_quality: u8,
    /// Enlarge every view N times (each pixel an N×N block, the intrinsics with it): a
    /// capture of photos larger than the method needs (`fipt run --downscale N` reads the
    /// views back exactly from PNG or EXR).
    #[arg(long, default_value_t = 1)]
    upscale: usize,
    /// Write each JPEG view's exposure into its EXIF (time = gain / 100 s, ISO 100, f/2), as a
    /// camera does.
    #[arg(long)]
    exif: bool,
    /// Split every triangle into 4^K (a scan is denser than a model).
    #[arg(long, default_value_t = 0)]
    subdivide: u32,
    /// Warp the mesh smoothly by up to this many millimetres.
    #[arg(long, default_value_t = 0.0)]
    mesh_warp: f32,
    /// A scanner's ripple on top of the warp: MM,CM (largest displacement in millimetres,
    /// wavelength in centimetres; it tilts the faces by about 2π·MM/(10·CM) radians). The
    /// mesh is refined to edges of a sixth of the wavelength first; `fipt eval --ceiling`
    /// follows the refinement.
    #[arg(long, value_name = "MM,CM", default_value = "0,0")]
    mesh_ripple: String,
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LayoutArg {
    Same,
    Real,
    ColmapText,
    ColmapBinary,
    Nerfstudio,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LdrArg {
    None,
    Fixed,
    Auto,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum FormatArg {
    Exr,
    Png,
    Jpg,
}

/// Two numbers `A,B` of option `flag`, or an error naming the form expected.
fn pair(flag: &str, text: &str, form: &str) -> Result<(f32, f32)> {
    let parsed = text
        .split_once(',')
        .and_then(|(x, y)| Some((x.trim().parse().ok()?, y.trim().parse().ok()?)));
    match parsed {
        Some(p) => Ok(p),
        None => bail!("{flag} {text}: expected {form}"),
    }
}

pub fn run(a: Args) -> Result<()> {
    let (mm, deg) = pair("--pose-noise", &a.pose_noise, "MM,DEG (e.g. 5,0.15)")?;
    let (ripple_mm, ripple_cm) = pair("--mesh-ripple", &a.mesh_ripple, "MM,CM (e.g. 3,15)")?;
    let req = DegradeRequest {
        source: a.source,
        out: a.out,
        layout: match a.layout {
            LayoutArg::Same => CopyLayout::Same,
            LayoutArg::Real => CopyLayout::Real,
            LayoutArg::ColmapText => CopyLayout::ColmapText,
            LayoutArg::ColmapBinary => CopyLayout::ColmapBinary,
            LayoutArg::Nerfstudio => CopyLayout::Nerfstudio,
        },
        lens: a.lens,
        drop_gt: a.drop_gt,
        pose_mm: mm,
        pose_deg: deg,
        pixel_noise: a.pixel_noise,
        ldr: match a.ldr {
            LdrArg::None => LdrMode::None,
            LdrArg::Fixed => LdrMode::Fixed,
            LdrArg::Auto => LdrMode::Auto,
        },
        format: match a.format {
            FormatArg::Exr => ViewFormat::Exr,
            FormatArg::Png => ViewFormat::Png,
            FormatArg::Jpg => ViewFormat::Jpg,
        },
        jpeg_quality: a.jpeg_quality,
        tone: a.tone,
        meter: match a.meter {
            MeterArg::Median => Meter::Median,
            MeterArg::Lights => Meter::Lights,
        },
        exif: a.exif,
        upscale: a.upscale,
        subdivide: a.subdivide,
        warp_mm: a.mesh_warp,
        ripple_mm,
        ripple_cm,
        seed: a.seed,
    };
    let rec = degrade(&req)?;
    let gains: Vec<f32> = rec.views.iter().map(|v| v.gain).collect();
    let (lo, hi) = gains
        .iter()
        .fold((f32::INFINITY, 0.0f32), |(l, h), &g| (l.min(g), h.max(g)));
    let clipped =
        rec.views.iter().map(|v| v.clipped_share).sum::<f64>() / rec.views.len().max(1) as f64;
    println!(
        "wrote {} views and a mesh of {} triangles to {}",
        rec.views.len(),
        rec.triangles,
        req.out.display()
    );
    println!(
        "{}; gains {lo:.4e} … {hi:.4e}, {:.2} % of pixels clipped",
        rec.note,
        100.0 * clipped
    );
    println!(
        "what was done to each view: {}",
        req.out.join(fipt_capture::degrade::RECORD_FILE).display()
    );
    Ok(())
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MeterArg {
    Median,
    Lights,
}

fn parse_tone(s: &str) -> Result<fipt_core::capture::Response, String> {
    fipt_capture::degrade::tone_curve(s)
}
