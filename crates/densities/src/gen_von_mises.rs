//! [`GenVonMises2`]: the generalised von Mises distribution with first and second harmonics.

use crate::error::{DensityError, finite};
use crate::quadrature;
use crate::scaled_bessel;
use crate::traits::{
    Density, Entropy, KlDivergence, Product, Rotate, distribution_through_density,
};
use crate::von_mises::{
    check_concentration, direction, hypot, natural_of_unit, sample_offset, scaled_cos_minus_one,
    within_concentration,
};
use liebayes_manifolds::{LieGroup, So2};
use nalgebra::Vector2;
use rand::Rng;
use std::f64::consts::{FRAC_PI_2, PI};

/// Above this `κ₁ + 4κ₂` the normaliser and the moments use the adaptive partition instead of the
/// periodic trapezoid rule (whose 32 + 12√κ points would grow without bound).
const TRAPEZOID_LIMIT: f64 = 1e4;

/// Steps [`global_maximum`] takes at most: each either halves its bracket (π/2 wide, so 54 reach
/// the resolution) or is a Newton step at most half the size of the one before (an emulation took
/// at most 64 over 200 000 draws rich in flat tops and nearly mirror-symmetric densities; were the
/// bound reached, the angle would still lie in the bracket of the maximum).
const MAX_MODE_STEPS: usize = 120;

/// Deepest bisection of the adaptive partition: cells of width 2π·2⁻⁶⁴ are far below the 1e-8 that
/// the largest concentration needs.
const MAX_DEPTH: usize = 64;

/// Most cells the adaptive partition makes (it makes a few hundred: 240 at κ₂ = 1e8, and the count
/// grows like the logarithm of the concentration).
const MAX_CELLS: usize = 1 << 12;

/// Proposals a draw makes at most: every envelope used accepts at least e^(−1) ≈ 0.37 of them (the
/// harmonic ones are chosen only then), so 400 rejections in a row have probability below 1e-80.
const MAX_PROPOSALS: usize = 400;

/// The generalised von Mises distribution of order 2 on the circle:
///
/// `p(θ) = exp(η₁ · u(θ) + η₂ · u(2θ)) / Z`, `u(θ) = (cos θ, sin θ)`,
///
/// with respect to dθ (total mass 2π). κ₁ = |η₁|, κ₂ = |η₂|, with κ₁ + 4κ₂ ≤ 1e16
/// ([`GenVonMises2::MAX_CONCENTRATION`]). It contains the von
/// Mises (η₂ = 0) and is the family in which the azimuth posterior is claimed to stay von Mises: that
/// claim is checked by measuring η₂, not assumed.
///
/// Everything is computed relative to a reference angle θ₀ (the mode): the exponent differences
/// `g(d) = f(θ₀ + d) − f(θ₀)` are formed from `u(θ₀ + d) − u(θ₀) = −2 sin²(d/2) u(θ₀) + sin d u′(θ₀)`
/// with the harmonics' values and slopes at θ₀ taken once, so they never subtract numbers of size κ,
/// and `ln p = g(d) − (ln Z − f(θ₀))`.
///
/// **Normaliser**: for `κ₁ + 4κ₂ ≤ 1e4` the periodic trapezoid rule on `N = 32 + 12 √(κ₁ + 4κ₂)`
/// points, exponentially accurate for this analytic periodic integrand (checked in the tests against
/// the Jacobi-Anger series `Z = 2π Σ_k I₂ₖ(κ₁) I_k(κ₂) cos(2k(μ₁ − μ₂))`); above, 20-point
/// Gauss-Legendre on the cells of an adaptive partition of the offsets (cells are bisected until g
/// varies by at most 1 over them, or until they carry less than e^(−40)/√κ of the mass), which costs
/// the same at every concentration.
#[derive(Clone, Debug, PartialEq)]
pub struct GenVonMises2 {
    eta1: Vector2<f64>,
    eta2: Vector2<f64>,
    /// θ₀, the reference angle (the mode, 0 for the uniform distribution).
    reference: f64,
    /// `ln Z − f(θ₀)`.
    log_normalizer_offset: f64,
}

