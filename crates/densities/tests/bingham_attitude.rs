//! The Bingham's attitude algebra against independent computations: the likelihood of a measured
//! direction ([`Bingham::from_direction`]) against the rotated-vector residual; the diffusion's
//! second moments ([`Bingham::diffusion_second_moment`]) against the moment equation of the Brownian
//! motion integrated numerically and against a Brownian Monte Carlo; the moment matching in both
//! directions ([`Bingham::from_diffusion_moment_matched`], [`Bingham::to_diffusion_moment_matched`])
//! against brute-force quadrature of the Bingham over S³; and their bad input.
//!
//! Tolerances: the direction identity to 1e-13 of its scale, the closed-form moments to the moment
//! equation's 1e-14, and the quadrature moments to 1e-11 (the rules' accuracy bounds this check).

use liebayes_densities::testing::DensitySubject;
use liebayes_densities::testing::strategies as dst;
use liebayes_densities::{Bingham, Density, DensityError, HeatKernelSo3};
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{LieGroup, Manifold, So3, Su2};
use nalgebra::{Matrix3, Matrix4, SMatrix, UnitQuaternion, Vector3, Vector4};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn coords(q: &Su2<f64>) -> Vector4<f64> {
    Vector4::from(q.to_quaternion_wxyz())
}

/// The matrix of `p ↦ q p` on (w, x, y, z) coordinates.
fn left(q: &Vector4<f64>) -> Matrix4<f64> {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    Matrix4::new(w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w)
}

/// `E[q qᵀ]` of `LD(1, Σ)` by the moment equation of the Brownian motion, independent of the closed
/// form: the step `q ← q exp(ξ/2)`, `ξ ~ N(0, Σ dt)`, has `E[p pᵀ] = e₀e₀ᵀ + dt B` with
/// `B = diag(−tr Σ/4, Σ/4)` to first order, so `dS/dt = Σ_ab S_ab L_a B L_bᵀ` (L_a the left
/// multiplication by the basis quaternion a); integrated from `e₀e₀ᵀ` to t = 1 by the classical
/// Runge-Kutta method in 400 steps (local error (|A| h)⁵, below 1e-15 for tr Σ ≤ 1).
fn moments_by_moment_equation(sigma: &Matrix3<f64>) -> Matrix4<f64> {
    let mut b = Matrix4::zeros();
    b[(0, 0)] = -sigma.trace() / 4.0;
    for i in 0..3 {
        for j in 0..3 {
            b[(i + 1, j + 1)] = sigma[(i, j)] / 4.0;
        }
    }
    let basis: Vec<Matrix4<f64>> = (0..4)
        .map(|a| left(&Vector4::from_fn(|k, _| if k == a { 1.0 } else { 0.0 })))
        .collect();
    // The linear map S ↦ Σ_ab S_ab L_a B L_bᵀ as a 16 × 16 matrix on column-major entries.
    let mut operator = SMatrix::<f64, 16, 16>::zeros();
    for a in 0..4 {
        for c in 0..4 {
            let image = basis[a] * b * basis[c].transpose();
            operator.set_column(
                a + 4 * c,
                &SMatrix::<f64, 16, 1>::from_column_slice(image.as_slice()),
            );
        }
    }
    let steps = 400;
    let h = 1.0 / f64::from(steps);
    let mut s = SMatrix::<f64, 16, 1>::zeros();
    s[0] = 1.0;
    for _ in 0..steps {
        let k1 = operator * s;
        let k2 = operator * (s + k1 * (h / 2.0));
        let k3 = operator * (s + k2 * (h / 2.0));
        let k4 = operator * (s + k3 * h);
        s += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
    }
    Matrix4::from_column_slice(s.as_slice())
}

