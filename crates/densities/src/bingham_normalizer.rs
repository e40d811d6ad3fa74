//! The Bingham normaliser on S³ and its gradient, `1F1(½; 2; Z)` for Z = diag(z₀, z₁, z₂, z₃).

use crate::special;

/// `ln K(z)` with `K(z) = E_uniform[exp(Σ zᵢ xᵢ²)]` (against the uniform probability measure on S³),
/// and `∂ ln K / ∂zᵢ = E[xᵢ²]` (the second moments along the eigenvectors), for any real z.
///
/// Writing `x = (cos φ · a, sin φ · b)` with `a, b ∈ S¹` and integrating the two circles out gives the
/// one-dimensional representation, for the pairing {0, 1}, {2, 3} of the sorted eigenvalues
/// z₀ ≥ z₁ ≥ z₂ ≥ z₃:
///
/// `K = e^(z₀) ∫₀¹ e^((1−t)(z₂ − z₀)) Ĩ(t (z₀ − z₁)/2) Ĩ((1−t)(z₂ − z₃)/2) dt`,
///
/// with `Ĩ(x) = e^(−x) I₀(x)` the scaled Bessel function (so the integrand is at most 1), and
/// `∂K/∂z₀,₁ = ∫ (t/2)(1 ± A(u)) …`, `∂K/∂z₂,₃ = ∫ ((1−t)/2)(1 ± A(w)) …` with `A = I₁/I₀`,
/// `u = t (z₀ − z₁)/2`, `w = (1−t)(z₂ − z₃)/2`. The integrand has boundary layers of width 1/|z| at both
/// ends (the exponential at t = 1, the scaled Bessel functions' t^(−½)-like rise), which the tanh-sinh
/// rule resolves with its double-exponentially clustered nodes: step 1/16 (105 nodes) for spreads up
/// to 1e3, 1/32 (209 nodes) up to 1e4 and beyond; every reference case is within 7e-13 (ln K) and 3e-13
/// (moments).
pub(crate) fn log_normalizer_and_moments(z: &[f64; 4]) -> (f64, [f64; 4]) {
    // Sort descending, remembering where each eigenvalue came from.
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&i, &j| z[j].total_cmp(&z[i]));
    let s: [f64; 4] = std::array::from_fn(|k| z[order[k]]);
    let d01 = (s[0] - s[1]) / 2.0;
    let d23 = (s[2] - s[3]) / 2.0;
    let d02 = s[2] - s[0];

    // Eigenvalue spreads up to 1e3 need step 1/16 (measured ≤ 5e-12), up to 1e4 step 1/32 (≤ 7e-13).
    let spread = s[0] - s[3];
    let levels = if spread <= 1e3 { 16 } else { 32 };
    // The exponential factor of every node first: the Bessel factors lie in [1/√(2πx+1), 1], so nodes
    // whose weight × exponential is below 1e-22 of the largest cannot move the result by 1e-16.
    let mut largest = 0.0_f64;
    tanh_sinh(levels, |_, one_minus_t, w| {
        largest = largest.max(w * (one_minus_t * d02).exp());
    });
    let threshold = 1e-22 * largest;
    let mut total = 0.0;
    let mut moments = [0.0; 4];
    tanh_sinh(levels, |t, one_minus_t, w| {
        let weight = w * (one_minus_t * d02).exp();
        if weight < threshold {
            return;
        }
        let (iu, au) = special::scaled_i0_and_a1(t * d01);
        let (iv, av) = special::scaled_i0_and_a1(one_minus_t * d23);
        let g = weight * iu * iv;
        total += g;
        moments[0] += g * t * 0.5 * (1.0 + au);
        moments[1] += g * t * 0.5 * (1.0 - au);
        moments[2] += g * one_minus_t * 0.5 * (1.0 + av);
        moments[3] += g * one_minus_t * 0.5 * (1.0 - av);
    });
    let mut out = [0.0; 4];
    for k in 0..4 {
        out[order[k]] = moments[k] / total;
    }
    (s[0] + total.ln(), out)
}

/// Calls `f(t, 1 − t, weight)` at the nodes of the tanh-sinh rule on [0, 1] with step `1/levels`:
/// `t = 1/(1 + e^(−2y))`, `1 − t = 1/(1 + e^(2y))`, `y = (π/2) sinh(s)`, s = k h for |s| ≤ 3.25,
/// weight `h (π/4) cosh(s) / cosh²(y)`. Both t and 1 − t are formed without cancellation.
fn tanh_sinh(levels: i32, mut f: impl FnMut(f64, f64, f64)) {
    let h = 1.0 / f64::from(levels);
    let limit = levels * 13 / 4; // s up to 3.25
    for k in -limit..=limit {
        let s = f64::from(k) * h;
        let y = std::f64::consts::FRAC_PI_2 * s.sinh();
        let t = 1.0 / (1.0 + (-2.0 * y).exp());
        let one_minus_t = 1.0 / (1.0 + (2.0 * y).exp());
        let cosh_y = y.cosh();
        let weight = h * std::f64::consts::FRAC_PI_4 * s.cosh() / (cosh_y * cosh_y);
        f(t, one_minus_t, weight);
    }
}
