//! Quadrature rules for checking densities independently of their closed forms. They are deliberately
//! the tests' own (not the library's `quadrature` module), so that a bug in the library's rules cannot
//! hide itself in the checks.

use std::f64::consts::PI;

/// Gauss-Legendre nodes and weights on [−1, 1] (Newton on the Legendre recurrence; nodes to full
/// precision, weights within 1e-13 relative up to n = 64, the end weights the least accurate).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let nf = n as f64;
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut derivative = 0.0;
            for _ in 0..100 {
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

/// `∫_0^length f(t) dt` for an integrand peaked at t = 0 with width about `width`: 30-point
/// Gauss-Legendre on geometric panels [0, w], [w, 2w], [2w, 4w], … clipped at `length`.
pub fn integrate_peaked(f: impl Fn(f64) -> f64, width: f64, length: f64) -> f64 {
    let rule = gauss_legendre(30);
    let mut sum = 0.0;
    let (mut a, mut b) = (0.0, width.min(length));
    loop {
        let (mid, half) = (f64::midpoint(a, b), (b - a) / 2.0);
        sum += rule
            .iter()
            .map(|(x, w)| w * half * f(mid + half * x))
            .sum::<f64>();
        if b >= length {
            return sum;
        }
        a = b;
        b = (2.0 * b).min(length);
    }
}

/// `∫_circle f(θ) dθ` by the trapezoid rule on n equispaced points, exponentially accurate for
/// periodic analytic integrands.
pub fn integrate_circle(f: impl Fn(f64) -> f64, n: usize) -> f64 {
    let h = 2.0 * PI / n as f64;
    (0..n).map(|i| f(-PI + h * i as f64)).sum::<f64>() * h
}

/// `ln ∫_circle exp(log_f(θ)) dθ` by the trapezoid rule in log-sum-exp form (no underflow).
pub fn log_integrate_circle(log_f: impl Fn(f64) -> f64, n: usize) -> f64 {
    let h = 2.0 * PI / n as f64;
    let values: Vec<f64> = (0..n).map(|i| log_f(-PI + h * i as f64)).collect();
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    max + (values.iter().map(|v| (v - max).exp()).sum::<f64>() * h).ln()
}

/// Gauss-Hermite rule for the standard normal (weights sum to 1), by the Golub-Welsch eigenproblem.
pub fn gauss_hermite(n: usize) -> Vec<(f64, f64)> {
    let jacobi = nalgebra::DMatrix::<f64>::from_fn(n, n, |i, j| {
        if i + 1 == j || j + 1 == i {
            (i.max(j) as f64).sqrt()
        } else {
            0.0
        }
    });
    let eigen = nalgebra::SymmetricEigen::new(jacobi);
    (0..n)
        .map(|k| (eigen.eigenvalues[k], eigen.eigenvectors[(0, k)].powi(2)))
        .collect()
}
