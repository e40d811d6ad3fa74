//! Gauss-Legendre and Gauss-Hermite quadrature, for the normalisers and CDFs that have no closed form
//! (and, through `testing::quadrature`, for the law suite's integrals over each space).
//! [`legendre_nodes`] gives the Gauss-Legendre rule for integrals of one's own, [`SphereRule`] the
//! rule on the unit sphere for integrands concentrated about a direction.

use crate::DensityError;
use liebayes_manifolds::S2;
use nalgebra::Vector3;
use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

/// Number of nodes of the rule the densities use.
pub(crate) const NODES: usize = 20;

/// Number of Gauss-Hermite nodes per axis the moment matching uses.
pub(crate) const HERMITE_NODES: usize = 16;

/// Newton steps per Legendre node: from Tricomi's initial guess the iteration converges
/// quadratically in under 10 steps for every n.
const NEWTON_STEPS: usize = 100;

/// The n-point Gauss-Legendre rule on [−1, 1] as (node, weight) pairs (exact for polynomials of
/// degree 2n − 1): the roots of Pₙ by Newton's method on the three-term recurrence from
/// `cos(π (i + ¾)/(n + ½))`, to full precision, and the weights `2/((1 − x²) Pₙ′(x)²)`.
///
/// Near ±1 that weight is sensitive to the rounding of the node: at a root,
/// `d ln w/dx = −2x/(1 − x²)`, so half an ulp of x moved the end weights of a 36-point rule by
/// 1e-14 and of a 128-point rule by 3e-13. The weight is therefore taken at the exact root, to
/// first order, `w(x) (1 + 2x δ/(1 − x²))` with the sub-ulp Newton step `δ = Pₙ(x)/Pₙ′(x)` at the
/// rounded node, and `1 − x²` is formed as `(1 − x)(1 + x)`. Measured against 40-digit weights:
/// within 1.5e-15 (n = 12), 7e-15 (n = 36), 1.4e-14 (n = 64 and 128), 9e-14 (n = 256) and
/// 1.5e-12 (n = 1024, where the recurrence's own rounding dominates), from 2.4e-15, 9e-14, 9e-14,
/// 3.4e-13, 6.9e-13 and 2.2e-12 before.
pub(crate) fn legendre_rule(n: usize) -> Vec<(f64, f64)> {
    let nf = n as f64;
    // (Pₙ(x), Pₙ′(x), 1 − x²); the derivative from (1 − x²) Pₙ′ = n (Pₙ₋₁ − x Pₙ).
    let legendre = |x: f64| {
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=n {
            let kf = k as f64;
            let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
            p0 = p1;
            p1 = p2;
        }
        let one_minus_x2 = (1.0 - x) * (1.0 + x);
        (p1, nf * (p0 - x * p1) / one_minus_x2, one_minus_x2)
    };
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            for _ in 0..NEWTON_STEPS {
                let (p, derivative, _) = legendre(x);
                let step = p / derivative;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            let (p, derivative, one_minus_x2) = legendre(x);
            let weight = 2.0 / (one_minus_x2 * derivative * derivative);
            let offset = p / derivative;
            (x, weight * (1.0 + 2.0 * x * offset / one_minus_x2))
        })
        .collect()
}

/// The largest rule [`legendre_nodes`] builds (its cost grows as n²).
pub const MAX_LEGENDRE_NODES: usize = 8192;

/// The n-point Gauss-Legendre rule on [−1, 1] as (node, weight) pairs, exact for polynomials of
/// degree 2n − 1, for n from 1 to [`MAX_LEGENDRE_NODES`]. Nodes within an ulp of the roots of Pₙ;
/// weights within 1.5e-15 relative at n = 12, 7e-15 at 36, 1.4e-14 at 128, 9e-14 at 256 and
/// 1.5e-12 at 1024 (against 40-digit values).
///
/// # Errors
/// [`DensityError::OutOfRange`] for n outside that range.
pub fn legendre_nodes(n: usize) -> Result<Vec<(f64, f64)>, DensityError> {
    if n == 0 || n > MAX_LEGENDRE_NODES {
        return Err(DensityError::OutOfRange {
            what: "number of Gauss-Legendre nodes",
            value: n as f64,
            range: "[1, 8192]",
        });
    }
    Ok(legendre_rule(n))
}

