//! The named approximations, with their errors measured (the figures are in docs/densities/).
//!
//! Von Mises ⊛ von Mises ≈ von Mises (first trigonometric moment matched). The exact convolution of
//! VM(μ₁, κ₁) and VM(μ₂, κ₂) has Fourier coefficients Aₙ(κ₁) Aₙ(κ₂) e^(in(μ₁+μ₂)), so its density is
//! the exact series `(1/2π)(1 + 2 Σ Aₙ(κ₁) Aₙ(κ₂) cos(n(θ − μ₁ − μ₂)))`, against which the
//! approximation's KL divergence is computed by quadrature.

mod common;

use common::quadrature::integrate_circle;
use liebayes_densities::{Density, VonMises, special};
use liebayes_manifolds::{Manifold, So2};

use std::f64::consts::PI;

/// `KL(exact convolution ‖ moment-matched von Mises)` for two von Mises of concentration κ.
fn convolution_kl(kappa: f64) -> f64 {
    let p = VonMises::new(So2::from_angle_unchecked(0.4), kappa).unwrap();
    let q = VonMises::new(So2::from_angle_unchecked(-1.1), kappa).unwrap();
    let approx = p.convolve_moment_matched(&q);
    let mu = 0.4 - 1.1;
    // Coefficients until they fall below 1e-17.
    let coefficients: Vec<f64> = (1..100_000)
        .map(|n| special::bessel_ratio(n, kappa).unwrap().powi(2))
        .take_while(|c| *c > 1e-17)
        .collect();
    let exact = |t: f64| {
        let series: f64 = coefficients
            .iter()
            .enumerate()
            .map(|(i, c)| c * ((i as f64 + 1.0) * (t - mu)).cos())
            .sum();
        (1.0 + 2.0 * series) / (2.0 * PI)
    };
    let points = 64 + 4 * coefficients.len();
    // The cosine series carries an absolute rounding of about eps · e_max: below 1e3 of that its values
    // are noise (far in the tails, where both densities are below e^(−28) of their peak and the true
    // integrand is negligible), and noise times ln(e/a) ≈ κ would swamp the KL at large κ.
    let noise = 1e3 * f64::EPSILON * exact(mu);
    integrate_circle(
        |t| {
            let e = exact(t);
            if e > noise {
                e * (e.ln() - approx.log_pdf(&So2::from_angle_unchecked(t)))
            } else {
                0.0
            }
        },
        points,
    )
}

#[test]
fn moment_matched_convolution_matches_the_first_moment_exactly() {
    for kappa in [1e-6, 0.5, 3.0, 50.0, 1e4] {
        let p = VonMises::new(So2::from_angle_unchecked(2.0), kappa).unwrap();
        let q = VonMises::new(So2::from_angle_unchecked(2.5), 2.0 * kappa).unwrap();
        let r = p.convolve_moment_matched(&q);
        let expected = special::a1(kappa).unwrap() * special::a1(2.0 * kappa).unwrap();
        assert!(
            (r.mean_resultant_length() - expected).abs() <= 1e-13,
            "κ {kappa}"
        );
        let mean = r.mean().unwrap();
        assert!(
            mean.distance(&So2::from_angle_unchecked(4.5)) < 1e-12,
            "mean {} for κ {kappa}",
            mean.angle()
        );
    }
}

/// The measured KL divergence against κ (κ₁ = κ₂ = κ). It vanishes in both limits (uniform as κ → 0,
/// Gaussian as κ → ∞, where von Mises convolution becomes Gaussian convolution) and peaks at moderate κ.
/// The bounds are the figures of docs/densities/von_mises.md rounded up in their second digit.
#[test]
fn moment_matched_convolution_error_against_concentration() {
    // Measured (κ, KL), rounded up in the second digit. At κ = 1e5 the true value (≈ 4.7e-12 by the
    // 0.047/κ² trend) is below this quadrature's resolution of about 1e-11.
    let table = [
        (0.01, 1e-15),
        (0.1, 2.5e-12),
        (0.3, 1.5e-8),
        (0.5, 7.0e-7),
        (1.0, 7.9e-5),
        (2.0, 2.1e-3),
        (3.0, 4.9e-3),
        (5.0, 4.2e-3),
        (10.0, 7.7e-4),
        (20.0, 1.5e-4),
        (30.0, 6.0e-5),
        (100.0, 4.9e-6),
        (1000.0, 4.8e-8),
        (1e4, 4.7e-10),
        (1e5, 1e-11),
    ];
    for (kappa, bound) in table {
        let kl = convolution_kl(kappa);
        eprintln!("kappa {kappa:>7}: KL(exact || moment-matched) = {kl:.3e}");
        assert!(
            kl >= -1e-11,
            "KL must be non-negative (to the quadrature's resolution): {kl}"
        );
        assert!(
            kl <= bound,
            "κ {kappa}: KL {kl:e} above the documented {bound:e}"
        );
    }
}

