//! The one error type of `fipt-geom`.
use std::path::PathBuf;

/// Errors of mesh loading and ray queries; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum GeomError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: cannot parse mesh: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: unsupported mesh format (expected .obj, .ply, .gltf or .glb)")]
    Format { path: PathBuf },
    #[error("{path}: the mesh has no usable triangle ({dropped} degenerate dropped)")]
    Empty { path: PathBuf, dropped: usize },
}

pub type Result<T, E = GeomError> = std::result::Result<T, E>;

/// A parse error in `path`.
pub(crate) fn parse_err(path: &std::path::Path, message: impl Into<String>) -> GeomError {
    GeomError::Parse {
        path: path.to_path_buf(),
        message: message.into(),
    }
}
