//! `fipt render`: path-traced views of a recovered scene (a `fipt run` output folder) or of a
//! mesh with given materials, from any cameras, optionally relit by a lights file
//! (fipt-pipeline's `render`), and what it wrote, printed.
use anyhow::Result;
use fipt_core::reflectance::ReflectanceModel;
use fipt_pipeline::render::{mean_psnr, render_request, RenderRequest};
use fipt_shading::lights::EmitterPolicy;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A `fipt run` output folder (renders the recovered scene), a `.glb` of `fipt export`, or,
    /// with --materials, a scene folder holding scene.obj (or .ply/.glb/.gltf) or a mesh file.
    source: PathBuf,
    /// Per-face materials (fipt's scene_gt.json or a scene_parts.json table): render a mesh
    /// with given materials instead of a recovered scene.
    #[arg(long)]
    materials: Option<PathBuf>,
    /// The scene folder of a run output, when the path in its report.json does not resolve
    /// from here.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Cameras: transforms.json (Mitsuba convention) or cam.txt (with K_list.txt beside it).
    #[arg(long)]
    cameras: PathBuf,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Image size when the cameras file has none (default for a run: its scene's).
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    size: Option<Vec<usize>>,
    #[arg(long, default_value_t = 64)]
    spp: u32,
    #[arg(long, default_value_t = fipt_pipeline::run_config::DEFAULT_MAX_BOUNCES)]
    max_bounces: u32,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Render only these view indices, comma-separated: `--views 0,3,5` (default: all).
    #[arg(long, value_delimiter = ',')]
    views: Option<Vec<usize>>,
    /// The reflectance model (default: the run's; `fipt` for --materials).
    #[arg(long)]
    brdf: Option<ReflectanceModel>,
    /// Lights to add (lights.json: spheres, quads, meshes, point and spot lights). Several
    /// files render each view under each into OUT/<file stem>/ and tile them into
    /// OUT/strip_{k:03}.png (a relighting strip).
    #[arg(long, num_args = 1..)]
    lights: Vec<PathBuf>,
    /// The scene's own emitters: keep, off (geometry stays, black) or scale=K. Overrides the
    /// lights file's `emitters`.
    #[arg(long)]
    emitters: Option<EmitterPolicy>,
    /// Material edits and inserted objects (edits.json), applied before the lights.
    #[arg(long)]
    edits: Option<PathBuf>,
    /// Reference images to compare with: a folder of `{k:03}_0001.exr` (or one holding
    /// `Image/`), or another render's `{k:03}_render.exr`. Writes `metrics.json` (sRGB PSNR per view and mean) into --out.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Denoise the views: `auto` (default: on for a recovered scene or a .glb, whose
    /// `{k:03}_render.exr` is denoised and `{k:03}_render_raw.exr` kept; off for --materials,
    /// which writes a scene's ground truth), `on` or `off`.
    #[arg(long, default_value = "auto", value_parser = ["auto", "on", "off"])]
    denoise: String,
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    let summary = render_request(
        &RenderRequest {
            source: a.source,
            materials: a.materials,
            scene: a.scene,
            cameras: a.cameras,
            out: a.out,
            size: a.size.map(|s| (s[0], s[1])),
            spp: a.spp,
            max_bounces: a.max_bounces,
            seed: a.seed,
            views: a.views,
            brdf: a.brdf,
            lights: a.lights,
            emitters: a.emitters,
            edits: a.edits,
            reference: a.reference,
            denoise: match a.denoise.as_str() {
                "on" => Some(true),
                "off" => Some(false),
                _ => None,
            },
        },
        components,
    )?;
    for (out, psnr) in &summary.outputs {
        if !psnr.is_empty() {
            println!("{:>5} {:>12}", "view", "sRGB PSNR dB");
            for (k, p) in psnr {
                println!("{k:>5} {p:>12.2}");
            }
            println!("{:>5} {:>12.2}", "mean", mean_psnr(psnr));
        }
        println!("wrote {}", out.display());
    }
    for strip in &summary.strips {
        println!("relighting strip: {}", strip.display());
    }
    Ok(())
}
