//! The command-line program end to end: a short azimuth study writes its table, CSV files and SVG plots,
//! and bad arguments fail with a message and a non-zero exit code.

use std::path::PathBuf;
use std::process::Command;

fn liebayes(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_liebayes"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn azimuth_study_writes_the_table_and_the_files() {
    let dir = std::env::temp_dir().join(format!("liebayes-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = liebayes(&[
        "azimuth",
        "--scenario",
        "line",
        "--runs",
        "4",
        "--baseline-runs",
        "2",
        "--duration",
        "30",
        "--particles",
        "100",
        "--cells",
        "36",
        "--mpf-particles",
        "36",
        "--seed",
        "5",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    for label in [
        "exact", "EKF", "UKF", "PF 100", "grid 36", "MPF 36", "seed 5",
    ] {
        assert!(stdout.contains(label), "{label} missing from\n{stdout}");
    }
    let file = |name: &str| -> PathBuf { dir.join(name) };
    let summary = std::fs::read_to_string(file("azimuth_line_summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 7, "{summary}");
    assert!(summary.starts_with("method,runs,failures,azimuth_rmse_deg"));
    let run = std::fs::read_to_string(file("azimuth_line_first_run.csv")).unwrap();
    // 30 measurements per method, six methods, one header.
    assert_eq!(run.lines().count(), 1 + 6 * 30);
    for plot in ["azimuth_line_first_run.svg", "azimuth_line_rmse.svg"] {
        let svg = std::fs::read_to_string(file(plot)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("azimuth"), "{plot}");
    }
    assert!(file("azimuth_line_over_time.csv").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_arguments_fail_with_a_reason() {
    let out = liebayes(&[
        "azimuth",
        "--runs",
        "2",
        "--baseline-runs",
        "0",
        "--sigma-m",
        "-1",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("sigma_m"));
    let out = liebayes(&["azimuth", "--scenario", "nowhere"]);
    assert!(!out.status.success());
    let out = liebayes(&["azimuth", "--duration", "0"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("duration"));
}
