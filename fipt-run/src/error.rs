//! The one error type of a fipt run (the host, its stages, the capture analysis, the evaluation): a component crate's error, a setting or input the
//! run refuses, a shard that finished its part, each with the context it happened in.
use std::fmt::Display;

/// Everything a stage, a request or a registered component can fail with.
///
/// The message of [`RunError::Invalid`] names the setting or file and the fix;
/// [`RunError::Context`] says what the run was doing when its source failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Core(#[from] fipt_core::CoreError),
    #[error(transparent)]
    Geom(#[from] fipt_geom::GeomError),
    #[error(transparent)]
    Shading(#[from] fipt_shading::ShadingError),
    #[error(transparent)]
    Neural(#[from] fipt_neural::NeuralError),
    #[error(transparent)]
    Emitter(#[from] fipt_emitter::EmitterError),
    #[error(transparent)]
    Export(#[from] fipt_export::ExportError),
    #[error(transparent)]
    Report(#[from] fipt_report::ReportError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    #[error(transparent)]
    Toml(#[from] toml::de::Error),
    /// Settings or inputs the run cannot use; the message names them and the fix.
    #[error("{0}")]
    Invalid(String),
    /// A shard computed its views and stopped; the message says what remains. Not a failure.
    #[error("{0}")]
    Stopped(String),
    /// A registered component's own error.
    #[error(transparent)]
    Component(Box<dyn std::error::Error + Send + Sync>),
    /// A bug: code of the run panicked. The run's folder is marked failed with this message,
    /// and what earlier stages stored is kept.
    #[error("internal error (a bug in fipt; please report it with the command and `fipt info` of the scene): {0}")]
    Internal(String),
    /// What the run was doing when `source` happened.
    #[error("{context}")]
    Context {
        context: String,
        #[source]
        source: Box<RunError>,
    },
}

/// `Result` with [`RunError`].
pub type Result<T, E = RunError> = std::result::Result<T, E>;

impl RunError {
    /// A setting or input the run cannot use.
    pub fn invalid(message: impl Into<String>) -> Self {
        RunError::Invalid(message.into())
    }

    /// A registered component's own error (a plug-in crate's error type).
    pub fn component(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        RunError::Component(Box::new(e))
    }

    /// The error of a caught panic's payload (its message where it is a string).
    pub fn from_panic(payload: Box<dyn std::any::Any + Send>) -> Self {
        let message = (payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into());
        RunError::Internal(message)
    }

    /// Whether this is (or wraps) a shard's [`RunError::Stopped`].
    pub fn is_stopped(&self) -> bool {
        match self {
            RunError::Stopped(_) => true,
            RunError::Context { source, .. } => source.is_stopped(),
            _ => false,
        }
    }
}

/// Says what the run was doing when a result failed (or an option was empty).
pub trait Context<T> {
    fn context<C: Display>(self, context: C) -> Result<T>;
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T>;
}

impl<T, E: Into<RunError>> Context<T> for std::result::Result<T, E> {
    fn context<C: Display>(self, context: C) -> Result<T> {
        self.map_err(|e| RunError::Context {
            context: context.to_string(),
            source: Box::new(e.into()),
        })
    }
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.map_err(|e| RunError::Context {
            context: context().to_string(),
            source: Box::new(e.into()),
        })
    }
}

impl<T> Context<T> for Option<T> {
    fn context<C: Display>(self, context: C) -> Result<T> {
        self.ok_or_else(|| RunError::Invalid(context.to_string()))
    }
    fn with_context<C: Display, F: FnOnce() -> C>(self, context: F) -> Result<T> {
        self.ok_or_else(|| RunError::Invalid(context().to_string()))
    }
}

/// A [`RunError::Invalid`] from a format string.
#[macro_export]
macro_rules! err {
    ($($arg:tt)*) => { $crate::error::RunError::Invalid(format!($($arg)*)) };
}

/// Returns a [`RunError::Invalid`] from a format string.
#[macro_export]
macro_rules! bail {
    ($($arg:tt)*) => { return Err($crate::err!($($arg)*)) };
}

/// An error and its causes on one line, each cause said once (an I/O error's message is often
/// part of its context's already).
pub fn describe(e: &(dyn std::error::Error + 'static)) -> String {
    let mut out = String::new();
    let mut cause = Some(e);
    while let Some(c) = cause {
        let s = c.to_string();
        if !out.contains(&s) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&s);
        }
        cause = c.source();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A caught panic becomes an internal error that keeps its message, whether the payload
    /// is a literal or a formatted string.
    #[test]
    fn a_panic_is_an_internal_error_with_its_message() {
        let quiet = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let literal = std::panic::catch_unwind(|| panic!("index out of bounds")).unwrap_err();
        let formatted =
            std::panic::catch_unwind(|| panic!("the len is {} but the index is 0", 0)).unwrap_err();
        std::panic::set_hook(quiet);
        for (payload, says) in [
            (literal, "index out of bounds"),
            (formatted, "the len is 0 but the index is 0"),
        ] {
            let e = RunError::from_panic(payload).to_string();
            assert!(
                e.starts_with("internal error (a bug in fipt") && e.ends_with(says),
                "{e}"
            );
        }
    }

    #[test]
    fn an_error_chain_says_each_cause_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory");
        let e: Result<(), fipt_core::CoreError> = Err(fipt_core::CoreError::io("/x/out", io));
        let e = e.context("creating the output folder").unwrap_err();
        assert_eq!(
            describe(&e),
            "creating the output folder: /x/out: No such file or directory"
        );
    }

    #[test]
    fn a_stopped_shard_is_seen_through_its_context() {
        let e: Result<()> = Err(RunError::Stopped("shard 1/2 done".into()));
        let e = e.context("the bake").unwrap_err();
        assert!(e.is_stopped());
        assert!(!RunError::invalid("x").is_stopped());
        let e: Result<()> = Err(err!("bad {}", 1));
        assert_eq!(e.unwrap_err().to_string(), "bad 1");
    }
}
