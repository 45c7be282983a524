//! # fipt-neural
//!
//! Will own the material field of fipt-rs: a multi-resolution hash-grid encoding and a small
//! MLP (candle) mapping a world position to albedo, roughness and metallic, plus the emission
//! mask, trained on baked shadings. This crate is a placeholder until the material-field issue
//! lands: it holds only its error type, so that dependants can already name it.

/// Errors of the material field (training, checkpoints, queries).
#[derive(Debug, thiserror::Error)]
pub enum NeuralError {
    /// A checkpoint or configuration could not be used.
    #[error("{path}: {message}")]
    Invalid {
        path: std::path::PathBuf,
        message: String,
    },
}
