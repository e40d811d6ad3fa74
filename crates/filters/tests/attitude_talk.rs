//! The talk's Bingham / heat-kernel attitude filter: one update and one propagation against Monte
//! Carlo of the prior, a run on the simulator, bad input, and the twelve BROAD trials (ignored:
//! release only). Its density algebra (the direction likelihood and the diffusion moment matching)
//! is tested in the densities crate (`tests/bingham_attitude.rs`).
//!
//! The BROAD data are looked for in `$LIEBAYES_BROAD_DIR`, else in `shared/broad` beside the
//! workspace.

use liebayes_densities::{Density, HeatKernelSo3};
use liebayes_filters::attitude::{
    DataError, ImuLog, SimulationSettings, TalkFilter, TalkParams, read_broad, run_talk_filter,
    simulate, trial_errors,
};
use liebayes_manifolds::{LieGroup, So3};
use liebayes_reference::broad::{TRIALS, data_dir};
use nalgebra::{Matrix4, UnitQuaternion, Vector3, Vector4};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn coords(q: &UnitQuaternion<f64>) -> Vector4<f64> {
    Vector4::new(q.w, q.i, q.j, q.k)
}

/// Weighted mean of `x` (one 4×4 matrix per sample) and the standard error of each entry,
/// `√(Σ wᵢ² (xᵢ − x̄)²) / Σ wᵢ`.
fn weighted_moment(samples: &[(f64, Matrix4<f64>)]) -> (Matrix4<f64>, Matrix4<f64>) {
    let total: f64 = samples.iter().map(|(w, _)| w).sum();
    let mean = samples
        .iter()
        .fold(Matrix4::zeros(), |acc, (w, x)| acc + x * *w)
        / total;
    let var = samples.iter().fold(Matrix4::zeros(), |acc, (w, x)| {
        acc + (x - mean).map(|d| d * d) * (w * w)
    });
    (mean, var.map(f64::sqrt) / total)
}

fn assert_within(what: &str, ours: &Matrix4<f64>, mc: &Matrix4<f64>, se: &Matrix4<f64>) {
    let mut worst = 0.0_f64;
    for i in 0..16 {
        let z = (ours[i] - mc[i]).abs() / (se[i] + 1e-12);
        worst = worst.max(z);
    }
    println!("{what}: largest |ours - MC| / standard error = {worst:.2}");
    assert!(worst < 5.0, "{what}: {worst} standard errors\n{ours}\n{mc}");
}

fn field() -> Vector3<f64> {
    let dip = 60f64.to_radians();
    Vector3::new(0.0, dip.cos(), -dip.sin())
}

/// One accelerometer + magnetometer update of a 20° prior against importance weights: 200 000
/// draws of the prior (the library's exact sampler), weighted by the Gaussian likelihoods of the
/// two unit directions computed directly; the posterior's second moments within 5 standard
/// errors, and its mode within 0.5° of the weighted scatter's principal axis.
#[test]
fn update_matches_importance_weighted_prior() {
    let params = TalkParams {
        acc_noise: 0.15,
        mag_noise: 0.3,
        initial_sigma: 20f64.to_radians(),
        ..TalkParams::default()
    };
    let prior_mean = UnitQuaternion::from_scaled_axis(Vector3::new(0.2, -0.3, 1.0));
    let mut filter = TalkFilter::new(&params, 100.0, &prior_mean, Some(field())).unwrap();
    let prior = filter.bingham().clone();
    let truth = prior_mean * UnitQuaternion::from_scaled_axis(Vector3::new(0.15, 0.1, -0.2));
    let acc = truth.inverse_transform_vector(&Vector3::z()) + Vector3::new(0.05, -0.03, 0.02);
    let mag = truth.inverse_transform_vector(&field()) + Vector3::new(-0.1, 0.05, 0.08);
    filter.update(&(acc * 9.81), Some(&(mag * 48.0))).unwrap();
    let (a, m) = (acc.normalize(), mag.normalize());
    let log_likelihood = |q: &UnitQuaternion<f64>| {
        -(a - q.inverse_transform_vector(&Vector3::z())).norm_squared()
            / (2.0 * params.acc_noise * params.acc_noise)
            - (m - q.inverse_transform_vector(&field())).norm_squared()
                / (2.0 * params.mag_noise * params.mag_noise)
    };
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let samples: Vec<(f64, Matrix4<f64>)> = (0..200_000)
        .map(|_| {
            let q = *prior.sample(&mut rng).as_unit_quaternion();
            let x = coords(&q);
            (log_likelihood(&q).exp(), x * x.transpose())
        })
        .collect();
    let (mc, se) = weighted_moment(&samples);
    let posterior = filter.bingham();
    assert_within("update", &posterior.second_moment(), &mc, &se);
    let principal = nalgebra::SymmetricEigen::new(mc);
    let k = principal.eigenvalues.imax();
    let axis = principal.eigenvectors.column(k);
    let mode = coords(posterior.mode().unwrap().as_unit_quaternion());
    let angle = 2.0 * mode.dot(&axis).abs().min(1.0).acos();
    println!(
        "update: mode vs weighted principal axis {:.4} deg",
        angle.to_degrees()
    );
    assert!(angle < 0.5f64.to_radians(), "{angle} rad");
}