/// The exponent about a reference angle θ₀: differences `g(d) = f(θ₀ + d) − f(θ₀)` and the derivative
/// `f′(θ₀ + d)`, with the bound `L₂ = κ₁ + 4κ₂ ≥ max |f″|`. Angles θ₀ + d are never formed: u(θ₀ + d)
/// is u(θ₀) rotated by d, so offsets far below the resolution of θ₀ (1e-16) keep their effect, as
/// concentrations past 1e32 need.
///
/// Both are trigonometric polynomials in d whose four coefficients, the values `Pₙ` and slopes `Qₙ`
/// of the harmonics at θ₀, are rounded once (to about `eps κ`), so g's rounding from one offset to
/// the next is relative to its terms (`Pₙ d²`, `Qₙ d`, with `Q₁ + 2Q₂ = f′(θ₀) ≈ 0` at the mode):
/// not the `eps κ d` of products of size κ formed anew at every d, which cost the normaliser up to
/// 7e-10 near κ = 1e16.
#[derive(Clone, Copy, Debug)]
struct Offsets {
    /// u(θ₀) and u(2θ₀).
    first: Vector2<f64>,
    second: Vector2<f64>,
    /// `(P₁, P₂) = (η₁ · u(θ₀), η₂ · u(2θ₀))`.
    values: (f64, f64),
    /// `(Q₁, Q₂) = (η₁ · u′(θ₀), η₂ · u′(2θ₀))`, `u′ = (−sin, cos)`.
    slopes: (f64, f64),
    curvature_bound: f64,
}

/// `u` rotated by the angle whose (cos, sin) is `(c, s)`.
fn rotate(u: &Vector2<f64>, c: f64, s: f64) -> Vector2<f64> {
    Vector2::new(u.x * c - u.y * s, u.y * c + u.x * s)
}

/// `(η · u, η · u′)` for a unit vector u and `u′ = (−u.y, u.x)`.
fn value_and_slope(eta: &Vector2<f64>, u: &Vector2<f64>) -> (f64, f64) {
    (eta.dot(u), eta.y * u.x - eta.x * u.y)
}

impl Offsets {
    fn new(eta1: &Vector2<f64>, eta2: &Vector2<f64>, reference: f64) -> Self {
        let (s, c) = reference.sin_cos();
        let (s2, c2) = (2.0 * reference).sin_cos();
        let (first, second) = (Vector2::new(c, s), Vector2::new(c2, s2));
        let (p1, q1) = value_and_slope(eta1, &first);
        let (p2, q2) = value_and_slope(eta2, &second);
        Self {
            first,
            second,
            values: (p1, p2),
            slopes: (q1, q2),
            curvature_bound: eta1.x.hypot(eta1.y) + 4.0 * eta2.x.hypot(eta2.y),
        }
    }

    /// `g(d) = η₁ · (u(θ₀ + d) − u(θ₀)) + η₂ · (u(2θ₀ + 2d) − u(2θ₀))
    ///       = −2 sin²(d/2) P₁ + sin d Q₁ − 2 sin² d P₂ + sin 2d Q₂`, for any d.
    fn g(&self, d: f64) -> f64 {
        let half = (0.5 * d).sin();
        let (s, c) = d.sin_cos();
        let (p1, p2) = self.values;
        let (q1, q2) = self.slopes;
        -2.0 * half * half * p1 + s * q1 - 2.0 * s * s * p2 + 2.0 * s * c * q2
    }

    /// `f′(θ₀ + d) = η₁ · u′(θ₀ + d) + 2 η₂ · u′(2θ₀ + 2d)
    ///            = cos d Q₁ − sin d P₁ + 2 (cos 2d Q₂ − sin 2d P₂)`, for any d.
    fn slope(&self, d: f64) -> f64 {
        let (s, c) = d.sin_cos();
        let (s2, c2) = (2.0 * d).sin_cos();
        let (p1, p2) = self.values;
        let (q1, q2) = self.slopes;
        c * q1 - s * p1 + 2.0 * (c2 * q2 - s2 * p2)
    }

    /// Visits the leaves of the adaptive partition of [−π, π) as `(start, width, g(centre), bound)`,
    /// `bound ≥ max g` on the cell: cells are bisected until `|f′(m)| r + L₂ r²/2 ≤ max_excess` (r the
    /// half width) or until their bound lies `cutoff` below the largest value of g seen so far. No
    /// allocation: the pending cells live on a fixed stack (depth-first, so it holds at most one
    /// pending sibling per level).
    fn partition(&self, max_excess: f64, cutoff: f64, mut visit: impl FnMut(f64, f64, f64, f64)) {
        let mut stack = [(0.0_f64, 0.0_f64, 0_u16); MAX_DEPTH + 1];
        stack[0] = (-PI, 2.0 * PI, 0);
        let mut pending = 1;
        let mut cells = 0;
        let mut largest = f64::NEG_INFINITY;
        while pending > 0 {
            pending -= 1;
            let (start, width, depth) = stack[pending];
            let r = 0.5 * width;
            let centre = start + r;
            let value = self.g(centre);
            largest = largest.max(value);
            let excess = self.slope(centre).abs() * r + 0.5 * self.curvature_bound * r * r;
            let bound = value + excess;
            let split = excess > max_excess
                && bound >= largest - cutoff
                && usize::from(depth) < MAX_DEPTH
                && cells + pending + 2 <= MAX_CELLS
                && pending + 2 <= MAX_DEPTH + 1;
            if split {
                // Right half first on the stack, so the left is visited first.
                stack[pending] = (centre, r, depth + 1);
                stack[pending + 1] = (start, r, depth + 1);
                pending += 2;
            } else {
                cells += 1;
                visit(start, width, value, bound);
            }
        }
    }