/// The accepted node counts of a [`SphereRule`] in colatitude and in longitude (inclusive).
pub const SPHERE_NODE_RANGE: (usize, usize) = (4, MAX_LEGENDRE_NODES);

/// The accepted angular widths of a [`SphereRule`] (rad, inclusive).
pub const SPHERE_WIDTH_RANGE: (f64, f64) = (1e-6, PI);

/// The default node counts `(colatitude, longitude)` of [`SphereRule::with_width`]: relative error
/// below 1e-8 for a von Mises-Fisher integrand of concentration κ from about 100 to 1e4 and beyond,
/// with the width `1/√κ`, times a smooth function.
pub const SPHERE_DEFAULT_NODES: (usize, usize) = (96, 96);

/// A product rule on the unit sphere S², against its surface measure (total 4π), centred on a
/// direction c: Gauss-Legendre in a mapped colatitude × the trapezoid rule in longitude.
///
/// With `t = 1 − cos α` (α the angle from c, `dω = dt dφ`), the colatitude map is
/// `t(x) = w (e^{Λx} − 1)`, `x ∈ [0, 1]`, `Λ = ln(1 + 2/w)`, `w = 1 − cos(width)`, so that
/// `dt = Λ (t + w) dx`: the nodes are spaced geometrically in t from about w at the centre to 2 at
/// the opposite pole. A von Mises-Fisher integrand `e^{−κ t}` about c becomes a smooth function
/// of x on the scale `1/Λ` when `width ≈ 1/√κ`, so a fixed number of nodes serves any κ (Λ grows
/// only as ln κ). An integrand with no peak at the centre still converges, with more nodes the
/// smaller the width.
///
/// # Example
/// ```
/// use liebayes_densities::quadrature::SphereRule;
/// use liebayes_manifolds::S2;
/// use nalgebra::Vector3;
/// // ∫ e^(κ (c · ω − 1)) dω = 2π (1 − e^(−2κ))/κ, here for κ = 400.
/// let c = S2::new(Vector3::new(0.0, 0.6, 0.8)).unwrap();
/// let kappa: f64 = 400.0;
/// let mut integral = 0.0;
/// SphereRule::with_width(1.0 / kappa.sqrt()).unwrap().for_each_node(&c, |omega, weight| {
///     integral += weight * (kappa * (c.as_vector().dot(omega) - 1.0)).exp();
/// });
/// let exact = 2.0 * std::f64::consts::PI * (1.0 - (-2.0 * kappa).exp()) / kappa;
/// assert!((integral / exact - 1.0).abs() < 1e-10);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereRule {
    colatitude_nodes: usize,
    longitude_nodes: usize,
    width: f64,
}

