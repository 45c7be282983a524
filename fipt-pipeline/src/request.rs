//! What `fipt run` is asked to do, and the output folder's lock.
use crate::error::Result;
use crate::shard::Sharding;
use fipt_core::image::BadPixelPolicy;
use fipt_core::shading::Shard;
use std::path::{Path, PathBuf};

/// What `fipt run` is asked to do.
#[derive(Clone, Debug)]
pub struct RunRequest {
    /// Scene folder (either layout).
    pub scene: PathBuf,
    /// Output folder (created; finished stages inside are reused).
    pub out: PathBuf,
    /// Settings preset: paper, balanced, fast, reference.
    pub preset: String,
    /// A TOML or JSON file laid over the preset ([`RunConfig`]'s sections).
    pub config: Option<PathBuf>,
    /// The method, over `[pipeline] method`.
    pub method: Option<String>,
    /// What to do with NaN/Inf/negative pixels.
    pub bad_pixels: BadPixelPolicy,
    /// Redo every stage.
    pub force: bool,
    /// The views of the next sharded stage that is not done to compute (then stop); all: an
    /// ordinary run.
    pub shard: Shard,
    /// Stop before the refinement when it is not done (a job array computes its shards).
    pub stop_before_refine: bool,
    /// Shrink the views by this factor on read, over `[capture] downscale`.
    pub downscale: Option<usize>,
}

impl RunRequest {
    /// An ordinary run of `scene` into `out` with `preset`.
    pub fn new(scene: impl Into<PathBuf>, out: impl Into<PathBuf>, preset: &str) -> Self {
        RunRequest {
            scene: scene.into(),
            out: out.into(),
            preset: preset.to_string(),
            config: None,
            method: None,
            bad_pixels: BadPixelPolicy::Reject,
            force: false,
            shard: Shard::ALL,
            stop_before_refine: false,
            downscale: None,
        }
    }

    /// The sharding of this run's stages.
    pub fn sharding(&self) -> Sharding {
        Sharding {
            shard: self.shard,
            stop_before_refine: self.stop_before_refine,
        }
    }
}

/// The output folder's lock: the whole folder for an unsharded run; a shard's own lock for a
/// shard, so that the tasks of a job array write their views side by side.
pub fn lock(out: &Path, shard: Shard, what: &str) -> Result<fipt_core::lock::OutputLock> {
    Ok(if shard.is_all() {
        fipt_core::lock::OutputLock::acquire(out, what)?
    } else {
        let what = format!("{what} --shard {shard}");
        fipt_core::lock::OutputLock::acquire_shard(out, shard.index, shard.count, &what)?
    })
}
