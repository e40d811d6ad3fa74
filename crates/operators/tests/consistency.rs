//! The Kalman filters' reports against their own claims, on data simulated from the models they use:
//! the normalised innovation squared `νᵀ S⁻¹ ν` of a consistent filter is χ² with M degrees of
//! freedom and independent from step to step, so n times its average over n steps is χ² with n M
//! degrees of freedom; the NEES of the final estimate, averaged over independent runs, likewise with
//! D degrees of freedom per run. The file checks ten such averages, each against its two-sided
//! 99.9 % band (`chi_square_quantile` at ±3.29), so that a consistent set of filters fails one with
//! probability below 1 %.
//!
//! * the linear Kalman filter on a constant-velocity model (exact, so the band must hold);
//! * the EKF and the UKF on SO(2) with a nonlinear measurement (the heading's unit vector), and on
//!   SO(3) with two measured reference directions, both with noise small enough that the
//!   linearisation error (of relative order P, about 1e-3 here) is far inside the band's width.
//!
//! Each test also runs a filter with a wrong noise model (R too small by a factor 4) and requires its
//! NIS to fall above the band: the check can fail. The sizes (10⁴ innovations, 10⁴ to 3·10⁴ degrees
//! of freedom) put the NIS bands' half-widths at 2.7 to 4.7 %; the whole file runs in well under a
//! second.

use liebayes_densities::{Density, Gaussian, ManifoldGaussian};
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, So2, So3};
use liebayes_operators::evaluation::chi_square_quantile;
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::{
    Condition, Ekf, MeasurementFn, MeasurementModel, ProcessFn, ProcessModel, Propagate, Ukf,
};
use nalgebra::{
    Matrix1, Matrix2, Matrix3, RowVector2, SMatrix, SVector, Vector1, Vector2, Vector3,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The averages of a simulation: NIS over every step of every run, NEES of the final estimates.
#[derive(Default)]
struct Averages {
    nis: Average,
    nees: Average,
}

/// The average of finite values.
#[derive(Default)]
struct Average {
    sum: f64,
    count: usize,
}

impl Average {
    fn add(&mut self, x: f64) {
        assert!(x.is_finite(), "a non-finite statistic: {x}");
        self.sum += x;
        self.count += 1;
    }

    fn mean(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum / self.count as f64)
    }

    fn count(&self) -> usize {
        self.count
    }
}

/// The standard normal 99.95 % quantile.
const Z_9995: f64 = 3.290_526_731_491_894;

/// The two-sided 99.9 % band of the average of `count` independent χ² values with `dim` degrees of
/// freedom each.
fn band(dim: usize, count: usize) -> (f64, f64) {
    let dof = (dim * count) as f64;
    (
        chi_square_quantile(-Z_9995, dof).unwrap() / count as f64,
        chi_square_quantile(Z_9995, dof).unwrap() / count as f64,
    )
}

/// Asserts that the average lies in its band (or, for a wrong model, above it).
fn check(name: &str, average: &Average, band: (f64, f64), consistent: bool) {
    let mean = average.mean().expect("at least one value");
    if consistent {
        assert!(
            band.0 <= mean && mean <= band.1,
            "{name}: average {mean} outside the band {band:?} of {} values",
            average.count()
        );
    } else {
        assert!(
            mean > band.1,
            "{name}: the wrong model's average {mean} is inside the band {band:?}"
        );
    }
}

#[test]
fn kalman_nis_is_in_its_band() {
    let (dt, q) = (0.1_f64, 0.5);
    let f = Matrix2::new(1.0, dt, 0.0, 1.0);
    let noise = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * q;
    let process = LinearProcess::new(f, noise).unwrap();
    let h = RowVector2::new(1.0, 0.0);
    let r = 0.04;
    let (runs, steps) = (200, 50);
    for (name, r_filter, consistent) in [("KF", r, true), ("KF, R too small", r / 4.0, false)] {
        let measurement = LinearMeasurement::new(h, Matrix1::new(r_filter)).unwrap();
        let mut averages = Averages::default();
        for run in 0..runs {
            let mut rng = ChaCha8Rng::seed_from_u64(run as u64);
            let mut filter = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::identity()).unwrap();
            let mut truth = filter.sample(&mut rng);
            let process_noise = Gaussian::new(Vector2::zeros(), noise).unwrap();
            let measurement_noise = Gaussian::new(Vector1::zeros(), Matrix1::new(r)).unwrap();
            for _ in 0..steps {
                truth = f * truth + process_noise.sample(&mut rng);
                let z = h * truth + measurement_noise.sample(&mut rng);
                filter = filter.propagate(&process, &Vector2::zeros()).unwrap();
                let step = filter.condition(&measurement, &z).unwrap();
                averages.nis.add(step.report.nis());
                filter = step.posterior;
            }
            averages.nees.add(filter.mahalanobis_squared(&truth));
        }
        check(name, &averages.nis, band(1, runs * steps), consistent);
        if consistent {
            check(name, &averages.nees, band(2, runs), true);
        }
    }
}