    /// Visits 20-point Gauss-Legendre nodes `(d, weight, g(d))` on every cell of the partition that
    /// can matter (bound within `40 + ½ ln(1 + L₂)` of the largest value: the rest carries less than
    /// 1e-17 of the mass), the cells refined until g varies by at most 1 across them.
    fn quadrature(&self, mut visit: impl FnMut(f64, f64, f64)) {
        let cutoff = 40.0 + 0.5 * self.curvature_bound.ln_1p();
        let rule = quadrature::gauss_legendre();
        let mut largest = f64::NEG_INFINITY;
        self.partition(1.0, cutoff, |start, width, value, bound| {
            largest = largest.max(value);
            if bound < largest - cutoff {
                return;
            }
            let (mid, half) = (start + 0.5 * width, 0.5 * width);
            for &(x, w) in rule {
                let d = mid + half * x;
                visit(d, w * half, self.g(d));
            }
        });
    }
}

/// `f(θ)`, directly (for `ln Z = f(θ₀) + (ln Z − f(θ₀))`; the densities use [`Offsets::g`]).
fn exponent(eta1: &Vector2<f64>, eta2: &Vector2<f64>, angle: f64) -> f64 {
    let (s, c) = angle.sin_cos();
    let (s2, c2) = (2.0 * angle).sin_cos();
    eta1.x * c + eta1.y * s + eta2.x * c2 + eta2.y * s2
}

/// The global maximum of `f(θ) = η₁ · u(θ) + η₂ · u(2θ)` (angle in (−π, π]), located exactly,
/// whatever the shape of f (flat tops, two local maxima closer than any grid).
///
/// With x = u(θ) on the unit circle, f is the quadratic `p · x + xᵀ M x` in the frame
/// `(u(μ₂), u′(μ₂))`, `2μ₂ = arg η₂`: `M = diag(κ₂, −κ₂)` and `p = (η₁ · u(μ₂), η₁ · u′(μ₂))`. As for
/// a trust-region step, a stationary unit x (`p + 2Mx = λx`) with `λ ≥ 2κ₂` is the global maximum,
/// since `f(y) − f(x) = (y − x)ᵀ(M − λ/2)(y − x) ≤ 0` for every unit y. With `t = λ − 2κ₂ ≥ 0`,
/// `x = (p₁/t, p₂/(t + 4κ₂))`: x lies in the quadrant of the signs of (p₁, p₂). Reflected into the
/// first quadrant (M is unchanged), x = (cos ψ, sin ψ) with ψ ∈ [0, π/2], where
/// `f′(ψ) = −|p₁| sin ψ + |p₂| cos ψ − 2κ₂ sin 2ψ = −sin ψ cos ψ F(ψ)` and
/// `F(ψ) = |p₁|/cos ψ − |p₂|/sin ψ + 4κ₂` does not decrease: f′ changes sign once, from
/// `f′(0) = |p₂| ≥ 0` to `f′(π/2) = −|p₁| ≤ 0`, at the ψ where `t = |p₁|/cos ψ ≥ 0`. That zero is
/// found by Newton's method from the first harmonic's mode `atan2(|p₂|, |p₁|)`, kept in the bracket
/// by bisection (where Newton's point leaves it, or does not halve the previous step), until a step
/// is below 1e-16 rad, at most [`MAX_MODE_STEPS`].
///
/// Where the maximum is not unique (p₁ = 0 and |p₂| < 4κ₂: two maxima mirrored in the axis u′(μ₂),
/// as for η₁ = 0) it is the one with `cos ψ` along +u(μ₂).
fn global_maximum(eta1: &Vector2<f64>, eta2: &Vector2<f64>) -> f64 {
    const RESOLUTION: f64 = 1e-16;
    let k2 = eta2.x.hypot(eta2.y);
    let (s, c) = (0.5 * eta2.y.atan2(eta2.x)).sin_cos();
    let (along, across) = (Vector2::new(c, s), Vector2::new(-s, c));
    let (p1, p2) = (eta1.dot(&along), eta1.dot(&across));
    let (a, b) = (p1.abs(), p2.abs());
    let (mut low, mut high) = (0.0, FRAC_PI_2);
    let mut psi = b.atan2(a);
    let mut last_step = FRAC_PI_2;
    for _ in 0..MAX_MODE_STEPS {
        let (s, c) = psi.sin_cos();
        let (s2, c2) = (2.0 * psi).sin_cos();
        let d1 = -a * s + b * c - 2.0 * k2 * s2;
        let d2 = -a * c - b * s - 4.0 * k2 * c2;
        if d1 > 0.0 {
            low = psi;
        } else {
            high = psi;
        }
        let newton = psi - d1 / d2;
        let next =
            if d2 < 0.0 && low < newton && newton < high && (newton - psi).abs() <= 0.5 * last_step
            {
                newton
            } else {
                0.5 * (low + high)
            };
        last_step = (next - psi).abs();
        psi = next;
        if last_step < RESOLUTION {
            break;
        }
    }
    let (s, c) = psi.sin_cos();
    let x = along * (if p1 < 0.0 { -c } else { c }) + across * (if p2 < 0.0 { -s } else { s });
    x.y.atan2(x.x)
}

