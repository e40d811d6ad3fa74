//! The process-noise helpers against independent computations: Van Loan's result against a
//! quadrature of `∫ exp(A s) G Q_c Gᵀ exp(A s)ᵀ ds` with a Taylor-series exponential, the closed forms
//! against Van Loan and against the textbook matrices, and the transport of a covariance between
//! conventions against the errors it transports.

use liebayes_operators::OperatorError;
use liebayes_operators::densities::ManifoldGaussian;
use liebayes_operators::evaluation::{nees, nis};
use liebayes_operators::manifolds::{Left, LieGroup, Manifold, Se3, So3};
use liebayes_operators::process_noise::{
    body_from_world, continuous_white_noise, per_axis, piecewise_white_noise, to_body_frame,
    to_world_frame, van_loan, world_from_body,
};
use nalgebra::{Matrix1, Matrix2, Matrix3, Matrix4, Matrix6, SMatrix, Vector2, Vector3, Vector6};
use proptest::prelude::*;

/// `exp(M)` by its Taylor series (enough terms for ‖M‖ ≤ 2 to reach rounding): independent of the
/// Padé approximant the library uses.
fn taylor_exp<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    let mut term = SMatrix::<f64, N, N>::identity();
    let mut sum = term;
    for k in 1..40 {
        term = term * m / f64::from(k);
        sum += term;
    }
    sum
}

/// `∫₀^dt exp(A s) G Q_c Gᵀ exp(A s)ᵀ ds` by composite Simpson with 2 000 intervals.
fn quadrature<const N: usize, const L: usize>(
    a: &SMatrix<f64, N, N>,
    g: &SMatrix<f64, N, L>,
    qc: &SMatrix<f64, L, L>,
    dt: f64,
) -> SMatrix<f64, N, N> {
    let intervals = 2000;
    let h = dt / f64::from(intervals);
    let integrand = |s: f64| {
        let phi = taylor_exp(&(a * s));
        phi * g * qc * g.transpose() * phi.transpose()
    };
    let mut sum = integrand(0.0) + integrand(dt);
    for i in 1..intervals {
        let weight = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += integrand(f64::from(i) * h) * weight;
    }
    sum * h / 3.0
}

#[test]
fn van_loan_matches_the_integral_for_a_damped_oscillator() {
    // A damped oscillator with a second, slower state and two noise inputs.
    let a = Matrix3::new(0.0, 1.0, 0.0, -4.0, -0.4, 0.3, 0.0, 0.0, -0.5);
    let g = SMatrix::<f64, 3, 2>::new(0.0, 0.0, 1.0, 0.2, 0.0, 1.0);
    let qc = Matrix2::new(0.5, 0.1, 0.1, 0.2);
    for dt in [1e-3, 0.05, 0.4] {
        let model = van_loan(&a, &g, &qc, dt).unwrap();
        let phi = taylor_exp(&(a * dt));
        assert!((model.transition - phi).amax() < 1e-14, "Φ at dt = {dt}");
        let q = quadrature(&a, &g, &qc, dt);
        let error = (model.noise - q).amax() / q.amax();
        assert!(error < 1e-11, "Q at dt = {dt}: relative error {error:e}");
        assert_eq!(model.noise, model.noise.transpose());
    }
}

#[test]
fn van_loan_gives_the_closed_forms_of_the_kinematic_chains() {
    let (q, dt) = (0.7, 0.25);
    let cv = van_loan(
        &Matrix2::new(0.0, 1.0, 0.0, 0.0),
        &Vector2::new(0.0, 1.0),
        &Matrix1::new(q),
        dt,
    )
    .unwrap();
    let expected = Matrix2::new(dt.powi(3) / 3.0, dt.powi(2) / 2.0, dt.powi(2) / 2.0, dt) * q;
    assert!((cv.noise - expected).amax() < 1e-15);
    assert_eq!(continuous_white_noise::<2>(dt, q).unwrap(), expected);
    let ca = van_loan(
        &Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
        &Vector3::new(0.0, 0.0, 1.0),
        &Matrix1::new(q),
        dt,
    )
    .unwrap();
    assert!((ca.noise - continuous_white_noise::<3>(dt, q).unwrap()).amax() < 1e-15);
    assert!(
        (ca.noise[(0, 0)] - q * dt.powi(5) / 20.0).abs() < 1e-18,
        "constant acceleration: Q₀₀ = q dt⁵/20"
    );
    let jerk_drift = Matrix4::new(
        0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
    );
    let jerk = van_loan(
        &jerk_drift,
        &nalgebra::Vector4::new(0.0, 0.0, 0.0, 1.0),
        &Matrix1::new(q),
        dt,
    )
    .unwrap();
    assert!((jerk.noise - continuous_white_noise::<4>(dt, q).unwrap()).amax() < 1e-15);
}

