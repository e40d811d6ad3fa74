//! The density law suite: the laws every family obeys, each a function usable on its own inside a
//! `proptest!` block, and all of them at once through [`density_laws!`](crate::density_laws).
//!
//! | law | function | needs |
//! |---|---|---|
//! | ∫ p = 1 against quadrature on the space | [`check_normalisation`] | [`Density`] |
//! | the mode is the maximum (over the quadrature nodes and the mode's neighbours) | [`check_mode`] | [`Density`] |
//! | the closed-form moments equal their quadrature | [`check_moments`] | [`Density`] |
//! | sample means equal the moments, within 5 standard errors of the sample size | [`check_sampler`] | [`Density`] |
//! | `ln p + ln q − ln ∫pq = ln (pq)` pointwise, `ln ∫pq` against quadrature, `pq = qp`, errors in step | [`check_product`] | [`Product`] |
//! | `KL(p‖p) = 0`, `KL ≥ 0`, KL against quadrature | [`check_kl`] | [`KlDivergence`] |
//! | entropy against quadrature | [`check_entropy`] | [`Entropy`] |
//! | `rotated(g)` is the density of `g · x` | [`check_rotated`] | [`Rotate`] |
//! | at the ends of the accepted range every quantity is finite | [`check_finite`] | [`Density`] |
//!
//! A family takes part by implementing [`DensitySubject`]: how to integrate over its space (nodes
//! from [`quadrature`](super::quadrature), placed where the density has its mass), which statistics
//! its sampler is checked on and their exact expectations, and the size of the terms its log density
//! sums, which rounding errors scale with.
//!
//! **Tolerances** are derived, never tuned: an integral against quadrature may differ by
//! [`QUADRATURE`] relative to the integral of the absolute integrand (the accuracy the rules are
//! built and tested for), plus rounding; an identity between log densities by
//! [`ROUNDING_ULPS`] units of rounding of the largest term summed (`ε (1 + scale)`); a sample mean by
//! [`STANDARD_ERRORS`] standard errors estimated from the sample's own variance.

use crate::{Density, Entropy, KlDivergence, Product, Rotate};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use rand::Rng;
use std::fmt::Debug;

/// Relative accuracy of the rules of [`quadrature`](super::quadrature) on the densities they are
/// placed for (tested in that module on closed forms).
pub const QUADRATURE: f64 = 1e-10;

/// Units of rounding `ε (1 + scale)` an identity between log densities may differ by: the terms
/// summed number a few dozen, each rounded.
pub const ROUNDING_ULPS: f64 = 64.0;

/// Standard errors a sample mean may lie from its expectation (a probability of 5.7e-7 per
/// statistic for a normal sample mean).
pub const STANDARD_ERRORS: f64 = 5.0;

/// Cases per law in [`density_laws!`](crate::density_laws), and for the sampler law, whose cases cost
/// [`SAMPLES`] draws each.
pub const CASES: u32 = 24;

/// Cases of the bad-input law per family (cheap: most raw numbers are refused at once).
pub const BAD_INPUT_CASES: u32 = 256;
/// Cases of the sampler law in [`density_laws!`](crate::density_laws).
pub const SAMPLER_CASES: u32 = 8;
/// Draws per case of the sampler law in [`density_laws!`](crate::density_laws).
pub const SAMPLES: u32 = 10_000;
/// The most draws [`check_sampler`] takes: 2²⁴ (16.8 M, 1678 times [`SAMPLES`]); beyond, its
/// standard errors are far below the rounding of the moments it compares, and the work (up to
/// 4.3e9 draws for `u32::MAX`, hours) would pass for a hang.
pub const MAX_SAMPLES: u32 = 1 << 24;
/// The seed of the sampler law's generator in [`density_laws!`](crate::density_laws) (a fixed seed:
/// the cases differ by their densities).
pub const SEED: u64 = 2026;

/// The generator of the sampler and finiteness laws in [`density_laws!`](crate::density_laws): a
/// `StdRng` seeded with [`SEED`].
pub fn rng() -> rand::rngs::StdRng {
    rand::SeedableRng::seed_from_u64(SEED)
}

