//! The Kalman filter against independent computations: the information form of Bayes' rule, the
//! Bayes identity `ln p(z) = ln p(z | x) + ln p(x) − ln p(x | z)` at an arbitrary x (which checks the
//! posterior and the evidence together, with the densities crate's own log-pdf), and the Gaussian
//! convolution for propagation.

use liebayes_densities::testing::strategies::gaussian;
use liebayes_densities::{Convolve, Density, Gaussian, Product};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::{Condition, OperatorError, Propagate};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, SMatrix, SVector, Vector2, Vector3};
use proptest::prelude::*;

fn matrix<const R: usize, const C: usize>(range: f64) -> impl Strategy<Value = SMatrix<f64, R, C>> {
    proptest::collection::vec(-range..range, R * C)
        .prop_map(|v| SMatrix::<f64, R, C>::from_column_slice(&v))
}

/// Scale of the numbers involved, for tolerances relative to them.
fn scale(values: &[f64]) -> f64 {
    1.0 + values.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn update_matches_the_information_form_and_the_bayes_identity(
        prior in gaussian::<3>(),
        h in matrix::<2, 3>(3.0),
        root in matrix::<2, 2>(2.0),
        z in matrix::<2, 1>(50.0),
        x in matrix::<3, 1>(5.0),
    ) {
        let r = root * root.transpose() + Matrix2::identity() * 0.1;
        let model = LinearMeasurement::new(h, r).unwrap();
        let z = Vector2::new(z[0], z[1]);
        let step = prior.condition(&model, &z).unwrap();

        // Information form: Λ⁺ = Λ + Hᵀ R⁻¹ H, h⁺ = Λ μ + Hᵀ R⁻¹ z.
        let r_inv = r.try_inverse().unwrap();
        let lambda = prior.natural().1 + h.transpose() * r_inv * h;
        let eta = prior.natural().1 * prior.mean() + h.transpose() * r_inv * z;
        let info = Gaussian::from_natural(eta, lambda).unwrap();
        let condition = prior.covariance().norm() * prior.natural().1.norm();
        let s = scale(info.covariance().as_slice()) * scale(info.mean().as_slice()) * condition;
        prop_assert!((step.posterior.mean() - info.mean()).amax() <= 1e-12 * s);
        prop_assert!((step.posterior.covariance() - info.covariance()).amax() <= 1e-12 * s);

        // Bayes identity at an arbitrary point near the prior mean.
        let x: Vector3<f64> = prior.mean() + Vector3::new(x[0], x[1], x[2]);
        let likelihood = Gaussian::new(h * x, r).unwrap().log_pdf(&z);
        let identity = likelihood + prior.log_pdf(&x) - step.posterior.log_pdf(&x);
        let terms = [likelihood, prior.log_pdf(&x), step.posterior.log_pdf(&x)];
        // Each log density rounds in proportion to its own condition number: the posterior's too,
        // which a precise measurement makes far larger than the prior's.
        let posterior = step.posterior.covariance().norm() * step.posterior.natural().1.norm();
        prop_assert!(
            (step.log_evidence - identity).abs() <= 1e-12 * scale(&terms) * condition.max(posterior),
            "{} vs {}", step.log_evidence, identity);
    }

    #[test]
    fn propagation_is_the_linear_map_then_convolution(
        prior in gaussian::<3>(),
        f in matrix::<3, 3>(2.0),
        noise in gaussian::<3>(),
    ) {
        // Only where F keeps the prior non-degenerate is the mapped prior a Gaussian we can build.
        prop_assume!(f.determinant().abs() > 1e-2);
        let model = LinearProcess::new(f, *noise.covariance()).unwrap();
        let next = prior.propagate(&model, noise.mean()).unwrap();
        let mapped = Gaussian::new(f * prior.mean(), f * prior.covariance() * f.transpose()).unwrap();
        let expected = mapped.convolve(&noise).unwrap();
        let s = scale(expected.covariance().as_slice()) * scale(expected.mean().as_slice());
        prop_assert!((next.mean() - expected.mean()).amax() <= 1e-12 * s);
        prop_assert!((next.covariance() - expected.covariance()).amax() <= 1e-12 * s);
    }
}