#[test]
fn piecewise_white_noise_is_the_textbook_matrix() {
    let (dt, var) = (0.3_f64, 2.5);
    let q2 = piecewise_white_noise::<2>(dt, var).unwrap();
    let e2 = Matrix2::new(
        dt.powi(4) / 4.0,
        dt.powi(3) / 2.0,
        dt.powi(3) / 2.0,
        dt.powi(2),
    ) * var;
    assert!((q2 - e2).amax() < 1e-16);
    let q3 = piecewise_white_noise::<3>(dt, var).unwrap();
    #[rustfmt::skip]
    let e3 = Matrix3::new(
        dt.powi(4) / 4.0, dt.powi(3) / 2.0, dt.powi(2) / 2.0,
        dt.powi(3) / 2.0, dt.powi(2),       dt,
        dt.powi(2) / 2.0, dt,               1.0,
    ) * var;
    assert!((q3 - e3).amax() < 1e-16);
    let q4 = piecewise_white_noise::<4>(dt, var).unwrap();
    #[rustfmt::skip]
    let e4 = Matrix4::new(
        dt.powi(6) / 36.0, dt.powi(5) / 12.0, dt.powi(4) / 6.0, dt.powi(3) / 6.0,
        dt.powi(5) / 12.0, dt.powi(4) / 4.0,  dt.powi(3) / 2.0, dt.powi(2) / 2.0,
        dt.powi(4) / 6.0,  dt.powi(3) / 2.0,  dt.powi(2),       dt,
        dt.powi(3) / 6.0,  dt.powi(2) / 2.0,  dt,               1.0,
    ) * var;
    assert!((q4 - e4).amax() < 1e-15);
}

#[test]
fn per_axis_repeats_the_block_axis_by_axis() {
    let block = Matrix2::new(1.0, 2.0, 2.0, 5.0);
    let q: Matrix6<f64> = per_axis(&block);
    for axis in 0..3 {
        assert_eq!(q.fixed_view::<2, 2>(2 * axis, 2 * axis), block);
    }
    assert_eq!(q.iter().filter(|v| **v != 0.0).count(), 12);
}