impl SphereRule {
    /// The rule with `colatitude_nodes` Gauss-Legendre nodes, `longitude_nodes` trapezoid nodes
    /// (both in [`SPHERE_NODE_RANGE`]) and the angular `width` (rad, in [`SPHERE_WIDTH_RANGE`]) of
    /// the region about the centre where the integrand is concentrated: `1/√κ` for a von
    /// Mises-Fisher factor of concentration κ, the angular standard deviation for others.
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] for a count or a width outside its range (NaN included).
    pub fn new(
        colatitude_nodes: usize,
        longitude_nodes: usize,
        width: f64,
    ) -> Result<Self, DensityError> {
        for (what, n) in [
            ("colatitude nodes of the sphere rule", colatitude_nodes),
            ("longitude nodes of the sphere rule", longitude_nodes),
        ] {
            if !(SPHERE_NODE_RANGE.0..=SPHERE_NODE_RANGE.1).contains(&n) {
                return Err(DensityError::OutOfRange {
                    what,
                    value: n as f64,
                    range: "[4, 8192]",
                });
            }
        }
        if !(SPHERE_WIDTH_RANGE.0..=SPHERE_WIDTH_RANGE.1).contains(&width) {
            return Err(DensityError::OutOfRange {
                what: "angular width of the sphere rule (rad)",
                value: width,
                range: "[1e-6, pi] rad (1/sqrt(kappa) for a von Mises-Fisher factor)",
            });
        }
        Ok(Self {
            colatitude_nodes,
            longitude_nodes,
            width,
        })
    }

    /// The rule with [`SPHERE_DEFAULT_NODES`] and the angular `width`.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn with_width(width: f64) -> Result<Self, DensityError> {
        Self::new(SPHERE_DEFAULT_NODES.0, SPHERE_DEFAULT_NODES.1, width)
    }

    /// The number of colatitude nodes.
    pub fn colatitude_nodes(&self) -> usize {
        self.colatitude_nodes
    }

    /// The number of longitude nodes.
    pub fn longitude_nodes(&self) -> usize {
        self.longitude_nodes
    }

    /// The angular width (rad).
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Calls `visit(ω, weight)` at every node of the rule centred on `centre`
    /// (`Σ weight f(ω) ≈ ∫ f dω`; the weights sum to 4π up to the rule's error).
    pub fn for_each_node(&self, centre: &S2<f64>, mut visit: impl FnMut(&Vector3<f64>, f64)) {
        let colatitudes = legendre_rule(self.colatitude_nodes);
        let c = centre.as_vector();
        let basis = centre.tangent_basis();
        let (e1, e2) = (basis.column(0), basis.column(1));
        // w = 1 − cos(width), without cancellation.
        let w = 2.0 * (0.5 * self.width).sin().powi(2);
        let lambda = (2.0 / w).ln_1p();
        let step = TAU / self.longitude_nodes as f64;
        let longitudes: Vec<(f64, f64)> = (0..self.longitude_nodes)
            .map(|j| ((j as f64 + 0.5) * step).sin_cos())
            .collect();
        for (xi, weight) in colatitudes {
            let x = 0.5 * (xi + 1.0);
            // t = w (e^{Λx} − 1) ∈ (0, 2).
            let t = (w * (lambda * x).exp_m1()).min(2.0);
            let ring = 0.5 * weight * lambda * (t + w) * step;
            let (cos_a, sin_a) = (1.0 - t, (t * (2.0 - t)).max(0.0).sqrt());
            for &(s, co) in &longitudes {
                let omega = c * cos_a + (e1 * co + e2 * s) * sin_a;
                visit(&omega, ring);
            }
        }
    }
}

/// The n-point Gauss-Hermite rule for the standard normal, `E[f(u)] ≈ Σ wᵢ f(uᵢ)` with Σ wᵢ = 1
/// (exact for polynomials of degree 2n − 1): nodes and weights by the Golub-Welsch eigenproblem of
/// the Jacobi matrix (off-diagonal √k).
pub(crate) fn hermite_rule(n: usize) -> Vec<(f64, f64)> {
    let jacobi = nalgebra::DMatrix::<f64>::from_fn(n, n, |i, j| {
        if i + 1 == j || j + 1 == i {
            (i.max(j) as f64).sqrt()
        } else {
            0.0
        }
    });
    // Unbounded iteration, on purpose: the Jacobi matrix is fixed by n alone (no user values), a
    // symmetric tridiagonal matrix with distinct eigenvalues for which the QR iteration with
    // Wilkinson shifts always converges.
    let eigen = nalgebra::SymmetricEigen::new(jacobi);
    let mut rule: Vec<(f64, f64)> = (0..n)
        .map(|k| (eigen.eigenvalues[k], eigen.eigenvectors[(0, k)].powi(2)))
        .collect();
    rule.sort_by(|a, b| a.0.total_cmp(&b.0));
    rule
}

