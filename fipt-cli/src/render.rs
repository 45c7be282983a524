//! `fipt render <scene> --materials M --cameras transforms.json --out DIR`.
use crate::progress::{bar, Stage};
use anyhow::{bail, Context, Result};
use fipt_core::dataset::{read_transforms, MESH_NAMES};
use fipt_core::materials::SceneMaterials;
use fipt_geom::Mesh;
use fipt_shading::render::{render, render_aovs, RenderConfig};
use fipt_shading::scene::{Scene, TableSurfaces};
use fipt_shading::synth::write_view;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder holding scene.obj (or .ply/.glb/.gltf), or a mesh file.
    scene: PathBuf,
    /// Per-face materials: fipt's scene_gt.json or a scene_parts.json table.
    #[arg(long)]
    materials: PathBuf,
    /// Cameras (transforms.json, Mitsuba convention).
    #[arg(long)]
    cameras: PathBuf,
    /// Output folder: Image/, the ground-truth maps and preview/.
    #[arg(long)]
    out: PathBuf,
    /// Image size when transforms.json has no width/height.
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    size: Option<Vec<usize>>,
    #[arg(long, default_value_t = 64)]
    spp: u32,
    #[arg(long, default_value_t = 7)]
    max_bounces: u32,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Render only these view indices (default: all).
    #[arg(long, value_delimiter = ',')]
    views: Option<Vec<usize>>,
    /// The reflectance model the materials are rendered with: fipt or principled.
    #[arg(long, default_value = "fipt")]
    brdf: fipt_core::reflectance::ReflectanceModel,
}

pub fn run(a: Args) -> Result<()> {
    let mesh_path = if a.scene.is_dir() {
        MESH_NAMES
            .iter()
            .map(|n| a.scene.join(n))
            .find(|p| p.is_file())
            .with_context(|| {
                format!("{}: no mesh ({})", a.scene.display(), MESH_NAMES.join(", "))
            })?
    } else {
        a.scene.clone()
    };
    let st = Stage::start("load");
    let mesh = Mesh::load(&mesh_path)?;
    let materials = SceneMaterials::read_any(&a.materials)?;
    let mut surfaces = TableSurfaces::new(materials, &mesh, &a.materials)?;
    surfaces.model = a.brdf;
    let size = a.size.as_ref().map(|s| (s[0], s[1]));
    let cams = read_transforms(&a.cameras, size)?;
    let scene = Scene::new(mesh, surfaces);
    st.done();
    if scene.lights.is_none() {
        eprintln!(
            "warning: no emitter in {}: renders will be black",
            a.materials.display()
        );
    }
    let views: Vec<usize> = a.views.clone().unwrap_or_else(|| (0..cams.len()).collect());
    if let Some(&bad) = views.iter().find(|&&k| k >= cams.len()) {
        bail!(
            "view {bad} requested but {} has {} frames",
            a.cameras.display(),
            cams.len()
        );
    }
    let cfg = RenderConfig {
        spp: a.spp,
        max_bounces: a.max_bounces,
        seed: a.seed,
        ..Default::default()
    };
    let semantic: Vec<u32> = (0..scene.surfaces.materials.materials.len() as u32).collect();
    let total: u64 = views
        .iter()
        .map(|&k| (cams[k].width * cams[k].height) as u64)
        .sum();
    let pb = bar(total, "render");
    let st = Stage::start("render");
    let mut rays = 0u64;
    for &k in &views {
        let (img, stats) = render(&scene, &cams[k], &cfg, k as u64, &|n| pb.inc(n as u64));
        rays += stats.rays;
        let aovs = render_aovs(&scene, &cams[k]);
        write_view(&a.out, k, &img, &aovs, &semantic)?;
    }
    pb.finish_and_clear();
    let secs = st.done();
    eprintln!(
        "{} views, {:.2} Mrays/s",
        views.len(),
        rays as f64 / secs / 1e6
    );
    println!("wrote {}", a.out.display());
    Ok(())
}
