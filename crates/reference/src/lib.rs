//! Test support shared by the crates' test suites: the independent reference vectors of
//! `../shared/reference/` (computed outside this project), read where present and skipped with a
//! message where not. Not published; a dev-dependency only.

use std::path::PathBuf;

pub use serde_json::Value;

/// The parsed reference file `name` (for example `"azimuth_vectors.json"`), or `None`, after saying so
/// on stderr, where the project's `../shared` folder is absent. `LIEBAYES_SHARED` overrides its path.
///
/// # Panics
/// When the file exists but is not valid JSON (a broken checkout, not a skip).
pub fn reference(name: &str) -> Option<Value> {
    let dir = std::env::var_os("LIEBAYES_SHARED").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared"),
        PathBuf::from,
    );
    let path = dir.join("reference").join(name);
    if let Ok(text) = std::fs::read_to_string(&path) {
        Some(serde_json::from_str(&text).expect("reference files are valid JSON"))
    } else {
        eprintln!(
            "SKIPPED: reference file {} not found (the project's ../shared folder is absent; set \
             LIEBAYES_SHARED to its path to run this check)",
            path.display()
        );
        None
    }
}

/// Relative error of `got` against `expected`, with exact zeros compared exactly.
pub fn relative_error(got: f64, expected: f64) -> f64 {
    if expected == 0.0 {
        got.abs()
    } else {
        ((got - expected) / expected).abs()
    }
}

/// A JSON number or array of numbers (nested to any depth) as a flat `Vec<f64>`.
///
/// # Panics
/// On anything else (a malformed reference file).
pub fn numbers(value: &Value) -> Vec<f64> {
    match value {
        Value::Number(n) => vec![n.as_f64().expect("a finite number")],
        Value::Array(items) => items.iter().flat_map(numbers).collect(),
        other => panic!("expected numbers in the reference file, found {other}"),
    }
}