/// `E[q qᵀ]` of a Bingham by brute-force quadrature over S³ (its own normaliser not used).
fn moments_by_quadrature(bingham: &Bingham) -> Matrix4<f64> {
    let nodes = bingham.quadrature();
    let peak = bingham.log_pdf(&bingham.mode().unwrap_or_else(Su2::identity));
    let (mut mass, mut moments) = (0.0, Matrix4::zeros());
    for (q, w) in &nodes {
        let x = coords(q);
        let f = w * (bingham.log_pdf(q) - peak).exp();
        mass += f;
        moments += x * x.transpose() * f;
    }
    moments / mass
}

/// A covariance `R diag(v) Rᵀ` with the variances `v` in the frame of `frame`.
fn covariance(frame: &So3<f64>, v: (f64, f64, f64)) -> Matrix3<f64> {
    let r = frame.to_matrix();
    r * Matrix3::from_diagonal(&Vector3::new(v.0, v.1, v.2)) * r.transpose()
}

fn direction() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0..1.0_f64, -1.0..1.0_f64, -1.0..1.0_f64)
        .prop_filter("not too short", |(x, y, z)| x * x + y * y + z * z > 0.01)
        .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// `qᵀ M q` is the log-likelihood `−|v − R(q)ᵀ h|²/(2σ²)` of a body-frame direction, and the
    /// density's log ratios are the likelihood's.
    #[test]
    fn direction_is_the_likelihood(
        q in st::su2::<f64>(), other in st::su2::<f64>(), v in direction(), h in direction(),
        scale in 0.1..3.0_f64, sigma in 0.05..2.0_f64,
    ) {
        let (v, h) = (v * scale, h * (1.0 + scale));
        let likelihood = Bingham::from_direction(&v, &h, sigma).unwrap();
        let log_likelihood = |q: &Su2<f64>| {
            let predicted = q.as_unit_quaternion().inverse_transform_vector(&h);
            -(v - predicted).norm_squared() / (2.0 * sigma * sigma)
        };
        let x = coords(&q);
        let quadratic = (x.transpose() * likelihood.natural() * x)[0];
        let expected = log_likelihood(&q);
        let scale = 1.0 + (v.norm() + h.norm()).powi(2) / (sigma * sigma);
        prop_assert!((quadratic - expected).abs() <= 1e-13 * scale, "{quadratic} vs {expected}");
        let ratio = likelihood.log_pdf(&q) - likelihood.log_pdf(&other);
        let expected_ratio = expected - log_likelihood(&other);
        prop_assert!((ratio - expected_ratio).abs() <= 1e-12 * scale, "{ratio} vs {expected_ratio}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// The closed-form moments of the diffusion are those of its moment equation, about the
    /// identity and turned to a mean (`L(q̄) S L(q̄)ᵀ`), from 0.06° to 40° per axis.
    #[test]
    fn diffusion_moments_solve_the_moment_equation(
        frame in st::so3::<f64>(),
        v in (1e-6..0.5_f64, 1e-6..0.5_f64, 1e-6..0.5_f64),
    ) {
        let sigma = covariance(&frame, v);
        let ours = Bingham::diffusion_second_moment(&sigma).unwrap();
        let reference = moments_by_moment_equation(&sigma);
        let error = (ours - reference).amax();
        prop_assert!(error <= 1e-14, "error {error:e}\n{ours}\n{reference}");
    }

    /// A Bingham matched to `LD(q̄, Σ)` has, by quadrature over S³, the diffusion's moments by the
    /// moment equation (anisotropic, 0.3° to 23° per axis), and matching back gives q̄ and Σ.
    #[test]
    fn matched_bingham_has_the_diffusion_moments(
        mean in st::su2::<f64>(), frame in st::so3::<f64>(),
        v in (3e-5..0.15_f64, 3e-5..0.15_f64, 3e-5..0.15_f64),
    ) {
        let sigma = covariance(&frame, v);
        let bingham = Bingham::from_diffusion_moment_matched(&mean, &sigma).unwrap();
        let l = left(&coords(&mean));
        let expected = l * moments_by_moment_equation(&sigma) * l.transpose();
        let quadrature = moments_by_quadrature(&bingham);
        // The quadrature's accuracy (1e-10 of the total mass) bounds the check; measured 3e-13.
        let error = (quadrature - expected).amax();
        prop_assert!(error <= 1e-11, "error {error:e}\n{quadrature}\n{expected}");
        let (back_mean, back_sigma) = bingham.to_diffusion_moment_matched().unwrap();
        prop_assert!(back_mean.distance(&mean) < 1e-7 || back_mean.distance(&mean.antipode()) < 1e-7);
        prop_assert!((back_sigma - sigma).amax() <= 1e-7 * sigma.amax(), "{back_sigma} vs {sigma}");
    }

    /// Any Bingham either has no diffusion or one that is positive definite and whose moments are
    /// the Bingham's by quadrature.
    #[test]
    fn matched_diffusion_is_positive_definite_or_refused(bingham in dst::bingham(1e3)) {
        match bingham.to_diffusion_moment_matched() {
            Ok((mean, sigma)) => {
                prop_assert!(sigma.cholesky().is_some(), "not positive definite: {sigma}");
                prop_assert!(sigma.symmetric_eigenvalues().min() > 0.0, "{sigma}");
                let l = left(&coords(&mean));
                let expected = l * moments_by_moment_equation(&sigma) * l.transpose();
                let quadrature = moments_by_quadrature(&bingham);
                let error = (quadrature - expected).amax();
                prop_assert!(error <= 1e-8, "error {error:e}\n{quadrature}\n{expected}");
            }
            Err(e) => prop_assert!(matches!(e, DensityError::OutOfRange { .. }), "{e}"),
        }
    }
}

/// A Bingham whose moments about the mode are those of no diffusion (one vector moment far smaller
/// than the product of the other two: `eᵢ < eⱼ eₖ`, a `σᵢ² < 0`) is refused, not returned with a
/// negative variance.
#[test]
fn a_bingham_of_no_diffusion_is_refused() {
    let bingham = Bingham::from_natural(Matrix4::from_diagonal(&Vector4::new(
        0.0, -400.0, -2.0, -2.0,
    )))
    .unwrap();
    let error = bingham.to_diffusion_moment_matched().unwrap_err();
    assert!(
        matches!(error, DensityError::OutOfRange { what, .. } if what.contains("variance")),
        "{error}"
    );
}

/// For an isotropic Σ = s I the conversions are the heat kernel's moment matches.
#[test]
fn isotropic_diffusion_is_the_heat_kernel() {
    let mean = Su2::from_unit_quaternion(UnitQuaternion::from_scaled_axis(Vector3::new(
        0.3, -1.1, 0.4,
    )));
    for s in [1e-5, 1e-3, 0.05, 0.5] {
        let ours =
            Bingham::from_diffusion_moment_matched(&mean, &(Matrix3::identity() * s)).unwrap();
        let kernel = HeatKernelSo3::new(mean.to_so3(), s).unwrap();
        let library = kernel.to_bingham_moment_matched().unwrap();
        let gap = (ours.second_moment() - library.second_moment()).amax();
        assert!(gap < 1e-12, "s = {s}: second moments differ by {gap}");
        let (_, sigma) = library.to_diffusion_moment_matched().unwrap();
        let back = library.to_heat_kernel_moment_matched().unwrap().variance();
        assert!(
            (sigma - Matrix3::identity() * back).amax() < 1e-10 * s,
            "s = {s}: {sigma} vs {back}"
        );
        assert!((back - s).abs() < 1e-8 * s, "s = {s}: {back}");
    }
}

/// `E[q qᵀ]` of `LD(1, Σ)` against a Monte Carlo of the random walk with right increments: 10 000
/// paths of 200 steps `exp(L n / √200)`, `L Lᵀ = Σ` (the discretisation bias, about |Σ|²/200 = 1e-5,
/// is below the standard error); every entry within 5 standard errors.
#[test]
fn diffusion_moments_match_a_brownian_monte_carlo() {
    let frame = UnitQuaternion::from_scaled_axis(Vector3::new(0.4, 0.2, -0.7))
        .to_rotation_matrix()
        .into_inner();
    let sd = Vector3::new(3.0_f64, 6.0, 12.0).map(f64::to_radians);
    let sigma = frame * Matrix3::from_diagonal(&sd.map(|s| s * s)) * frame.transpose();
    let l = sigma.cholesky().unwrap().l();
    let steps = 200;
    let scale = 1.0 / f64::from(steps).sqrt();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let paths = 10_000;
    let (mut sum, mut sum_squares) = (Matrix4::zeros(), Matrix4::zeros());
    for _ in 0..paths {
        let mut q = UnitQuaternion::identity();
        for _ in 0..steps {
            let n = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
            q *= UnitQuaternion::from_scaled_axis(l * n * scale);
        }
        let x = Vector4::new(q.w, q.i, q.j, q.k);
        let outer = x * x.transpose();
        sum += outer;
        sum_squares += outer.component_mul(&outer);
    }
    let n = f64::from(paths);
    let mean = sum / n;
    let standard_error =
        (sum_squares / n - mean.component_mul(&mean)).map(|v| (v.max(0.0) / n).sqrt());
    let ours = Bingham::diffusion_second_moment(&sigma).unwrap();
    let worst = (0..16)
        .map(|i| (ours[i] - mean[i]).abs() / (standard_error[i] + 1e-12))
        .fold(0.0_f64, f64::max);
    assert!(worst < 5.0, "{worst} standard errors\n{ours}\n{mean}");
}

#[test]
fn bad_input_is_refused() {
    let nan = Vector3::new(f64::NAN, 0.0, 0.0);
    assert!(matches!(
        Bingham::from_direction(&Vector3::x(), &Vector3::z(), 0.0),
        Err(DensityError::OutOfRange { .. })
    ));
    assert!(matches!(
        Bingham::from_direction(&Vector3::x(), &Vector3::z(), -1.0),
        Err(DensityError::OutOfRange { .. })
    ));
    assert!(matches!(
        Bingham::from_direction(&Vector3::x(), &Vector3::z(), f64::NAN),
        Err(DensityError::NonFinite { .. })
    ));
    assert!(matches!(
        Bingham::from_direction(&nan, &Vector3::z(), 1.0),
        Err(DensityError::NonFinite { .. })
    ));
    assert!(matches!(
        Bingham::from_direction(&Vector3::x(), &nan, 1.0),
        Err(DensityError::NonFinite { .. })
    ));
    // Overflowing entries, and a spread beyond the Bingham's range.
    assert!(Bingham::from_direction(&Vector3::x(), &Vector3::z(), 1e-200).is_err());
    assert!(Bingham::from_direction(&Vector3::x(), &Vector3::z(), 1e-7).is_err());
    let asymmetric = Matrix3::new(1.0, 2.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    assert!(Bingham::diffusion_second_moment(&asymmetric).is_err());
    assert!(Bingham::diffusion_second_moment(&(-Matrix3::identity())).is_err());
    assert!(Bingham::diffusion_second_moment(&(Matrix3::identity() * f64::INFINITY)).is_err());
    // Entries near overflow (the eigensolver's NaN was returned as Ok), and the largest accepted.
    assert!(Bingham::diffusion_second_moment(&Matrix3::repeat(1e308)).is_err());
    let uniform = Bingham::diffusion_second_moment(&(Matrix3::identity() * 1e100)).unwrap();
    assert!((uniform - nalgebra::Matrix4::identity() / 4.0).amax() < 1e-15);
    // Too concentrated for a Bingham.
    assert!(
        Bingham::from_diffusion_moment_matched(&Su2::identity(), &(Matrix3::identity() * 1e-12))
            .is_err()
    );
    assert!(Bingham::uniform().to_diffusion_moment_matched().is_err());
}
