//! The one error type of `fipt-shading`.
use std::path::PathBuf;

/// Errors of scene assembly and synthetic-scene writing.
#[derive(Debug, thiserror::Error)]
pub enum ShadingError {
    #[error(transparent)]
    Core(#[from] fipt_core::CoreError),
    #[error(transparent)]
    Geom(#[from] fipt_geom::GeomError),
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("unknown synthetic scene `{0}` (available: cornell, cornell-metal, room)")]
    UnknownScene(String),
}

pub type Result<T, E = ShadingError> = std::result::Result<T, E>;
