//! The crate's error type.

use thiserror::Error;

/// What can go wrong in setting up or combining a study.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ExperimentError {
    /// A setting is outside its range.
    #[error("{what} is {value}, outside {range}")]
    OutOfRange {
        /// The setting.
        what: &'static str,
        /// Its value, as given.
        value: String,
        /// The accepted range.
        range: &'static str,
    },
    /// Text that should name a shard is not of the form `K/N`.
    #[error("shard {0:?} is not of the form K/N with 1 <= K <= N (for example 2/8)")]
    BadShard(String),
    /// A scenario that cannot be simulated with its settings.
    #[error("scenario: {0}")]
    Scenario(String),
    /// A method whose settings are refused, before any run.
    #[error("method {label}: {source}")]
    Method {
        /// The method's label.
        label: String,
        /// What is wrong with its settings.
        #[source]
        source: liebayes_operators::OperatorError,
    },
    /// A table (or another record of a study) that is not well formed.
    #[error("{0}")]
    Invalid(String),
    /// Two partial summaries that cannot be merged.
    #[error("cannot merge these summaries: {0}")]
    Incompatible(String),
}
