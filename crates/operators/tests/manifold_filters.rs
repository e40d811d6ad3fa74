//! The EKF and the UKF on manifolds against independent computations:
//!
//! * on Rⁿ with a linear model both must equal the exact Kalman filter (the UKF is exact for linear
//!   models; the EKF's numerical Jacobians are exact to rounding for them);
//! * on SO(2) across the ±π cut, the angle must be corrected through `local`/`retract`, so that the
//!   result equals a Kalman filter run on the unwrapped angle;
//! * on SO(3), propagation by a fixed right increment Δ has the exact answer `(μ Δ, Ad(Δ⁻¹) P Ad(Δ⁻¹)ᵀ)`,
//!   which both filters must reproduce (the UKF's manifold mean is exact here by symmetry).

use liebayes_densities::{DensityError, Gaussian, ManifoldGaussian};
use liebayes_manifolds::{LieGroup, Manifold, Rn, So2, So3};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::smoother::GaussianTransition;
use liebayes_operators::{
    Condition, Conditioned, Ekf, MeasurementFn, MeasurementModel, OperatorError, ProcessFn,
    ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix1, Matrix2, Matrix3, SMatrix, Vector1, Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

/// `x′ = F x + u + w` on R², written as a manifold model with its exact Jacobian F.
struct Linear {
    f: Matrix2<f64>,
    q: Matrix2<f64>,
}

impl ProcessModel<Rn<f64, 2>, 2> for Linear {
    type Input = Vector2<f64>;
    fn transition(&self, x: &Rn<f64, 2>, u: &Vector2<f64>) -> Rn<f64, 2> {
        Rn::new_unchecked(self.f * x.coords() + u)
    }
    fn noise(&self, _: &Rn<f64, 2>, _: &Vector2<f64>) -> Matrix2<f64> {
        self.q
    }
    fn jacobian(&self, _: &Rn<f64, 2>, _: &Vector2<f64>) -> Matrix2<f64> {
        self.f
    }
}

/// `z = H x + n` on R², with its exact Jacobian H.
struct LinearZ {
    h: SMatrix<f64, 1, 2>,
    r: f64,
}

impl MeasurementModel<Rn<f64, 2>, 2, 1> for LinearZ {
    fn predict(&self, x: &Rn<f64, 2>) -> Vector1<f64> {
        self.h * x.coords()
    }
    fn noise(&self, _: &Rn<f64, 2>) -> Matrix1<f64> {
        Matrix1::new(self.r)
    }
    fn jacobian(&self, _: &Rn<f64, 2>) -> SMatrix<f64, 1, 2> {
        self.h
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn ekf_and_ukf_equal_the_kalman_filter_for_linear_models(
        mean in proptest::array::uniform2(-10.0..10.0f64),
        l in proptest::array::uniform3(0.2..2.0f64),
        f in proptest::array::uniform4(-1.5..1.5f64),
        h in proptest::array::uniform2(-2.0..2.0f64),
        r in 0.05..4.0f64,
        z in -20.0..20.0f64,
    ) {
        let lower = Matrix2::new(l[0], 0.0, l[2] - 1.0, l[1]);
        let p = lower * lower.transpose();
        let f = Matrix2::new(f[0], f[1], f[2], f[3]);
        let q = Matrix2::new(0.3, 0.1, 0.1, 0.2);
        let u = Vector2::new(0.5, -1.0);
        let h = SMatrix::<f64, 1, 2>::new(h[0], h[1]);
        let kalman = Gaussian::new(Vector2::from(mean), p).unwrap();
        let manifold = ManifoldGaussian::new(Rn::new_unchecked(Vector2::from(mean)), p).unwrap();

        let k = kalman.propagate(&LinearProcess::new(f, q).unwrap(), &u).unwrap();
        let e = manifold.propagate(&Ekf(Linear { f, q }), &u).unwrap();
        let s = manifold.propagate(&Ukf::new(Linear { f, q }), &u).unwrap();
        for g in [&e, &s] {
            for i in 0..2 {
                prop_assert!(close(g.mean().coords()[i], k.mean()[i], 1e-9));
                for j in 0..2 {
                    prop_assert!(close(g.covariance()[(i, j)], k.covariance()[(i, j)], 1e-8));
                }
            }
        }

        let zv = Vector1::new(z);
        let kz = k.condition(&LinearMeasurement::new(h, Matrix1::new(r)).unwrap(), &zv).unwrap();
        let model = LinearZ { h, r };
        let ez = e.condition(&Ekf(model), &zv).unwrap();
        let sz = s.condition(&Ukf::new(LinearZ { h, r }), &zv).unwrap();
        for g in [&ez, &sz] {
            prop_assert!(close(g.log_evidence, kz.log_evidence, 1e-8));
            // The reports: innovation, its covariance, the gain and the NIS of the Kalman filter.
            let (a, b) = (&g.report, &kz.report);
            prop_assert!(close(a.innovation()[0], b.innovation()[0], 1e-8));
            prop_assert!(close(a.covariance()[0], b.covariance()[0], 1e-8));
            prop_assert!(close(a.nis(), b.nis(), 1e-7));
            let s_inv = 1.0 / b.covariance()[0];
            prop_assert!(close(b.nis(), b.innovation()[0].powi(2) * s_inv, 1e-12));
            for i in 0..2 {
                prop_assert!(close(a.gain()[i], b.gain()[i], 1e-7));
            }
            for i in 0..2 {
                prop_assert!(close(g.posterior.mean().coords()[i], kz.posterior.mean()[i], 1e-8));
                for j in 0..2 {
                    prop_assert!(close(
                        g.posterior.covariance()[(i, j)],
                        kz.posterior.covariance()[(i, j)],
                        1e-7
                    ));
                }
            }
        }
    }
}

/// A nonlinear motion on R²: `x′ = (x₀ + a x₁², x₁ + b sin x₀) + w`.
struct Bent {
    a: f64,
    b: f64,
}

impl ProcessModel<Rn<f64, 2>, 2> for Bent {
    type Input = ();
    fn transition(&self, x: &Rn<f64, 2>, (): &()) -> Rn<f64, 2> {
        let v = x.coords();
        Rn::new_unchecked(Vector2::new(
            v[0] + self.a * v[1] * v[1],
            v[1] + self.b * v[0].sin(),
        ))
    }
    fn noise(&self, _: &Rn<f64, 2>, (): &()) -> Matrix2<f64> {
        Matrix2::new(0.02, 0.005, 0.005, 0.01)
    }
}

/// Range and bearing of a point on R² (nonlinear, M = 2).
struct RangeBearing;

impl MeasurementModel<Rn<f64, 2>, 2, 2> for RangeBearing {
    fn predict(&self, x: &Rn<f64, 2>) -> Vector2<f64> {
        let v = x.coords();
        Vector2::new(v.norm(), v[1].atan2(v[0]))
    }
    fn noise(&self, _: &Rn<f64, 2>) -> Matrix2<f64> {
        Matrix2::new(0.01, 0.0, 0.0, 1e-4)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The laws the smoother and the Joseph-form update rest on, on nonlinear models and for
    /// scalings with `β D + κ α² ≥ 0`. A prediction's recorded noise Ω completes its
    /// linearisation, `P′ = F̂ P F̂ᵀ + Ω` with `F̂ = Cᵀ P⁻¹` (the EKF's Ω is Q itself), and is
    /// positive semi-definite; the UKF's posterior equals the textbook `P − K S Kᵀ`, which it
    /// computes in Joseph's form.
    #[test]
    fn unscented_noise_completes_the_linearisation_and_the_update_is_p_minus_ksk(
        mean in proptest::array::uniform2(1.0..5.0f64),
        l in proptest::array::uniform3(0.05..0.8f64),
        bend in proptest::array::uniform2(-0.5..0.5f64),
        alpha in prop_oneof![Just(1e-3), Just(0.1), Just(0.5), Just(1.0)],
        beta in 0.0..3.0f64,
    ) {
        let lower = Matrix2::new(l[0], 0.0, l[2] - 0.4, l[1]);
        let p = lower * lower.transpose() + Matrix2::identity() * 1e-3;
        let prior = ManifoldGaussian::new(Rn::new_unchecked(Vector2::from(mean)), p).unwrap();
        let process = Bent { a: bend[0], b: bend[1] };
        let ekf = Ekf(&process).predict_with_cross(&prior, &()).unwrap();
        prop_assert_eq!(ekf.noise, process.noise(prior.mean(), &()));
        let ukf = Ukf::with_scaling(&process, alpha, beta, 0.0).unwrap();
        let prediction = ukf.predict_with_cross(&prior, &()).unwrap();
        let slope = (p.try_inverse().unwrap() * prediction.cross_covariance).transpose();
        let completed = slope * p * slope.transpose() + prediction.noise;
        let predicted = prediction.density.covariance();
        prop_assert!((completed - predicted).amax() <= 1e-10 * predicted.amax(),
            "{completed} against {predicted}");
        // Ω less Q, the sigma points' own part (its rounding is about 1e6 ε of the terms at
        // α = 1e-3, where the centre's weight is −1e6).
        let spread = prediction.noise - process.noise(prior.mean(), &());
        let lowest = spread.symmetric_eigenvalues().min();
        prop_assert!(lowest >= -1e-8 * predicted.amax(), "Ω − Q has the eigenvalue {lowest}");

        let z = RangeBearing.predict(prior.mean()) + Vector2::new(0.05, -0.01);
        let sensor = Ukf::with_scaling(&RangeBearing, alpha, beta, 0.0).unwrap();
        let step = prior.condition(&sensor, &z).unwrap();
        let (gain, s) = (step.report.gain(), step.report.covariance());
        let textbook = p - gain * s * gain.transpose();
        let posterior = step.posterior.covariance();
        prop_assert!((posterior - textbook).amax() <= 1e-9 * p.amax(),
            "{posterior} against {textbook}");
    }
}

/// A constant angle with random-walk noise.
#[derive(Clone, Copy)]
struct Drift(f64);

impl ProcessModel<So2<f64>, 1> for Drift {
    type Input = ();
    fn transition(&self, x: &So2<f64>, (): &()) -> So2<f64> {
        *x
    }
    fn noise(&self, _: &So2<f64>, (): &()) -> Matrix1<f64> {
        Matrix1::new(self.0)
    }
}

/// The angle itself, measured with noise; the residual wraps.
#[derive(Clone, Copy)]
struct Heading(f64);

impl MeasurementModel<So2<f64>, 1, 1> for Heading {
    fn predict(&self, x: &So2<f64>) -> Vector1<f64> {
        Vector1::new(x.angle())
    }
    fn noise(&self, _: &So2<f64>) -> Matrix1<f64> {
        Matrix1::new(self.0)
    }
    fn residual(&self, z: &Vector1<f64>, predicted: &Vector1<f64>) -> Vector1<f64> {
        // z ⊟ ẑ through SO(2).
        So2::from_angle_unchecked(predicted[0]).local(&So2::from_angle_unchecked(z[0]))
    }
}

#[test]
fn angles_are_corrected_across_the_cut() {
    // Mean 0.05 rad short of π, measurement 0.03 rad past it (= −π + 0.03): a coordinate average would
    // put the posterior near 0; the unwrapped Kalman answer is π − 0.05 + K · 0.08.
    let (p, q, r) = (0.2_f64.powi(2), 0.01, 0.1_f64.powi(2));
    let prior =
        ManifoldGaussian::new(So2::from_angle_unchecked(PI - 0.05), Matrix1::new(p)).unwrap();
    let z = Vector1::new(-PI + 0.03);
    for (name, predicted, posterior) in [
        {
            let x = prior.propagate(&Ekf(Drift(q)), &()).unwrap();
            let post = x.condition(&Ekf(Heading(r)), &z).unwrap().posterior;
            ("EKF", x, post)
        },
        {
            let x = prior.propagate(&Ukf::new(Drift(q)), &()).unwrap();
            let post = x.condition(&Ukf::new(Heading(r)), &z).unwrap().posterior;
            ("UKF", x, post)
        },
    ] {
        let p1 = p + q;
        let gain = p1 / (p1 + r);
        assert!(
            (predicted.mean().angle() - (PI - 0.05)).abs() < 1e-12,
            "{name}"
        );
        assert!((predicted.covariance()[0] - p1).abs() < 1e-12, "{name}");
        let expected = So2::from_angle_unchecked(PI - 0.05 + gain * 0.08);
        // The UKF's sigma points see the measurement's wrap too: equal to the Kalman answer to 1e-9.
        assert!(
            posterior.mean().distance(&expected) < 1e-9,
            "{name}: {:?}",
            posterior.mean()
        );
        assert!(
            (posterior.covariance()[0] - (1.0 - gain) * p1).abs() < 1e-9,
            "{name}"
        );
    }
}

/// One EKF and one UKF step (propagate, then condition) with the given models.
fn steps<P, H>(
    prior: &ManifoldGaussian<So2<f64>, 1>,
    process: P,
    measurement: H,
    z: f64,
) -> [(f64, f64, f64, f64); 2]
where
    P: ProcessModel<So2<f64>, 1, Input = ()> + Copy,
    H: MeasurementModel<So2<f64>, 1, 1> + Copy,
{
    let z = Vector1::new(z);
    let e = prior.propagate(&Ekf(process), &()).unwrap();
    let e = e.condition(&Ekf(measurement), &z).unwrap();
    let u = prior.propagate(&Ukf::new(process), &()).unwrap();
    let u = u.condition(&Ukf::new(measurement), &z).unwrap();
    [e, u].map(|step| {
        (
            step.posterior.mean().angle(),
            step.posterior.covariance()[0],
            step.log_evidence,
            step.report.nis(),
        )
    })
}

/// Models from closures and models by reference are the hand-written models: the EKF and the UKF take
/// bit for bit the same steps with each (a nonlinear process, a wrapped residual, numerical and
/// analytic Jacobians).
#[test]
fn closure_models_and_references_equal_the_hand_written_models() {
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(3.0), Matrix1::new(0.04)).unwrap();
    let z = -3.05;
    let (q, r) = (0.01, 0.02);
    let expected = steps(&prior, Drift(q), Heading(r), z);
    // By reference (the type parameters say it, or the compiler would take the Copy values).
    let by_reference = steps::<&Drift, &Heading>(&prior, &Drift(q), &Heading(r), z);
    assert_eq!(by_reference, expected);
    let drift = ProcessFn::new(|x: &So2<f64>, (): &()| *x, |_, ()| Matrix1::new(q));
    let heading = MeasurementFn::new(|x: &So2<f64>| Vector1::new(x.angle()), |_| Matrix1::new(r))
        .with_residual(|z: &Vector1<f64>, p: &Vector1<f64>| {
            So2::from_angle_unchecked(p[0]).local(&So2::from_angle_unchecked(z[0]))
        });
    assert_eq!(steps(&prior, &drift, &heading, z), expected);
    // With analytic Jacobians (exact here: F = 1, H = 1) instead of central differences the steps
    // agree to the differences' rounding.
    let drift = drift.with_jacobian(|_, ()| Matrix1::new(1.0));
    let heading = heading.with_jacobian(|_| Matrix1::new(1.0));
    for (a, b) in steps(&prior, &drift, &heading, z).iter().zip(&expected) {
        assert!(
            close(a.0, b.0, 1e-9) && close(a.1, b.1, 1e-9),
            "{a:?} vs {b:?}"
        );
        assert!(
            close(a.2, b.2, 1e-9) && close(a.3, b.3, 1e-9),
            "{a:?} vs {b:?}"
        );
    }
    // Not trivially equal: the step moved the mean across the cut and shrank the covariance.
    assert!(expected[0].0 < 0.0 && expected[0].1 < 0.04);
}

/// `R′ = R Δ`: right multiplication by a fixed increment.
struct Turn(So3<f64>);

impl ProcessModel<So3<f64>, 3> for Turn {
    type Input = ();
    fn transition(&self, x: &So3<f64>, (): &()) -> So3<f64> {
        x.compose(&self.0)
    }
    fn noise(&self, _: &So3<f64>, (): &()) -> Matrix3<f64> {
        Matrix3::identity() * 1e-4
    }
}

#[test]
fn so3_propagation_transports_the_covariance_by_the_adjoint() {
    let mean = So3::exp(&Vector3::new(0.3, -1.2, 2.0));
    let delta = So3::exp(&Vector3::new(0.7, 0.4, -0.9));
    let l = Matrix3::new(0.3, 0.0, 0.0, 0.05, 0.2, 0.0, -0.1, 0.02, 0.25);
    let prior = ManifoldGaussian::new(mean, l * l.transpose()).unwrap();
    let ad = delta.inverse().adjoint();
    let expected = ad * prior.covariance() * ad.transpose() + Matrix3::identity() * 1e-4;
    for (name, got) in [
        ("EKF", prior.propagate(&Ekf(Turn(delta)), &()).unwrap()),
        ("UKF", prior.propagate(&Ukf::new(Turn(delta)), &()).unwrap()),
    ] {
        assert!(got.mean().distance(&mean.compose(&delta)) < 1e-12, "{name}");
        let error = (got.covariance() - expected).amax();
        assert!(error < 1e-9, "{name}: covariance off by {error:e}");
    }
}

/// Range to a beacon at the origin: nonlinear, with an analytic Jacobian to check the default against.
struct Range;

impl MeasurementModel<Rn<f64, 2>, 2, 1> for Range {
    fn predict(&self, x: &Rn<f64, 2>) -> Vector1<f64> {
        Vector1::new(x.coords().norm())
    }
    fn noise(&self, _: &Rn<f64, 2>) -> Matrix1<f64> {
        Matrix1::new(0.01)
    }
}

/// The default central differences (step 1e-6): rounding error about 1e-16 |h| / 1e-6 and truncation
/// error about 1e-12 |h‴|, so 1e-9 here, where |h| = 5 and h‴ is of order 1/25.
#[test]
fn numerical_jacobian_matches_the_analytic_one() {
    let x = Rn::new_unchecked(Vector2::new(3.0, -4.0));
    let analytic = x.coords().transpose() / 5.0;
    assert!((Range.jacobian(&x) - analytic).amax() < 1e-9);
    // A linear model far from the origin: the truncation error vanishes, the rounding error remains.
    let far = Rn::new_unchecked(Vector2::new(300.0, -400.0));
    let z = LinearZ {
        h: SMatrix::<f64, 1, 2>::new(0.5, 2.0),
        r: 1.0,
    };
    let numeric = MeasurementModel::jacobian(&Numeric(&z), &far);
    assert!((numeric - z.h).amax() < 1e-16 * 1000.0 / 1e-6 * 10.0);
}

/// A model that keeps the default (numerical) Jacobian of another's prediction.
struct Numeric<'a>(&'a LinearZ);

impl MeasurementModel<Rn<f64, 2>, 2, 1> for Numeric<'_> {
    fn predict(&self, x: &Rn<f64, 2>) -> Vector1<f64> {
        self.0.predict(x)
    }
    fn noise(&self, x: &Rn<f64, 2>) -> Matrix1<f64> {
        self.0.noise(x)
    }
}