/// The 20-point Gauss-Legendre rule, computed once.
pub(crate) fn gauss_legendre() -> &'static [(f64, f64); NODES] {
    static RULE: OnceLock<[(f64, f64); NODES]> = OnceLock::new();
    RULE.get_or_init(|| {
        let rule = legendre_rule(NODES);
        std::array::from_fn(|i| rule[i])
    })
}

/// `∫_a^b f` by the 20-point rule on `panels` equal panels.
pub(crate) fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let rule = gauss_legendre();
    let width = (b - a) / panels as f64;
    (0..panels)
        .map(|p| {
            let mid = a + width * (p as f64 + 0.5);
            rule.iter()
                .map(|(x, w)| w * f(mid + 0.5 * width * x))
                .sum::<f64>()
                * 0.5
                * width
        })
        .sum()
}

/// The 16-point Gauss-Hermite rule for the standard normal, computed once.
pub(crate) fn gauss_hermite() -> &'static [(f64, f64); HERMITE_NODES] {
    static RULE: OnceLock<[(f64, f64); HERMITE_NODES]> = OnceLock::new();
    RULE.get_or_init(|| {
        let rule = hermite_rule(HERMITE_NODES);
        std::array::from_fn(|i| rule[i])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rules integrate the monomials they must integrate exactly: `∫₋₁¹ x^k = 2/(k + 1)` for even
    /// k ≤ 2n − 1 (0 for odd k), and the standard normal's moments `(k − 1)!!`.
    #[test]
    fn rules_are_exact_for_their_polynomial_degree() {
        for n in [1, 2, 5, 20, 40] {
            let rule = legendre_rule(n);
            for k in 0..2 * n {
                let got: f64 = rule
                    .iter()
                    .map(|(x, w)| w * x.powi(i32::try_from(k).unwrap()))
                    .sum();
                let expected = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    0.0
                };
                assert!(
                    (got - expected).abs() < 1e-14,
                    "Legendre n {n}, x^{k}: {got}"
                );
            }
        }
        for n in [1, 3, 8, 16] {
            let rule = hermite_rule(n);
            for k in 0..2 * n {
                let got: f64 = rule
                    .iter()
                    .map(|(x, w)| w * x.powi(i32::try_from(k).unwrap()))
                    .sum();
                let expected = if k % 2 == 0 {
                    (1..k).step_by(2).map(|j| j as f64).product::<f64>()
                } else {
                    0.0
                };
                // Odd moments vanish by symmetry, to the rounding of E|x|^k; the weights of the
                // outer nodes carry relative errors of a few hundred ε.
                let scale: f64 = rule
                    .iter()
                    .map(|(x, w)| w * x.abs().powi(i32::try_from(k).unwrap()))
                    .sum();
                assert!(
                    (got - expected).abs() < 1e-12 * (1.0 + scale),
                    "Hermite n {n}, x^{k}: {got}"
                );
            }
        }
    }

    #[test]
    fn legendre_nodes_are_exact_and_refuse_bad_counts() {
        for n in [4, 17, 96, 500] {
            let rule = legendre_nodes(n).unwrap();
            assert!(legendre_nodes(0).is_err() && legendre_nodes(8193).is_err());
            for degree in [0, 1, 2, 7, 2 * n - 1] {
                let got: f64 = rule
                    .iter()
                    .map(|&(x, w)| w * x.powi(i32::try_from(degree).unwrap()))
                    .sum();
                let expected = if degree % 2 == 1 {
                    0.0
                } else {
                    2.0 / (degree as f64 + 1.0)
                };
                assert!(
                    (got - expected).abs() < 1e-13,
                    "n {n} degree {degree}: {got}"
                );
            }
        }
    }
}
