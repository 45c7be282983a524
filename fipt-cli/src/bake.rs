//! `fipt bake <scene> --out DIR`: the initial shading bake alone.
use crate::info::Policy;
use crate::progress::{bar, Stage};
use crate::scene::LoadedScene;
use anyhow::Result;
use fipt_core::image::Image;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::ShadingBaker;
use fipt_core::shading::ViewShadings;
use fipt_shading::bake::{BakeConfig, BakeStats};
use fipt_shading::bake_store::{load_if_current, save, BakeManifest, FORMAT_VERSION};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder.
    scene: PathBuf,
    /// Output folder; the shadings go to OUT/bake/.
    #[arg(long)]
    out: PathBuf,
    /// Settings preset: paper or balanced (the reference's sample counts), fast, reference (its estimators too).
    #[arg(long, default_value = "balanced")]
    preset: String,
    /// A TOML or JSON file of bake settings laid over the preset.
    #[arg(long)]
    config: Option<PathBuf>,
    /// What to do with NaN/Inf/negative pixels.
    #[arg(long, value_enum, default_value = "reject")]
    bad_pixels: Policy,
    /// Bake again even if a finished bake with the same inputs and settings exists.
    #[arg(long)]
    force: bool,
    /// The reflectance model whose shadings are baked: principled (as `fipt run`'s presets) or
    /// fipt (as `--preset reference`).
    #[arg(long, default_value = "principled")]
    brdf: ReflectanceModel,
}

pub fn run(a: Args, components: &crate::Components) -> Result<()> {
    let cfg: BakeConfig = crate::config::load_preset_section(
        &a.preset,
        BakeConfig::preset,
        a.config.as_deref(),
        "bake",
    )?;
    let settings = serde_json::to_value(&cfg)?;
    let baker = components.baker(crate::components::SLF_BAKER, &settings, a.brdf)?;
    let _lock = fipt_core::lock::OutputLock::acquire(&a.out, "fipt bake")?;
    let scene = crate::scene::load(&a.scene, a.bad_pixels.into())?;
    let dir = a.out.join("bake");
    stage(&scene, baker.as_ref(), &settings, &dir, a.force)?;
    println!("wrote {}", dir.display());
    Ok(())
}

/// The bake stage with `baker` (built from `settings`): reuses a finished bake of the same
/// inputs, baker and settings in `dir` unless `force`; otherwise bakes, saves (manifest last)
/// and writes previews of Ld.
pub fn stage(
    scene: &LoadedScene,
    baker: &dyn ShadingBaker,
    settings: &serde_json::Value,
    dir: &Path,
    force: bool,
) -> Result<(BakeManifest, Vec<ViewShadings>)> {
    let name = baker.name().to_string();
    if !force {
        match load_if_current(dir, &scene.cache_key, settings, &name)? {
            Ok((m, sh)) => {
                eprintln!(
                    "reusing the bake in {} ({} views, baked in {:.1} s); --force to redo it",
                    dir.display(),
                    m.views,
                    m.seconds_total
                );
                return Ok((m, sh));
            }
            Err(why) => eprintln!("baking: {why}"),
        }
    }
    let split = scene.ds.train();
    let pb = bar(1, "bake");
    let st = Stage::start("bake");
    let baked = baker.bake(&scene.geometry, &split.views, &scene.images, &|d, t| {
        pb.set_length(t as u64);
        pb.set_position(d as u64);
    })?;
    let shadings = baked.output;
    pb.finish_and_clear();
    let secs = st.done();
    let manifest = BakeManifest {
        version: FORMAT_VERSION,
        baker: name,
        inputs_hash: scene.cache_key.clone(),
        config: settings.clone(),
        split: split.name.clone(),
        views: shadings.len(),
        width: scene.ds.width,
        height: scene.ds.height,
        stats: baked.report.clone(),
        seconds_total: secs,
    };
    let st = Stage::start("write bake");
    save(dir, &manifest, &shadings)?;
    for (k, s) in shadings.iter().enumerate() {
        let img = Image {
            width: s.width,
            height: s.height,
            data: s.ld.clone(),
        };
        img.write_png(&dir.join("preview").join(format!("{k:03}_ld.png")), 1.0)?;
    }
    st.done();
    // The built-in baker's figures in words; any other baker's report as it is.
    let Ok(stats) = serde_json::from_value::<BakeStats>(baked.report.clone()) else {
        eprintln!("{}: {}", manifest.baker, baked.report);
        return Ok((manifest, shadings));
    };
    let rays = stats.rays_diffuse + stats.rays_specular;
    eprintln!(
        "primary {:.2} s, SLF {:.2} s ({} voxels, {:.1} MiB), diffuse {:.2} s ({} cache entries for {} pixels), specular {:.2} s",
        stats.seconds_primary,
        stats.seconds_slf,
        stats.slf_occupied_voxels,
        stats.slf_memory_bytes as f64 / (1 << 20) as f64,
        stats.seconds_diffuse,
        stats.cache_entries,
        stats.valid_pixels,
        stats.seconds_specular
    );
    eprintln!(
        "{:.0} pixels/s, {:.2} Mrays/s",
        stats.valid_pixels as f64 / secs,
        rays as f64 / secs / 1e6
    );
    Ok((manifest, shadings))
}