/// Trapezoid points for the normaliser: the integrand's Fourier coefficients decay like those of a von
/// Mises of concentration at most κ₁ + 4κ₂, whose aliasing error 2 A_N is below 1e-16 for N ≥ 9√κ.
fn trapezoid_points(offsets: &Offsets) -> usize {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let extra = (12.0 * offsets.curvature_bound.min(TRAPEZOID_LIMIT).sqrt()).ceil() as usize;
    32 + extra
}

/// Visits quadrature nodes `(d, weight, g(d))` for integrals over the circle of functions of
/// the density: the trapezoid rule at moderate concentration, the adaptive Gauss-Legendre rule above.
fn for_each_node(offsets: &Offsets, mut visit: impl FnMut(f64, f64, f64)) {
    if offsets.curvature_bound <= TRAPEZOID_LIMIT {
        let n = trapezoid_points(offsets);
        let h = 2.0 * PI / n as f64;
        for i in 0..n {
            let d = h * i as f64 - PI;
            visit(d, h, offsets.g(d));
        }
    } else {
        offsets.quadrature(visit);
    }
}

/// `ln Z − f(θ₀)`, by log-sum-exp over the nodes.
fn log_normalizer_offset(offsets: &Offsets) -> f64 {
    let mut largest = f64::NEG_INFINITY;
    let mut sum = 0.0;
    for_each_node(offsets, |_, weight, g| {
        if g > largest {
            sum *= (largest - g).exp();
            largest = g;
        }
        sum += weight * (g - largest).exp();
    });
    largest + sum.ln()
}

impl GenVonMises2 {
    /// The largest accepted `κ₁ + 4κ₂`: the density's peaks are about 1/√(κ₁ + 4κ₂) wide, and an angle
    /// near π is resolved only to 4.4e-16 in f64, so beyond 1e16 (peaks of 1e-8 rad) a second mode near
    /// the antipode of the first can no longer be integrated or sampled. The von Mises, whose one mode is
    /// the origin of its offsets, has no such limit.
    pub const MAX_CONCENTRATION: f64 = 1e16;

