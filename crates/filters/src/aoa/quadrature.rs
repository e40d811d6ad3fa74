//! The exact posterior of one angle-of-arrival update, by deterministic quadrature: the reference
//! the Gaussian filters and the particle filters are measured against (the paper's Sec. 4.2
//! example).
//!
//! **The reduction.** A prior `θ ~ N(m, P)` in R³ and one reading of an anchor at s whose likelihood
//! depends on θ only through the direction `ω = (θ − s)/|θ − s|` (true of both noise models, von
//! Mises-Fisher and azimuth-elevation). With `θ = s + r ω`, `dθ = r² dr dω`,
//!
//! `p(θ | y) ∝ L(ω) N(s + r ω; m, P)`,
//! `E[θ | y] = s + ∫ L(ω) ω M₃(ω) dω / ∫ L(ω) M₂(ω) dω`,
//! `E[(θ − s)(θ − s)ᵀ | y] = ∫ L(ω) ω ωᵀ M₄(ω) dω / ∫ L(ω) M₂(ω) dω`,
//!
//! with the radial moments `M_k(ω) = ∫₀^∞ r^k N(s + r ω; m, P) dr` in closed form
//! ([`log_radial_moments`]). What is left is an integral over the sphere, done by the densities'
//! rule centred on the measured direction ([`SphereRule`]).

use super::anchor::Anchor;
use super::estimate::PositionEstimate;
use super::filter::PositionGaussian;
use liebayes_densities::quadrature::SphereRule;
use liebayes_densities::special::normal_cdf;
use liebayes_manifolds::S2;
use liebayes_operators::OperatorError;
use nalgebra::{Cholesky, Matrix3, Vector3};
use std::f64::consts::TAU;

/// The largest distance of the prior mean from the anchor, in prior standard deviations
/// (`|m − s| / √λ_max(P)`), and the largest condition number of P: beyond them the radial moments
/// leave the range where they are computed in full precision (and the direction is then fixed by the
/// prior alone).
pub const PRIOR_LIMIT: f64 = 1e8;

/// Terms of the continued fraction of the scaled radial integrals (converged to 1e-14 for
/// `w ≥ 2`).
const FRACTION_DEPTH: usize = 160;

/// Below this `z` the radial integrals are taken from the continued fraction.
const FRACTION_BELOW: f64 = -2.0;

