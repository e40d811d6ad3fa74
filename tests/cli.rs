//! The command-line program end to end: a study writes its table and files, bad settings and
//! unwritable folders fail at once with one line and write nothing, and the shards of a study merge
//! to the whole run's summary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn liebayes(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_liebayes"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// A fresh, empty folder for one test.
fn folder(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("liebayes-cli-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The file names of a folder, sorted (none if it does not exist).
fn files(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A failure: exit code 1, nothing on stdout, one line `liebayes: ...` on stderr containing
/// `needle`.
fn assert_fails(out: &Output, needle: &str) {
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(out.stdout.is_empty(), "{}", text(&out.stdout));
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("liebayes: ") && stderr.contains(needle),
        "{needle:?} not in {stderr}"
    );
}

/// A small study of the azimuth command: every filter on every scenario, 8 s, small filters.
const SMALL: [&str; 13] = [
    "azimuth",
    "--runs",
    "12",
    "--baseline-runs",
    "5",
    "--duration",
    "8",
    "--particles",
    "200",
    "--cells",
    "36",
    "--mpf-particles",
    "36",
];

/// The tables of every scenario.
const TABLES: [&str; 3] = ["azimuth_circle", "azimuth_line", "azimuth_static"];

fn small(extra: &[&str]) -> Output {
    let args: Vec<&str> = SMALL.iter().chain(extra).copied().collect();
    liebayes(&args)
}

#[test]
fn a_study_writes_the_table_and_the_files() {
    let dir = folder("study");
    let out = small(&["--seed", "5", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    for label in [
        "exact",
        "EKF",
        "UKF",
        "PF 200",
        "grid 36",
        "MPF 36",
        "seed 5",
        "nees_position",
        "wrote 18 files",
    ] {
        assert!(stdout.contains(label), "{label} missing from\n{stdout}");
    }
    let mut expected = Vec::new();
    for table in TABLES {
        for file in [
            ".summary.json",
            "_first_run.csv",
            "_first_run.svg",
            "_over_time.csv",
            "_over_time.svg",
            "_summary.csv",
        ] {
            expected.push(format!("{table}{file}"));
        }
    }
    assert_eq!(files(&dir), expected);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    // A heading and one line per filter.
    assert_eq!(read("azimuth_line_summary.csv").lines().count(), 7);
    // A heading and 8 epochs per filter (measurements at t = 0, 1, …, 7 s).
    assert_eq!(
        read("azimuth_line_over_time.csv").lines().count(),
        1 + 6 * 8
    );
    for plot in ["azimuth_line_first_run.svg", "azimuth_line_over_time.svg"] {
        let svg = read(plot);
        assert!(svg.starts_with("<svg") && svg.contains("azimuth"), "{plot}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_settings_fail_with_a_reason_and_write_nothing() {
    let dir = folder("settings");
    let out_dir = dir.join("out");
    let out = out_dir.to_str().unwrap();
    assert_fails(
        &liebayes(&["azimuth", "--runs", "0", "--out", out]),
        "--runs is 0",
    );
    assert_fails(
        &liebayes(&["azimuth", "--duration", "-1", "--out", out]),
        "duration (s) is -1",
    );
    // The settings that used to panic, abort, hang or run on silently: each refused at once, in
    // one line that names it, before any run and without a file.
    for (args, needle) in [
        (&["--dt", "1e-300"][..], "propagation steps"),
        (&["--duration", "1e300"], "propagation steps"),
        (&["--duration", "1e12"], "propagation steps"),
        (&["--particles", "18446744073709551615"], "--particles"),
        (&["--particles", "100000000"], "--particles"),
        (&["--cells", "1099511627776"], "--cells"),
        (&["--mpf-particles", "0"], "--mpf-particles"),
        (&["--q", "1e200"], "q"),
        (&["--sigma-m", "1e-200"], "sigma_m"),
        (&["--sigma0", "nan"], "sigma_0"),
        (&["--measure-every", "0"], "measure_every"),
        (&["--duration", "100000"], "measurement epochs"),
        (&["--runs", "2000000000000"], "--runs"),
    ] {
        let mut all = vec!["azimuth"];
        all.extend_from_slice(args);
        all.extend(["--out", out]);
        assert_fails(&liebayes(&all), needle);
    }
    assert_fails(
        &liebayes(&["particles", "--tolerance", "NaN"]),
        "--tolerance is NaN",
    );
    assert_fails(
        &liebayes(&["particles", "--scenario", "static"]),
        "unobservable",
    );
    assert_fails(&small(&["--shard", "4/3", "--out", out]), "4/3");
    assert_fails(&small(&["--shard", "2/3"]), "needs --out");
    assert_fails(&liebayes(&["azimuth", "--nowhere"]), "--nowhere");
    assert_fails(&liebayes(&["merge", "--out", out]), "<DIR>");
    assert!(!out_dir.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_unwritable_folder_fails_before_any_run() {
    let dir = folder("unwritable");
    let file = dir.join("a-file");
    std::fs::write(&file, b"").unwrap();
    // The folder is checked before the study: nothing runs, nothing is printed (a small study, so
    // that a regression fails the test rather than running for hours).
    let small_study = ["azimuth", "--runs", "2", "--duration", "4", "--out"];
    let below = file.join("out");
    let args: Vec<&str> = small_study
        .iter()
        .copied()
        .chain([below.to_str().unwrap()])
        .collect();
    let out = liebayes(&args);
    assert_fails(&out, "cannot create the output folder");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        let locked = dir.join("locked");
        std::fs::create_dir(&locked).unwrap();
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
        // Root writes into read-only folders: then there is nothing to check.
        if std::fs::write(locked.join("probe"), b"").is_err() {
            let args: Vec<&str> = small_study
                .iter()
                .copied()
                .chain([locked.to_str().unwrap()])
                .collect();
            let out = liebayes(&args);
            assert_fails(&out, "cannot write into the output folder");
            assert!(files(&locked).is_empty());
        }
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    assert_eq!(files(&dir), ["a-file", "locked"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The JSON summaries of a folder, parsed, with the measured timing of every row removed.
fn summaries(dir: &Path) -> Vec<(String, serde_json::Value)> {
    files(dir)
        .into_iter()
        .filter(|f| f.ends_with(".summary.json"))
        .map(|f| {
            let text = std::fs::read_to_string(dir.join(&f)).unwrap();
            let mut table: serde_json::Value = serde_json::from_str(&text).unwrap();
            for row in table["summaries"].as_array_mut().unwrap() {
                assert!(row.as_object_mut().unwrap().remove("timing").is_some());
            }
            (f, table)
        })
        .collect()
}

#[test]
fn shards_merge_to_the_whole_run() {
    let dir = folder("merge");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let out = small(&["--out", &path("whole")]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for k in 1..=3 {
        let shard = format!("{k}/3");
        let out = small(&["--shard", &shard, "--out", &path(&format!("part-{k}"))]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        assert!(
            text(&out.stdout).contains(&format!("shard {k}/3 of 12 and 5 runs: partial summary")),
            "{}",
            text(&out.stdout)
        );
        assert_eq!(
            files(&dir.join(format!("part-{k}"))),
            TABLES.map(|t| format!("{t}.summary.json"))
        );
    }
    // Two of three shards: the missing runs are named and only the summaries written.
    let out = liebayes(&[
        "merge",
        &path("part-1"),
        &path("part-3"),
        "--out",
        &path("some"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("azimuth_circle exact: runs 4..8 of 12"));
    assert_eq!(files(&dir.join("some")).len(), 3);
    // All three, in any order: the whole run's files, and its summaries but for the timing.
    let out = liebayes(&[
        "merge",
        &path("part-3"),
        &path("part-1"),
        &path("part-2"),
        "--out",
        &path("merged"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(files(&dir.join("merged")), files(&dir.join("whole")));
    assert_eq!(
        summaries(&dir.join("merged")),
        summaries(&dir.join("whole"))
    );
    let read = |d: &str, f: &str| std::fs::read_to_string(dir.join(d).join(f)).unwrap();
    assert_eq!(
        read("merged", "azimuth_line_first_run.csv"),
        read("whole", "azimuth_line_first_run.csv")
    );
    // The same shard twice: one line, nothing written.
    let twice = liebayes(&[
        "merge",
        &path("part-1"),
        &path("part-2"),
        &path("part-1"),
        "--out",
        &path("twice"),
    ]);
    assert_fails(&twice, "merged twice");
    assert!(files(&dir.join("twice")).is_empty());
    assert_fails(
        &liebayes(&["merge", &path("part-1"), "--out", &path("part-1")]),
        "one of the folders to merge",
    );
    assert_fails(
        &liebayes(&["merge", &path("nowhere"), "--out", &path("x")]),
        "cannot read the folder",
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A change to a summary's JSON.
type Edit = fn(&mut serde_json::Value);

/// Crafted summaries (a sum flagged NaN, a count of 2^64 − 1, a minimum above the maximum, an
/// epoch repeated in the trace) are refused by `merge`, naming the file and the field, with nothing
/// written.
#[test]
fn merge_refuses_crafted_summaries() {
    let dir = folder("crafted");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let out = liebayes(&[
        "azimuth",
        "--runs",
        "3",
        "--baseline-runs",
        "2",
        "--duration",
        "4",
        "--particles",
        "50",
        "--cells",
        "36",
        "--mpf-particles",
        "36",
        "--out",
        &path("good"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let file = "azimuth_line.summary.json";
    let original = std::fs::read_to_string(dir.join("good").join(file)).unwrap();
    let edits: [(&str, Edit); 4] = [
        ("flagged NaN", |row| {
            row["metrics"][0]["series"]["epochs"][0]["sum"]["nan"] = true.into();
        }),
        ("exceed the 3 runs", |row| {
            row["times"]["epochs"][1]["non_finite"] = (u64::MAX / 2).into();
        }),
        ("min <= max", |row| {
            row["times"]["epochs"][0]["min"] = 1e300.into();
        }),
        ("strictly increasing", |row| {
            let times = &mut row["trace"]["times"];
            times[1] = times[0].clone();
        }),
    ];
    for (k, (field, edit)) in edits.into_iter().enumerate() {
        let bad = dir.join(format!("bad-{k}"));
        std::fs::create_dir_all(&bad).unwrap();
        let mut table: serde_json::Value = serde_json::from_str(&original).unwrap();
        edit(&mut table["summaries"][0]);
        std::fs::write(bad.join(file), table.to_string()).unwrap();
        let out_dir = path(&format!("out-{k}"));
        let out = liebayes(&["merge", bad.to_str().unwrap(), "--out", &out_dir]);
        assert_fails(&out, field);
        assert!(text(&out.stderr).contains(file), "{}", text(&out.stderr));
        assert!(files(Path::new(&out_dir)).is_empty());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Summaries that are valid but extreme are merged into whole tables, neither hanging nor
/// panicking: a trace value of 1e308 made the first-run plot's axis infinitely wide (plotters'
/// tick search never ended), a row label of 70 000 characters overflowed the printed table's
/// formatting width (a panic), and a time per step of 1e300 s printed `inf` nanoseconds.
#[test]
fn merge_draws_and_prints_extreme_but_valid_summaries() {
    let dir = folder("extreme");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let out = small(&["--out", &path("good")]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let file = "azimuth_circle.summary.json";
    let original = std::fs::read_to_string(dir.join("good").join(file)).unwrap();
    let edits: [(&str, Edit); 3] = [
        ("huge trace", |row| {
            let values = row["trace"]["values"].as_array_mut().unwrap();
            let last = values.len() - 1;
            values[last] = 1e308.into();
            values[0] = (-1e308).into();
        }),
        ("long label", |row| {
            row["label"]["name"] = "x".repeat(70_000).into();
        }),
        // As many steps as the row timed, each of 1e300 s.
        ("slow steps", |row| {
            let mut timing = liebayes::experiments::RunningStats::default();
            for _ in 0..row["timing"]["count"].as_u64().unwrap() {
                timing.add(1e300);
            }
            row["timing"] = serde_json::to_value(&timing).unwrap();
        }),
    ];
    for (k, (what, edit)) in edits.iter().enumerate() {
        let crafted = dir.join(format!("crafted-{k}"));
        std::fs::create_dir_all(&crafted).unwrap();
        let mut table: serde_json::Value = serde_json::from_str(&original).unwrap();
        edit(&mut table["summaries"][0]);
        std::fs::write(crafted.join(file), table.to_string()).unwrap();
        let merged = path(&format!("merged-{k}"));
        let out = liebayes(&["merge", crafted.to_str().unwrap(), "--out", &merged]);
        assert!(out.status.success(), "{what}: {}", text(&out.stderr));
        assert!(!text(&out.stdout).contains("inf"), "{what}");
        assert!(
            files(Path::new(&merged)).contains(&"azimuth_circle_first_run.svg".to_owned()),
            "{what}: {:?}",
            files(Path::new(&merged))
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An entry named like a summary that is not a regular file is refused in one line naming it,
/// before any file is read, nothing written: a FIFO `*.summary.json` used to block `merge` forever
/// in its open (a hang here would be caught by the harness's time limit), and a folder of that
/// name is not a summary either.
#[cfg(unix)]
#[test]
fn merge_refuses_a_fifo_or_a_folder_named_like_a_summary() {
    let dir = folder("merge-fifo");
    let fifo = dir.join("fifo");
    std::fs::create_dir_all(&fifo).unwrap();
    let pipe = fifo.join("azimuth_line.summary.json");
    let made = Command::new("mkfifo")
        .arg(&pipe)
        .status()
        .expect("mkfifo runs");
    assert!(made.success(), "mkfifo {}", pipe.display());
    let nested = dir.join("nested");
    std::fs::create_dir_all(nested.join("azimuth_line.summary.json")).unwrap();
    for (input, entry) in [
        (&fifo, &pipe),
        (&nested, &nested.join("azimuth_line.summary.json")),
    ] {
        let out_dir = dir.join("out");
        let out = liebayes(&[
            "merge",
            input.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ]);
        assert_fails(&out, "is not a regular file");
        assert!(
            text(&out.stderr).contains(entry.to_str().unwrap()),
            "{}",
            text(&out.stderr)
        );
        assert!(files(&out_dir).is_empty());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The angle-of-arrival parts write their tables and plots; the track study's per-run box plots
/// come with its tables; bad settings fail at once and write nothing.
#[test]
fn aoa_parts_write_their_files_and_refuse_bad_settings() {
    let dir = folder("aoa");
    let d = dir.to_str().unwrap();
    let out = liebayes(&["aoa", "table1", "--samples", "3000", "--out", d]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let printed = text(&out.stdout);
    assert!(
        printed.contains("VMF") && printed.contains("Model II"),
        "{printed}"
    );
    let out = liebayes(&["aoa", "update", "--particles", "5000", "--out", d]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("exact AE"));
    let out = liebayes(&[
        "aoa",
        "track",
        "--data",
        "model2",
        "--runs",
        "6",
        "--particles",
        "300",
        "--steps",
        "10",
        "--fit-samples",
        "2000",
        "--out",
        d,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let names = files(&dir);
    for name in [
        "aoa_table1.csv",
        "aoa_update_corrected.csv",
        "aoa_update_corrected.svg",
        "aoa_update_literal.csv",
        "aoa_track_model2_summary.csv",
        "aoa_track_model2_position_error_relative.csv",
        "aoa_track_model2_position_error_relative.svg",
        "aoa_track_model2.summary.json",
    ] {
        assert!(
            names.iter().any(|n| n == name),
            "{name} missing from {names:?}"
        );
    }
    let relative =
        std::fs::read_to_string(dir.join("aoa_track_model2_position_error_relative.csv")).unwrap();
    // Twelve filters against PF-VMF (IEKF-VMF among them), and the header.
    assert_eq!(relative.lines().count(), 13, "{relative}");
    let empty = folder("aoa-bad");
    let e = empty.to_str().unwrap();
    for (args, needle) in [
        (vec!["aoa", "table1", "--samples", "0"], "--samples"),
        (vec!["aoa", "table1", "--samples", "1"], "--samples is 1"),
        (
            vec!["aoa", "track", "--fit-samples", "1"],
            "--fit-samples is 1",
        ),
        (vec!["aoa", "table1", "--sigma-deg", "-1"], "--sigma-deg"),
        (vec!["aoa", "update", "--particles", "0"], "--particles"),
        (vec!["aoa", "track", "--runs", "0"], "--runs"),
        (vec!["aoa", "track", "--steps", "0"], "--steps"),
        (vec!["aoa", "track", "--steps", "20000"], "--steps"),
        (
            vec!["aoa", "track", "--reference-runs", "900"],
            "--reference-runs",
        ),
        (
            vec!["aoa", "track", "--match-tolerance", "0.01"],
            "--match-tolerance",
        ),
        (
            vec!["aoa", "track", "--particles", "100000000"],
            "--particles",
        ),
    ] {
        let mut args = args.clone();
        args.extend(["--out", e]);
        assert_fails(&liebayes(&args), needle);
    }
    assert!(files(&empty).is_empty());
}

#[test]
fn attitude_simulate_writes_its_files_and_prints_the_table() {
    let dir = folder("attitude-sim");
    let out = liebayes(&[
        "attitude",
        "--simulate",
        "--samples",
        "300",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let printed = text(&out.stdout);
    assert!(
        printed.contains("RMSE (deg)") && printed.contains("Madgwick"),
        "{printed}"
    );
    let names = files(&dir);
    assert!(
        names.contains(&"simulated_seed1.errors.svg".to_owned()),
        "{names:?}"
    );
    assert!(
        names.contains(&"simulated_seed1.ekf-9d.csv".to_owned()),
        "{names:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn inertial_writes_its_table_and_refuses_bad_settings() {
    let dir = folder("inertial");
    let out = liebayes(&["inertial", "--runs", "2", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let printed = text(&out.stdout);
    assert!(
        printed.contains("right-invariant EKF, iterated fix")
            && printed.contains("nees_navigation"),
        "{printed}"
    );
    let names = files(&dir);
    assert!(
        names.contains(&"inertial.summary.json".to_owned()),
        "{names:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    let empty = folder("inertial-bad");
    for (args, needle) in [
        (vec!["inertial", "--runs", "0"], "--runs is 0"),
        (
            vec!["inertial", "--initial-velocity", "sideways"],
            "sideways",
        ),
    ] {
        let mut args = args;
        let e = empty.to_str().unwrap();
        args.extend(["--out", e]);
        assert_fails(&liebayes(&args), needle);
    }
    assert!(files(&empty).is_empty());
}

#[test]
fn attitude_bad_broad_folder_fails_with_one_line() {
    let dir = folder("attitude-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let out = liebayes(&["attitude", "--broad", dir.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("holds no .mat trial"),
        "{}",
        text(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The main job reads its BROAD folder before any study: a folder without a trial, or with a
/// corrupt one, fails at once in one line naming it, nothing printed and nothing written (the job
/// writes into `out/` under the working directory, here a fresh folder). It used to run the
/// azimuth, angle-of-arrival and simulated attitude studies first, minutes of work, writing their
/// files.
#[test]
fn the_main_job_refuses_a_bad_broad_folder_before_any_study() {
    let dir = folder("main-job-broad");
    let broad = dir.join("broad");
    std::fs::create_dir_all(&broad).unwrap();
    let main_job = || {
        Command::new(env!("CARGO_BIN_EXE_liebayes"))
            .current_dir(&dir)
            .env("LIEBAYES_BROAD_DIR", &broad)
            .output()
            .expect("the binary runs")
    };
    let out = main_job();
    assert_fails(&out, "holds no .mat trial");
    assert!(
        text(&out.stderr).contains(broad.to_str().unwrap()),
        "{}",
        text(&out.stderr)
    );
    std::fs::write(broad.join("corrupt.mat"), b"not a MATLAB file").unwrap();
    assert_fails(&main_job(), "corrupt.mat");
    assert_eq!(files(&dir), ["broad"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--samples` beyond the most steps a run records (2^24) is refused as the command line is parsed,
/// in one line, nothing written: 2^28 used to ask for about 28 GB and filter them all before the
/// recording refused the run.
#[test]
fn attitude_samples_beyond_the_recording_limit_are_refused_at_once() {
    let dir = folder("attitude-samples");
    let out_dir = dir.join("out");
    let out = out_dir.to_str().unwrap();
    for samples in ["16777217", "268435456", "18446744073709551616", "1", "x"] {
        for runs in [None, Some("2")] {
            let mut args = vec!["attitude", "--simulate", "--samples", samples, "--out", out];
            if let Some(runs) = runs {
                args.extend(["--runs", runs]);
            }
            assert_fails(&liebayes(&args), "from 2 to 16777216");
        }
    }
    assert!(!out_dir.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A CSV log longer than a run records (2^24 samples) is refused as it is read, at its first line
/// beyond the limit, naming the file and the line, before any filter runs, nothing written. The
/// log comes through a pipe, never on disk; its samples all at t = 0, since the count is refused
/// before the times are looked at.
#[cfg(target_os = "linux")]
#[test]
fn attitude_csv_beyond_the_recording_limit_is_refused_while_read() {
    use std::io::Write as _;
    const LIMIT: usize = 1 << 24;
    const BLOCK: usize = 4096;
    let dir = folder("attitude-csv-long");
    let out_dir = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_liebayes"))
        .args(["attitude", "--csv", "/dev/stdin", "--out"])
        .arg(&out_dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let mut stdin = child.stdin.take().unwrap();
    // Stops at a broken pipe once the binary has stopped reading.
    let writer = std::thread::spawn(move || -> std::io::Result<()> {
        let block = "0,0,0,0,0,0,9.8\n".repeat(BLOCK);
        stdin.write_all(b"t,gx,gy,gz,ax,ay,az\n")?;
        for _ in 0..=LIMIT / BLOCK {
            stdin.write_all(block.as_bytes())?;
        }
        Ok(())
    });
    let out = child.wait_with_output().unwrap();
    let _ = writer.join().unwrap();
    // Sample 2^24 + 1 is on line 2^24 + 2 (the header is line 1).
    assert_fails(
        &out,
        &format!("/dev/stdin: line {}: more than {LIMIT} samples", LIMIT + 2),
    );
    assert!(files(&out_dir).is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Writes `log` as an IMU CSV file (the documented layout, shortest round-trip decimals).
fn write_imu_csv(path: &Path, log: &liebayes::filters::attitude::ImuLog) {
    use std::fmt::Write;
    let mag = log.magnetometer();
    let mut text = String::from(if mag.is_some() {
        "t,gx,gy,gz,ax,ay,az,mx,my,mz\n"
    } else {
        "t,gx,gy,gz,ax,ay,az\n"
    });
    for (k, (g, a)) in log.gyroscope().iter().zip(log.accelerometer()).enumerate() {
        let t = k as f64 * log.interval();
        write!(text, "{t},{},{},{},{},{},{}", g.x, g.y, g.z, a.x, a.y, a.z).unwrap();
        if let Some(m) = mag {
            write!(text, ",{},{},{}", m[k].x, m[k].y, m[k].z).unwrap();
        }
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// `--csv` round trip: a simulated log written as CSV, run by the binary, its estimates read back
/// equal the library's run on the same file bit for bit (9D with a magnetometer, 6D without; the
/// filter's, and with `--offline` the smoother's); a malformed file fails with one line naming the
/// line and writes nothing.
#[test]
fn attitude_csv_round_trip() {
    use liebayes::filters::attitude::{
        ImuLog, LogScenario, Method, SimulationSettings, estimates, read_estimates_csv,
        read_imu_csv, run_log, simulate,
    };
    let dir = folder("attitude-csv");
    let settings = SimulationSettings {
        samples: 600,
        ..SimulationSettings::default()
    };
    let simulated = simulate(&settings, 3).unwrap();
    let six = ImuLog::new(
        simulated.rate(),
        simulated.gyroscope().to_vec(),
        simulated.accelerometer().to_vec(),
        None,
    )
    .unwrap();
    for (stem, log, method, offline) in [
        ("nine", &simulated, "ekf-9d", false),
        ("six", &six, "ekf-6d", false),
        ("nine", &simulated, "ekf-offline-9d", true),
        ("six", &six, "ekf-offline-6d", true),
    ] {
        let input = dir.join(format!("{stem}.csv"));
        write_imu_csv(&input, log);
        let out_dir = dir.join(format!("{method}-out"));
        let mut args = vec![
            "attitude",
            "--csv",
            input.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ];
        if offline {
            args.push("--offline");
        }
        let out = liebayes(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        assert!(
            text(&out.stdout).contains("600 samples"),
            "{}",
            text(&out.stdout)
        );
        let read = |p: &Path| std::io::BufReader::new(std::fs::File::open(p).unwrap());
        let written =
            read_estimates_csv(read(&out_dir.join(format!("{stem}.{method}.csv"))), "out").unwrap();
        let log = read_imu_csv(read(&input), "in").unwrap();
        let scenario = LogScenario::new(log).unwrap();
        let expected = run_log("in", &scenario, &Method::from_name(method).unwrap()).unwrap();
        assert_eq!(written.orientations.len(), 600);
        for (w, (_, e)) in written.orientations.iter().zip(estimates(&expected)) {
            let e = e.orientation;
            assert!(
                w.coords == e.coords || w.coords == -e.coords,
                "{w:?} vs {e:?}"
            );
        }
    }
    let bad = dir.join("bad.csv");
    std::fs::write(
        &bad,
        "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,9.8\n0.01,0,0,x,0,0,9.8\n",
    )
    .unwrap();
    let out_dir = dir.join("bad-out");
    let out = liebayes(&[
        "attitude",
        "--csv",
        bad.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("line 3") && stderr.trim().lines().count() == 1,
        "{stderr}"
    );
    assert!(files(&out_dir).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A trial whose name is too long for its output files is refused before any trial runs (the
/// output folder the command created removed again), and so is, in the main job, a trial named like the main job's simulated log: each used to fail after
/// the runs (on a file name, or on a file "written twice" reported as an internal error).
#[cfg(unix)]
#[test]
fn broad_trial_names_are_checked_before_any_run() {
    let data = liebayes_reference::broad::shipped_dir();
    let shipped = data.join(format!("{}.mat", liebayes_reference::broad::SHIPPED[1]));
    let dir = folder("broad-names");
    let long = dir.join("long");
    std::fs::create_dir_all(&long).unwrap();
    std::os::unix::fs::symlink(&shipped, long.join("01_first.mat")).unwrap();
    std::os::unix::fs::symlink(&shipped, long.join(format!("{}.mat", "z".repeat(112)))).unwrap();
    let out_dir = dir.join("out");
    let out = liebayes(&[
        "attitude",
        "--broad",
        long.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert_fails(&out, "rename the trial file");
    // The folder the command created for its output is gone with the failure.
    assert!(!out_dir.exists());
    let clash = dir.join("clash");
    std::fs::create_dir_all(&clash).unwrap();
    std::os::unix::fs::symlink(&shipped, clash.join("simulated_seed1.mat")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_liebayes"))
        .current_dir(&dir)
        .env("LIEBAYES_BROAD_DIR", &clash)
        .output()
        .expect("the binary runs");
    assert_fails(&out, "takes the name of the main job's simulated log");
    assert!(files(&dir.join("out")).is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--broad` on a folder of one shipped trial: the per-trial table with every method, the NEES
/// table, and per method an estimates CSV, the error plot and the summary.
#[test]
fn attitude_broad_one_trial() {
    let data = liebayes_reference::broad::shipped_dir();
    let trial = liebayes_reference::broad::SHIPPED[1];
    let dir = folder("attitude-broad");
    let input = dir.join("in");
    std::fs::create_dir_all(&input).unwrap();
    let name = format!("{trial}.mat");
    std::fs::copy(data.join(&name), input.join(&name)).unwrap();
    let out_dir = dir.join("out");
    let out = liebayes(&[
        "attitude",
        "--broad",
        input.to_str().unwrap(),
        "--method",
        "ekf-9d",
        "--method",
        "ekf-6d",
        "--method",
        "madgwick-9d",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let printed = text(&out.stdout);
    for needle in [trial, "EKF 9D", "EKF 6D", "Madgwick 9D", "heading NEES"] {
        assert!(printed.contains(needle), "{needle}: {printed}");
    }
    let names = files(&out_dir);
    for method in ["ekf-9d", "ekf-6d", "madgwick-9d"] {
        assert!(
            names.contains(&format!("{trial}.{method}.csv")),
            "{names:?}"
        );
    }
    for file in [
        format!("{trial}.errors.svg"),
        "broad.summary.json".to_owned(),
    ] {
        assert!(names.contains(&file), "{names:?}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("broad.summary.json")).unwrap())
            .unwrap();
    assert!(summary["nees"]["EKF 9D"].is_array(), "{summary}");
    assert!(summary["nees"]["Madgwick 9D"].is_null(), "{summary}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--offline` names its methods itself: with `--method` it is refused in one line.
#[test]
fn attitude_offline_with_a_method_is_refused() {
    let out = liebayes(&["attitude", "--simulate", "--offline", "--method", "ekf-9d"]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("--offline") && stderr.trim().lines().count() == 1,
        "{stderr}"
    );
}

#[test]
fn attitude_unknown_method_is_refused() {
    let out = liebayes(&["attitude", "--simulate", "--method", "vqf"]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("vqf") && stderr.contains("ekf-9d") && stderr.trim().lines().count() == 1,
        "{stderr}"
    );
}

/// A CSV log with a corrupt gyroscope reading (1e200 rad/s, beyond the sensor's range) is refused
/// with one line naming the file and the row, and nothing is written.
#[test]
fn attitude_csv_with_a_corrupt_reading_is_refused() {
    let dir = folder("attitude-corrupt");
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("corrupt.csv");
    std::fs::write(
        &input,
        "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,9.8\n0.01,0,0,0,0,0,9.8\n0.02,1e200,0,0,0,0,9.8\n",
    )
    .unwrap();
    let out_dir = dir.join("out");
    let out = liebayes(&[
        "attitude",
        "--csv",
        input.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("corrupt.csv")
            && stderr.contains("row 2")
            && stderr.trim().lines().count() == 1,
        "{stderr}"
    );
    assert!(files(&out_dir).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The attitude command's arguments are checked before any work (an audit of the command line):
/// a method named twice ran every trial and then failed on a file written twice; `--method` with
/// `--csv` or `--runs` was ignored without a word; a study's `--samples` beyond what it scores
/// failed without naming `--samples`; a `--csv` input whose name makes no plain output name failed
/// after the filter had run; and a FIFO named like a BROAD trial blocked the reader forever.
#[cfg(unix)]
#[test]
fn attitude_arguments_are_checked_before_any_work() {
    let dir = folder("attitude-arguments");
    let out_dir = dir.join("out");
    let out = out_dir.to_str().unwrap();
    let cases: [(&[&str], &str); 5] = [
        (
            &["--simulate", "--method", "ekf-9d", "--method", "ekf-9d"],
            "--method ekf-9d is given twice",
        ),
        (
            &["--csv", "log.csv", "--method", "ekf-6d"],
            "cannot be used with",
        ),
        (
            &["--simulate", "--runs", "2", "--method", "ekf-6d"],
            "cannot be used with",
        ),
        (
            &["--simulate", "--runs", "2", "--samples", "200000"],
            "--samples is 200000",
        ),
        (
            &["--csv", "walk 1.csv", "--out", out],
            "rename the input file",
        ),
    ];
    for (args, needle) in cases {
        let mut all = vec!["attitude"];
        all.extend_from_slice(args);
        let output = liebayes(&all);
        assert!(!output.status.success(), "{args:?}");
        assert!(
            text(&output.stderr).contains(needle),
            "{args:?}: {}",
            text(&output.stderr)
        );
        assert!(files(&out_dir).is_empty(), "{args:?}");
    }
    let broad = dir.join("broad");
    std::fs::create_dir_all(&broad).unwrap();
    let pipe = broad.join("trial.mat");
    let made = Command::new("mkfifo")
        .arg(&pipe)
        .status()
        .expect("mkfifo runs");
    assert!(made.success());
    let output = liebayes(&["attitude", "--broad", broad.to_str().unwrap()]);
    assert_fails(&output, "is not a regular file");
    // The library's reader refuses it too, naming the file.
    let error = liebayes::filters::attitude::read_broad(&pipe).unwrap_err();
    assert!(error.to_string().contains("not a regular file"), "{error}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A command interrupted while files are staged removes its temporaries and exits with 128 + the
/// signal's number: the attitude comparison stages each method's estimates as its run ends and
/// commits them all at the end, so once the first temporary shows, the next runs are under way.
/// The wait is for the file, bounded by the child's own run (it commits and exits in the end).
#[cfg(unix)]
#[test]
fn an_interrupted_command_leaves_no_file() {
    let dir = folder("interrupted");
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_liebayes"))
        .args(["attitude", "--simulate", "--samples", "20000", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let staged = loop {
        let staged = |f: &String| Path::new(f).extension().is_some_and(|e| e == "tmp");
        if files(&out).iter().any(staged) {
            break true;
        }
        if child.try_wait().unwrap().is_some() {
            break false;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert!(staged, "the command ended before it staged a file");
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("interrupted by signal 2: removed"),
        "{stderr}"
    );
    assert!(files(&out).is_empty(), "{:?}", files(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A write that fails names the file being written, not the input: an estimates file too large
/// for the limit the shell sets (`ulimit -f`) used to fail as `simulated_seed1: File too large`.
/// Nothing is left in the folder.
#[cfg(unix)]
#[test]
fn a_failed_write_names_the_file_written() {
    let dir = folder("write-fails");
    let out = dir.join("out");
    let script = format!(
        "trap '' XFSZ; ulimit -f 40; exec '{}' attitude --simulate --samples 3000 --method ekf-6d \
         --out '{}'",
        env!("CARGO_BIN_EXE_liebayes"),
        out.display()
    );
    let output = Command::new("sh")
        .args(["-c", &script])
        .output()
        .expect("sh runs");
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "{}: File too large",
            out.join("simulated_seed1.ekf-6d.csv").display()
        )),
        "{stderr}"
    );
    assert!(files(&out).is_empty(), "{:?}", files(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}