#[test]
fn bad_input_is_refused_with_a_typed_error() {
    let a = Matrix2::new(0.0, 1.0, 0.0, 0.0);
    let g = Vector2::new(0.0, 1.0);
    let q = Matrix1::new(1.0);
    assert!(matches!(
        van_loan(&a, &g, &q, -0.1),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        van_loan(&a, &g, &q, f64::NAN),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(matches!(
        van_loan(&a, &g, &Matrix1::new(-1.0), 0.1),
        Err(OperatorError::NotPositiveDefinite { .. })
    ));
    let asymmetric = Matrix2::new(1.0, 0.5, 0.0, 1.0);
    assert!(matches!(
        van_loan(&a, &Matrix2::identity(), &asymmetric, 0.1),
        Err(OperatorError::NotPositiveDefinite { .. })
    ));
    // exp(A dt) overflows: an error, not an infinite matrix.
    let explosive = Matrix2::new(800.0, 0.0, 0.0, 1.0);
    assert!(van_loan(&explosive, &g, &q, 1.0).is_err());
    let huge = Matrix2::new(f64::MAX, 0.0, 0.0, 1.0);
    assert!(van_loan(&huge, &g, &q, 10.0).is_err());
    assert!(continuous_white_noise::<2>(f64::INFINITY, 1.0).is_err());
    assert!(continuous_white_noise::<2>(0.1, -1.0).is_err());
    assert!(continuous_white_noise::<3>(1e200, 1.0).is_err());
    assert!(piecewise_white_noise::<2>(0.1, f64::NAN).is_err());
    assert!(piecewise_white_noise::<4>(1e120, 1.0).is_err());
}

/// A symmetric positive definite 6 × 6 matrix from a seed vector.
fn spd6(seed: &Vector6<f64>) -> Matrix6<f64> {
    let l = Matrix6::from_fn(|i, j| if i >= j { seed[(i + 2 * j) % 6] } else { 0.0 });
    l * l.transpose() + Matrix6::identity() * 0.1
}

#[test]
fn the_transported_covariance_is_that_of_the_transported_errors() {
    let x = Se3::new(
        So3::exp(&Vector3::new(0.4, -1.2, 2.0)),
        Vector3::new(3.0, -2.0, 10.0),
    )
    .unwrap();
    let world = Left::new(x);
    let ad = x.adjoint();
    // Each body-frame error δ is the world-frame error Ad(x) δ of the same point.
    for delta in [
        Vector6::new(0.1, -0.2, 0.3, 0.01, 0.02, -0.03),
        Vector6::new(-1.0, 0.5, 0.0, 0.5, -0.4, 0.3),
    ] {
        let point = x.retract(&delta);
        let world_error = world.local(&Left::new(point));
        assert!(
            (world_error - ad * delta).amax() < 1e-12,
            "{world_error} vs {}",
            ad * delta
        );
    }
    // Hence Cov(δ_w) = Ad Cov(δ_b) Adᵀ, and back.
    let p = spd6(&Vector6::new(0.3, -0.1, 0.2, 0.05, 0.4, -0.2));
    let pw = world_from_body(&x, &p).unwrap();
    assert!((pw - ad * p * ad.transpose()).amax() < 1e-12 * pw.amax());
    assert!((body_from_world(&x, &pw).unwrap() - p).amax() < 1e-12 * pw.amax());
    let density = ManifoldGaussian::new(x, p).unwrap();
    let there = to_world_frame(&density).unwrap();
    assert_eq!(there.mean().inner(), &x);
    let back = to_body_frame(&there).unwrap();
    assert!((back.covariance() - p).amax() < 1e-12 * pw.amax());
    // A translation near overflow: Ad P Adᵀ overflows, an error rather than an infinite matrix;
    // a non-finite P is refused.
    let far = Se3::new(*x.rotation(), Vector3::new(1e200, -1e200, 3e199)).unwrap();
    for huge in [world_from_body(&far, &p), body_from_world(&far, &p)] {
        assert!(matches!(huge, Err(OperatorError::NonFinite { .. })));
    }
    let mut bad = p;
    bad[(2, 4)] = f64::NAN;
    assert!(matches!(
        world_from_body(&x, &bad),
        Err(OperatorError::NonFinite { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Van Loan's Q is symmetric positive semi-definite and Φ is invertible, for any stable or
    /// unstable drift of moderate size.
    #[test]
    fn van_loan_noise_is_positive_semi_definite(
        entries in proptest::array::uniform9(-2.0..2.0_f64),
        gain in proptest::array::uniform3(-1.0..1.0_f64),
        density in 0.0..10.0_f64,
        dt in 0.0..0.5_f64,
    ) {
        let a = Matrix3::from_row_slice(&entries);
        let model = van_loan(&a, &Vector3::from(gain), &Matrix1::new(density), dt).unwrap();
        let eigen = model.noise.symmetric_eigenvalues();
        prop_assert!(eigen.min() >= -1e-12 * model.noise.amax().max(1e-300));
        prop_assert!(model.transition.determinant() > 0.0);
    }

    /// The transport is exact for every rotation: body → world → body is the identity.
    #[test]
    fn transport_round_trips(
        axis in proptest::array::uniform3(-3.0..3.0_f64),
        seed in proptest::array::uniform3(-1.0..1.0_f64),
    ) {
        let x = So3::exp(&Vector3::from(axis));
        let s = Vector3::from(seed);
        let p = s * s.transpose() + Matrix3::identity() * 0.01;
        let back = body_from_world(&x, &world_from_body(&x, &p).unwrap()).unwrap();
        prop_assert!((back - p).amax() < 1e-12);
    }
}

/// Van Loan's generator beyond the matrix exponential's range: A dt = 1e40 made nalgebra's
/// exponential count its squarings from an overflowed norm estimate (u64::MAX of them), and the
/// call never returned. It is refused at once; a stiff but representable step still works.
#[test]
fn van_loan_refuses_a_generator_beyond_the_exponential() {
    let one = Matrix1::new(1.0);
    for (a, dt) in [(1.0, 1e40), (-1.0, 1e39), (1e20, 1.0)] {
        let error = van_loan(&Matrix1::new(a), &one, &Matrix1::new(0.0), dt).unwrap_err();
        assert!(matches!(error, OperatorError::OutOfRange { .. }), "{error}");
    }
    // A nilpotent drift (A² = 0) over a long step: the exponential's estimate of ‖|G|²⁷‖ overflowed
    // at a one-norm of 4e11, under the earlier bound of 1e15, with the same endless squarings.
    let nilpotent = Matrix2::new(1.0, 1.0, -1.0, -1.0);
    let error = van_loan(
        &nilpotent,
        &Vector2::new(1.0, 0.0),
        &Matrix1::new(0.0),
        2e11,
    )
    .unwrap_err();
    assert!(matches!(error, OperatorError::OutOfRange { .. }), "{error}");
    // Near the bound the call returns (an error here: the exponential's squarings of this
    // generator overflow), and at an ordinary step Φ = exp(A dt) = I + A dt.
    let gain = Vector2::new(1.0, 0.0);
    assert!(van_loan(&nilpotent, &gain, &Matrix1::new(0.0), 2.4e9).is_err());
    let model = van_loan(&nilpotent, &gain, &Matrix1::new(0.0), 10.0).unwrap();
    let expected = Matrix2::identity() + nilpotent * 10.0;
    assert!(
        (model.transition - expected).amax() <= 1e-12,
        "{}",
        model.transition
    );
    let stiff = van_loan(&Matrix1::new(-50.0), &one, &one, 1.0).unwrap();
    assert!((stiff.transition[0] - (-50.0_f64).exp()).abs() < 1e-30);
    assert!((stiff.noise[0] - (1.0 - (-100.0_f64).exp()) / 100.0).abs() < 1e-15);
}

/// q dt^p with dt^p below f64's range: `continuous_white_noise::<2>(1e-120, 1e300)` took
/// dt³ = 0 and returned an indefinite Q as Ok; its entries are now q dt³/3, q dt²/2 and q dt to
/// rounding, and Q is positive definite.
#[test]
fn white_noise_of_tiny_steps_and_huge_densities_is_exact() {
    let q = continuous_white_noise::<2>(1e-120, 1e300).unwrap();
    let expected = Matrix2::new(1e-60 / 3.0, 5e59, 5e59, 1e180);
    for (got, want) in q.iter().zip(expected.iter()) {
        assert!(
            (got - want).abs() <= 4.0 * f64::EPSILON * want,
            "{got:e} vs {want:e}"
        );
    }
    assert!(q[(0, 0)] * q[(1, 1)] > q[(0, 1)] * q[(1, 0)]);
    // Subnormal steps, and products below f64's range, which are 0.
    let tiny = continuous_white_noise::<3>(1e-310, 1.0).unwrap();
    assert_eq!(tiny[(2, 2)], 1e-310);
    assert_eq!(tiny[(0, 0)], 0.0);
    // Entries rounded in the subnormal range each keep part of their precision: 7 units of the
    // last place for q dt and 2, 4, 4 for the others made an indefinite Q (smallest eigenvalue
    // −2.4 % of the largest), returned as Ok. Refused, as is an entry that underflows to zero
    // beside normal ones.
    for (dt, q) in [(1.0, 3.5e-323), (1e-3, 1e-315)] {
        let error = continuous_white_noise::<2>(dt, q).unwrap_err();
        assert!(
            matches!(error, OperatorError::NotPositiveDefinite { .. }),
            "{error}"
        );
    }
    let error = piecewise_white_noise::<2>(1.0, 1.5e-323).unwrap_err();
    assert!(
        matches!(error, OperatorError::NotPositiveDefinite { .. }),
        "{error}"
    );
    // Ordinary arguments: the closed form to rounding.
    let q = continuous_white_noise::<2>(0.1, 0.3).unwrap();
    assert!((q[(0, 0)] - 0.3 * 1e-3 / 3.0).abs() < 1e-18);
}

/// Cholesky reads one triangle: `nees` of an asymmetric P (`[[1, 1e300], [0, 1]]`) returned 2 as
/// if P were the identity, while the same 1e300 in the other triangle was an error. An asymmetric
/// P is refused either way.
#[test]
fn nees_refuses_an_asymmetric_covariance() {
    let e = Vector2::new(1.0, 1.0);
    for p in [
        Matrix2::new(1.0, 1e300, 0.0, 1.0),
        Matrix2::new(1.0, 0.0, 1e-3, 1.0),
    ] {
        let error = nees(&e, &p).unwrap_err();
        assert!(matches!(error, OperatorError::OutOfRange { .. }), "{error}");
        assert!(nis(&e, &p).is_err());
    }
    // Symmetric to rounding: accepted.
    let p = Matrix2::new(2.0, 0.5, 0.5 + 1e-16, 1.0);
    assert!(nees(&e, &p).is_ok());
}

/// Only a covariance is transported: an asymmetric P (upper triangle 1e300, lower −1e300) was
/// returned as its symmetric part and a negative definite P as a "covariance", both as `Ok`. Each
/// is refused by both directions of the transport, while a positive semi-definite P of rank one
/// (a process noise on one body axis) is transported.
#[test]
fn only_symmetric_positive_semi_definite_matrices_are_transported() {
    let x = Se3::exp(&Vector6::new(0.3, -0.2, 0.5, 1.0, -2.0, 0.5));
    let mut asymmetric = Matrix6::identity();
    asymmetric[(0, 1)] = 1e300;
    asymmetric[(1, 0)] = -1e300;
    let negative = -Matrix6::identity();
    // Every 2 × 2 minor non-negative, yet indefinite: the determinant of the leading 3 × 3 block
    // is 1 − 3 (0.9²) − 2 (0.9³) < 0.
    let mut indefinite = Matrix6::identity();
    for (i, j, v) in [(0, 1, 0.9), (0, 2, 0.9), (1, 2, -0.9)] {
        indefinite[(i, j)] = v;
        indefinite[(j, i)] = v;
    }
    for p in [asymmetric, negative, indefinite] {
        for moved in [world_from_body(&x, &p), body_from_world(&x, &p)] {
            assert!(
                matches!(moved, Err(OperatorError::NotPositiveDefinite { .. })),
                "{moved:?}"
            );
        }
    }
    let mut one_axis = Matrix6::zeros();
    one_axis[(3, 3)] = 0.25;
    let ad = x.adjoint();
    let moved = world_from_body(&x, &one_axis).unwrap();
    assert!((moved - ad * one_axis * ad.transpose()).amax() < 1e-12 * moved.amax());
}

/// Van Loan's generator holds `exp(−A dt)` beside `exp(A dt)`: a stable drift over a long step
/// (A = −I, dt = 1e9, where Φ = e^{−1e9} I is 0) overflows in that block, and was refused as
/// "exp(A dt) overflows", which it does not. The error names the generator's exponential and both
/// blocks, and says what to do.
#[test]
fn an_overflowing_van_loan_exponential_is_named() {
    let gain = Vector2::new(1.0, 0.0);
    let decay = van_loan(&(-Matrix2::identity()), &gain, &Matrix1::new(1.0), 1e9);
    let growth = van_loan(&Matrix2::identity(), &gain, &Matrix1::new(1.0), 1e3);
    for result in [decay, growth] {
        let error = result.unwrap_err();
        let message = error.to_string();
        assert!(
            matches!(error, OperatorError::NonFinite { .. })
                && message.contains("Van Loan's generator")
                && message.contains("exp(-A dt)")
                && message.contains("take shorter steps"),
            "{message}"
        );
    }
}