/// What the law suite needs to know about a family beyond its traits.
pub trait DensitySubject: Density<Point: Debug> + Clone + Debug {
    /// Nodes and weights `(xᵢ, wᵢ)`, `∫ f dμ ≈ Σ wᵢ f(xᵢ)` against the family's base measure, placed
    /// where `self` has its mass and accurate to [`QUADRATURE`] for `self`, for densities of the
    /// family concentrated at least as much at the same place, and for smooth functions times them
    /// (the rules of [`quadrature`](super::quadrature)).
    fn quadrature(&self) -> Vec<(Self::Point, f64)>;

    /// Points near `x`, from about 1e-6 of the density's width to the width, in every direction of
    /// the space (for [`check_mode`]).
    fn neighbours(&self, x: &Self::Point) -> Vec<Self::Point>;

    /// The statistics `T(x)` the sampler law compares, each with a finite variance (for example
    /// `(cos θ, sin θ, cos 2θ, sin 2θ)` on the circle).
    fn statistics(&self, x: &Self::Point) -> Vec<f64>;

    /// `E[T(x)]` from the family's closed forms (the default sums the statistics over
    /// [`quadrature`](DensitySubject::quadrature), for families without them).
    fn exact_moments(&self) -> Vec<f64> {
        quadrature_moments(self)
    }

    /// The size of the largest term `log_pdf` sums near the density's mass and of its sensitivity to
    /// the rounding of a point's coordinates (κ for a von Mises, the eigenvalue spread for a Bingham,
    /// π²/(2s) for a heat kernel, `|x|/σ_min` for a Gaussian), which the rounding tolerances scale
    /// with.
    fn log_scale(&self) -> f64;

    /// The factor by which the relative rounding of `ln p(x)` grows with `|ln p(x)|` far from the mass:
    /// 1 (the default) where ln p is a sum of a few terms, `2 N cond(L)` for a Gaussian, whose
    /// Mahalanobis term is a triangular solve with the Cholesky factor L.
    fn log_condition(&self) -> f64 {
        1.0
    }

    /// The factor by which a relative perturbation ε of the density's parameters changes `ln p(x)`
    /// relative to its size: 1 (the default) for the families whose log density is a sum of a few
    /// terms; `cond(P) = λ_max/λ_min` for a Gaussian, since a Mahalanobis term `dᵀ P⁻¹ d` moves by
    /// `dᵀ P⁻¹ δP P⁻¹ d ≤ cond(P) ‖δP‖/‖P‖ · dᵀ P⁻¹ d`. The product law needs it: the product's
    /// parameters and `ln ∫pq` are computed from p's and q's (a sum of precisions, a solved mean),
    /// so they carry a relative rounding of a few ε, which this factor carries into the log
    /// densities that cancel.
    fn parameter_condition(&self) -> f64 {
        1.0
    }

    /// Nodes for `∫ p f(q)` with f a function of another density q of the family (the KL law); the
    /// default is [`quadrature`](DensitySubject::quadrature). A family whose log density is nearly
    /// singular somewhere (the heat kernel's at the cut locus of its centre, for small variances)
    /// places nodes that resolve `other` there too.
    fn pair_quadrature(&self, other: &Self) -> Vec<(Self::Point, f64)> {
        let _ = other;
        self.quadrature()
    }
}

/// `ROUNDING_ULPS · ε · condition · |value|`: the rounding of a log density of size `value`.
fn term_rounding(value: f64, condition: f64) -> f64 {
    ROUNDING_ULPS * f64::EPSILON * condition * value.abs()
}

/// `ε (1 + scale)` times [`ROUNDING_ULPS`].
pub fn rounding(scale: f64) -> f64 {
    ROUNDING_ULPS * f64::EPSILON * (1.0 + scale.abs())
}

/// `E[T]` by the density's own quadrature.
fn quadrature_moments<P: DensitySubject>(p: &P) -> Vec<f64> {
    let nodes = p.quadrature();
    let mut sums: Vec<f64> = Vec::new();
    for (x, w) in &nodes {
        let weight = w * p.log_pdf(x).exp();
        let t = p.statistics(x);
        if sums.is_empty() {
            sums = vec![0.0; t.len()];
        }
        for (s, v) in sums.iter_mut().zip(&t) {
            *s += weight * v;
        }
    }
    sums
}

