//! Gauss-Legendre and Gauss-Hermite quadrature, for the normalisers and CDFs that have no closed form
//! (and, through `testing::quadrature`, for the law suite's integrals over each space).
//! [`legendre_nodes`] gives the Gauss-Legendre rule for integrals of one's own.

use std::f64::consts::PI;
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
pub(crate) fn legendre_rule(n: usize) -> Vec<(f64, f64)> {
    let nf = n as f64;
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..NEWTON_STEPS {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                derivative = nf * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / derivative;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * derivative * derivative))
        })
        .collect()
}

/// The largest rule [`legendre_nodes`] builds (its cost grows as n²).
pub const MAX_LEGENDRE_NODES: usize = 8192;

/// The n-point Gauss-Legendre rule on [−1, 1] as (node, weight) pairs, exact for polynomials of
/// degree 2n − 1 (nodes and weights to full precision), for n from 1 to [`MAX_LEGENDRE_NODES`].
///
/// # Errors
/// [`DensityError::OutOfRange`](crate::DensityError::OutOfRange) for n outside that range.
pub fn legendre_nodes(n: usize) -> Result<Vec<(f64, f64)>, crate::DensityError> {
    if n == 0 || n > MAX_LEGENDRE_NODES {
        return Err(crate::DensityError::OutOfRange {
            what: "number of Gauss-Legendre nodes",
            value: n as f64,
            range: "[1, 8192]",
        });
    }
    Ok(legendre_rule(n))
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
}