    /// The distribution `exp(κ₁ cos(θ − μ₁) + κ₂ cos 2(θ − μ₂)) / Z` with the location `μ₁` and
    /// concentration `κ₁ ≥ 0` of the first harmonic and those of the second (μ₂ matters modulo π),
    /// the parametrisation of Gatto and Jammalamadaka, *The generalized von Mises distribution*
    /// (Statistical Methodology, 2007): `η₁ = κ₁ u(μ₁)`, `η₂ = κ₂ u(2μ₂)`.
    ///
    /// `ηᵢ` is rounded so that `|ηᵢ| ≤ κᵢ`: every `κ₁ + 4κ₂ ≤ 1e16` is accepted, at every angle.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] for a negative or non-finite
    /// concentration, and as [`from_natural`](Self::from_natural) when `κ₁ + 4κ₂` exceeds 1e16.
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::{Density, GenVonMises2};
    /// use liebayes_manifolds::So2;
    /// // With κ₂ = 0 it is the von Mises: the mode is the first mean.
    /// let p = GenVonMises2::new(So2::from_angle_unchecked(1.0), 3.0, So2::from_angle_unchecked(0.0), 0.0).unwrap();
    /// let mode = p.mode().unwrap();
    /// assert!((mode.angle() - 1.0).abs() < 1e-9);
    /// assert!(p.log_pdf(&mode) > p.log_pdf(&So2::from_angle_unchecked(-2.0)));
    /// ```
    pub fn new(
        mean1: So2<f64>,
        concentration1: f64,
        mean2: So2<f64>,
        concentration2: f64,
    ) -> Result<Self, DensityError> {
        let k1 = check_concentration("first-harmonic concentration kappa1", concentration1)?;
        let k2 = check_concentration("second-harmonic concentration kappa2", concentration2)?;
        let doubled = mean2.compose(&mean2);
        // |ηᵢ| ≤ κᵢ after rounding, so `from_natural` refuses exactly the κ₁ + 4κ₂ above 1e16 (κ₁ =
        // 1e16 was refused for 3.8 % of the angles).
        Self::from_natural(
            natural_of_unit(mean1.cos(), mean1.sin(), k1),
            natural_of_unit(doubled.cos(), doubled.sin(), k2),
        )
    }

    /// The distribution with first- and second-harmonic natural parameters η₁, η₂.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite components, [`DensityError::OutOfRange`] when
    /// `κ₁ + 4κ₂` exceeds 1e16 (see [`MAX_CONCENTRATION`](Self::MAX_CONCENTRATION)).
    pub fn from_natural(eta1: Vector2<f64>, eta2: Vector2<f64>) -> Result<Self, DensityError> {
        for &v in eta1.iter().chain(eta2.iter()) {
            finite("harmonic parameter", v)?;
        }
        let combined = eta1.x.hypot(eta1.y) + 4.0 * eta2.x.hypot(eta2.y);
        if combined > Self::MAX_CONCENTRATION {
            return Err(DensityError::OutOfRange {
                what: "combined concentration |eta1| + 4 |eta2|",
                value: combined,
                range: "[0, 1e16]; beyond it use VonMises (no second harmonic) or a ManifoldGaussian",
            });
        }
        if combined == 0.0 {
            return Ok(Self::uniform());
        }
        let reference = global_maximum(&eta1, &eta2);
        let offsets = Offsets::new(&eta1, &eta2, reference);
        Ok(Self {
            eta1,
            eta2,
            reference,
            log_normalizer_offset: log_normalizer_offset(&offsets),
        })
    }

    /// The uniform distribution, `1/(2π)` (what [`from_natural`](Self::from_natural) returns for
    /// η₁ = η₂ = 0).
    pub fn uniform() -> Self {
        Self {
            eta1: Vector2::zeros(),
            eta2: Vector2::zeros(),
            reference: 0.0,
            log_normalizer_offset: (2.0 * PI).ln(),
        }
    }

    /// The natural parameters `(η₁, η₂)` of the first and second harmonics.
    pub fn natural(&self) -> (Vector2<f64>, Vector2<f64>) {
        (self.eta1, self.eta2)
    }

    fn offsets(&self) -> Offsets {
        Offsets::new(&self.eta1, &self.eta2, self.reference)
    }

    /// The first and second trigonometric moments `(E u(θ), E u(2θ))`, `u(θ) = (cos θ, sin θ)`, by
    /// the normaliser's quadrature rule (exponentially accurate, as the normaliser).
    pub fn trigonometric_moments(&self) -> (Vector2<f64>, Vector2<f64>) {
        let (mut m1, mut m2) = (Vector2::zeros(), Vector2::zeros());
        let offsets = self.offsets();
        for_each_node(&offsets, |d, weight, g| {
            let w = (g - self.log_normalizer_offset).exp() * weight;
            let (s, c) = d.sin_cos();
            let (s2, c2) = (2.0 * d).sin_cos();
            m1 += rotate(&offsets.first, c, s) * w;
            m2 += rotate(&offsets.second, c2, s2) * w;
        });
        (m1, m2)
    }

