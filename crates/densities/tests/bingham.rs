//! Bingham on S³ against the reference vectors `bingham_vectors.json` (normaliser in both conventions and
//! second moments, eigenvalues 0 to −1e4) and `bingham_spread_vectors.json` (eigenvalue spreads 1 to
//! 1e12), and its laws: normalisation by Monte Carlo over the uniform distribution (independent of the
//! quadrature), product, sample moments from the ACG sampler against the normaliser's gradient, KL,
//! entropy, mode, antipodal symmetry and rotation invariance.

mod common;

use liebayes_densities::{
    Bingham, Density, DensityError, Entropy, KlDivergence, Product, Rotate, special,
};
use liebayes_manifolds::Su2;
use liebayes_manifolds::testing::strategies as st;
use nalgebra::{Matrix4, Quaternion, Vector4};
use proptest::prelude::*;
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::collections::BTreeMap;

fn diagonal(z: [f64; 4]) -> Bingham {
    Bingham::from_natural(Matrix4::from_diagonal(&Vector4::from(z))).unwrap()
}

/// One case of a Bingham reference file in `crates/reference/data`.
struct ReferenceCase {
    /// The eigenvalues (0, l₁, l₂, l₃) of a diagonal parameter matrix (the file's `lambdas` after the 0).
    z: [f64; 4],
    /// `logK_unif`: ln E_(q ~ uniform(S³))[exp(Σₖ zₖ qₖ²)].
    log_k: f64,
    /// `logK_raw`, the same against the surface measure (= `logK_unif` + ln 2π²), where the file has it.
    log_k_surface: Option<f64>,
    /// `second_moments`: E[qₖ²] along the axes of z, in the order of z.
    moments: [f64; 4],
}

impl ReferenceCase {
    fn spread(&self) -> f64 {
        let max = self.z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = self.z.iter().copied().fold(f64::INFINITY, f64::min);
        max - min
    }
}

/// A reference number: a JSON number (`bingham_vectors.json` stores f64s) or a decimal string
/// (`bingham_spread_vectors.json`, 30 significant digits), parsed by Rust's correctly rounded
/// `str::parse`, so that the value compared with is the reference rounded once.
fn reference_number(value: &common::Value) -> f64 {
    value.as_f64().unwrap_or_else(|| {
        let text = value.as_str().expect("a number or a decimal string");
        text.parse().unwrap_or_else(|e| panic!("{text}: {e}"))
    })
}

fn reference_cases(file: &str) -> Vec<ReferenceCase> {
    common::reference(file)["cases"]
        .as_array()
        .unwrap()
        .iter()
        .map(|case| {
            let l = common::numbers(&case["lambdas"]);
            let moments: Vec<f64> = case["second_moments"]
                .as_array()
                .unwrap()
                .iter()
                .map(reference_number)
                .collect();
            ReferenceCase {
                z: [0.0, l[0], l[1], l[2]],
                log_k: reference_number(&case["logK_unif"]),
                log_k_surface: case.get("logK_raw").map(reference_number),
                moments: [moments[0], moments[1], moments[2], moments[3]],
            }
        })
        .collect()
}

/// Both ways in refuse eigenvalues whose spread exceeds `Bingham::MAX_SPREAD`, with the documented
/// range error.
fn assert_refused(z: &[f64; 4]) {
    let built = Bingham::from_natural(Matrix4::from_diagonal(&Vector4::from(*z))).map(|_| ());
    let direct = special::bingham_log_normalizer_and_moments(z).map(|_| ());
    for result in [built, direct] {
        assert!(
            matches!(result, Err(DensityError::OutOfRange { what, .. }) if what.contains("spread")),
            "{z:?} (spread beyond {:e}) must be refused as out of range: {result:?}",
            Bingham::MAX_SPREAD
        );
    }
}

/// Bounds of the reference checks, 10 to 15 times the worst errors measured (2026-12-04) over both
/// files and both ways in: ln K 1.3e-15 (`bingham_vectors.json`, spread 1e3; 4.4e-16 in
/// `bingham_spread_vectors.json`, spread 1), second moments 2.8e-15 (`bingham_spread_vectors.json`,
/// spread 1e10; 1.7e-15 in `bingham_vectors.json`). The references are good to far beyond f64
/// (`bingham_vectors.json` holds the f64 roundings of 30- to 40-digit values, which the 60-digit
/// computation behind `bingham_spread_vectors.json` reproduces to 1.0e-16), so these are the
/// library's own errors, and the margin is for other platforms' `exp` and `ln`.
const LOG_K_BOUND: f64 = 2e-14;
const MOMENT_BOUND: f64 = 3e-14;

