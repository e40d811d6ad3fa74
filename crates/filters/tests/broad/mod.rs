//! What the attitude filters' BROAD tests share: the twelve trials read as scenarios, the grid of
//! noise settings and its leave-one-trial-out cross-validation.

use liebayes_filters::attitude::{
    AttitudeParams, FieldOffset, LogScenario, MEASURED_FIELD_OFFSET, Method, evaluate, read_broad,
};
use liebayes_reference::broad::TRIALS;
use std::path::Path;

/// The twelve trials of `dir`, by name.
pub fn logs(dir: &Path) -> Vec<(String, LogScenario)> {
    TRIALS
        .iter()
        .map(|trial| {
            let log = read_broad(dir.join(format!("{trial}.mat"))).expect("a BROAD trial");
            (
                (*trial).to_owned(),
                LogScenario::new(log).expect("a non-empty trial"),
            )
        })
        .collect()
}

/// The method of `name` on the twelve trials of `dir`: prints each trial's RMSE (total / heading /
/// inclination, deg) and NEES per degree of freedom (heading / tilt), and returns the mean RMSE.
pub fn scores(dir: &Path, name: &str) -> [f64; 3] {
    let methods = [Method::from_name(name).expect("a method name")];
    let evaluation = evaluate(&logs(dir), &methods, &mut |_, _, _| Ok(())).expect("the runs");
    for (trial, row) in evaluation.trials.iter().zip(&evaluation.scores) {
        let e = row[0].errors().expect("scored");
        let [heading, tilt, _] = row[0].nees().expect("a covariance");
        println!(
            "| {trial} | {:.2} / {:.2} / {:.2} | {heading:.2} / {:.2} |",
            e.total,
            e.heading,
            e.inclination,
            tilt / 2.0
        );
    }
    let mean = evaluation.mean_errors(0).expect("scored");
    println!("mean: {:.2} / {:.2} / {:.2}", mean[0], mean[1], mean[2]);
    mean
}

