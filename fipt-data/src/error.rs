//! The one error type of `fipt-core`.
use std::path::PathBuf;

/// Everything that can go wrong while reading, validating or writing fipt data.
///
/// Each variant names the file (and where it matters the view or pixel) and says what to do.
#[derive(Debug, thiserror::Error)]
pub enum CoreError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: cannot read EXR: {message}")]
    Exr { path: PathBuf, message: String },
    /// A PNG or JPEG that cannot be decoded (truncated, not an image).
    #[error("{path}: cannot read the image: {message}")]
    ImageRead { path: PathBuf, message: String },
    #[error("{path}: cannot write image: {message}")]
    ImageWrite { path: PathBuf, message: String },
    #[error("{path}: invalid JSON: {message}")]
    Json { path: PathBuf, message: String },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error(
        "{path}: image is {got_w}x{got_h} but {expected_w}x{expected_h} was expected ({hint})"
    )]
    SizeMismatch {
        path: PathBuf,
        got_w: usize,
        got_h: usize,
        expected_w: usize,
        expected_h: usize,
        hint: String,
    },
    #[error(
        "{path}: {nan} NaN, {inf} infinite and {negative} negative pixel values (first at pixel ({x}, {y})); \
         fix the image or pass `--bad-pixels clamp` to replace them by 0 / clamp them to the finite range"
    )]
    BadPixels {
        path: PathBuf,
        nan: usize,
        inf: usize,
        negative: usize,
        x: usize,
        y: usize,
    },
    /// Bad settings or inputs of a computation (no file involved); the message says what to
    /// change.
    #[error("{what}: {message}")]
    Config { what: String, message: String },
    /// A method's (or another component's) own error, carried through the contract whole: the
    /// host may look inside (`fipt run` recovers its own errors from FIPT's method so).
    #[error(transparent)]
    Component(Box<dyn std::error::Error + Send + Sync>),
    /// A failure inside a pluggable model (material field, optimiser backend).
    #[error("{context}: {message}")]
    Model { context: String, message: String },
    #[error(
        "{path}: frame {frame}: rotation part of the camera-to-world matrix is not orthonormal \
         (max |RᵀR − I| = {error:.2e}, det = {det:.4}); {hint}"
    )]
    BadPose {
        path: PathBuf,
        frame: usize,
        error: f32,
        det: f32,
        hint: String,
    },
}

impl CoreError {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        CoreError::Io {
            path: path.into(),
            source,
        }
    }
    /// A [`CoreError::Config`] error.
    pub fn config(what: impl Into<String>, message: impl Into<String>) -> Self {
        CoreError::Config {
            what: what.into(),
            message: message.into(),
        }
    }
    /// An invalid-input error naming the file.
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        CoreError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }
}

pub type Result<T, E = CoreError> = std::result::Result<T, E>;
