//! The pictures of a finished run: contact sheets and `report.html` (fipt-report).
use crate::error::{Context, Result};
use std::path::{Path, PathBuf};

/// Writes the report of run folder `out` of scene `ds`; returns the HTML page.
pub fn write(
    out: &Path,
    ds: &fipt_core::dataset::Dataset,
    views: usize,
) -> Result<Option<PathBuf>> {
    let opts = fipt_report::Options { views };
    let files = fipt_report::write_report(out, ds, &opts).context("writing the report")?;
    Ok(files.last().cloned())
}

/// Views per split the report at the end of `fipt run` shows.
pub const VIEWS: usize = 4;

/// The report at the end of `fipt run`: its failure does not fail the run (every result is
/// already written), it is noted.
pub fn write_or_warn(out: &Path, ds: &fipt_core::dataset::Dataset) -> Option<PathBuf> {
    write(out, ds, VIEWS).unwrap_or_else(|e| {
        crate::note!("warning: the pictures of the report were not written: {e:#}");
        None
    })
}

/// `fipt report RUN`: the pictures of a finished run written again, under the run folder's
/// lock (nothing else may write there meanwhile); `scene` overrides the scene its report names.
pub fn rewrite(run: &Path, scene: Option<&Path>, views: usize) -> Result<Option<PathBuf>> {
    let opened = crate::recovered::RunOutput::open(run, scene)?;
    let _lock = fipt_core::lock::OutputLock::acquire(run, "fipt report")?;
    let (ds, _) = opened.open_scene()?;
    write(run, &ds, views)
}