/// One gyroscope step against Monte Carlo: draws of the prior (an anisotropic Bingham after an
/// update), each turned by the talk's smoothed rate `ω̃ Δt` and diffused by an independent
/// isotropic heat-kernel draw of variance `σ̃² Δt²` (the library's sampler); the propagated
/// Bingham's second moments within 5 standard errors. The rate's Kalman update is checked
/// against the talk's formulas.
#[test]
fn propagation_matches_rotated_and_diffused_prior() {
    let params = TalkParams {
        gyro_noise: 1.0,
        rate_walk: 2.0,
        acc_noise: 0.2,
        initial_sigma: 15f64.to_radians(),
        initial_rate_sigma: 1.5,
        ..TalkParams::default()
    };
    let (rate, dt) = (10.0, 0.1);
    let mean = UnitQuaternion::from_scaled_axis(Vector3::new(-0.5, 0.1, 0.3));
    let mut filter = TalkFilter::new(&params, rate, &mean, None).unwrap();
    let acc = mean.inverse_transform_vector(&Vector3::new(0.1, 0.0, 1.0));
    filter.update(&acc, None).unwrap();
    let prior = filter.bingham().clone();
    let gyr = Vector3::new(0.8, -1.2, 2.0);
    filter.propagate(&gyr).unwrap();
    // The talk's formulas, with ω̄₀ = 0.
    let (su, sa, so) = (1.0, 4.0 * dt * dt, 1.5 * 1.5);
    let d = su + sa + so;
    let smoothed = gyr * (so / d);
    let added = (su + sa) * so / d * dt * dt;
    let (rate_mean, rate_var) = filter.rate();
    assert!((rate_mean - gyr * ((sa + so) / d)).amax() < 1e-14);
    assert!((rate_var - su * (sa + so) / d).abs() < 1e-14);
    let turn = UnitQuaternion::from_scaled_axis(smoothed * dt);
    let kernel = HeatKernelSo3::new(So3::identity(), added).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let samples: Vec<(f64, Matrix4<f64>)> = (0..200_000)
        .map(|_| {
            let q = *prior.sample(&mut rng).as_unit_quaternion();
            let eta = *kernel.sample(&mut rng).as_unit_quaternion();
            let x = coords(&(q * turn * eta));
            (1.0, x * x.transpose())
        })
        .collect();
    let (mc, se) = weighted_moment(&samples);
    assert_within("propagation", &filter.bingham().second_moment(), &mc, &se);
}

fn mean_nees_and_rmse(log: &ImuLog, run: &liebayes_filters::attitude::TalkRun) -> (f64, f64) {
    let reference = log.reference().unwrap();
    let (mut nees, mut squared, mut n) = (0.0, 0.0, 0.0);
    for ((q, c), r) in run.orientations.iter().zip(&run.covariances).zip(reference) {
        let r = r.unwrap();
        let xi = (q.inverse() * r).scaled_axis();
        nees += (xi.transpose() * c.try_inverse().unwrap() * xi)[0];
        squared += xi.norm_squared();
        n += 1.0;
    }
    (nees / n, (squared / n).sqrt())
}

/// Ten seconds of the simulator without gyro bias and with little linear acceleration: the
/// error stays below 0.5° throughout the last half, and the mean NEES (3 for a consistent filter)
/// is reported.
#[test]
fn simulator_error_stays_bounded() {
    let settings = SimulationSettings {
        samples: 2858,
        acceleration_bound: 0.05,
        gyro_bias_walk: 0.0,
        initial_gyro_bias: Vector3::zeros(),
        ..SimulationSettings::default()
    };
    let log = simulate(&settings, 3).unwrap();
    let params = TalkParams {
        gyro_noise: settings.gyro_noise,
        rate_walk: 35.0,
        acc_noise: 0.2,
        mag_noise: 0.2,
        ..TalkParams::default()
    };
    let run = run_talk_filter(&log, &params).unwrap();
    let reference = log.reference().unwrap();
    let half = log.len() / 2;
    let worst = run.orientations[half..]
        .iter()
        .zip(&reference[half..])
        .map(|(q, r)| q.angle_to(&r.unwrap()))
        .fold(0.0_f64, f64::max);
    let (nees, rmse) = mean_nees_and_rmse(&log, &run);
    let sigma = run.reported_sigma();
    let mean_sigma = sigma[half..].iter().sum::<f64>() / (sigma.len() - half) as f64;
    println!(
        "simulator: RMSE {:.3} deg, worst in the last half {:.3} deg, mean reported sigma \
         {:.3} deg, mean NEES {nees:.2} (3 if consistent)",
        rmse.to_degrees(),
        worst.to_degrees(),
        mean_sigma.to_degrees(),
    );
    assert!(
        worst < 0.5f64.to_radians(),
        "worst {} deg",
        worst.to_degrees()
    );
}

