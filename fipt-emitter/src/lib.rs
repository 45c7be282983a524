//! # fipt-emitter
//!
//! Will own emitter extraction: which triangles emit (from the trained emission mask), their
//! radiance (per-channel median of the HDR pixels that see them), grouped into lights. A
//! placeholder until the pipeline issue lands: it holds only its error type.

/// Errors of emitter extraction.
#[derive(Debug, thiserror::Error)]
pub enum EmitterError {
    /// The inputs of the extraction do not fit together.
    #[error("{0}")]
    Invalid(String),
}
