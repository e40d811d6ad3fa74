//! Test helpers: reading the independent reference vectors of `../shared/reference/`.
#![allow(dead_code)] // each test binary uses a different subset of these helpers

use std::path::PathBuf;

/// The parsed reference file `name`, or `None` (after saying so on stderr) where `../shared` is absent.
pub fn reference(name: &str) -> Option<serde_json::Value> {
    let dir = std::env::var_os("LIEBAYES_SHARED").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared"),
        PathBuf::from,
    );
    let path = dir.join("reference").join(name);
    if let Ok(text) = std::fs::read_to_string(&path) {
        Some(serde_json::from_str(&text).expect("reference files are valid JSON"))
    } else {
        {
            eprintln!(
                "SKIPPED: reference file {} not found (the project's ../shared folder is absent; set \
                 LIEBAYES_SHARED to its path to run this check)",
                path.display()
            );
            None
        }
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

pub mod quadrature;
