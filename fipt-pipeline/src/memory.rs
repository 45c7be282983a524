//! Refusing work that would not fit in the memory available.
use crate::bail;
use crate::error::Result;
use fipt_core::memory::{available_bytes, gib};

/// Refuses work (`what`, e.g. "the export's texture atlas") that needs `bytes` when less is
/// available.
pub fn check_bytes(what: &str, bytes: u64) -> Result<()> {
    match available_bytes() {
        Some(avail) if bytes > avail => bail!(
            "{what} needs {:.1} GiB but {:.1} GiB are available: lower it",
            gib(bytes),
            gib(avail)
        ),
        _ => Ok(()),
    }
}
