//! The Kalman filter against independent computations: the information form of Bayes' rule, the
//! Bayes identity `ln p(z) = ln p(z | x) + ln p(x) − ln p(x | z)` at an arbitrary x (which checks the
//! posterior and the evidence together, with the densities crate's own log-pdf), and the Gaussian
//! convolution for propagation.

use liebayes_densities::testing::strategies::gaussian;
use liebayes_densities::{Convolve, Density, Gaussian, Product};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::{Condition, OperatorError, Propagate};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, SMatrix, Vector2, Vector3};
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