/// ⌊log₁₀ spread⌋, `i32::MIN` for spread 0.
#[allow(clippy::cast_possible_truncation)] // a finite spread ≤ 1e300 has a decade within ±330
fn decade(spread: f64) -> i32 {
    if spread > 0.0 {
        spread.log10().floor() as i32
    } else {
        i32::MIN
    }
}

/// The largest errors of one spread decade: (cases, ln K, second moments).
type DecadeWorst = (usize, f64, f64);

/// Checks the library against every case of the reference file `file`, through both ways in: the
/// `Bingham` of the diagonal parameter matrix diag(z) (`Density::log_normalizer`,
/// `log_normalizer_surface` and the diagonal of `second_moment`, which is in the axes of z because
/// the eigenvectors of a diagonal matrix are the axes) and `special::bingham_log_normalizer_and_moments(z)`
/// (z as given, unsorted in some cases).
///
/// Conventions. `logK_unif` is ln E_uniform[exp(Σ zₖ qₖ²)] with the uniform *probability* measure on
/// S³, which is the library's convention for `ln K` (its density is against that measure), so the two
/// are compared as they stand: no constant is added, and no shift either, because the largest
/// eigenvalue of every case is 0 (the library's `ln K` is z_max plus the normaliser of z − z_max).
/// `logK_raw`, against the surface measure, is compared with `log_normalizer_surface`, which adds
/// ln 2π² (= ln |S³|) in f64.
///
/// Errors: ln K as |Δ ln K| / max(1, |ln K|) (the relative error of K itself where |ln K| ≤ 1), each
/// second moment relative, the smallest (about 1/(2·spread)) included. Cases whose spread exceeds
/// `Bingham::MAX_SPREAD` must be refused with the documented range error. Returns the worst errors
/// per decade of the spread (keyed by [`decade`]) and the number of cases checked to be refused.
fn check_against_reference(
    file: &str,
    log_bound: f64,
    moment_bound: f64,
) -> (BTreeMap<i32, DecadeWorst>, usize) {
    let cases = reference_cases(file);
    assert!(!cases.is_empty(), "{file} has no cases");
    let mut worst = BTreeMap::<i32, DecadeWorst>::new();
    let mut refused = 0;
    for case in &cases {
        let z = case.z;
        let spread = case.spread();
        if spread > Bingham::MAX_SPREAD {
            assert_refused(&z);
            refused += 1;
            continue;
        }
        let b = Bingham::from_natural(Matrix4::from_diagonal(&Vector4::from(z)))
            .unwrap_or_else(|e| panic!("{file}: {z:?}: {e}"));
        let (direct_log_k, direct_moments) = special::bingham_log_normalizer_and_moments(&z)
            .unwrap_or_else(|e| panic!("{file}: {z:?}: {e}"));
        let second = b.second_moment();
        let mut logs = vec![
            ("ln K (Bingham)", b.log_normalizer(), case.log_k),
            ("ln K (special)", direct_log_k, case.log_k),
        ];
        if let Some(surface) = case.log_k_surface {
            logs.push(("ln K surface", b.log_normalizer_surface(), surface));
        }
        let entry = worst.entry(decade(spread)).or_insert((0, 0.0, 0.0));
        entry.0 += 1;
        for (what, got, expected) in logs {
            let error = (got - expected).abs() / expected.abs().max(1.0);
            assert!(
                error <= log_bound,
                "{file}: {what} at {z:?}: {got} vs {expected} ({error:.1e} > {log_bound:e})"
            );
            entry.1 = entry.1.max(error);
        }
        for k in 0..4 {
            for (what, got) in [("Bingham", second[(k, k)]), ("special", direct_moments[k])] {
                let expected = case.moments[k];
                let error = common::relative_error(got, expected);
                assert!(
                    error <= moment_bound,
                    "{file}: E[q_{k}²] ({what}) at {z:?}: {got} vs {expected} ({error:.1e} > {moment_bound:e})"
                );
                entry.2 = entry.2.max(error);
            }
        }
    }
    for (decade, (n, log_k, moment)) in &worst {
        let decade = if *decade == i32::MIN {
            "0".to_string()
        } else {
            format!("1e{decade}")
        };
        println!(
            "{file}: spread {decade:>5} ({n:2} cases): ln K {log_k:.1e}, moments {moment:.1e}"
        );
    }
    (worst, refused)
}

/// Against the reviewers' reference vectors `bingham_vectors.json` (28 cases, eigenvalues 0 to −1e4,
/// stored as f64, both conventions of ln K).
#[test]
fn matches_the_reference_vectors() {
    let (worst, refused) =
        check_against_reference("bingham_vectors.json", LOG_K_BOUND, MOMENT_BOUND);
    assert_eq!(worst.values().map(|w| w.0).sum::<usize>(), 28);
    assert_eq!(refused, 0);
}