/// With H = I the update is the normalised product of the prior and the likelihood, and the evidence
/// is the product's log integral (the densities crate's `Product`).
#[test]
fn identity_measurement_is_the_gaussian_product() {
    let prior = Gaussian::new(Vector2::new(1.0, -2.0), Matrix2::new(2.0, 0.3, 0.3, 1.0)).unwrap();
    let r = Matrix2::new(0.5, -0.1, -0.1, 0.7);
    let z = Vector2::new(0.4, 0.9);
    let step = prior
        .condition(&LinearMeasurement::new(Matrix2::identity(), r).unwrap(), &z)
        .unwrap();
    let likelihood = Gaussian::new(z, r).unwrap();
    let product = prior.product(&likelihood).unwrap();
    assert!((step.posterior.mean() - product.mean()).amax() < 1e-14);
    assert!((step.posterior.covariance() - product.covariance()).amax() < 1e-14);
    assert!((step.log_evidence - prior.log_product_integral(&likelihood).unwrap()).abs() < 1e-14);
}

#[test]
fn bad_models_and_inputs_are_refused_with_the_reason() {
    let asymmetric = Matrix2::new(1.0, 0.5, 0.0, 1.0);
    let err = LinearProcess::new(Matrix2::identity(), asymmetric).unwrap_err();
    assert!(err.to_string().contains("symmetric"), "{err}");
    let negative = Matrix2::new(-1.0, 0.0, 0.0, 1.0);
    assert!(LinearMeasurement::new(Matrix2::identity(), negative).is_err());
    let nan = Matrix2x3::from_element(f64::NAN);
    assert!(matches!(
        LinearMeasurement::new(nan, Matrix2::identity()),
        Err(OperatorError::NonFinite { .. })
    ));
    let prior = Gaussian::new(Vector2::zeros(), Matrix2::identity()).unwrap();
    let model = LinearMeasurement::new(Matrix2::identity(), Matrix2::identity()).unwrap();
    let err = prior
        .condition(&model, &Vector2::new(f64::INFINITY, 0.0))
        .unwrap_err();
    assert!(err.to_string().contains("measurement z"), "{err}");
    // A measurement of a direction the prior is certain about, with zero noise: S is singular, and
    // the step is an error, not NaN.
    let process = LinearProcess::new(Matrix3::identity(), Matrix3::zeros()).unwrap();
    assert!(process.noise().amax() == 0.0);
    let exact = LinearMeasurement::new(Matrix2::zeros(), Matrix2::zeros()).unwrap();
    assert!(prior.condition(&exact, &Vector2::new(0.0, 1.0)).is_err());
}

