//! The tiny scene and settings the pipeline's end-to-end tests run on.
use fipt_synth::{build, write_dataset, SynthOptions};
use std::path::{Path, PathBuf};

/// A cornell of `views` training views (and one val view) of 24×16 at 8 spp in `dir/scene`,
/// and `dir/run.toml`: small samples, steps and networks, with `extra` TOML tables appended.
pub fn tiny_run(dir: &Path, views: usize, extra: &str) -> (PathBuf, PathBuf) {
    let scene = dir.join("scene");
    let mut opts = SynthOptions::defaults("cornell");
    (opts.train_views, opts.val_views, opts.width, opts.height) = (views, 1, 24, 16);
    opts.render.spp = 8;
    write_dataset(build("cornell").unwrap(), &scene, &opts, &|_, _| {}).unwrap();
    let config = dir.join("run.toml");
    std::fs::write(
        &config,
        "[bake]\ndiffuse_samples = 8\nspecular_samples = [4, 4, 4, 4, 4, 4]\n\
         [refine]\ndiffuse_samples = 8\nspecular_samples = [4, 4, 4, 4, 4, 4]\nlight_samples = 4\n\
         [train.field]\nmlp_width = 16\nmask_width = 16\n[train.field.grid]\nlevels = 4\n\
         [render]\nspp = 2\nval_spp = 2\nmax_bounces = 3\nseed = 0\n"
            .to_string()
            + extra,
    )
    .unwrap();
    (scene, config)
}
