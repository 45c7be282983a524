//! The one error type of `fipt-neural`.
use std::path::PathBuf;

/// Everything that can go wrong while building, training, saving or querying a field.
#[derive(Debug, thiserror::Error)]
pub enum NeuralError {
    /// A candle operation failed; `context` says which step.
    #[error("{context}: {source}")]
    Candle {
        context: String,
        #[source]
        source: candle_core::Error,
    },
    /// Bad settings; the message names the key and the accepted range.
    #[error("{what}: {message}")]
    Config { what: String, message: String },
    /// A checkpoint or input file could not be used.
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error(transparent)]
    Core(#[from] fipt_core::CoreError),
}

impl NeuralError {
    pub fn config(what: impl Into<String>, message: impl Into<String>) -> Self {
        NeuralError::Config {
            what: what.into(),
            message: message.into(),
        }
    }
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        NeuralError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// Adds context to candle results.
pub trait CandleContext<T> {
    fn ctx(self, context: &str) -> Result<T>;
}

impl<T> CandleContext<T> for candle_core::Result<T> {
    fn ctx(self, context: &str) -> Result<T> {
        self.map_err(|source| NeuralError::Candle {
            context: context.to_string(),
            source,
        })
    }
}

impl From<NeuralError> for fipt_core::CoreError {
    fn from(e: NeuralError) -> Self {
        match e {
            NeuralError::Core(c) => c,
            NeuralError::Invalid { path, message } => {
                fipt_core::CoreError::Invalid { path, message }
            }
            other => fipt_core::CoreError::Model {
                context: "material field".into(),
                message: other.to_string(),
            },
        }
    }
}

pub type Result<T, E = NeuralError> = std::result::Result<T, E>;