    /// Visits the centred first harmonics `(u(θᵢ) − m, pᵢ)`, `u(θ) = (cos θ, sin θ)`, at the
    /// normaliser's quadrature nodes θᵢ, with probabilities `pᵢ = wᵢ / Σⱼ wⱼ` (`wᵢ` the density
    /// times the node's weight) and the mean `m = Σᵢ pᵢ u(θᵢ)` of the same nodes: so that
    /// `Σᵢ pᵢ (u(θᵢ) − m)(u(θᵢ) − m)ᵀ`, the covariance of u, and any projection of it, is a sum of
    /// squares. The offsets from the reference θ₀ are formed as
    /// `u(θ₀ + d) − u(θ₀) = −2 sin²(d/2) u(θ₀) + sin d u′(θ₀)`, so the small spread of a
    /// concentrated density keeps its digits (Var cos θ ≈ 5e-25 at κ = 1e12, where
    /// `E cos² − (E cos)²` cancelled to ±1e-16).
    pub(crate) fn for_each_centred_harmonic(&self, mut visit: impl FnMut(Vector2<f64>, f64)) {
        let offsets = self.offsets();
        let (u, slope) = (
            offsets.first,
            Vector2::new(-offsets.first.y, offsets.first.x),
        );
        let step = |d: f64| {
            let half = (0.5 * d).sin();
            u * (-2.0 * half * half) + slope * d.sin()
        };
        let (mut total, mut mean) = (0.0, Vector2::zeros());
        for_each_node(&offsets, |d, weight, g| {
            let w = (g - self.log_normalizer_offset).exp() * weight;
            total += w;
            mean += step(d) * w;
        });
        mean /= total;
        for_each_node(&offsets, |d, weight, g| {
            let w = (g - self.log_normalizer_offset).exp() * weight;
            visit(step(d) - mean, w / total);
        });
    }

    /// `ln p` at the offset d from the reference angle.
    fn log_pdf_at_offset(&self, d: f64) -> f64 {
        self.offsets().g(d) - self.log_normalizer_offset
    }

    /// The offset of `x` from the reference, in (−π, π], by the rotation `θ₀⁻¹ x` (no difference of
    /// angles is rounded).
    fn offset_of(&self, x: &So2<f64>) -> f64 {
        So2::from_angle_unchecked(self.reference)
            .inverse()
            .compose(x)
            .angle()
    }
}

impl Density for GenVonMises2 {
    type Point = So2<f64>;

    /// `η₁ · u(θ) + η₂ · u(2θ) − ln Z`, evaluated as `g(θ − θ₀) − (ln Z − f(θ₀))`.
    fn log_pdf(&self, x: &So2<f64>) -> f64 {
        self.log_pdf_at_offset(self.offset_of(x))
    }

    /// `ln Z` (see the type docs).
    fn log_normalizer(&self) -> f64 {
        exponent(&self.eta1, &self.eta2, self.reference) + self.log_normalizer_offset
    }

    /// One exact draw; see [`GenVonMises2Sampler`], which this builds and uses once. For many draws
    /// from one distribution, build the sampler with [`GenVonMises2::sampler`] and keep it: where the
    /// partition envelope is needed that is the difference between building it per draw and a binary
    /// search.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        rand::distr::Distribution::sample(&self.sampler(), rng)
    }

    /// The global maximum of the exponent (the reference angle), located as the one zero of f′ in the
    /// quadrant that the trust-region condition singles out (see `global_maximum`), so flat tops and
    /// close pairs of local maxima cannot mislead it; `None` where the maximum is not unique: for the
    /// uniform distribution, and for η₁ = 0, where the density has period π and its maxima are μ₂ and
    /// μ₂ + π.
    fn mode(&self) -> Option<So2<f64>> {
        if self.eta1 == Vector2::zeros() {
            return None;
        }
        Some(So2::from_angle_unchecked(self.reference))
    }
}

impl GenVonMises2 {
    /// The exact sampler with its envelope chosen and built (see [`GenVonMises2Sampler`]).
    pub fn sampler(&self) -> GenVonMises2Sampler {
        let (k1, k2) = (
            self.eta1.x.hypot(self.eta1.y),
            self.eta2.x.hypot(self.eta2.y),
        );
        // ln of the acceptance rates Z / (2π I₀(κ₁) e^κ₂) and Z / (2π I₀(κ₂) e^κ₁).
        let log_z_minus = self.log_normalizer() - (2.0 * PI).ln() - k1 - k2;
        let first = log_z_minus - scaled_bessel::log_scaled_i0(k1);
        let second = log_z_minus - scaled_bessel::log_scaled_i0(k2);
        let envelope = if first.max(second) < -1.0 {
            Envelope::Cells(CellEnvelope::new(&self.offsets()))
        } else if first >= second {
            Envelope::FirstHarmonic
        } else {
            Envelope::SecondHarmonic
        };
        GenVonMises2Sampler {
            density: self.clone(),
            envelope,
        }
    }
}