/// `(∫ p, ∫ p |ln p|)` over the density's quadrature.
fn mass_and_log_magnitude<P: DensitySubject>(p: &P, nodes: &[(P::Point, f64)]) -> (f64, f64) {
    let (mut mass, mut magnitude) = (0.0, 0.0);
    for (x, w) in nodes {
        let l = p.log_pdf(x);
        let density = l.exp();
        if density > 0.0 {
            mass += w * density;
            magnitude += w * density * l.abs();
        }
    }
    (mass, magnitude)
}

/// **Normalisation**: `∫ p dμ = 1` against the family's quadrature, within
/// `QUADRATURE + rounding(log_scale + ∫ p |ln p|)`; `ln Z` and every node's log density finite (or
/// −∞ where the density underflows).
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_normalisation<P: DensitySubject>(p: &P) -> Result<(), TestCaseError> {
    prop_assert!(
        p.log_normalizer().is_finite(),
        "ln Z = {} for {p:?}",
        p.log_normalizer()
    );
    let nodes = p.quadrature();
    for (x, _) in &nodes {
        let l = p.log_pdf(x);
        prop_assert!(
            !l.is_nan() && l < f64::INFINITY,
            "ln p = {l} at {x:?} for {p:?}"
        );
    }
    let (mass, magnitude) = mass_and_log_magnitude(p, &nodes);
    let tolerance = QUADRATURE + rounding(p.log_scale() + magnitude);
    prop_assert!(
        (mass - 1.0).abs() <= tolerance,
        "∫ p = {mass} (error {:e}, tolerance {tolerance:e}) over {} nodes for {p:?}",
        mass - 1.0,
        nodes.len()
    );
    Ok(())
}

/// **Mode**: where [`Density::mode`] is `Some(m)`, `ln p(m) ≥ ln p(x) − rounding(log_scale + |ln p(m)|)`
/// for every quadrature node x and every neighbour of m.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_mode<P: DensitySubject>(p: &P) -> Result<(), TestCaseError> {
    let Some(m) = p.mode() else {
        return Ok(());
    };
    let at_mode = p.log_pdf(&m);
    prop_assert!(at_mode.is_finite(), "ln p(mode) = {at_mode} for {p:?}");
    let tolerance = rounding(p.log_scale()) + term_rounding(at_mode, p.log_condition());
    let nodes = p.quadrature();
    let neighbours = p.neighbours(&m);
    for x in nodes.iter().map(|(x, _)| x).chain(neighbours.iter()) {
        let l = p.log_pdf(x);
        prop_assert!(
            l <= at_mode + tolerance,
            "ln p = {l} at {x:?} exceeds ln p(mode) = {at_mode} at {m:?} by {:e} (tolerance \
             {tolerance:e}) for {p:?}",
            l - at_mode
        );
    }
    Ok(())
}

/// **Moments**: the closed-form [`DensitySubject::exact_moments`] equal the statistics integrated
/// against the density by quadrature, within `QUADRATURE ∫ p |T| + rounding`.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_moments<P: DensitySubject>(p: &P) -> Result<(), TestCaseError> {
    let exact = p.exact_moments();
    let nodes = p.quadrature();
    let (mut sums, mut magnitudes) = (vec![0.0; exact.len()], vec![0.0; exact.len()]);
    for (x, w) in &nodes {
        let weight = w * p.log_pdf(x).exp();
        let t = p.statistics(x);
        prop_assert_eq!(
            t.len(),
            exact.len(),
            "statistics and exact moments differ in length"
        );
        for k in 0..t.len() {
            sums[k] += weight * t[k];
            magnitudes[k] += weight * t[k].abs();
        }
    }
    for k in 0..exact.len() {
        let tolerance =
            QUADRATURE * (1.0 + magnitudes[k]) + rounding(p.log_scale()) * magnitudes[k];
        prop_assert!(
            (sums[k] - exact[k]).abs() <= tolerance,
            "moment {k}: quadrature {} vs exact {} (tolerance {tolerance:e}) for {p:?}",
            sums[k],
            exact[k]
        );
    }
    Ok(())
}