/// A prior far finer than a singular process noise: a constant-velocity model with the piecewise
/// white noise `Γ Γᵀ` (rank 1) and a prior variance p₀ of 1e-18 to 1e-90 per axis. The exact
/// `F Σ Fᵀ + Q` has a smallest eigenvalue of about p₀, below the rounding of its entries (1e-16):
/// the prediction was refused as not positive definite, so a filter could not take the step
/// after a fix that fine. The Kalman filter, the EKF, the UKF and the Rao-Blackwellized composite
/// now predict it raised to its rounding, `64 N ε max P′ᵢᵢ` on the diagonal; the EKF's and the
/// UKF's records keep `P′ = F̂ P F̂ᵀ + Ω` with the raised Ω.
#[test]
fn a_prior_finer_than_a_singular_noise_is_predicted_at_its_rounding() {
    use liebayes_densities::{GenVonMises2, HarmonicGaussian, ManifoldGaussian};
    use liebayes_manifolds::Rn;
    use liebayes_operators::process_noise::piecewise_white_noise;
    use liebayes_operators::smoother::GaussianTransition;
    use liebayes_operators::{Ekf, ProcessFn, Ukf};
    use nalgebra::Matrix2x3;
    let f = Matrix2::new(1.0, 1.0, 0.0, 1.0);
    let q = piecewise_white_noise::<2>(1.0, 1.0).unwrap();
    let process = LinearProcess::new(f, q).unwrap();
    let motion = ProcessFn::new(
        move |x: &Rn<f64, 2>, (): &()| Rn::new(f * x.coords()).unwrap(),
        move |_: &Rn<f64, 2>, (): &()| q,
    )
    .with_jacobian(move |_: &Rn<f64, 2>, (): &()| f);
    let mean = Vector2::new(1.0, 2.0);
    // The largest predicted variance is q₂₂ = 1 (to 1e-18).
    let floor = Matrix2::identity() * (64.0 * 2.0 * f64::EPSILON);
    for p0 in [1e-18, 1e-30, 1e-60, 1e-90] {
        let prior = Matrix2::identity() * p0;
        let exact = f * prior * f.transpose() + q;
        let kf = Gaussian::new(mean, prior)
            .unwrap()
            .propagate(&process, &Vector2::zeros())
            .unwrap();
        let start = ManifoldGaussian::new(Rn::new(mean).unwrap(), prior).unwrap();
        let ekf = Ekf(&motion).predict_with_cross(&start, &()).unwrap();
        let ukf = Ukf::new(&motion).predict_with_cross(&start, &()).unwrap();
        let angle = GenVonMises2::from_natural(Vector2::new(1.0, 0.5), Vector2::zeros()).unwrap();
        let composite = HarmonicGaussian::new(angle, Matrix2x3::zeros(), prior)
            .unwrap()
            .propagate(&process, &Vector2::zeros())
            .unwrap();
        let predicted = [
            ("KF", kf.covariance()),
            ("EKF", ekf.density.covariance()),
            ("UKF", ukf.density.covariance()),
            ("Rao-Blackwellized", composite.covariance()),
        ];
        for (name, covariance) in predicted {
            let off = (covariance - exact - floor).amax();
            assert!(off < 1e-15, "{name}, {p0:e}: {covariance} is {off:e} off");
        }
        for (name, record) in [("EKF", &ekf), ("UKF", &ukf)] {
            // C = P F̂ᵀ, so F̂ = Cᵀ / p₀.
            let slope = record.cross_covariance.transpose() / p0;
            let rebuilt = slope * prior * slope.transpose() + record.noise;
            let off = (rebuilt - record.density.covariance()).amax();
            assert!(off < 1e-15, "{name}, {p0:e}: Omega is {off:e} off");
        }
    }
}