/// Heat kernel → Bingham by second moments: KL(heat kernel ‖ Bingham) against s, by quadrature over the
/// rotation angle (both isotropic, so both are functions of the angle alone, against the same normalised
/// Haar measure). The Bingham's density at angle t is exp(z₁ sin²(t/2) − ln K) (z₁ the common eigenvalue).
fn heat_kernel_bingham_kl(s: f64) -> (f64, f64) {
    use liebayes_densities::HeatKernelSo3;
    use liebayes_manifolds::{LieGroup, So3};
    let h = HeatKernelSo3::new(So3::identity(), s).unwrap();
    let b = h.to_bingham_moment_matched().unwrap();
    let z1 = b.eigenvalues()[1] - b.eigenvalues()[0];
    let log_k = b.log_normalizer() - b.eigenvalues()[0];
    let end = (12.0 * s.sqrt()).min(std::f64::consts::PI);
    let kl = common::quadrature::integrate_peaked(
        |t| {
            let log_bingham = z1 * (t / 2.0).sin().powi(2) - log_k;
            h.angle_pdf(t).unwrap() * (h.log_density_of_angle(t).unwrap() - log_bingham)
        },
        s.sqrt().min(end),
        end,
    );
    (kl, z1)
}

/// Measured KL(heat kernel ‖ moment-matched Bingham), rounded up in the second digit.
#[test]
fn heat_kernel_to_bingham_error_against_variance() {
    // At s = 7.6e-3 (σ = 5°) and 0.03 (σ ≈ 10°) an independent computation of the divergence (by
    // quadrature over the rotation angle) gives 6e-6 and 1e-4.
    let table = [
        (3e-4, 9.5e-9),
        (1e-3, 1.1e-7),
        (7.6e-3, 6.1e-6),
        (0.03, 9.7e-5),
        (0.1, 1.2e-3),
        (0.5, 3.4e-2),
        (1.0, 2.5e-2),
        (2.0, 1.6e-3),
        (5.0, 2.0e-8),
    ];
    for (s, bound) in table {
        let (kl, z1) = heat_kernel_bingham_kl(s);
        eprintln!(
            "s {s:>7}: z1 {z1:>12.4}  (-2/s - 3/2 = {:>12.4}), KL(heat || Bingham) = {kl:.3e}",
            -2.0 / s - 1.5
        );
        assert!(kl >= -1e-12, "KL must be non-negative: {kl}");
        assert!(
            kl <= bound,
            "s {s}: KL {kl:e} above the documented {bound:e}"
        );
    }
}

#[test]
fn bingham_to_heat_kernel_inverts_the_isotropic_case() {
    use liebayes_densities::HeatKernelSo3;
    use liebayes_manifolds::{LieGroup, So3};
    for s in [1e-3, 0.05, 0.7, 3.0] {
        let centre = So3::exp(&nalgebra::Vector3::new(0.3, -1.0, 2.5));
        let h = HeatKernelSo3::new(centre, s).unwrap();
        let back = h
            .to_bingham_moment_matched()
            .unwrap()
            .to_heat_kernel_moment_matched()
            .unwrap();
        assert!(
            (back.variance() - s).abs() <= 1e-9 * s,
            "s {s}: {}",
            back.variance()
        );
        assert!(
            back.mean().distance(&centre) <= 1e-9,
            "centre moved by {}",
            back.mean().distance(&centre)
        );
    }
}