/// **Sampler**: the means of the statistics over `n` draws lie within [`STANDARD_ERRORS`] standard
/// errors (`√(σ²/n)`, σ² the larger of the sample variance and the variance by quadrature) of
/// [`DensitySubject::exact_moments`], plus `QUADRATURE` and
/// rounding for the moments themselves. Draws by [`Density::sample`] (so by the family's
/// `Distribution` too, which calls it).
///
/// # Errors
/// The law's failure, with the numbers; a failure naming n, before any draw, for n = 0 (no draw to
/// compare) and for n above [`MAX_SAMPLES`].
pub fn check_sampler<P: DensitySubject, R: Rng + ?Sized>(
    p: &P,
    rng: &mut R,
    n: u32,
) -> Result<(), TestCaseError> {
    prop_assert!(n > 0, "check_sampler needs at least one draw (n = 0)");
    prop_assert!(
        n <= MAX_SAMPLES,
        "check_sampler takes at most MAX_SAMPLES = 2^24 draws (n = {n})"
    );
    let exact = p.exact_moments();
    let (mut sums, mut squares) = (vec![0.0; exact.len()], vec![0.0; exact.len()]);
    for _ in 0..n {
        let x = p.sample(rng);
        let t = p.statistics(&x);
        prop_assert_eq!(
            t.len(),
            exact.len(),
            "statistics and exact moments differ in length"
        );
        // Centred at the exact moment, so that the variance keeps its digits.
        for k in 0..t.len() {
            let d = t[k] - exact[k];
            sums[k] += d;
            squares[k] += d * d;
        }
    }
    // The variance of each statistic by quadrature: a rare mode (a second mode of a bimodal
    // density, carrying 2e-5 of the mass) is often missing from the sample, whose own variance then
    // understates the spread by orders of magnitude; the larger of the two is used.
    let mut exact_variances = vec![0.0; exact.len()];
    for (x, w) in &p.quadrature() {
        let weight = w * p.log_pdf(x).exp();
        let t = p.statistics(x);
        prop_assert_eq!(
            t.len(),
            exact.len(),
            "statistics at a quadrature node and exact moments differ in length"
        );
        for (k, t) in t.iter().enumerate() {
            exact_variances[k] += weight * (t - exact[k]).powi(2);
        }
    }
    let count = f64::from(n);
    for k in 0..exact.len() {
        let offset = sums[k] / count;
        let variance = (squares[k] / count - offset * offset)
            .max(exact_variances[k])
            .max(0.0);
        let tolerance = STANDARD_ERRORS * (variance / count).sqrt()
            + QUADRATURE * (1.0 + exact[k].abs())
            + rounding(p.log_scale()) * exact[k].abs();
        prop_assert!(
            offset.abs() <= tolerance,
            "statistic {k}: sample mean {} vs exact {} (tolerance {tolerance:e}, {n} draws) for {p:?}",
            exact[k] + offset,
            exact[k]
        );
    }
    Ok(())
}