#[test]
fn bad_input_is_refused_with_typed_errors() {
    let good = TalkParams::default();
    let fields: [fn(&mut TalkParams, f64); 6] = [
        |p, v| p.gyro_noise = v,
        |p, v| p.rate_walk = v,
        |p, v| p.acc_noise = v,
        |p, v| p.mag_noise = v,
        |p, v| p.initial_sigma = v,
        |p, v| p.initial_rate_sigma = v,
    ];
    for set in fields {
        for value in [f64::NAN, f64::INFINITY, -1.0] {
            let mut p = good;
            set(&mut p, value);
            assert!(matches!(p.validate(), Err(DataError::BadValue { .. })));
        }
    }
    let q = UnitQuaternion::identity();
    assert!(TalkFilter::new(&good, 0.0, &q, None).is_err());
    assert!(TalkFilter::new(&good, 100.0, &q, Some(Vector3::new(0.0, 2.0, 0.0))).is_err());
    // Too concentrated for a Bingham.
    let tight = TalkParams {
        initial_sigma: 1e-6,
        ..good
    };
    assert!(TalkFilter::new(&tight, 100.0, &q, None).is_err());
    let mut filter = TalkFilter::new(&good, 100.0, &q, Some(field())).unwrap();
    let before = filter.clone();
    assert!(filter.propagate(&Vector3::new(f64::NAN, 0.0, 0.0)).is_err());
    assert!(
        filter
            .update(&Vector3::new(0.0, f64::INFINITY, 0.0), None)
            .is_err()
    );
    let sharp = TalkParams {
        acc_noise: 1e-5,
        ..good
    };
    let mut sharp_filter = TalkFilter::new(&sharp, 100.0, &q, None).unwrap();
    let sharp_before = sharp_filter.clone();
    assert!(sharp_filter.update(&Vector3::z(), None).is_err());
    assert_eq!(sharp_filter, sharp_before);
    assert_eq!(filter, before);
    // A zero reading skips its update.
    filter
        .update(&Vector3::zeros(), Some(&Vector3::zeros()))
        .unwrap();
    assert_eq!(filter.bingham(), before.bingham());
    let empty = ImuLog::new(285.0, Vec::new(), Vec::new(), None).unwrap();
    assert!(matches!(
        run_talk_filter(&empty, &good),
        Err(DataError::NothingToScore { .. })
    ));
    let zero = ImuLog::new(285.0, vec![Vector3::zeros()], vec![Vector3::zeros()], None).unwrap();
    assert!(matches!(
        run_talk_filter(&zero, &good),
        Err(DataError::BadValue { .. })
    ));
}

/// The talk's filter on the twelve BROAD trials with one parameter set (σ_U = 0.1 rad/s,
/// σ_A = 30 rad/s², σ_V = 0.2, σ_W = 1, the best of the five settings listed in
/// `docs/filters/attitude.md`; or σ_U, σ_A, σ_V, σ_W from `$LIEBAYES_TALK_NOISE` as four
/// comma-separated numbers), printing
/// each trial's total / heading / inclination RMSE, the mean reported σ and the mean. About 80 s
/// in release; run with
/// `cargo test --release -p liebayes-filters --test attitude_talk -- --ignored --nocapture`.
#[test]
#[ignore = "about a minute in release: cargo test --release -p liebayes-filters --test attitude_talk -- --ignored"]
fn broad_twelve_trials() {
    let Some(dir) = data_dir() else { return };
    let mut params = TalkParams {
        gyro_noise: 0.1,
        rate_walk: 30.0,
        acc_noise: 0.2,
        mag_noise: 1.0,
        ..TalkParams::default()
    };
    if let Some(text) = std::env::var_os("LIEBAYES_TALK_NOISE") {
        let v: Vec<f64> = text
            .to_string_lossy()
            .split(',')
            .map(|x| x.trim().parse().expect("LIEBAYES_TALK_NOISE: four numbers"))
            .collect();
        assert_eq!(v.len(), 4, "LIEBAYES_TALK_NOISE: four numbers");
        (
            params.gyro_noise,
            params.rate_walk,
            params.acc_noise,
            params.mag_noise,
        ) = (v[0], v[1], v[2], v[3]);
    }
    println!("{params:?}");
    let mut sum = [0.0; 3];
    for name in TRIALS {
        let log = read_broad(dir.join(format!("{name}.mat"))).expect("BROAD trial reads");
        let run = run_talk_filter(&log, &params).expect("the filter runs");
        let e = trial_errors(&run.orientations, &log).expect("scored");
        let sigma = run.reported_sigma();
        let mean_sigma = sigma.iter().sum::<f64>() / sigma.len() as f64;
        println!(
            "| {name} | {:.2} / {:.2} / {:.2} | {:.2} |",
            e.total,
            e.heading,
            e.inclination,
            mean_sigma.to_degrees()
        );
        sum[0] += e.total;
        sum[1] += e.heading;
        sum[2] += e.inclination;
    }
    println!(
        "| mean (12) | {:.2} / {:.2} / {:.2} | |",
        sum[0] / 12.0,
        sum[1] / 12.0,
        sum[2] / 12.0,
    );
    assert!(sum[0].is_finite());
}
