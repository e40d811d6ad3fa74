//! Where the test suites find the BROAD recordings (real IMU data with optical ground truth): two
//! trials ship with the repository in `data/broad/` ([`SHIPPED`], [`shipped_dir`]), so every
//! checkout runs the real-data tests on them; the twelve trials the project's figures are measured
//! on ([`TRIALS`]) are read from `$LIEBAYES_BROAD_DIR` when it is set ([`data_dir`]); the
//! examples take any folder of them ([`folder_trials`]).

use std::path::PathBuf;

/// The environment variable naming a folder with the twelve trials of [`TRIALS`].
pub const VARIABLE: &str = "LIEBAYES_BROAD_DIR";

/// The twelve BROAD trials of the project's figures, by file stem.
pub const TRIALS: [&str; 12] = [
    "01_undisturbed_slow_rotation_A",
    "05_undisturbed_slow_rotation_with_breaks_B",
    "07_undisturbed_fast_rotation_B",
    "10_undisturbed_slow_translation_A",
    "14_undisturbed_slow_translation_with_breaks_B",
    "16_undisturbed_fast_translation_B",
    "21_undisturbed_fast_combined",
    "24_disturbed_tapping_A",
    "27_disturbed_phone_vibration_B",
    "28_disturbed_stationary_magnet_A",
    "32_disturbed_attached_magnet_1cm",
    "35_disturbed_attached_magnet_4cm",
];

/// The two trials in the repository: one undisturbed, one with a magnet attached to the sensor.
pub const SHIPPED: [&str; 2] = [
    "01_undisturbed_slow_rotation_A",
    "35_disturbed_attached_magnet_4cm",
];

/// The repository's `data/broad/` folder, which holds the [`SHIPPED`] trials.
///
/// # Panics
/// When a shipped trial is missing: a broken checkout, which must fail the test rather than skip.
pub fn shipped_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/broad");
    for trial in SHIPPED {
        let file = dir.join(format!("{trial}.mat"));
        assert!(
            file.exists(),
            "the shipped BROAD trial {} is missing: a broken checkout",
            file.display()
        );
    }
    dir
}

/// The folder of the twelve [`TRIALS`] when `$LIEBAYES_BROAD_DIR` asks for them; `None` when the
/// variable is not set (after printing that the twelve-trial check is skipped and how to run it).
///
/// # Panics
/// When the variable is set and the folder lacks any of the twelve: a test asked to run on them
/// fails, naming the missing file, rather than pass without them.
pub fn data_dir() -> Option<PathBuf> {
    let Some(dir) = std::env::var_os(VARIABLE).map(PathBuf::from) else {
        println!(
            "skipped: the twelve-trial BROAD check runs with {VARIABLE} set to a folder of them"
        );
        return None;
    };
    for trial in TRIALS {
        let file = dir.join(format!("{trial}.mat"));
        assert!(
            file.exists(),
            "{VARIABLE} is set but {} is missing",
            file.display()
        );
    }
    Some(dir)
}

/// The trials the real-data tests run on: the twelve from `$LIEBAYES_BROAD_DIR` when it is set,
/// else the two shipped ones; each as `(stem, path)`.
///
/// # Panics
/// As [`data_dir`] and [`shipped_dir`].
pub fn trials() -> Vec<(&'static str, PathBuf)> {
    let (dir, names): (PathBuf, &[&'static str]) = match std::env::var_os(VARIABLE) {
        Some(_) => (data_dir().unwrap_or_default(), &TRIALS),
        None => (shipped_dir(), &SHIPPED),
    };
    names
        .iter()
        .map(|name| (*name, dir.join(format!("{name}.mat"))))
        .collect()
}

/// The `.mat` files of the folder `arg` names (an example's first argument), else of
/// `$LIEBAYES_BROAD_DIR`, sorted by name.
///
/// # Errors
/// A message saying what to give when neither names a folder, or that the folder cannot be read.
pub fn folder_trials(arg: Option<String>) -> Result<Vec<PathBuf>, String> {
    let dir = arg
        .map(PathBuf::from)
        .or_else(|| std::env::var_os(VARIABLE).map(PathBuf::from))
        .ok_or(format!(
            "no BROAD folder: give it as the argument or set {VARIABLE}"
        ))?;
    let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mat"))
        .collect();
    files.sort();
    Ok(files)
}