/// Which filter a simulation runs.
#[derive(Clone, Copy, Debug)]
enum Filter {
    Extended,
    Unscented,
}

/// Simulates `runs` trajectories of `steps` steps from the prior and the models, truth drawn from
/// the models' own noise (`x′ = f(x) ⊞ w`, `z = h(x) + n`), and filters each with `filter` using
/// `measurement` (which may carry a wrong noise).
#[allow(clippy::too_many_arguments)]
fn simulate<X, P, H, T, const D: usize, const M: usize>(
    filter: Filter,
    prior: &ManifoldGaussian<X, D>,
    process: &P,
    truth_measurement: &T,
    measurement: &H,
    runs: usize,
    steps: usize,
) -> Averages
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D, Input = ()>,
    T: MeasurementModel<X, D, M>,
    H: MeasurementModel<X, D, M>,
{
    let mut averages = Averages::default();
    for run in 0..runs {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + run as u64);
        let mut density = prior.clone();
        let mut truth = prior.sample(&mut rng);
        for _ in 0..steps {
            let moved = process.transition(&truth, &());
            truth = ManifoldGaussian::new(moved, process.noise(&truth, &()))
                .unwrap()
                .sample(&mut rng);
            let z = Gaussian::new(
                truth_measurement.predict(&truth),
                truth_measurement.noise(&truth),
            )
            .unwrap()
            .sample(&mut rng);
            let step = match filter {
                Filter::Extended => density
                    .propagate(&Ekf(process), &())
                    .and_then(|d| d.condition(&Ekf(measurement), &z)),
                Filter::Unscented => density
                    .propagate(&Ukf::new(process), &())
                    .and_then(|d| d.condition(&Ukf::new(measurement), &z)),
            }
            .unwrap();
            averages.nis.add(step.report.nis());
            density = step.posterior;
        }
        averages.nees.add(density.mahalanobis_squared(&truth));
    }
    averages
}

#[test]
fn ekf_and_ukf_nis_on_a_heading_seen_as_a_unit_vector() {
    let (rate, q, sigma) = (0.3, 1e-3, 0.05);
    let process = ProcessFn::new(
        |x: &So2<f64>, (): &()| x.retract(&Vector1::new(rate)),
        |_, ()| Matrix1::new(q),
    );
    let unit_vector = |variance: f64| {
        MeasurementFn::new(
            |x: &So2<f64>| {
                let (s, c) = x.angle().sin_cos();
                Vector2::new(c, s)
            },
            move |_| Matrix2::identity() * variance,
        )
    };
    let truth = unit_vector(sigma * sigma);
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(3.0), Matrix1::new(0.01)).unwrap();
    let (runs, steps) = (200, 50);
    for filter in [Filter::Extended, Filter::Unscented] {
        let right = simulate(filter, &prior, &process, &truth, &truth, runs, steps);
        let name = format!("{filter:?} on SO(2)");
        check(&name, &right.nis, band(2, runs * steps), true);
        check(&name, &right.nees, band(1, runs), true);
        let wrong = unit_vector(sigma * sigma / 4.0);
        let wrong = simulate(filter, &prior, &process, &truth, &wrong, runs, steps);
        check(&name, &wrong.nis, band(2, runs * steps), false);
    }
}

/// `[Rᵀ g; Rᵀ m]`: two known world directions (gravity, a magnetic field) seen in the body frame.
fn directions(x: &So3<f64>) -> SVector<f64, 6> {
    let g = x.inverse().act(&Vector3::new(0.0, 0.0, 1.0));
    let m = x.inverse().act(&Vector3::new(0.6, 0.0, 0.8));
    SVector::<f64, 6>::from_iterator(g.iter().chain(m.iter()).copied())
}

#[test]
fn ekf_and_ukf_nis_on_an_attitude_seen_through_two_directions() {
    let increment = So3::exp(&Vector3::new(0.05, -0.02, 0.1));
    let process = ProcessFn::new(
        move |x: &So3<f64>, (): &()| x.compose(&increment),
        |_, ()| Matrix3::identity() * 1e-4,
    );
    let sensors = |variance: f64| {
        MeasurementFn::new(directions, move |_| {
            SMatrix::<f64, 6, 6>::identity() * variance
        })
    };
    let sigma = 0.02;
    let truth = sensors(sigma * sigma);
    let mean = So3::exp(&Vector3::new(0.3, 2.5, -0.4));
    let prior = ManifoldGaussian::new(mean, Matrix3::identity() * 0.01).unwrap();
    let (runs, steps) = (100, 50);
    for filter in [Filter::Extended, Filter::Unscented] {
        let right = simulate(filter, &prior, &process, &truth, &truth, runs, steps);
        let name = format!("{filter:?} on SO(3)");
        check(&name, &right.nis, band(6, runs * steps), true);
        check(&name, &right.nees, band(3, runs), true);
        let wrong = sensors(sigma * sigma / 4.0);
        let wrong = simulate(filter, &prior, &process, &truth, &wrong, runs, steps);
        check(&name, &wrong.nis, band(6, runs * steps), false);
    }
}