/// **Product**: `product` and `log_product_integral` fail together (in both orders); where they
/// succeed, at every quadrature node x of pq, `ln p(x) + ln q(x) − ln ∫pq = ln (pq)(x)` and
/// `ln (pq)(x) = ln (qp)(x)` within the rounding of the terms, `ln ∫pq = ln ∫qp`, and `ln ∫pq`
/// equals `ln Σ wᵢ p(xᵢ) q(xᵢ)` within `QUADRATURE + rounding`.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_product<P: DensitySubject + Product>(p: &P, q: &P) -> Result<(), TestCaseError> {
    let (pq, qp) = (p.product(q), q.product(p));
    let (lpq, lqp) = (p.log_product_integral(q), q.log_product_integral(p));
    prop_assert_eq!(
        pq.is_ok(),
        lpq.is_ok(),
        "product and its integral disagree on failing"
    );
    prop_assert_eq!(pq.is_ok(), qp.is_ok(), "p q and q p disagree on failing");
    prop_assert_eq!(
        lpq.is_ok(),
        lqp.is_ok(),
        "ln ∫pq and ln ∫qp disagree on failing"
    );
    let (Ok(pq), Ok(qp), Ok(lpq), Ok(lqp)) = (pq, qp, lpq, lqp) else {
        return Ok(());
    };
    prop_assert!(lpq.is_finite(), "ln ∫pq = {lpq}");
    let scale = p.log_scale() + q.log_scale() + pq.log_scale() + lpq.abs();
    // The rounding of the product's computed parameters (and of ln ∫pq's), carried into the log
    // densities whose difference is checked: its size is that of the terms that cancel, |ln ∫pq|.
    let combined = p
        .parameter_condition()
        .max(q.parameter_condition())
        .max(pq.parameter_condition());
    prop_assert!(
        (lpq - lqp).abs() <= rounding(scale),
        "ln ∫pq = {lpq} but ln ∫qp = {lqp}"
    );
    let nodes = pq.quadrature();
    for (x, _) in &nodes {
        let (lp, lq, l) = (p.log_pdf(x), q.log_pdf(x), pq.log_pdf(x));
        if lp == f64::NEG_INFINITY || lq == f64::NEG_INFINITY {
            prop_assert_eq!(
                l,
                f64::NEG_INFINITY,
                "p q vanishes at {:?} but (pq) does not",
                x
            );
            continue;
        }
        let tolerance = rounding(scale)
            + term_rounding(lp, p.log_condition())
            + term_rounding(lq, q.log_condition())
            + term_rounding(lpq, p.log_condition().max(q.log_condition()))
            + term_rounding(l, pq.log_condition().max(qp.log_condition()))
            + term_rounding(lpq, combined);
        prop_assert!(
            (lp + lq - lpq - l).abs() <= tolerance,
            "ln p + ln q − ln ∫pq = {} but ln (pq) = {l} at {x:?} (tolerance {tolerance:e})",
            lp + lq - lpq
        );
        let l_other = qp.log_pdf(x);
        prop_assert!(
            (l - l_other).abs() <= tolerance,
            "ln (pq) = {l} but ln (qp) = {l_other} at {x:?}"
        );
    }
    let quadrature = super::quadrature::log_integral(&nodes, |x| p.log_pdf(x) + q.log_pdf(x));
    let (_, magnitude) = mass_and_log_magnitude(&pq, &nodes);
    // ln ∫pq is itself a log density (a Mahalanobis term for Gaussians): its rounding grows with its
    // size times the condition of the factor it is solved with.
    let tolerance = QUADRATURE
        + rounding(scale + magnitude)
        + term_rounding(lpq, p.log_condition().max(q.log_condition()))
        + term_rounding(lpq, combined);
    prop_assert!(
        (quadrature - lpq).abs() <= tolerance,
        "ln ∫pq = {lpq} but quadrature gives {quadrature} (tolerance {tolerance:e}) for {p:?} and \
         {q:?}"
    );
    Ok(())
}

/// `(Σ w p (ln p − ln q), Σ w p |ln p − ln q|)` over p's quadrature.
fn quadrature_kl<P: DensitySubject>(p: &P, q: &P, nodes: &[(P::Point, f64)]) -> (f64, f64) {
    let (mut kl, mut magnitude) = (0.0, 0.0);
    for (x, w) in nodes {
        let lp = p.log_pdf(x);
        let density = lp.exp();
        if density > 0.0 {
            let d = lp - q.log_pdf(x);
            kl += w * density * d;
            magnitude += w * density * d.abs();
        }
    }
    (kl, magnitude)
}

/// **Kullback-Leibler**: `KL(p‖p) = 0` within the rounding of p's terms, `KL(p‖q) ≥ −rounding`, and
/// `KL(p‖q)` equal to `Σ wᵢ p(xᵢ) (ln p(xᵢ) − ln q(xᵢ))` over p's quadrature within
/// `QUADRATURE (1 + ∫ p |ln p − ln q|) + rounding`.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_kl<P: DensitySubject + KlDivergence>(p: &P, q: &P) -> Result<(), TestCaseError> {
    let own = p.kl_divergence(p);
    prop_assert!(
        own.abs() <= rounding(p.log_scale()),
        "KL(p‖p) = {own} for {p:?}"
    );
    let kl = p.kl_divergence(q);
    prop_assert!(kl.is_finite(), "KL(p‖q) = {kl}");
    let nodes = p.pair_quadrature(q);
    let (quadrature, magnitude) = quadrature_kl(p, q, &nodes);
    let scale =
        p.log_scale() + q.log_scale() + magnitude * p.log_condition().max(q.log_condition());
    prop_assert!(
        kl >= -rounding(scale),
        "KL(p‖q) = {kl} < 0 for {p:?} and {q:?}"
    );
    let tolerance = QUADRATURE * (1.0 + magnitude) + rounding(scale);
    prop_assert!(
        (kl - quadrature).abs() <= tolerance,
        "KL(p‖q) = {kl} but quadrature gives {quadrature} (tolerance {tolerance:e}) for {p:?} and \
         {q:?}"
    );
    Ok(())
}

