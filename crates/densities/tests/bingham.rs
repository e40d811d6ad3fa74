//! Bingham on S³ against the reference vectors `bingham_vectors.json` (normaliser in both conventions and
//! second moments, eigenvalues 0 to −1e4), and its laws: normalisation by Monte Carlo over the uniform
//! distribution (independent of the quadrature), product, sample moments from the ACG sampler against
//! the normaliser's gradient, KL, entropy, mode, antipodal symmetry and rotation invariance.

mod common;

use liebayes_densities::{Bingham, Density, Entropy, KlDivergence, Product, Rotate, special};
use liebayes_manifolds::Su2;
use liebayes_manifolds::testing::strategies as st;
use nalgebra::{Matrix4, Quaternion, Vector4};
use proptest::prelude::*;
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn diagonal(z: [f64; 4]) -> Bingham {
    Bingham::from_natural(Matrix4::from_diagonal(&Vector4::from(z))).unwrap()
}

#[test]
fn matches_the_reference_vectors() {
    let reference = common::reference("bingham_vectors.json");
    let (mut worst_log, mut worst_moment) = (0.0_f64, 0.0_f64);
    for case in reference["cases"].as_array().unwrap() {
        let l: Vec<f64> = case["lambdas"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let b = diagonal([0.0, l[0], l[1], l[2]]);
        for (got, key) in [
            (b.log_normalizer(), "logK_unif"),
            (b.log_normalizer_surface(), "logK_raw"),
        ] {
            let expected = case[key].as_f64().unwrap();
            let error = if expected == 0.0 {
                got.abs()
            } else {
                common::relative_error(got, expected)
            };
            assert!(
                error <= 1e-10,
                "{key} for {l:?}: {got} vs {expected} ({error:e})"
            );
            worst_log = worst_log.max(error);
        }
        let expected: Vec<f64> = case["second_moments"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        // The diagonal matrix's eigenvectors are the axes, sorted by eigenvalue: map back by value.
        let moments = b.second_moment();
        for k in 0..4 {
            let error = common::relative_error(moments[(k, k)], expected[k]);
            assert!(
                error <= 1e-10,
                "E[q_{k}²] for {l:?}: {} vs {} ({error:e})",
                moments[(k, k)],
                expected[k]
            );
            worst_moment = worst_moment.max(error);
        }
    }
    eprintln!("Bingham: worst ln K error {worst_log:.1e}, worst moment error {worst_moment:.1e}");
}

/// Parameter matrices from the exported strategy: any orientation in SO(4), eigenvalues spread from 0 to
/// −30 (Monte Carlo over the uniform distribution needs bounded weights) or to −1e4 (for the laws that
/// do not integrate).
use liebayes_densities::testing::strategies::bingham;

fn uniform_quaternion(rng: &mut ChaCha8Rng) -> Su2<f64> {
    let v = Vector4::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
    let v = v / v.norm();
    Su2::from_quaternion_unchecked(Quaternion::new(v[0], v[1], v[2], v[3]))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// E_uniform[exp(qᵀMq)] = K by 40 000 uniform draws: relative standard error √(Var w)/(K √n) with
    /// w = exp(qᵀMq) ≤ 1, bounded by √(K⁻¹/n) (since E[w²] ≤ E[w]).
    #[test]
    fn normaliser_matches_monte_carlo(b in bingham(30.0), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 40_000;
        let shift = b.eigenvalues()[0];
        let mean = (0..n).map(|_| (b.log_pdf(&uniform_quaternion(&mut rng)) + b.log_normalizer() - shift).exp()).sum::<f64>() / f64::from(n);
        let k = (b.log_normalizer() - shift).exp();
        let tolerance = 5.0 * (1.0 / (k * f64::from(n))).sqrt();
        prop_assert!((mean / k - 1.0).abs() <= tolerance, "MC {mean} vs K {k}");
    }

    /// Samples of the ACG rejection sampler have the second moments given by the normaliser's gradient.
    #[test]
    fn samples_have_the_gradient_moments(b in bingham(1e3), seed in any::<u64>()) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 20_000;
        let mut scatter = Matrix4::zeros();
        let mut eigen = Vector4::zeros();
        for _ in 0..n {
            let [w, x, y, z] = b.sample(&mut rng).to_quaternion_wxyz();
            let q = Vector4::new(w, x, y, z);
            scatter += q * q.transpose();
            let u = b.orientation().transpose() * q;
            eigen += u.component_mul(&u);
        }
        let scatter = scatter / f64::from(n);
        // Each entry of q qᵀ lies in [−1, 1]: standard error ≤ 1/√n; 5 of them.
        let error = (scatter - b.second_moment()).amax();
        prop_assert!(error <= 5.0 / f64::from(n).sqrt(), "scatter error {error}");
        // Along the eigenvectors uₖ² ∈ [0, 1] has variance ≤ mₖ(1 − mₖ): a much sharper check where the
        // distribution is concentrated.
        for k in 0..4 {
            let m = b.eigen_moments()[k];
            let tolerance = 5.0 * (m * (1.0 - m) / f64::from(n)).sqrt() + 1e-12;
            let got = eigen[k] / f64::from(n);
            prop_assert!((got - m).abs() <= tolerance, "E[u_{k}²] = {got} vs {m} ± {tolerance}");
        }
    }

    #[test]
    fn product_kl_entropy_mode_symmetry_and_invariance(
        p in bingham(1e4), q in bingham(1e4), x in st::su2::<f64>(), g in st::su2::<f64>(),
    ) {
        let scale = 1.0 + p.eigenvalues().amax().abs() + q.eigenvalues().amax().abs() + p.eigenvalues()[3].abs() + q.eigenvalues()[3].abs();
        let tolerance = 1e-11 * scale;
        let pq = p.product(&q).unwrap();
        let lhs = p.log_pdf(&x) + q.log_pdf(&x) - p.log_product_integral(&q).unwrap();
        prop_assert!((lhs - pq.log_pdf(&x)).abs() <= tolerance, "{lhs} vs {}", pq.log_pdf(&x));
        prop_assert!(p.kl_divergence(&p).abs() <= tolerance);
        prop_assert!(p.kl_divergence(&q) >= -tolerance);
        prop_assert!((p.log_pdf(&x) - p.log_pdf(&x.antipode())).abs() <= tolerance, "antipodal symmetry");
        if let Some(m) = p.mode() {
            prop_assert!(p.log_pdf(&m) >= p.log_pdf(&x) - tolerance);
        }
        let r = p.rotated(&g);
        prop_assert!((r.log_pdf(&liebayes_manifolds::LieGroup::compose(&g, &x)) - p.log_pdf(&x)).abs() <= tolerance);
        prop_assert!((r.log_normalizer() - p.log_normalizer()).abs() <= tolerance);
        // Entropy = ln K − Σ z E[u²] ≤ ln(1) = 0 against the uniform probability measure.
        prop_assert!(p.entropy() <= tolerance);
    }
}

#[test]
fn bad_parameter_matrices_are_refused() {
    let mut m = Matrix4::identity();
    m[(0, 1)] = 0.5;
    assert!(
        Bingham::from_natural(m)
            .unwrap_err()
            .to_string()
            .contains("symmetric")
    );
    m[(1, 0)] = f64::NAN;
    assert!(Bingham::from_natural(m).is_err());
    assert!(Bingham::new(Matrix4::identity() * 2.0, Vector4::zeros()).is_err());
    // Uniform: no mode; entropy 0.
    let uniform = diagonal([0.0; 4]);
    assert!(uniform.mode().is_none());
    assert!(uniform.entropy().abs() < 1e-15);
}

/// At moderate concentration the envelope (an angular central Gaussian) and the Bingham differ most,
/// so a sampler that returns envelope draws too often shows here: 200 000 draws, 5 standard errors
/// (variance of uₖ² ≤ mₖ(1 − mₖ)).
#[test]
fn sampler_is_exact_at_moderate_concentration() {
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    for z in [
        [0.0, -1.0, -2.0, -3.0],
        [0.0, -3.0, -3.0, -8.0],
        [0.0, 0.0, -5.0, -5.0],
        [0.0, -0.5, -10.0, -20.0],
    ] {
        let b = diagonal(z);
        let n = 200_000;
        let mut sums = Vector4::zeros();
        for _ in 0..n {
            let [w, x, y, zz] = b.sample(&mut rng).to_quaternion_wxyz();
            sums += Vector4::new(w * w, x * x, y * y, zz * zz);
        }
        let moments = b.second_moment().diagonal();
        for k in 0..4 {
            let m = moments[k];
            let tolerance = 5.0 * (m * (1.0 - m) / f64::from(n)).sqrt();
            let got = sums[k] / f64::from(n);
            assert!(
                (got - m).abs() <= tolerance,
                "z {z:?}: E[q_{k}²] = {got} vs {m} ± {tolerance}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// The maximum-likelihood fit of a Bingham's own second-moment matrix returns that Bingham.
    #[test]
    fn fit_inverts_the_second_moments(b in bingham(3e3)) {
        let fitted = Bingham::from_second_moment(b.second_moment()).unwrap();
        let shift = b.eigenvalues()[0];
        for k in 1..4 {
            let (got, expected) = (fitted.eigenvalues()[k], b.eigenvalues()[k] - shift);
            prop_assert!((got - expected).abs() <= 1e-6 * (1.0 + expected.abs()), "z_{k}: {got} vs {expected}");
        }
        prop_assert!((fitted.second_moment() - b.second_moment()).amax() <= 1e-9);
    }
}

/// The normaliser and its gradient at spreads 1e3 to 1e12 against 60-digit values
/// (`tests/data/bingham_spread.json`, made by `tools/bingham_spread_reference.py`: the Bessel form
/// for the other pairing of the eigenvalues, {0, 2} and {1, 3}, by mpmath's adaptive quadrature,
/// the moments by central differences), seven shapes per spread: ln K within 1e-13 of
/// max(1, |ln K|), and every second moment, the smallest (about 1/(2 spread)) included, within
/// 1e-12 relative.
#[test]
fn matches_the_reference_up_to_the_largest_spread() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/bingham_spread.json"
    );
    let text = std::fs::read_to_string(path)
        .expect("tests/data/bingham_spread.json is part of the repository");
    let reference: serde_json::Value = text.parse().expect("valid JSON");
    let number = |v: &serde_json::Value| -> f64 { v.as_str().unwrap().parse().unwrap() };
    let (mut worst_log, mut worst_moment) = (0.0_f64, 0.0_f64);
    for case in reference["cases"].as_array().unwrap() {
        let z: Vec<f64> = case["z"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let z = [z[0], z[1], z[2], z[3]];
        let (log_k, moments) = special::bingham_log_normalizer_and_moments(&z).unwrap();
        let expected = number(&case["log_normalizer"]);
        let error = (log_k - expected).abs() / expected.abs().max(1.0);
        assert!(
            error <= 1e-13,
            "ln K at {z:?}: {log_k} vs {expected} ({error:e})"
        );
        worst_log = worst_log.max(error);
        for (k, m) in moments.iter().enumerate() {
            let expected = number(&case["moments"][k]);
            let error = common::relative_error(*m, expected);
            assert!(
                error <= 1e-12,
                "E[q_{k}²] at {z:?}: {m} vs {expected} ({error:e})"
            );
            worst_moment = worst_moment.max(error);
        }
    }
    println!("worst relative error: ln K {worst_log:.1e}, moments {worst_moment:.1e}");
}

/// The fit inverts the moments at every concentration up to the largest spread: for seven shapes
/// (one, two or three large gaps, a unit gap, two close middle eigenvalues, a generic set) at
/// spreads 1e3, 1e6, 1e9, 1e11 and 0.99e12 (a fit at exactly the largest spread, 1e12, may land a
/// rounding beyond it and be refused), the fit of the diagonal scatter `diag(E[uₖ²])` returns the
/// eigenvalues to 1e-10 relative, and its moments agree to 1e-10 relative (the small ones, about
/// 1/(2·spread), included).
#[test]
fn fit_inverts_the_moments_up_to_the_largest_spread() {
    for s in [1e3, 1e6, 1e9, 1e11, 0.99e12] {
        for l in [
            [-s, -s, -s],
            [0.0, 0.0, -s],
            [0.0, -s, -s],
            [-s / 3.0, -2.0 * s / 3.0, -s],
            [-1.0, -s / 2.0, -s],
            [-s * 1e-3, -s * 1e-3 - 1.0, -s],
            [-0.37 * s, -0.61 * s, -s],
        ] {
            let b = diagonal([0.0, l[0], l[1], l[2]]);
            let moments = b.eigen_moments();
            let fitted = Bingham::from_second_moment(Matrix4::from_diagonal(&moments)).unwrap();
            for k in 1..4 {
                let (got, expected) = (fitted.eigenvalues()[k], b.eigenvalues()[k]);
                assert!(
                    (got - expected).abs() <= 1e-10 * (1.0 + expected.abs()),
                    "spread {s:e}, {l:?}: z_{k} {got} vs {expected}"
                );
                let (got, expected) = (fitted.eigen_moments()[k], moments[k]);
                assert!(
                    common::relative_error(got, expected) <= 1e-10,
                    "spread {s:e}, {l:?}: E[u_{k}²] {got} vs {expected}"
                );
            }
        }
    }
}

#[test]
fn fit_refuses_degenerate_scatter() {
    let mut s = Matrix4::from_diagonal(&Vector4::new(0.5, 0.3, 0.2, 0.0));
    assert!(
        Bingham::from_second_moment(s)
            .unwrap_err()
            .to_string()
            .contains("infinite concentration")
    );
    s[(0, 0)] = f64::NAN;
    assert!(Bingham::from_second_moment(s).is_err());
    assert!(Bingham::from_second_moment(Matrix4::zeros()).is_err());
}
