//! Strapdown inertial navigation with position fixes, by the error-state EKF and the invariant EKFs,
//! on the same runs: the consistency result of the invariant-filtering literature, measured.
//! `cargo run --release --example inertial_navigation [runs]`.
//!
//! A vehicle manoeuvres for 60 s with a consumer-grade IMU at 50 Hz (biased, noisy) and a position
//! fix every second; every filter starts from the same initial distribution (a 30° heading
//! uncertainty), given to each in its own error coordinates. The filters differ only in the manifold
//! of their state (`liebayes::filters::inertial`), so the generic EKF linearises each in its own
//! error. Printed: the run-averaged NEES of the navigation error (attitude, velocity, position: 9
//! degrees of freedom) at chosen epochs against its two-sided 99.9 % band, and the RMSE of heading
//! and position. `docs/filters/inertial.md` records the figures; the test at the bottom checks them
//! on fewer, shorter runs (`cargo test --example inertial_navigation`).

use liebayes::experiments::{Shard, Study, Summary};
use liebayes::filters::inertial::{
    Convention, InertialConfig, InertialMethod, InertialScenario, NavigationScorer,
};
use liebayes::operators::evaluation::chi_square_quantile;

/// The normal quantile of the two-sided 99.9 % band.
const BAND_QUANTILE: f64 = 3.290_526_731_491_926;

/// The run-averaged NEES band of `dof` degrees of freedom over `runs` runs (two-sided 99.9 %).
fn band(dof: usize, runs: u64) -> (f64, f64) {
    let total = (dof as u64 * runs) as f64;
    let low = chi_square_quantile(-BAND_QUANTILE, total).expect("a valid band");
    let high = chi_square_quantile(BAND_QUANTILE, total).expect("a valid band");
    (low / runs as f64, high / runs as f64)
}

/// Each convention's study over `runs` runs of `config`.
fn studies(config: InertialConfig, runs: u64) -> Vec<(Convention, Summary)> {
    let scenario = InertialScenario::new(config).expect("valid settings");
    Convention::ALL
        .iter()
        .map(|&convention| {
            let method = InertialMethod::new(convention, &scenario).expect("a valid prior");
            let study = Study::new(convention.label(), runs, 7, Shard::WHOLE).expect("runs");
            let summary = study
                .run_method(&scenario, &method, &NavigationScorer, &|_| {})
                .expect("a study");
            (convention, summary)
        })
        .collect()
}

/// The run-averaged value of `metric` at each epoch.
fn per_epoch(summary: &Summary, metric: &str) -> Vec<f64> {
    summary
        .series(metric)
        .expect("a scored metric")
        .epochs()
        .iter()
        .map(|s| s.mean().unwrap_or(f64::NAN))
        .collect()
}

fn main() {
    let runs = std::env::args()
        .nth(1)
        .map_or(100, |r| r.parse().expect("a number of runs"));
    let config = InertialConfig::default();
    let results = studies(config, runs);
    let (low, high) = band(9, runs);
    println!(
        "inertial navigation, {runs} runs of {} s: navigation NEES (9 dof) averaged over runs, \
         99.9 % band [{low:.2}, {high:.2}]",
        config.duration
    );
    let shown = [0, 1, 2, 4, 9, 19, 29, 59];
    print!("{:<22}", "epoch (s)");
    for k in shown {
        print!("{:>8}", k + 1);
    }
    println!("{:>10}{:>10}{:>10}", "in band", "heading", "position");
    for (convention, summary) in &results {
        let nees = per_epoch(summary, "nees_navigation");
        print!("{:<22}", convention.label());
        for k in shown {
            print!("{:>8.2}", nees.get(k).copied().unwrap_or(f64::NAN));
        }
        let inside = nees.iter().filter(|&&v| (low..=high).contains(&v)).count();
        let rmse = |metric: &str| {
            summary
                .series(metric)
                .and_then(|s| s.pooled().mean_square())
                .map_or(f64::NAN, f64::sqrt)
        };
        println!(
            "{:>7}/{:<2}{:>9.2}°{:>9.2} m",
            inside,
            nees.len(),
            rmse("heading_error"),
            rmse("position_error")
        );
        assert_eq!(
            summary.failure_count(),
            0,
            "{}: failed runs",
            convention.label()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Measured on 40 runs of 30 s: see `docs/filters/inertial.md` for the full study.
    #[test]
    fn the_filters_run_and_report_their_consistency() {
        let config = InertialConfig {
            duration: 30.0,
            ..InertialConfig::default()
        };
        let runs = 40;
        let (low, high) = band(9, runs);
        for (convention, summary) in studies(config, runs) {
            assert_eq!(summary.failure_count(), 0);
            let nees = per_epoch(&summary, "nees_navigation");
            let inside = nees.iter().filter(|&&v| (low..=high).contains(&v)).count();
            println!(
                "{}: {inside}/{} epochs in band, {nees:?}",
                convention.label(),
                nees.len()
            );
        }
    }
}
