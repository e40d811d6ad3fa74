//! The program's one error type: why a command stopped, with what it was doing, the library's or
//! the system's error kept as the source.

use std::error::Error;
use std::fmt;

/// A cause kept as the source: any library or system error.
type Source = Box<dyn Error + Send + Sync>;

/// Why a command stopped, printed on one line as `liebayes: <context>: <cause>`.
#[derive(Debug)]
pub enum CliError {
    /// A setting or an input the program refuses: the message says what to give instead.
    Invalid(String),
    /// A call that failed: what the program was doing (`"EKF on circle"`, `"reading FILE"`), and
    /// the error it got.
    Failed {
        /// What the program was doing.
        context: String,
        /// The error.
        source: Source,
    },
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Invalid(message) => f.write_str(message),
            CliError::Failed { context, source } if context.is_empty() => write!(f, "{source}"),
            CliError::Failed { context, source } => write!(f, "{context}: {source}"),
        }
    }
}

impl Error for CliError {
    fn source(&self) -> Option<&(dyn Error + 'static)> {
        match self {
            CliError::Invalid(_) => None,
            CliError::Failed { source, .. } => Some(source.as_ref()),
        }
    }
}

/// The library's and the system's errors convert with `?`, without a context: their messages say
/// what failed.
macro_rules! from_source {
    ($($error:ty),* $(,)?) => {
        $(impl From<$error> for CliError {
            fn from(source: $error) -> Self {
                CliError::Failed { context: String::new(), source: Box::new(source) }
            }
        })*
    };
}

from_source!(
    liebayes::experiments::ExperimentError,
    liebayes::filters::FilterError,
    liebayes::filters::attitude::DataError,
    liebayes::operators::OperatorError,
    std::io::Error,
    serde_json::Error,
);

/// Adds what the program was doing to an error.
pub trait Context<T> {
    /// The error, if any, as [`CliError::Failed`] with the context `what()`.
    ///
    /// # Errors
    /// The error, with its context.
    fn context(self, what: impl FnOnce() -> String) -> Result<T, CliError>;
}

impl<T, E: Error + Send + Sync + 'static> Context<T> for Result<T, E> {
    fn context(self, what: impl FnOnce() -> String) -> Result<T, CliError> {
        self.map_err(|source| CliError::Failed {
            context: what(),
            source: Box::new(source),
        })
    }
}

/// A refusal: `Err(format!("--runs is {n}: give at least 1").into())`.
impl From<String> for CliError {
    fn from(message: String) -> Self {
        CliError::Invalid(message)
    }
}

impl From<&str> for CliError {
    fn from(message: &str) -> Self {
        CliError::Invalid(message.to_owned())
    }
}

/// A failure reported as text by a drawing library (the plots), with what was being drawn.
pub fn failed(context: impl Into<String>, message: impl fmt::Display) -> CliError {
    CliError::Failed {
        context: context.into(),
        source: message.to_string().into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use liebayes::experiments::ExperimentError;

    #[test]
    fn the_context_leads_and_the_source_is_kept() {
        let refused: Result<(), ExperimentError> =
            Err(ExperimentError::Scenario("no target".into()));
        let error = refused.context(|| "EKF on circle".to_owned()).unwrap_err();
        assert_eq!(error.to_string(), "EKF on circle: scenario: no target");
        let source = error.source().unwrap();
        assert_eq!(source.to_string(), "scenario: no target");
        let bare: CliError = ExperimentError::BadShard("9".into()).into();
        assert!(bare.to_string().starts_with("shard \"9\""), "{bare}");
        assert!(CliError::from("--runs is 0").source().is_none());
        assert_eq!(
            failed("plotting x", "no room").to_string(),
            "plotting x: no room"
        );
    }
}