/// KL(manifold Gaussian ‖ moment-matched Bingham) as an expectation over ξ ~ N(0, Σ) by 24-point
/// Gauss-Hermite cubature (the tests' own rule). The manifold Gaussian's density against the normalised
/// Haar measure is N(ξ) · 8π² / (2(1 − cos θ)/θ²), θ = |ξ|, while the wrap-around beyond π is negligible
/// (σ ≤ 20°).
fn manifold_gaussian_bingham_kl(covariance: &nalgebra::Matrix3<f64>) -> (f64, f64) {
    use liebayes_densities::{Bingham, Density, ManifoldGaussian};
    use liebayes_manifolds::{LieGroup, So3, Su2};
    let mean = So3::exp(&nalgebra::Vector3::new(0.4, -0.2, 1.0));
    let tg = ManifoldGaussian::<So3<f64>, 3>::new(mean, *covariance).unwrap();
    let b: Bingham = tg.to_bingham_moment_matched().unwrap();
    let eigen = nalgebra::SymmetricEigen::new(*covariance);
    let scale = eigen.eigenvalues.map(f64::sqrt);
    let rule = common::quadrature::gauss_hermite(24);
    let log_det = eigen.eigenvalues.iter().map(|l| l.ln()).sum::<f64>();
    let mut kl = 0.0;
    for (a, wa) in &rule {
        for (bb, wb) in &rule {
            for (c, wc) in &rule {
                let u = nalgebra::Vector3::new(*a, *bb, *c);
                let xi = eigen.eigenvectors * u.component_mul(&scale);
                let theta = xi.norm();
                let log_gauss = -0.5 * u.norm_squared()
                    - 1.5 * (2.0 * std::f64::consts::PI).ln()
                    - 0.5 * log_det;
                let jacobian = if theta < 1e-4 {
                    1.0 - theta * theta / 12.0
                } else {
                    2.0 * (1.0 - theta.cos()) / (theta * theta)
                };
                let log_haar =
                    log_gauss + (8.0 * std::f64::consts::PI.powi(2)).ln() - jacobian.ln();
                let q: Su2<f64> = mean.to_su2().compose(&Su2::exp(&xi));
                kl += wa * wb * wc * (log_haar - b.log_pdf(&q));
            }
        }
    }
    // Σ round trip: Bingham → manifold Gaussian with Σ = 4 E[v vᵀ].
    let back = b.to_manifold_gaussian_moment_matched().unwrap();
    let mismatch = (back.covariance() - covariance).amax() / covariance.amax();
    (kl, mismatch)
}

/// Measured KL(manifold Gaussian ‖ Bingham) and the relative Σ mismatch of the reverse map, against σ,
/// for an isotropic and an anisotropic (1 : 0.5 : 0.2 in variance, correlated) Σ; rounded up.
#[test]
fn manifold_gaussian_bingham_error_against_spread() {
    let shape = nalgebra::Matrix3::new(1.0, 0.2, 0.0, 0.2, 0.5, 0.1, 0.0, 0.1, 0.2);
    // (σ in degrees, KL bound isotropic, KL bound anisotropic): measured, rounded up in the second digit.
    let table = [
        (1.0, 9.7e-9, 4.1e-9),
        (5.0, 6.1e-6, 2.6e-6),
        (10.0, 1.1e-4, 4.2e-5),
        (20.0, 1.9e-3, 7.4e-4),
    ];
    for (degrees, isotropic_bound, anisotropic_bound) in table {
        let sigma = f64::to_radians(degrees);
        for (name, cov, bound) in [
            (
                "isotropic",
                nalgebra::Matrix3::identity() * sigma * sigma,
                isotropic_bound,
            ),
            ("anisotropic", shape * sigma * sigma, anisotropic_bound),
        ] {
            let (kl, mismatch) = manifold_gaussian_bingham_kl(&cov);
            eprintln!(
                "sigma {degrees:>4} deg, {name:>11}: KL(TG || Bingham) = {kl:.3e}, Sigma round-trip mismatch {mismatch:.2e}"
            );
            assert!(
                (0.0..=bound).contains(&kl),
                "σ {degrees}°, {name}: KL {kl:e} outside [0, {bound:e}]"
            );
            // The reverse map matches the second moments exactly (to the fit's 1e-11): Σ comes back.
            assert!(
                mismatch <= 1e-10,
                "σ {degrees}°, {name}: Σ round trip off by {mismatch:e}"
            );
        }
    }
}