/// The last estimate of each filter and smoother of a state whose first coordinate is read with
/// variance `r`: the Kalman filter, the EKF, the UKF, both iterated updates, the RTS smoother (its
/// smoothed last epoch) and the fixed-lag smoother (lag 5), from `N(0, p0 I)` with
/// `x′ = F x + w`, `w ~ N(0, Q)`, and a reading `z(k)` at steps 1 to `steps`; panics naming the
/// filter and the step it refuses.
fn every_filter_tracks<const N: usize>(
    (f, q, p0): (SMatrix<f64, N, N>, SMatrix<f64, N, N>, f64),
    r: f64,
    z: impl Fn(u32) -> f64,
    steps: u32,
) -> Vec<(&'static str, SVector<f64, N>, SMatrix<f64, N, N>)> {
    use liebayes_densities::ManifoldGaussian;
    use liebayes_manifolds::Rn;
    use liebayes_operators::fixed_lag::FixedLagSmoother;
    use liebayes_operators::iterated::{IteratedEkf, IteratedUkf};
    use liebayes_operators::smoother::RtsSmoother;
    use liebayes_operators::{Ekf, MeasurementFn, ProcessFn, Ukf};
    use nalgebra::{Matrix1, Vector1};
    let h = SMatrix::<f64, 1, N>::from_fn(|_, j| if j == 0 { 1.0 } else { 0.0 });
    let process = LinearProcess::new(f, q).unwrap();
    let sensor = LinearMeasurement::new(h, Matrix1::new(r)).unwrap();
    let motion = ProcessFn::new(
        move |x: &Rn<f64, N>, (): &()| Rn::new(f * x.coords()).unwrap(),
        move |_: &Rn<f64, N>, (): &()| q,
    )
    .with_jacobian(move |_: &Rn<f64, N>, (): &()| f);
    let measure = MeasurementFn::new(
        |x: &Rn<f64, N>| Vector1::new(x.coords()[0]),
        move |_: &Rn<f64, N>| Matrix1::new(r),
    )
    .with_jacobian(move |_: &Rn<f64, N>| h);
    let prior = SMatrix::<f64, N, N>::identity() * p0;
    let start = ManifoldGaussian::new(Rn::new(SVector::zeros()).unwrap(), prior).unwrap();
    let mut kf = Gaussian::new(SVector::zeros(), prior).unwrap();
    let mut filters = [start.clone(), start.clone(), start.clone(), start.clone()];
    let mut rts = RtsSmoother::new(start.clone());
    let mut lag = FixedLagSmoother::new(start, 5).unwrap();
    for k in 1..=steps {
        let z = Vector1::new(z(k));
        kf = kf.propagate(&process, &SVector::zeros()).or_panic("KF", k);
        kf = kf.condition(&sensor, &z).or_panic("KF", k).posterior;
        let [ekf, ukf, iekf, iukf] = &mut filters;
        *ekf = ekf.propagate(&Ekf(&motion), &()).or_panic("EKF", k);
        let updated = ekf.condition(&Ekf(&measure), &z);
        *ekf = updated.or_panic("EKF", k).posterior;
        *ukf = ukf.propagate(&Ukf::new(&motion), &()).or_panic("UKF", k);
        let updated = ukf.condition(&Ukf::new(&measure), &z);
        *ukf = updated.or_panic("UKF", k).posterior;
        *iekf = iekf.propagate(&Ekf(&motion), &()).or_panic("IEKF", k);
        let updated = iekf.condition(&IteratedEkf::new(&measure), &z);
        *iekf = updated.or_panic("IEKF", k).posterior;
        *iukf = iukf.propagate(&Ukf::new(&motion), &()).or_panic("IUKF", k);
        let updated = iukf.condition(&IteratedUkf::new(&measure), &z);
        *iukf = updated.or_panic("IUKF", k).posterior;
        rts.propagate(&Ekf(&motion), &()).or_panic("RTS", k);
        rts.condition(&Ekf(&measure), &z).or_panic("RTS", k);
        lag.propagate(&Ekf(&motion), &()).or_panic("fixed-lag", k);
        lag.condition(&Ekf(&measure), &z).or_panic("fixed-lag", k);
    }
    let mut ends = vec![("KF", *kf.mean(), *kf.covariance())];
    for (name, g) in ["EKF", "UKF", "IEKF", "IUKF"].into_iter().zip(&filters) {
        ends.push((name, *g.mean().coords(), *g.covariance()));
    }
    let smoothed = rts.smooth().or_panic("RTS backward pass", steps);
    let g = smoothed.last().unwrap();
    ends.push(("RTS", *g.mean().coords(), *g.covariance()));
    let lagged = lag.smooth().or_panic("fixed-lag backward pass", steps);
    let g = lagged.iter().last().unwrap();
    ends.push(("fixed-lag", *g.mean().coords(), *g.covariance()));
    ends
}

/// A step's result, or a panic naming the filter and the step that refused it.
trait OrPanic<T> {
    fn or_panic(self, name: &str, step: u32) -> T;
}