/// `ln M_k(ω)` for k = 2, 3, 4, the radial moments of the prior along the ray `s + r ω`:
///
/// `M_k(ω) = ∫₀^∞ r^k N(s + r ω; m, P) dr`, the exponent `−(a r² − 2 b r + c)/2` with
/// `a = ωᵀP⁻¹ω`, `b = ωᵀP⁻¹(m − s)`, `c = (m − s)ᵀP⁻¹(m − s)`. Completing the square
/// (`μ = b/a`, `z = b/√a`, `q = c − z² ≥ 0` the P-distance² of m from the ray's line) and
/// substituting `r = (x + z)/√a`:
///
/// `M_k = (2π)^{−3/2} |P|^{−1/2} e^{−q/2} a^{−(k+1)/2} J_k(z)`,
/// `J_k(z) = ∫_{−z}^∞ (x + z)^k e^{−x²/2} dx = √(2π) [P_k(z) Φ(z) + Q_k(z) φ(z)]`,
///
/// with Φ, φ the standard normal CDF and density and (from the recurrence
/// `k h_k = h_{k−2} + z h_{k−1}` of `h_k = J_k/(√(2π) k!)`, `h_{−1} = φ`, `h_0 = Φ`)
///
/// | k | P_k | Q_k |
/// |---|---|---|
/// | 2 | z² + 1 | z |
/// | 3 | z³ + 3z | z² + 2 |
/// | 4 | z⁴ + 6z² + 3 | z³ + 5z |
///
/// For `z ≥ −2` the bracket is summed as written (all terms positive for z ≥ 0; at most two digits
/// cancel at z = −2). For `z < −2` (rays pointing away from the prior mean) it cancels, and
/// `J_k = e^{−z²/2} E_k(w)`, `w = −z`, `E_k(w) = ∫₀^∞ y^k e^{−wy − y²/2} dy = k! ∏_{n=0}^{k} ρ_n`
/// with the ratios from the continued fraction `ρ_n = 1/(w + (n+1) ρ_{n+1})` evaluated from depth
/// [`FRACTION_DEPTH`] down (all terms positive: no cancellation); then `e^{−q/2} J_k =
/// e^{−c/2} E_k`. Everything is in logs: valid for any finite `a > 0`, `z`, `q ≥ 0`.
///
/// Takes `ln |P|^{−1/2} (2π)^{−3/2}` as `log_normalizer`.
fn log_radial_moments(a: f64, z: f64, q: f64, log_normalizer: f64) -> [f64; 3] {
    let ln_a = a.ln();
    let base = |k: f64| log_normalizer - 0.5 * (k + 1.0) * ln_a;
    if z >= FRACTION_BELOW {
        let (cdf, density) = (normal_cdf(z), (-0.5 * z * z).exp() / TAU.sqrt());
        let z2 = z * z;
        let j2 = (z2 + 1.0) * cdf + z * density;
        let j3 = (z2 + 3.0) * z * cdf + (z2 + 2.0) * density;
        let j4 = (z2 * z2 + 6.0 * z2 + 3.0) * cdf + (z2 + 5.0) * z * density;
        let common = 0.5 * TAU.ln() - 0.5 * q;
        [
            base(2.0) + common + j2.ln(),
            base(3.0) + common + j3.ln(),
            base(4.0) + common + j4.ln(),
        ]
    } else {
        let w = -z;
        let mut rho = [0.0; 5];
        let mut tail = 0.0;
        for n in (0..FRACTION_DEPTH).rev() {
            tail = 1.0 / (w + (n + 1) as f64 * tail);
            if n < 5 {
                rho[n] = tail;
            }
        }
        let ln_e = |k: usize, factorial: f64| {
            factorial.ln() + rho[..=k].iter().map(|r| r.ln()).sum::<f64>()
        };
        let common = -0.5 * (q + z * z);
        [
            base(2.0) + common + ln_e(2, 2.0),
            base(3.0) + common + ln_e(3, 6.0),
            base(4.0) + common + ln_e(4, 24.0),
        ]
    }
}

/// The prior in units of its largest standard deviation (so that every quantity of the radial
/// moments stays far from overflow), seen from the anchor.
struct ScaledPrior {
    /// The unit: `√λ_max(P)`.
    unit: f64,
    /// `(m − s)/unit`.
    offset: Vector3<f64>,
    /// The scaled precision `unit² P⁻¹`.
    precision: Matrix3<f64>,
    /// `precision · offset`.
    pulled: Vector3<f64>,
    /// `offsetᵀ precision offset` (the c of the radial exponent).
    c: f64,
    /// `ln[(2π)^{−3/2} |P/unit²|^{−1/2}]`.
    log_normalizer: f64,
}

impl ScaledPrior {
    fn new(prior: &PositionGaussian, anchor: &Anchor) -> Result<Self, OperatorError> {
        let covariance = *prior.covariance();
        // A bounded iteration (nalgebra's `symmetric_eigenvalues` has no limit); NaN when it does
        // not converge, refused below.
        let (largest, smallest) = nalgebra::SymmetricEigen::try_new(covariance, f64::EPSILON, 1000)
            .map_or((f64::NAN, f64::NAN), |e| {
                (e.eigenvalues.max(), e.eigenvalues.min())
            });
        let conditioned = largest > 0.0 && smallest > 0.0 && largest <= PRIOR_LIMIT * smallest;
        if !conditioned {
            return Err(OperatorError::OutOfRange {
                what: "condition number of the prior covariance",
                value: largest / smallest,
                range: "at most 1e8",
            });
        }
        let unit = largest.sqrt();
        let offset = (prior.mean().coords() - anchor.position()) / unit;
        let distance = offset.norm();
        if distance.is_nan() || distance > PRIOR_LIMIT {
            return Err(OperatorError::OutOfRange {
                what: "distance of the prior mean from the anchor (prior standard deviations)",
                value: distance,
                range: "at most 1e8",
            });
        }
        let cholesky =
            Cholesky::new(covariance / largest).ok_or(OperatorError::NotPositiveDefinite {
                what: "prior covariance (in the exact single-update posterior)",
            })?;
        let precision: Matrix3<f64> = cholesky.inverse();
        let log_normalizer =
            -1.5 * TAU.ln() - cholesky.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        let pulled = precision * offset;
        Ok(Self {
            unit,
            offset,
            precision,
            pulled,
            c: offset.dot(&pulled),
            log_normalizer,
        })
    }