/// The Bingham → manifold Gaussian match stopped after 50 fixed-point steps without checking its
/// residual: eigenvalues (0, −0.2, −0.2, −0.2) came back as Ok with second moments 2 % off, and
/// (0, −1, −1, −1) 7e-5 off. A match is now returned only at its documented residual: the second
/// comes back through the reverse map (eigenvalue gaps to 1e-8), the first, whose moments no
/// Gaussian on the tangent space reaches, is refused.
#[test]
fn the_bingham_to_gaussian_match_converges_or_is_refused() {
    use liebayes_densities::{Bingham, DensityError};
    let bingham = |gap: f64| {
        Bingham::new(
            nalgebra::Matrix4::identity(),
            nalgebra::Vector4::new(0.0, -gap, -gap, -gap),
        )
        .unwrap()
    };
    let matched = bingham(1.0).to_manifold_gaussian_moment_matched().unwrap();
    let back = matched.to_bingham_moment_matched().unwrap();
    let gaps = back.eigenvalues().map(|z| z - back.eigenvalues()[0]);
    for gap in gaps.iter().skip(1) {
        assert!((gap + 1.0).abs() < 1e-8, "{gaps:?}");
    }
    let error = bingham(0.2)
        .to_manifold_gaussian_moment_matched()
        .unwrap_err();
    assert!(matches!(error, DensityError::OutOfRange { .. }), "{error}");
}

/// (κ, κ₁₂): the moment-matched convolution of two von Mises of concentration κ, whose complement
/// `d = 1 − A(κ)²` gives `κ₁₂ = A⁻¹(1 − d) ≈ 1/(2d) + ¼ ≈ κ/2`. References: mpmath with
/// `mp.dps = 60 + log₁₀ κ`, `D = 1 − I₁(κ)/I₀(κ)` by `besseli`, `d = 2D − D²`, and κ₁₂ solving
/// `1/D(k) = 1/d` by `k ← k − (1/D(k) − 1/d)/2` from `1/(2d) + ¼` to 50 digits (D also checked
/// against its Hankel series). The first two straddle the switch to the asymptotic inverse at
/// d = 1e-9 (Newton below κ = 1e9, the closed form above). The digits are as mpmath printed them
/// (the last lie past f64).
#[allow(clippy::excessive_precision)]
const CONCENTRATED: [(f64, f64); 6] = [
    (0.999e9, 4.995_000_002_500_000_003_1e8),
    (1.001e9, 5.005_000_002_500_000_003_1e8),
    (1e110, 5.000_000_000_000_000_117_8e109),
    (1e150, 4.999_999_999_999_999_904_2e149),
    (1e200, 4.999_999_999_999_999_848_7e199),
    (1e300, 5.000_000_000_000_000_262_5e299),
];

/// Concentrations up to the documented 1e300: Newton's step for the inverse underflowed from
/// κ ≈ 1e108 on, and the result was κ itself (1e110, 1e150, twice too large), 4.34e181 for 1e200 and
/// 4.34e281 for 1e300. Tolerance 1e-15 relative (4.5 ulp): the inputs' `1 − A(κ)` carry a few ulp
/// (the crate's one_minus_a1) and d's relative error passes to κ₁₂ with condition number 1, plus
/// the rounding of 1/(2d) + ¼.
#[test]
fn moment_matched_convolution_of_concentrated_inputs() {
    for (kappa, expected) in CONCENTRATED {
        let p = VonMises::new(So2::from_angle_unchecked(0.3), kappa).unwrap();
        let got = p.convolve_moment_matched(&p).concentration();
        assert!(
            (got / expected - 1.0).abs() <= 1e-15,
            "κ {kappa:e}: {got:e}, reference {expected:e}, relative error {:e}",
            got / expected - 1.0
        );
    }
}
