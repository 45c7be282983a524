//! # fipt-emitter
//!
//! Emitter extraction (method §4.4) behind [`fipt_core::emitter::EmitterExtractor`]:
//! [`MaskExtractor`] averages the trained emission mask over uniform points of every triangle,
//! keeps the triangles above a threshold, gives each the per-channel median of the HDR pixels
//! whose centre ray hits it, and groups connected emitter triangles into lights.
mod mask;

pub mod outline;
pub use mask::{MaskExtractor, MaskExtractorConfig};

/// Errors of emitter extraction.
#[derive(Debug, thiserror::Error)]
pub enum EmitterError {
    /// The inputs of the extraction do not fit together.
    #[error("{0}")]
    Invalid(String),
}