/// **Entropy**: `−∫ p ln p` against quadrature, within `QUADRATURE (1 + ∫ p |ln p|) + rounding`.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_entropy<P: DensitySubject + Entropy>(p: &P) -> Result<(), TestCaseError> {
    let entropy = p.entropy();
    prop_assert!(entropy.is_finite(), "H = {entropy} for {p:?}");
    let nodes = p.quadrature();
    let (mut quadrature, mut magnitude) = (0.0, 0.0);
    for (x, w) in &nodes {
        let l = p.log_pdf(x);
        let density = l.exp();
        if density > 0.0 {
            quadrature -= w * density * l;
            magnitude += w * density * l.abs();
        }
    }
    let tolerance = QUADRATURE * (1.0 + magnitude) + rounding(p.log_scale() + magnitude);
    prop_assert!(
        (entropy - quadrature).abs() <= tolerance,
        "H = {entropy} but quadrature gives {quadrature} (tolerance {tolerance:e}) for {p:?}"
    );
    Ok(())
}

/// **Rotation**: `rotated(g).log_pdf(act(g, x)) = log_pdf(x)` at every quadrature node x, within the
/// rounding of the terms; `ln Z` unchanged. The strategies' subjects and rotations are in range, so
/// an error from `rotated` fails the law.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_rotated<G: Debug, P: DensitySubject + Rotate<G>>(
    p: &P,
    g: &G,
) -> Result<(), TestCaseError> {
    let r = p
        .rotated(g)
        .map_err(|e| TestCaseError::fail(format!("rotated by {g:?} failed: {e}")))?;
    let scale = p.log_scale() + r.log_scale();
    prop_assert!(
        (r.log_normalizer() - p.log_normalizer()).abs() <= rounding(scale + p.log_normalizer()),
        "ln Z changes from {} to {} under {g:?}",
        p.log_normalizer(),
        r.log_normalizer()
    );
    for (x, _) in &p.quadrature() {
        let (before, after) = (p.log_pdf(x), r.log_pdf(&P::act(g, x)));
        let tolerance = rounding(scale) + term_rounding(before, p.log_condition());
        prop_assert!(
            (after - before).abs() <= tolerance,
            "ln p(x) = {before} but ln (g p)(g x) = {after} at {x:?} for {g:?} (tolerance \
             {tolerance:e})"
        );
    }
    Ok(())
}

/// **Finite at the ends of the range** (for the extreme strategies, where quadrature cannot resolve
/// the density): `ln Z`, `ln p` at the mode and at 16 draws are finite (or −∞ where the density
/// underflows away from the mode), and so are the draws' statistics.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_finite<P: DensitySubject, R: Rng + ?Sized>(
    p: &P,
    rng: &mut R,
) -> Result<(), TestCaseError> {
    prop_assert!(
        p.log_normalizer().is_finite(),
        "ln Z = {} for {p:?}",
        p.log_normalizer()
    );
    if let Some(m) = p.mode() {
        let l = p.log_pdf(&m);
        prop_assert!(l.is_finite(), "ln p(mode) = {l} for {p:?}");
    }
    for _ in 0..16 {
        let x = p.sample(rng);
        let l = p.log_pdf(&x);
        prop_assert!(
            !l.is_nan() && l < f64::INFINITY,
            "ln p = {l} at the draw {x:?} for {p:?}"
        );
        for t in p.statistics(&x) {
            prop_assert!(t.is_finite(), "statistic {t} at the draw {x:?} for {p:?}");
        }
    }
    Ok(())
}

/// **Bad input** (for a constructor fed raw numbers of every magnitude, NaN and ±∞ among them, by
/// the `_raw` strategies): it refuses them with a typed error whose message says what is wrong, or
/// returns a density that is [finite](check_finite) (ln Z, ln p at the mode and at draws, the
/// draws' statistics). Never a panic, never a NaN.
///
/// # Errors
/// The law's failure, with the numbers.
pub fn check_bad_input<P: DensitySubject, E: std::fmt::Display, R: Rng + ?Sized>(
    built: &Result<P, E>,
    rng: &mut R,
) -> Result<(), TestCaseError> {
    match built {
        Err(e) => {
            prop_assert!(!e.to_string().is_empty(), "an error without a message");
            Ok(())
        }
        Ok(p) => check_finite(p, rng),
    }
}
