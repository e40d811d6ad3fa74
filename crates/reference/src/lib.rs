//! Test support shared by the crates' test suites: the independent reference vectors kept in this
//! crate's `data/` folder (numbers computed independently of this project's code; `data/README.md`
//! says how), which ship with the repository so every checkout runs every reference check, and
//! the bad-input harness [`fuzz`]. Not published; a dev-dependency only.

use std::path::PathBuf;

pub mod broad;
pub mod fuzz;

pub use serde_json::Value;

/// The parsed reference file `name` (for example `"azimuth_vectors.json"`) from `data/`.
///
/// # Panics
/// When the file is missing or not valid JSON: a broken checkout, which must fail the test rather than
/// skip it.
pub fn reference(name: &str) -> Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("reference file {} unreadable: {e}", path.display()));
    serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("reference file {} is not valid JSON: {e}", path.display()))
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