/// The production filter's settings that cannot be read off the sensors' physics, every
/// combination of: the gyroscope's angle random walk at its physical white noise (1e-4 rad/√s,
/// the rest phases' Allan deviation), the default 4.5e-3, twice and four times that (inflated
/// values absorb unmodelled errors in motion); the rate-proportional noise (scale factor and axis
/// errors), 0.004 and 0.008; the magnetometer's heading σ, 12° and 24°; the bounded-velocity σ, 1
/// to 4 m/s; the velocity's random walk, 0.05 to 0.3 m/s/√s; the bounded-position σ, 0.5 to 2 m;
/// the field offset's σ_c, 1° and 2° (4°, the RMS of BROAD's measured 10-s offsets, was chosen
/// by one fold of twelve on a grid with it); the bounded-velocity updates' interval, 0.25 and
/// 0.5 s. The reported covariance is the filter's own (κ = 1: [`cross_validate`] calibrates it),
/// the rest at their defaults: 1728 settings. (A first grid of 216 settings, velocity σ from 0.5 to
/// 2 m/s, walk 0.1 and 0.3, position σ from 0.3 to 1 m, gyroscope up to 9e-3, had most held-out
/// choices on its edges; this one extends it past them.)
pub fn noise_grid() -> Vec<AttitudeParams> {
    let mut grid = Vec::new();
    for gyro_noise in [1e-4, 4.5e-3, 9e-3, 1.8e-2] {
        for rate_noise in [0.004, 0.008] {
            for heading_deg in [12.0_f64, 24.0] {
                for velocity_bound in [1.0, 2.0, 4.0] {
                    for velocity_walk in [0.05, 0.1, 0.3] {
                        for position_bound in [0.5, 1.0, 2.0] {
                            for offset_deg in [1.0_f64, 2.0] {
                                for velocity_interval in [0.25, 0.5] {
                                    let mut params = AttitudeParams {
                                        gyro_noise,
                                        rate_noise,
                                        velocity_bound,
                                        velocity_walk,
                                        position_bound,
                                        velocity_interval,
                                        tilt_variance_scale: 1.0,
                                        ..AttitudeParams::default()
                                    };
                                    params.magnetometer.heading_sigma = heading_deg.to_radians();
                                    params.magnetometer.offset = Some(FieldOffset {
                                        sigma: offset_deg.to_radians(),
                                        ..MEASURED_FIELD_OFFSET
                                    });
                                    grid.push(params);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    grid
}

/// Runs `method` with every setting of [`noise_grid`] on every log and cross-validates the choice
/// (`Evaluation::leave_one_out`): prints each held-out trial's choice and score, and the
/// cross-validated mean with the pooled NEES per degree of freedom; returns the cross-validated
/// mean (total, heading, inclination).
///
/// With the setting it cross-validates the reported tilt variance's factor κ
/// (`AttitudeParams::tilt_variance_scale`; the grid reports the filter's own covariance, κ = 1):
/// each held-out trial's κ makes the pooled tilt NEES of the other eleven, at the setting chosen
/// without it, one per degree of freedom (a tilt NEES scales as 1/κ exactly), and the held-out
/// NEES divided by it are pooled; it prints them per trial and pooled, and κ from all twelve.
pub fn cross_validate(
    logs: &[(String, LogScenario)],
    method: impl Fn(AttitudeParams) -> Method,
) -> [f64; 3] {
    let grid = noise_grid();
    let methods: Vec<Method> = grid.iter().cloned().map(method).collect();
    let evaluation = evaluate(logs, &methods, &mut |_, _, _| Ok(())).expect("the runs");
    let cv = evaluation.leave_one_out().expect("scored logs");
    for ((trial, row), &best) in evaluation
        .trials
        .iter()
        .zip(&evaluation.scores)
        .zip(&cv.chosen)
    {
        let e = row[best].errors().expect("scored");
        let [heading, tilt, _] = row[best].nees().expect("a covariance");
        let p = &grid[best];
        println!(
            "| {trial} | {:.1e} / {} / {:.0} / {} / {} / {} / {:.0} / {} | {:.2} / {:.2} / {:.2} \
             | {heading:.2} / {:.2} |",
            p.gyro_noise,
            p.rate_noise,
            p.magnetometer.heading_sigma.to_degrees(),
            p.velocity_bound,
            p.velocity_walk,
            p.position_bound,
            p.magnetometer.offset.map_or(0.0, |o| o.sigma.to_degrees()),
            p.velocity_interval,
            e.total,
            e.heading,
            e.inclination,
            tilt / 2.0
        );
    }
    let tilt_sums = |trial: usize, j: usize| {
        let s = evaluation.scores[trial][j]
            .stats("tilt_nees")
            .expect("a covariance");
        (s.sum(), s.count() as f64)
    };
    let kappa = |without: Option<usize>, j: usize| {
        let (sum, count) = (0..logs.len())
            .filter(|&k| Some(k) != without)
            .map(|k| tilt_sums(k, j))
            .fold((0.0, 0.0), |(s, c), (ds, dc)| (s + ds, c + dc));
        sum / count / 2.0
    };
    let (mut sum, mut count) = (0.0, 0.0);
    for (i, &best) in cv.chosen.iter().enumerate() {
        let (held, n) = tilt_sums(i, best);
        let k = kappa(Some(i), best);
        println!(
            "| {} | κ {k:.4} | calibrated tilt NEES per dof {:.2} |",
            evaluation.trials[i],
            held / n / k / 2.0
        );
        sum += held / k;
        count += n;
    }
    let most = (0..grid.len())
        .max_by_key(|&j| cv.chosen.iter().filter(|&&c| c == j).count())
        .expect("a setting");
    println!(
        "calibrated tilt NEES per dof, cross-validated and pooled: {:.3}; κ from all twelve at the \
         setting chosen most: {:.4}",
        sum / count / 2.0,
        kappa(None, most)
    );
    let [heading, tilt, _] = cv.pooled.nees().expect("a covariance");
    let in_sample = (0..grid.len())
        .filter_map(|j| evaluation.mean_errors(j))
        .map(|e| e[0])
        .fold(f64::INFINITY, f64::min);
    let [total, head, inclination] = cv.mean_errors;
    println!(
        "cross-validated mean (12): {total:.3} / {head:.3} / {inclination:.3}; pooled NEES \
         heading {heading:.2}, tilt {:.2} per degree of freedom; best in-sample mean {in_sample:.2}",
        tilt / 2.0
    );
    cv.mean_errors
}
