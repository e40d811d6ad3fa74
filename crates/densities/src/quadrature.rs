//! Gauss-Legendre quadrature, for the normalisers and CDFs that have no closed form.

use std::f64::consts::PI;
use std::sync::OnceLock;

/// Number of nodes of the rule.
pub(crate) const NODES: usize = 20;

/// The 20-point Gauss-Legendre rule on [−1, 1] as (node, weight) pairs, computed once by Newton's
/// method on the Legendre recurrence (to full precision; exact for polynomials of degree 39).
pub(crate) fn gauss_legendre() -> &'static [(f64, f64); NODES] {
    static RULE: OnceLock<[(f64, f64); NODES]> = OnceLock::new();
    RULE.get_or_init(|| {
        let n = NODES as f64;
        std::array::from_fn(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=NODES {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                derivative = n * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / derivative;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * derivative * derivative))
        })
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

/// Number of Gauss-Hermite nodes per axis.
pub(crate) const HERMITE_NODES: usize = 16;

/// The Gauss-Hermite rule for the standard normal, `E[f(u)] ≈ Σ wᵢ f(uᵢ)` with Σ wᵢ = 1, exact for
/// polynomials of degree 31: nodes and weights by the Golub-Welsch eigenproblem of the Jacobi matrix
/// (off-diagonal √k), computed once.
pub(crate) fn gauss_hermite() -> &'static [(f64, f64); HERMITE_NODES] {
    static RULE: OnceLock<[(f64, f64); HERMITE_NODES]> = OnceLock::new();
    RULE.get_or_init(|| {
        let jacobi = nalgebra::DMatrix::<f64>::from_fn(HERMITE_NODES, HERMITE_NODES, |i, j| {
            if i + 1 == j || j + 1 == i {
                (i.max(j) as f64).sqrt()
            } else {
                0.0
            }
        });
        let eigen = nalgebra::SymmetricEigen::new(jacobi);
        std::array::from_fn(|k| (eigen.eigenvalues[k], eigen.eigenvectors[(0, k)].powi(2)))
    })
}