    /// `ln M_k(ω)`, k = 2, 3, 4 (scaled units), for the unit vector ω.
    fn log_radial_moments(&self, omega: &Vector3<f64>) -> [f64; 3] {
        let a = omega.dot(&(self.precision * omega));
        let b = omega.dot(&self.pulled);
        // q = |m − s − μω|²_P, from the vector itself: ≥ 0, no cancellation of c − b²/a.
        let e = self.offset - omega * (b / a);
        let q = e.dot(&(self.precision * e)).max(0.0).min(self.c);
        log_radial_moments(a, b / a.sqrt(), q, self.log_normalizer)
    }
}

/// The fewest effective nodes `(Σ w)² / Σ w²` (w the posterior weights) on which
/// [`exact_posterior`] rests its moments: with fewer the angular spread is not resolved.
pub const MIN_EFFECTIVE_NODES: f64 = 4.0;

/// The exact posterior mean and covariance of the position after one reading of `anchor`, for the
/// Gaussian prior `prior` = N(m, P) and a likelihood that depends on the position θ only through
/// its direction from the anchor: `log_likelihood(ω)` is `ln L` (up to a constant) at the unit
/// vector ω in **world axes** (for an anchor with rotation R, the reading's own axes see `R ω`).
/// The sphere integral of the module's reduction is done by `rule` centred on `centre` (world
/// axes; any nonzero length): the measured direction `Rᵀ u(y)`, or, for an azimuth-elevation
/// likelihood close to the anchor's pole, the pole. The rule must resolve the product `L(ω) M₂(ω)`:
/// put its centre and width where it is concentrated.
///
/// Nodes where `ln L = −∞` contribute nothing.
///
/// # Errors
/// * [`OperatorError::NonFinite`] for a centre that is not finite, or a log likelihood that is
///   NaN or +∞ at a node;
/// * [`OperatorError::OutOfRange`] for a zero centre, a prior mean farther than [`PRIOR_LIMIT`]
///   standard deviations from the anchor or a covariance with a condition number above it, or a
///   likelihood that is zero at every node (centre the rule on the measured direction);
/// * [`OperatorError::NotPositiveDefinite`] when the prior covariance cannot be factored, or the
///   posterior covariance is not positive definite or rests on fewer than
///   [`MIN_EFFECTIVE_NODES`] nodes (`(Σ w)² / Σ w²`: a likelihood narrower than the rule resolves,
///   whose angular spread the rule cannot measure).
pub fn exact_posterior(
    prior: &PositionGaussian,
    anchor: &Anchor,
    centre: &Vector3<f64>,
    log_likelihood: impl Fn(&Vector3<f64>) -> f64,
    rule: &SphereRule,
) -> Result<PositionEstimate, OperatorError> {
    if let Some(&value) = centre.iter().find(|v| !v.is_finite()) {
        return Err(OperatorError::NonFinite {
            what: "centre of the sphere rule",
            value,
        });
    }
    let scale = centre.amax();
    if scale == 0.0 {
        return Err(OperatorError::OutOfRange {
            what: "length of the centre of the sphere rule",
            value: 0.0,
            range: "a nonzero finite vector (the measured direction, world axes)",
        });
    }
    let norm = centre.norm();
    let centre = if (1e-150..=1e150).contains(&norm) {
        S2::new_unchecked(centre / norm)
    } else {
        // Scaled by the largest component first: the squared length would be subnormal (the
        // direction off the sphere) or overflow.
        let direction = centre / scale;
        S2::new_unchecked(direction / direction.norm())
    };
    let scaled = ScaledPrior::new(prior, anchor)?;
    let mut peak = f64::NEG_INFINITY;
    let (mut mass, mut first, mut second) = (0.0, Vector3::zeros(), Matrix3::zeros());
    // Σ w², for the effective number of nodes (Σ w)² / Σ w².
    let mut mass_of_squares = 0.0;
    let mut failure = None;
    rule.for_each_node(&centre, |omega, weight| {
        if failure.is_some() {
            return;
        }
        let ln_l = log_likelihood(omega);
        if ln_l.is_nan() || ln_l == f64::INFINITY {
            failure = Some(ln_l);
            return;
        }
        if ln_l == f64::NEG_INFINITY {
            return;
        }
        let [m2, m3, m4] = scaled.log_radial_moments(omega);
        let ln_w = weight.ln() + ln_l + m2;
        if ln_w > peak {
            let scale = (peak - ln_w).exp();
            mass *= scale;
            mass_of_squares *= scale * scale;
            first *= scale;
            second *= scale;
            peak = ln_w;
        }
        let w0 = (ln_w - peak).exp();
        mass += w0;
        mass_of_squares += w0 * w0;
        first += omega * (w0 * (m3 - m2).exp());
        second += omega * omega.transpose() * (w0 * (m4 - m2).exp());
    });
    if let Some(value) = failure {
        return Err(OperatorError::NonFinite {
            what: "log likelihood at a node of the sphere rule",
            value,
        });
    }
    if !(mass > 0.0 && peak.is_finite()) {
        return Err(OperatorError::OutOfRange {
            what: "likelihood times prior summed over the sphere rule",
            value: 0.0,
            range: "positive (centre the rule on the measured direction)",
        });
    }
    if mass * mass < MIN_EFFECTIVE_NODES * mass_of_squares {
        return Err(OperatorError::NotPositiveDefinite {
            what: "exact posterior covariance (the likelihood is narrower than the sphere rule \
                   resolves, fewer than 4 nodes carry it: narrow the rule's width or add nodes)",
        });
    }
    let mean = first / mass;
    let moment = second / mass;
    let spread = moment - mean * mean.transpose();
    let covariance = (spread + spread.transpose()) * (0.5 * scaled.unit * scaled.unit);
    let mean = anchor.position() + mean * scaled.unit;
    match mean
        .iter()
        .chain(covariance.iter())
        .find(|v| !v.is_finite())
    {
        Some(&value) => Err(OperatorError::NonFinite {
            what: "exact posterior moments",
            value,
        }),
        // A likelihood narrower than the rule resolves (κ = 1e204) leaves a spread that
        // cancellation makes indefinite.
        None if nalgebra::Cholesky::new(covariance).is_none() => {
            Err(OperatorError::NotPositiveDefinite {
                what: "exact posterior covariance (the likelihood is narrower than the sphere \
                       rule resolves: narrow the rule's width or add nodes)",
            })
        }
        None => Ok(PositionEstimate { mean, covariance }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `M_k` by brute force: the trapezoid rule on a fine radial grid.
    fn brute(a: f64, b: f64, c: f64, k: i32) -> f64 {
        let n = 400_000;
        let top = (b / a).max(0.0) + 40.0 / a.sqrt();
        let h = top / f64::from(n);
        (0..=n)
            .map(|i| {
                let r = h * f64::from(i);
                let f = r.powi(k) * (-(a * r * r - 2.0 * b * r + c) / 2.0).exp();
                if i == 0 || i == n { 0.5 * f } else { f }
            })
            .sum::<f64>()
            * h
    }

    #[test]
    fn radial_moments_match_brute_force_on_both_branches() {
        for &(a, b, c) in &[
            (1.0_f64, 2.0_f64, 5.0_f64),
            (0.5, -0.3, 1.0),
            (2.0, -1.0, 0.6),
            (1.0, -2.5, 7.0),
            (3.0, -9.0, 30.0),
            (1.0, 0.0, 0.0),
            (0.7, 5.0, 40.0),
        ] {
            let z = b / a.sqrt();
            let q = c - b * b / a;
            let got = log_radial_moments(a, z, q, 0.0);
            for (i, k) in [2, 3, 4].into_iter().enumerate() {
                let expected = brute(a, b, c, k).ln();
                assert!(
                    (got[i] - expected).abs() < 1e-9,
                    "a {a} b {b} c {c} k {k}: {} vs {expected}",
                    got[i]
                );
            }
        }
    }

    #[test]
    fn the_two_branches_agree_at_the_switch() {
        for z in [FRACTION_BELOW - 1e-12, FRACTION_BELOW + 1e-12] {
            let here = log_radial_moments(1.3, z, 0.4, 0.0);
            let there = log_radial_moments(1.3, FRACTION_BELOW, 0.4, 0.0);
            for i in 0..3 {
                assert!(
                    (here[i] - there[i]).abs() < 1e-11,
                    "{z}: {here:?} {there:?}"
                );
            }
        }
    }
}
