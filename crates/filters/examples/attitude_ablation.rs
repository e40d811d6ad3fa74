//! The production attitude filter's ablation on BROAD: each modelling choice switched off in turn,
//! with the mean total / heading / inclination RMSE (deg) over the trials in the BROAD folder and
//! the heading and tilt NEES pooled over their scored samples.
//!
//! ```text
//! cargo run --release -p liebayes-filters --example attitude_ablation [DIR]
//! ```
//! DIR defaults to `$LIEBAYES_BROAD_DIR` or `../shared/broad`.

use liebayes_filters::attitude::{
    AttitudeParams, ImuLog, NeesSums, Propagation, Sensors, read_broad, run_attitude_ekf,
    track_nees, trial_errors,
};
use std::path::PathBuf;

fn main() {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .or_else(liebayes_reference::broad::data_dir);
    let Some(dir) = dir else {
        eprintln!("no BROAD folder: give it as the argument or set LIEBAYES_BROAD_DIR");
        std::process::exit(2);
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("readable folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mat"))
        .collect();
    files.sort();
    let logs: Vec<(String, ImuLog)> = files
        .iter()
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, read_broad(p).expect("a BROAD trial"))
        })
        .collect();
    let only = std::env::var("ABLATION_ONLY").ok();
    let verbose = std::env::var("ABLATION_TRIALS").is_ok();
    println!("| variant | total | heading | inclination | NEES heading | NEES tilt |");
    println!("|---|---|---|---|---|---|");
    for (label, sensors, params) in variants() {
        if only.as_deref().is_some_and(|o| !label.contains(o)) {
            continue;
        }
        let mut sums = [0.0; 3];
        let mut pooled = NeesSums::default();
        for (name, log) in &logs {
            let track = run_attitude_ekf(log, &params, sensors).expect("a run");
            let e = trial_errors(&track.orientations, log).expect("scored");
            let n = track_nees(&track, log).expect("scored").expect("σ");
            let (nh, nt) = (n.heading_mean(), n.tilt_mean());
            if verbose {
                println!(
                    "|   {name} | {:.2} | {:.2} | {:.2} | {nh:.2} | {nt:.2} |",
                    e.total, e.heading, e.inclination
                );
            }
            pooled.add(&n);
            for (s, v) in sums.iter_mut().zip([e.total, e.heading, e.inclination]) {
                *s += v;
            }
        }
        let n = logs.len() as f64;
        println!(
            "| {label} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            sums[0] / n,
            sums[1] / n,
            sums[2] / n,
            pooled.heading_mean(),
            pooled.tilt_mean()
        );
    }
}

fn variants() -> Vec<(&'static str, Sensors, AttitudeParams)> {
    let base = AttitudeParams::default();
    let mut v = vec![("9D, all parts", Sensors::NineD, base.clone())];
    let mut p = base.clone();
    p.estimate_bias = false;
    v.push(("9D, no gyro bias", Sensors::NineD, p));
    let mut p = base.clone();
    p.rest = None;
    v.push(("9D, no rest detection", Sensors::NineD, p));
    let mut p = base.clone();
    p.magnetometer.disturbance = None;
    v.push(("9D, no disturbance rejection", Sensors::NineD, p));
    let mut p = base.clone();
    p.magnetometer.offset = None;
    v.push(("9D, no field offset state", Sensors::NineD, p));
    let mut p = base.clone();
    p.magnetometer.delay = 0.0;
    v.push(("9D, no magnetometer delay", Sensors::NineD, p));
    let mut p = base.clone();
    p.propagation = Propagation::Ukf;
    v.push(("9D, UKF propagation", Sensors::NineD, p));
    v.push(("6D, all parts", Sensors::SixD, base));
    v
}
