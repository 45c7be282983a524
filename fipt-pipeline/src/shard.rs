//! Sharded stages (`fipt run --shard K/N`, `fipt bake --shard K/N`): the bake and each
//! refinement are independent per view, so the tasks of a job array each compute their views
//! into the shared output folder; the last shard (or the next `fipt run`) merges the
//! manifests. A shard run stops once its part is written; the stages in between (training)
//! run on one machine. `scripts/slurm/fipt-sharded.sh` drives it.
use crate::bail;
use crate::error::{Result, RunError};
use fipt_bake::bake_store::{merge_shards, BakeManifest, ShardState};
use fipt_core::shading::Shard;
use std::path::Path;

/// Refuses a per-view stage whose component (`what` `name`) handed over `written` views when
/// `shard` of `views` asked for another number.
pub fn check_handed_over(
    what: &str,
    name: &str,
    written: usize,
    views: usize,
    shard: Shard,
) -> Result<()> {
    let expected = (0..views).filter(|k| shard.contains(*k)).count();
    if written != expected {
        bail!("{what} `{name}` handed over {written} of the {expected} views it was asked for");
    }
    Ok(())
}

/// Merges the finished shards of the stage in `dir` (named `what`) when all are present.
/// A plain run (`shard` = all) that finds a partial set computes the missing shards here with
/// `compute` (each returns [`RunError::Stopped`] once its views are written), then
/// merges: the shards already done are kept, and a set left by an abandoned job array is no
/// dead end. With `compute` None (a run told to stop before the stage), the set is left as it
/// is. A shard run goes on to compute its part.
pub fn merge(
    dir: &Path,
    what: &str,
    shard: Shard,
    check: impl Fn(&BakeManifest) -> Option<String>,
    compute: Option<&mut dyn FnMut(Shard) -> Result<()>>,
) -> Result<()> {
    match merge_shards(dir, &check)? {
        ShardState::Merged { count } => {
            crate::note!("{what}: merged the {count} shards in {}", dir.display())
        }
        ShardState::Partial { count, missing } if shard.is_all() => {
            let Some(compute) = compute else {
                return Ok(());
            };
            let list: Vec<String> = missing.iter().map(|k| format!("{k}/{count}")).collect();
            crate::note!(
                "warning: {}: the {what} is sharded in {count} and shards {} are not done: computing them here (the {} done are kept)",
                dir.display(),
                list.join(", "),
                count - missing.len()
            );
            for k in missing {
                let part = Shard::new(k, count).expect("k < count");
                match compute(part) {
                    Err(e) if e.is_stopped() => {}
                    other => other?,
                }
            }
            if let ShardState::Partial { missing, .. } = merge_shards(dir, check)? {
                bail!(
                    "{}: shards {missing:?} of the {what} are still missing after computing them",
                    dir.display()
                );
            }
        }
        _ => {}
    }
    Ok(())
}

/// The [`RunError::Stopped`] of a shard run that wrote (or found) its part of `what`:
/// not a failure; it says what is done and what comes next.
pub fn done(
    dir: &Path,
    what: &str,
    shard: Shard,
    check: impl Fn(&BakeManifest) -> Option<String>,
) -> RunError {
    let state = merge_shards(dir, check);
    let next = match state {
        Ok(ShardState::Merged { count }) => format!("all {count} shards are done and merged"),
        Ok(ShardState::Partial { missing, count }) => format!(
            "waiting for shards {}",
            missing
                .iter()
                .map(|k| format!("{k}/{count}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Ok(ShardState::None) => "its manifest is not in place".into(),
        Err(e) => format!("merging failed: {e}"),
    };
    RunError::Stopped(format!(
        "shard {shard} of the {what} is in {} ({next}); a `fipt run` without --shard goes on from there",
        dir.display()
    ))
}

/// How a `fipt run` treats its sharded stages.
#[derive(Clone, Copy, Debug)]
pub struct Sharding {
    /// The views this run computes of the bake and the refinements (all: unsharded).
    pub shard: Shard,
    /// Stop before a refinement that is not done (`--stop-before refine`), so that a job array
    /// computes it.
    pub stop_before_refine: bool,
}
