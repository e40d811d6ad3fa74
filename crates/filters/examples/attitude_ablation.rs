//! The production attitude filter's ablation on BROAD: each modelling choice switched off in turn,
//! with the mean total / heading / inclination RMSE (deg) over the trials in the BROAD folder and
//! the heading and tilt NEES pooled over their scored samples (the heading's a χ²(1) mean, 1 for
//! a consistent filter; the tilt's a χ²(2) mean, 2 for a consistent filter).
//!
//! ```text
//! cargo run --release -p liebayes-filters --example attitude_ablation [DIR]
//! ```
//! DIR defaults to `$LIEBAYES_BROAD_DIR`. `ABLATION_ONLY=text` runs the variants whose label
//! contains `text`; `ABLATION_TRIALS=1` prints every trial's row too.

use liebayes_filters::FilterError;
use liebayes_filters::attitude::{
    AttitudeParams, LogScenario, Method, Propagation, Sensors, evaluate, read_broad,
};

fn main() {
    let files = liebayes_reference::broad::folder_trials(std::env::args().nth(1)).unwrap_or_else(
        |message| {
            eprintln!("{message}");
            std::process::exit(2);
        },
    );
    let logs: Vec<(String, LogScenario)> = files
        .iter()
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            let log = read_broad(p).expect("a BROAD trial");
            (name, LogScenario::new(log).expect("a non-empty trial"))
        })
        .collect();
    let only = std::env::var("ABLATION_ONLY").ok();
    let verbose = std::env::var("ABLATION_TRIALS").is_ok();
    let (labels, methods): (Vec<&str>, Vec<Method>) = variants()
        .into_iter()
        .filter(|(label, _)| only.as_deref().is_none_or(|o| label.contains(o)))
        .unzip();
    let evaluation =
        evaluate(&logs, &methods, &mut |_, _, _| Ok::<_, FilterError>(())).expect("the runs");
    println!("| variant | total | heading | inclination | NEES heading | NEES tilt |");
    println!("|---|---|---|---|---|---|");
    for (j, label) in labels.iter().enumerate() {
        if verbose {
            for (name, row) in evaluation.trials.iter().zip(&evaluation.scores) {
                let e = row[j].errors().expect("scored");
                let [nh, nt, _] = row[j].nees().expect("the EKF's covariance");
                println!(
                    "|   {name} | {:.2} | {:.2} | {:.2} | {nh:.2} | {nt:.2} |",
                    e.total, e.heading, e.inclination
                );
            }
        }
        let [total, heading, inclination] = evaluation.mean_errors(j).expect("scored");
        let pooled = evaluation.pooled(j).expect("a log");
        let [nh, nt, _] = pooled.nees().expect("the EKF's covariance");
        println!("| {label} | {total:.2} | {heading:.2} | {inclination:.2} | {nh:.2} | {nt:.2} |");
    }
}

/// The variants: the default filter, then one modelling choice off (or changed) at a time.
fn variants() -> Vec<(&'static str, Method)> {
    let base = AttitudeParams::default();
    let ekf = |params: AttitudeParams, sensors| Method::Ekf { params, sensors };
    let changed = |change: fn(&mut AttitudeParams)| {
        let mut p = base.clone();
        change(&mut p);
        ekf(p, Sensors::NineD)
    };
    vec![
        ("9D, all parts", ekf(base.clone(), Sensors::NineD)),
        ("9D, no gyro bias", changed(|p| p.estimate_bias = false)),
        ("9D, no rest detection", changed(|p| p.rest = None)),
        (
            "9D, no disturbance rejection",
            changed(|p| p.magnetometer.disturbance = None),
        ),
        (
            "9D, no position bound (σ 1 km)",
            changed(|p| p.position_bound = 1e3),
        ),
        (
            "9D, no field offset state",
            changed(|p| p.magnetometer.offset = None),
        ),
        (
            "9D, no magnetometer delay",
            changed(|p| p.magnetometer.delay = 0.0),
        ),
        ("9D, no IMU delay", changed(|p| p.imu_delay = 0.0)),
        (
            "9D, UKF propagation",
            changed(|p| p.propagation = Propagation::Ukf),
        ),
        ("6D, all parts", ekf(base.clone(), Sensors::SixD)),
    ]
}
