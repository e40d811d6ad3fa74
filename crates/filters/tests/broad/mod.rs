//! What the attitude filters' BROAD tests share: the twelve trials read as scenarios, and the
//! leave-one-trial-out cross-validation of a grid of noise settings.

use liebayes_filters::FilterError;
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
    let evaluation = evaluate(
        &logs(dir),
        &methods,
        &mut |_, _, _| Ok::<_, FilterError>(()),
    )
    .expect("the runs");
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

/// The values a grid gives each setting that cannot be read off the sensors' physics (the heading
/// σ and the field offset's σ_c in degrees).
pub struct Axes {
    pub gyro_noise: &'static [f64],
    pub rate_noise: &'static [f64],
    pub heading_deg: &'static [f64],
    pub velocity_bound: &'static [f64],
    pub velocity_walk: &'static [f64],
    pub position_bound: &'static [f64],
    pub offset_deg: &'static [f64],
    pub velocity_interval: &'static [f64],
}

/// Every combination of `axes` (the first axis outermost), the rest as in `base`, each reporting
/// the filter's own covariance (κ = 1: [`cross_validate`] calibrates it).
pub fn grid(base: &AttitudeParams, axes: &Axes) -> Vec<AttitudeParams> {
    let mut grid = vec![AttitudeParams {
        tilt_variance_scale: 1.0,
        ..base.clone()
    }];
    let mut along = |values: &[f64], set: fn(&mut AttitudeParams, f64)| {
        grid = grid
            .iter()
            .flat_map(|p| {
                values.iter().map(move |&v| {
                    let mut p = p.clone();
                    set(&mut p, v);
                    p
                })
            })
            .collect();
    };
    along(axes.gyro_noise, |p, v| p.gyro_noise = v);
    along(axes.rate_noise, |p, v| p.rate_noise = v);
    along(axes.heading_deg, |p, v| {
        p.magnetometer.heading_sigma = v.to_radians();
    });
    along(axes.velocity_bound, |p, v| p.velocity_bound = v);
    along(axes.velocity_walk, |p, v| p.velocity_walk = v);
    along(axes.position_bound, |p, v| p.position_bound = v);
    along(axes.offset_deg, |p, v| {
        p.magnetometer.offset = Some(FieldOffset {
            sigma: v.to_radians(),
            ..MEASURED_FIELD_OFFSET
        });
    });
    along(axes.velocity_interval, |p, v| p.velocity_interval = v);
    grid
}

/// Runs `method` with every setting of `grid` on every log and cross-validates the choice
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
    grid: &[AttitudeParams],
    method: impl Fn(AttitudeParams) -> Method,
) -> [f64; 3] {
    let methods: Vec<Method> = grid.iter().cloned().map(method).collect();
    let evaluation =
        evaluate(logs, &methods, &mut |_, _, _| Ok::<_, FilterError>(())).expect("the runs");
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