/// Exact rejection sampling of a [`GenVonMises2`] from the best of three envelopes, chosen once:
///
/// * the von Mises of η₁, accepting with `exp(η₂ · u(2θ) − κ₂)`, acceptance rate
///   `Z / (2π I₀(κ₁) e^κ₂)`;
/// * the bimodal von Mises of η₂ on the doubled angle, accepting with `exp(η₁ · u(θ) − κ₁)`, rate
///   `Z / (2π I₀(κ₂) e^κ₁)`;
/// * when both rates fall below e^(−1) (strong harmonics whose modes disagree, or any concentration
///   beyond that): a piecewise-constant envelope on the cells of the adaptive partition of the
///   offsets from the mode, bisected until `|f′(m)| r + L₂ r²/2 ≤ ½` (m the centre, r the half width,
///   `L₂ = κ₁ + 4κ₂ ≥ max |f″|`), cell i carrying `exp(g(mᵢ) + excessᵢ)`, an upper bound of `exp(g)`
///   on it. Where the cell is not negligible the envelope exceeds the density by at most e, so the
///   rate is at least e^(−1); a few hundred cells serve any concentration. A draw picks a cell by
///   binary search in the cumulative masses.
///
/// The acceptance exponents are formed without cancellation (`κ (cos d − 1)`, and g), so the sampler
/// stays exact at concentrations up to 1e300. Implements [`rand::distr::Distribution`].
#[derive(Clone, Debug)]
pub struct GenVonMises2Sampler {
    density: GenVonMises2,
    envelope: Envelope,
}

#[derive(Clone, Debug)]
enum Envelope {
    FirstHarmonic,
    SecondHarmonic,
    Cells(CellEnvelope),
}

/// The piecewise-constant envelope on the partition: per cell its start, width and bound, and the
/// cumulative masses `Σ width · exp(bound − max bound)`.
#[derive(Clone, Debug)]
struct CellEnvelope {
    cells: Vec<(f64, f64, f64)>,
    cumulative: Vec<f64>,
}

impl CellEnvelope {
    fn new(offsets: &Offsets) -> Self {
        let mut cells = Vec::new();
        offsets.partition(0.5, 60.0, |start, width, _, bound| {
            cells.push((start, width, bound));
        });
        let max = cells.iter().map(|c| c.2).fold(f64::NEG_INFINITY, f64::max);
        let cumulative = cells
            .iter()
            .scan(0.0, |total, &(_, width, bound)| {
                *total += width * (bound - max).exp();
                Some(*total)
            })
            .collect();
        Self { cells, cumulative }
    }

    /// One offset from the mode.
    fn draw<R: Rng + ?Sized>(&self, offsets: &Offsets, rng: &mut R) -> f64 {
        let count = self.cumulative.len();
        let total = self.cumulative[count - 1];
        let mut d = 0.0;
        for _ in 0..MAX_PROPOSALS {
            let target = rng.random::<f64>() * total;
            let i = self
                .cumulative
                .partition_point(|&c| c < target)
                .min(count - 1);
            let (start, width, bound) = self.cells[i];
            d = start + rng.random::<f64>() * width;
            if rng.random::<f64>().ln() < offsets.g(d) - bound {
                break;
            }
        }
        d
    }
}

distribution_through_density!(GenVonMises2);

impl rand::distr::Distribution<So2<f64>> for GenVonMises2Sampler {
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        let p = &self.density;
        let (k1, k2) = (p.eta1.x.hypot(p.eta1.y), p.eta2.x.hypot(p.eta2.y));
        match &self.envelope {
            Envelope::Cells(cells) => {
                let d = cells.draw(&p.offsets(), rng);
                So2::from_angle_unchecked(p.reference).compose(&So2::from_angle_unchecked(d))
            }
            Envelope::FirstHarmonic => {
                let mut a = So2::identity();
                for _ in 0..MAX_PROPOSALS {
                    a = von_mises_draw(&p.eta1, k1, rng);
                    let (s2, c2) = (2.0 * a.angle()).sin_cos();
                    if rng.random::<f64>().ln() < scaled_cos_minus_one(&p.eta2, k2, c2, s2) {
                        break;
                    }
                }
                a
            }
            Envelope::SecondHarmonic => {
                let mut a = So2::identity();
                for _ in 0..MAX_PROPOSALS {
                    let doubled = von_mises_draw(&p.eta2, k2, rng).angle();
                    let half = So2::from_angle_unchecked(doubled / 2.0);
                    a = if rng.random::<bool>() {
                        half
                    } else {
                        half.compose(&So2::from_angle_unchecked(PI))
                    };
                    if rng.random::<f64>().ln()
                        < scaled_cos_minus_one(&p.eta1, k1, a.cos(), a.sin())
                    {
                        break;
                    }
                }
                a
            }
        }
    }
}