/// The normaliser and its gradient at eigenvalue spreads 1 to 1e12 against
/// `bingham_spread_vectors.json` (56 cases: seven shapes, ties included, at spreads 1, 10, 1e3,
/// 1e6, 1e8, 1e9, 1e10 and 1e12; 30 significant digits from an inverse Laplace transform on a
/// Talbot contour, independent of the library's Bessel form, each case cross-checked to 1e-52 by at
/// least two other methods; made by `crates/densities/tools/bingham_spread_reference.py`).
#[test]
fn matches_the_reference_up_to_the_largest_spread() {
    let file = "bingham_spread_vectors.json";
    let (worst, refused) = check_against_reference(file, LOG_K_BOUND, MOMENT_BOUND);
    // Every case lies within the accepted range (the largest spread, 1e12, is the limit itself).
    assert_eq!(
        (worst.values().map(|w| w.0).sum::<usize>(), refused),
        (56, 0)
    );
    assert_eq!(worst.keys().max(), Some(&12));
    // The file ends at the limit; its shapes stretched just past it are refused.
    let at_limit: Vec<_> = reference_cases(file)
        .into_iter()
        .filter(|case| case.spread() == Bingham::MAX_SPREAD)
        .collect();
    assert_eq!(at_limit.len(), 7);
    for case in at_limit {
        assert_refused(&case.z.map(|v| v * (1.0 + 1e-6)));
    }
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
        let r = p.rotated(&g).unwrap();
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

/// An orthogonal 4×4 matrix: left multiplication by a unit quaternion.
fn left_multiplication(q: [f64; 4]) -> nalgebra::Matrix4<f64> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let [w, x, y, z] = q.map(|v| v / n);
    nalgebra::Matrix4::new(w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w)
}

/// Only differences of eigenvalues matter, but the product eigendecomposed `M₁ + M₂` itself: with a
/// common eigenvalue of 1e15 the gaps (2, 6, 20) of p·p came out (3.25, 7, 20.5), and the log
/// integral lost its digits. And the unique-mode test was relative to |z₀|, so (1e12, 1e12 − 10, …)
/// had no mode (the moment matches refused it) while (0, −10, …) did. Both are now shift-free.
#[test]
fn a_common_eigenvalue_shift_changes_nothing() {
    use liebayes_densities::{Bingham, Product};
    let v = left_multiplication([0.3, -0.5, 0.7, 0.41]);
    let at =
        |c: f64| Bingham::new(v, nalgebra::Vector4::new(c, c - 1.0, c - 3.0, c - 10.0)).unwrap();
    let unshifted = at(0.0);
    let reference = unshifted.log_product_integral(&unshifted).unwrap();
    for c in [1e6, 1e12, 1e15] {
        let p = at(c);
        let product = p.product(&p).unwrap();
        let z = product.eigenvalues();
        for (k, want) in [(1, -2.0), (2, -6.0), (3, -20.0)] {
            // The gaps to rounding of the shift-free sum (entries of size 20), not of 2c.
            assert!((z[k] - z[0] - want).abs() < 1e-12, "c = {c:e}: {z:?}");
        }
        let integral = p.log_product_integral(&p).unwrap();
        assert!(
            (integral - reference).abs() < 1e-12,
            "c = {c:e}: {integral} vs {reference}"
        );
    }
    let peaked = |c: f64| {
        Bingham::new(
            nalgebra::Matrix4::identity(),
            nalgebra::Vector4::new(c, c - 10.0, c - 10.0, c - 10.0),
        )
        .unwrap()
    };
    let reference = peaked(0.0).to_heat_kernel_moment_matched().unwrap();
    let shifted = peaked(1e12).to_heat_kernel_moment_matched().unwrap();
    assert!((shifted.variance() / reference.variance() - 1.0).abs() < 1e-12);
}

/// A gap of 10 between the two largest eigenvalues beside a spread of 1e12 is a unique mode (a
/// tolerance of 1e-10 of the spread took it for a repeated eigenvalue); a gap of 0 is not.
#[test]
fn a_small_gap_beside_a_large_spread_is_a_mode() {
    use liebayes_densities::{Bingham, Density};
    let at = |gap: f64| {
        Bingham::new(Matrix4::identity(), Vector4::new(0.0, -gap, -1e12, -1e12)).unwrap()
    };
    let mode = at(10.0).mode().expect("a unique mode");
    assert!((mode.to_quaternion_wxyz()[0] - 1.0).abs() < 1e-15);
    assert!(at(0.0).mode().is_none());
}
