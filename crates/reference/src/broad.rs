//! Where the test suites find the BROAD recordings (real IMU data with optical ground truth), which
//! do not ship with the repository: `$LIEBAYES_BROAD_DIR` when set, else `shared/broad` beside the
//! workspace. Tests that need them skip, saying so, where they are absent.

use std::path::PathBuf;

/// The twelve BROAD trials the suites use, by file stem.
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

/// The folder of the BROAD trials, or `None` (after printing "skipped: BROAD data not found at …")
/// when it does not hold the first trial.
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("LIEBAYES_BROAD_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/broad"),
        PathBuf::from,
    );
    if dir.join(format!("{}.mat", TRIALS[0])).exists() {
        Some(dir)
    } else {
        println!("skipped: BROAD data not found at {}", dir.display());
        None
    }
}