impl<T> OrPanic<T> for Result<T, OperatorError> {
    fn or_panic(self, name: &str, step: u32) -> T {
        self.unwrap_or_else(|e| panic!("{name}, step {step}: {e}"))
    }
}

/// Readings of a position, exact to 1e-30 with a process noise of 1e-30 and a prior of 1, fix the
/// velocity after two. After the first, `F Σ Fᵀ + Q` is `0.5 [1 1; 1 1]` to within the rounding
/// of its entries; Cholesky's own rounding let it through as positive definite, and the second
/// update was refused by every filter (its Joseph form is singular whatever R). A prediction
/// singular to rounding, some pivot of its correlation matrix below `N ε`, is now raised as one
/// that fails is: the Kalman filter, the EKF, the UKF, both iterated updates, the RTS and the
/// fixed-lag smoother take 20 steps and end with the velocity 1 and its variance below 1e-12. The
/// test is free of units: a state with uncorrelated variances 1e6 and 1e-12 is predicted exactly.
#[test]
fn a_prediction_singular_to_rounding_is_raised_like_a_failed_one() {
    use liebayes_operators::process_noise::piecewise_white_noise;
    let f = Matrix2::new(1.0, 1.0, 0.0, 1.0);
    let q = piecewise_white_noise::<2>(1.0, 1e-30).unwrap();
    for (name, mean, covariance) in every_filter_tracks((f, q, 1.0), 1e-30, f64::from, 20) {
        assert!((mean[1] - 1.0).abs() < 1e-9, "{name}: velocity {}", mean[1]);
        assert!(covariance[(1, 1)] < 1e-12, "{name}: {covariance:e}");
    }
    let mixed = Matrix2::new(1e6, 0.0, 0.0, 1e-12);
    let still = LinearProcess::new(Matrix2::identity(), Matrix2::zeros()).unwrap();
    let predicted = Gaussian::new(Vector2::zeros(), mixed)
        .unwrap()
        .propagate(&still, &Vector2::zeros())
        .unwrap();
    assert_eq!(*predicted.covariance(), mixed);
}

/// A constant-acceleration track `x = t²/2` (dt = 1, q = 1) read at every step, from a diffuse
/// prior (1e30, readings of variance 1) and from a prior of 1 (readings exact to 1e-30). The
/// reading is far finer than the prediction, `I − K H` all but cancels along it, and the Joseph
/// form summed as `(I − K H) Σ (I − K H)ᵀ` rounded at the size of Σ: the posterior came out
/// negative along the reading and the Kalman filter's update was refused at step 4 from the diffuse
/// prior, at step 46 from the exact readings. Summed as Gram matrices, every filter and smoother
/// takes 300 steps and ends within five of its standard deviations of the track (plus 1e3 roundings
/// of the track's value, the finest an exact reading can fix).
#[test]
fn a_reading_far_finer_than_its_prediction_keeps_the_update_positive_definite() {
    use liebayes_operators::process_noise::piecewise_white_noise;
    let f = Matrix3::new(1.0, 1.0, 0.5, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0);
    let q = piecewise_white_noise::<3>(1.0, 1.0).unwrap();
    let z = |k: u32| f64::from(k) * f64::from(k) / 2.0;
    let steps = 300;
    let t = f64::from(steps);
    let track = Vector3::new(t * t / 2.0, t, 1.0);
    for (p0, r) in [(1e30, 1.0), (1.0, 1e-30)] {
        for (name, mean, covariance) in every_filter_tracks((f, q, p0), r, z, steps) {
            for i in 0..3 {
                let bound = 5.0 * covariance[(i, i)].sqrt() + 1e3 * f64::EPSILON * track[i].abs();
                let error = (mean[i] - track[i]).abs();
                assert!(
                    error <= bound,
                    "{name}, p0 {p0:e}, state {i}: {error:e} > {bound:e}"
                );
            }
        }
    }
}