/// One draw from the von Mises with natural parameter η (|η| = κ), uniform for κ = 0.
fn von_mises_draw<R: Rng + ?Sized>(eta: &Vector2<f64>, kappa: f64, rng: &mut R) -> So2<f64> {
    if kappa == 0.0 {
        return So2::from_angle_unchecked(rng.random_range(-PI..PI));
    }
    direction(eta, kappa).compose(&sample_offset(kappa, rng))
}

impl Product for GenVonMises2 {
    /// Natural parameters add (exact).
    ///
    /// # Errors
    /// As [`from_natural`](GenVonMises2::from_natural), where `κ₁ + 4κ₂` of the sum exceeds 1e16.
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Self::from_natural(self.eta1 + other.eta1, self.eta2 + other.eta2)
    }

    /// `ln ∫ p q = ln Z₁₂ − ln Z_p − ln Z_q` (`Z₁₂ = Z(η₁ + η₁′, η₂ + η₂′)`), evaluated at the
    /// product's reference angle θ₁₂ as `ln p(θ₁₂) + ln q(θ₁₂) + (ln Z₁₂ − f₁₂(θ₁₂))`: as the
    /// exponents add, `f₁₂(θ₁₂) − f_p(θ_p) − f_q(θ_q) = g_p(θ₁₂ ⊖ θ_p) + g_q(θ₁₂ ⊖ θ_q)` exactly (g the
    /// offsets' exponent differences, θ_p, θ_q the references), so only those and the normalisers
    /// less their maxima enter, and no numbers of size κ are subtracted (the difference of the three
    /// `ln Z` was 0.81 nats off at κ = 5e15).
    ///
    /// # Errors
    /// As [`product`](Product::product).
    fn log_product_integral(&self, other: &Self) -> Result<f64, DensityError> {
        let joint = self.product(other)?;
        let reference = So2::from_angle_unchecked(joint.reference);
        Ok(self.log_pdf(&reference) + other.log_pdf(&reference) + joint.log_normalizer_offset)
    }
}

impl Rotate<So2<f64>> for GenVonMises2 {
    /// The harmonics turned by g and 2g, `η₁ ← R(g) η₁`, `η₂ ← R(2g) η₂`, each kept at `|ηᵢ| ≤ κᵢ`
    /// (the rounding of [`new`](GenVonMises2::new)), so that `κ₁ + 4κ₂` stays within
    /// [`MAX_CONCENTRATION`](GenVonMises2::MAX_CONCENTRATION) (κ₁ = 1e16 turned by some angles went
    /// an ulp beyond it, and the serde reader and a product with the uniform refused the result);
    /// the mode turns by g and the normaliser, taken relative to the mode, is unchanged, so nothing
    /// is recomputed.
    fn rotated(&self, g: &So2<f64>) -> Result<Self, DensityError> {
        let doubled = g.compose(g);
        let (k1, k2) = (hypot(&self.eta1), hypot(&self.eta2));
        Ok(Self {
            eta1: within_concentration(rotate(&self.eta1, g.cos(), g.sin()), k1, hypot),
            eta2: within_concentration(rotate(&self.eta2, doubled.cos(), doubled.sin()), k2, hypot),
            reference: g
                .compose(&So2::from_angle_unchecked(self.reference))
                .angle(),
            log_normalizer_offset: self.log_normalizer_offset,
        })
    }

    /// `g x`.
    fn act(g: &So2<f64>, x: &So2<f64>) -> So2<f64> {
        g.compose(x)
    }
}

impl Entropy for GenVonMises2 {
    /// `−∫ p ln p dθ` by the normaliser's quadrature rule (no closed form).
    fn entropy(&self) -> f64 {
        let mut total = 0.0;
        for_each_node(&self.offsets(), |_, weight, g| {
            let l = g - self.log_normalizer_offset;
            total -= weight * l.exp() * l;
        });
        total
    }
}

impl KlDivergence for GenVonMises2 {
    /// `∫ p ln(p/q) dθ` by `p`'s quadrature rule (where p has its mass), q evaluated at the same
    /// angles.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let mut total = 0.0;
        for_each_node(&self.offsets(), |d, weight, g| {
            let lp = g - self.log_normalizer_offset;
            let x =
                So2::from_angle_unchecked(self.reference).compose(&So2::from_angle_unchecked(d));
            let lq = other.log_pdf_at_offset(other.offset_of(&x));
            total += weight * lp.exp() * (lp - lq);
        });
        total
    }
}