#[test]
fn bad_input_is_refused_with_a_reason() {
    let x = Rn::new_unchecked(Vector2::new(3.0, -4.0));
    assert!(matches!(
        ManifoldGaussian::new(x, Matrix2::new(1.0, 0.0, 0.0, -1.0)),
        Err(DensityError::OutOfRange { .. })
    ));
    assert!(matches!(
        ManifoldGaussian::new(x, Matrix2::new(f64::NAN, 0.0, 0.0, 1.0)),
        Err(DensityError::NonFinite { .. })
    ));
    let g = ManifoldGaussian::new(x, Matrix2::identity()).unwrap();
    assert!(matches!(
        g.condition(&Ekf(Range), &Vector1::new(f64::INFINITY)),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(Ukf::<Range, 1>::with_scaling(Range, 0.0, 2.0, 0.0).is_err());
}

/// `x′ = x ⊞ w`: the identity motion with noise Q, on any manifold.
struct Still<const D: usize>(SMatrix<f64, D, D>);

impl<X: Manifold<D, Scalar = f64>, const D: usize> ProcessModel<X, D> for Still<D> {
    type Input = ();
    fn transition(&self, x: &X, (): &()) -> X {
        x.clone()
    }
    fn noise(&self, _: &X, (): &()) -> SMatrix<f64, D, D> {
        self.0
    }
}

/// On every manifold of the crate, the identity motion must leave the mean where it is and add Q to the
/// covariance, in both filters: the EKF's numerical Jacobian of `local ∘ retract` is the identity and the
/// UKF's sigma points are symmetric, so its manifold mean is exact. This checks that each space's
/// `retract` and `local` are consistent with what the filters assume of them.
fn identity_motion_is_exact<X: Manifold<D, Scalar = f64> + std::fmt::Debug, const D: usize>(
    mean: &X,
) {
    let l = SMatrix::<f64, D, D>::from_fn(|i, j| match i.cmp(&j) {
        std::cmp::Ordering::Equal => 0.3,
        std::cmp::Ordering::Greater => 0.05,
        std::cmp::Ordering::Less => 0.0,
    });
    let p = l * l.transpose();
    let q = SMatrix::<f64, D, D>::identity() * 1e-3;
    let prior = ManifoldGaussian::new(mean.clone(), p).unwrap();
    for (name, got) in [
        ("EKF", prior.propagate(&Ekf(Still(q)), &()).unwrap()),
        ("UKF", prior.propagate(&Ukf::new(Still(q)), &()).unwrap()),
    ] {
        assert!(got.mean().distance(mean) < 1e-12, "{name} on {mean:?}");
        let error = (got.covariance() - (p + q)).amax();
        assert!(
            error < 1e-8,
            "{name} on {mean:?}: covariance off by {error:e}"
        );
    }
}

#[test]
fn identity_motion_is_exact_on_every_space() {
    use liebayes_manifolds::{S2, Su2};
    identity_motion_is_exact(&So2::from_angle_unchecked(3.1));
    identity_motion_is_exact(&So3::exp(&Vector3::new(0.1, 3.0, -0.2)));
    identity_motion_is_exact(&Su2::exp(&Vector3::new(2.0, -4.0, 1.0)));
    identity_motion_is_exact(&S2::from_vector_normalizing(&Vector3::new(0.3, -0.4, 0.8)).unwrap());
    identity_motion_is_exact(&Rn::new_unchecked(Vector3::new(1e3, -2.0, 0.5)));
}

/// Measurements far finer than the prior (R = 1e-30 against P of order 1): S = H P Hᵀ + R
/// rounds to H P Hᵀ, and the posterior along the measured direction, of variance about R, is lost
/// to the rounding of P. Of 200 such updates on R² (P and H drawn from a fixed generator), the
/// EKF refused 122 and the UKF 136 as not positive definite, and a filter stopped there for good
/// (each later update as fine as the first); the linear Kalman filter, without the retry until
/// later, refused as many. Each is now made once more with R raised above that rounding: every
/// update succeeds, with a positive definite posterior whose mean is the exact update's to 1e-9
/// and whose variance along the measured direction is of the order of rounding (at most
/// `512 ε |H|² max |Pᵢⱼ|`).
#[test]
fn measurements_finer_than_rounding_are_kept_above_it() {
    use rand::{Rng, SeedableRng};
    type Step<R> = Result<Conditioned<ManifoldGaussian<Rn<f64, 2>, 2>, R>, OperatorError>;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for case in 0..200 {
        let a = Matrix2::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let p = a * a.transpose() + Matrix2::identity() * 1e-3;
        let h = SMatrix::<f64, 1, 2>::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0));
        let model = LinearZ { h, r: 1e-30 };
        let prior = ManifoldGaussian::new(
            Rn::new_unchecked(Vector2::new(rng.random_range(-1.0..1.0), 0.3)),
            p,
        )
        .unwrap();
        let z = Vector1::new(rng.random_range(-1.0..1.0));
        let s = (h * p * h.transpose())[0];
        let rounding = 512.0 * f64::EPSILON * h.norm_squared() * p.amax();
        let exact = prior.mean().coords()
            + p * h.transpose() * ((z[0] - (h * prior.mean().coords())[0]) / s);
        let linear = LinearMeasurement::new(h, Matrix1::new(1e-30)).unwrap();
        let kf = Gaussian::new(*prior.mean().coords(), p)
            .unwrap()
            .condition(&linear, &z)
            .map(|step| (*step.posterior.mean(), *step.posterior.covariance()));
        let moments =
            |step: Step<_>| step.map(|s| (*s.posterior.mean().coords(), *s.posterior.covariance()));
        for (name, step) in [
            ("KF", kf),
            ("EKF", moments(prior.condition(&Ekf(&model), &z))),
            ("UKF", moments(prior.condition(&Ukf::new(&model), &z))),
        ] {
            let (mean, posterior) = step.unwrap_or_else(|e| panic!("case {case} {name}: {e}"));
            let posterior = &posterior;
            assert!(
                posterior.cholesky().is_some(),
                "case {case} {name}: {posterior}"
            );
            let along = (h * posterior * h.transpose())[0];
            assert!(
                along <= rounding,
                "case {case} {name}: {along:e} against {rounding:e}"
            );
            assert!(
                (mean - exact).amax() <= 1e-9 * (1.0 + exact.amax()),
                "case {case} {name}"
            );
        }
    }
}
