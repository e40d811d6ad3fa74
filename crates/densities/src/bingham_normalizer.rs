//! The Bingham normaliser on S³ and its gradient, `1F1(½; 2; Z)` for Z = diag(z₀, z₁, z₂, z₃).

use crate::scaled_bessel::scaled_i0_and_difference;
use std::sync::OnceLock;

/// `ln K(z) − max z` with `K(z) = E_uniform[exp(Σ zᵢ xᵢ²)]` (against the uniform probability measure on
/// S³), and `∂ ln K / ∂zᵢ = E[xᵢ²]` (the second moments along the eigenvectors), for finite z whose
/// spread is representable (the callers check both). The largest eigenvalue is left out so that log
/// densities `Σ (zᵢ − z₀) uᵢ² − (ln K − z₀)` never subtract numbers of its size.
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
/// rule resolves with its double-exponentially clustered nodes (53 to 833 of them, by the eigenvalue
/// spread, see `nodes_for_spread`); Ĩ and A come from [`scaled_i0_i1`](crate::special::scaled_i0_i1)'s
/// polynomial pieces, with `1 − A` summed without cancellation. Every reference case is within 2e-13
/// (ln K) and 1.4e-14 (moments, relative).
pub(crate) fn log_normalizer_and_moments(z: &[f64; 4]) -> (f64, [f64; 4]) {
    // Sort descending, remembering where each eigenvalue came from.
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&i, &j| z[j].total_cmp(&z[i]));
    let s: [f64; 4] = std::array::from_fn(|k| z[order[k]]);
    let d01 = (s[0] - s[1]) / 2.0;
    let d23 = (s[2] - s[3]) / 2.0;
    let d02 = s[2] - s[0];

    let nodes = nodes_for_spread(s[0] - s[3]);
    // The log of weight × exponential at every node first (no exp): the Bessel factors lie in
    // [1/√(2πx+1), 1], so nodes more than 50.7 below the largest (a factor 1e-22) cannot move the result
    // by 1e-16, and the largest becomes the scale that keeps every exponential at most 1.
    let largest = nodes
        .iter()
        .map(|n| n.ln_weight + n.one_minus_t * d02)
        .fold(f64::NEG_INFINITY, f64::max);
    let threshold = largest - 50.7;
    let mut total = 0.0;
    let mut moments = [0.0; 4];
    for n in nodes {
        let exponent = n.ln_weight + n.one_minus_t * d02;
        if exponent < threshold {
            continue;
        }
        let (iu, du) = scaled_i0_and_difference(n.t * d01);
        let (iw, dw) = scaled_i0_and_difference(n.one_minus_t * d23);
        let factor = (exponent - largest).exp();
        let g = factor * iu * iw;
        total += g;
        // (1 ± A) I₀ = 2 I₀ − (I₀ − I₁) or I₀ − I₁, each without cancellation.
        let half_t = 0.5 * n.t * factor * iw;
        let half_one_minus_t = 0.5 * n.one_minus_t * factor * iu;
        moments[0] += half_t * (2.0 * iu - du);
        moments[1] += half_t * du;
        moments[2] += half_one_minus_t * (2.0 * iw - dw);
        moments[3] += half_one_minus_t * dw;
    }
    let mut out = [0.0; 4];
    for k in 0..4 {
        out[order[k]] = moments[k] / total;
    }
    (largest + total.ln(), out)
}

/// A node of the tanh-sinh rule on [0, 1], with `1 − t` formed without cancellation and the log of
/// its weight.
struct Node {
    t: f64,
    one_minus_t: f64,
    ln_weight: f64,
}

/// The rule for an eigenvalue spread `z_max − z_min`, each step the coarsest whose ln K and moments
/// were measured (300 random eigenvalue sets per spread, against the rule with half the step) within
/// 1e-14: step 1/8 (53 nodes) to 10, 1/16 (105 nodes) to 300, 1/32 (209 nodes) to 3e4, 1/64 (417
/// nodes) to 1e8, 1/128 (833 nodes) beyond. The boundary layer at t = 1 has width 1/spread; in the
/// rule's variable it sits where sinh s ≈ ln(spread)/π, and the step there must shrink as that
/// grows: at 1e9, 1/64 agrees with 1/512 to 2e-13 (moments), at 1e12 to 1.4e-14 only at 1/96;
/// 1/128 agrees with 1/512 to 5e-15 up to 1e14 and 2.4e-14 at 1e16.
fn nodes_for_spread(spread: f64) -> &'static [Node] {
    static RULES: OnceLock<[Vec<Node>; 5]> = OnceLock::new();
    let [h8, h16, h32, h64, h128] = RULES.get_or_init(|| {
        [
            tanh_sinh(8),
            tanh_sinh(16),
            tanh_sinh(32),
            tanh_sinh(64),
            tanh_sinh(128),
        ]
    });
    if spread <= 10.0 {
        h8
    } else if spread <= 300.0 {
        h16
    } else if spread <= 3e4 {
        h32
    } else if spread <= 1e8 {
        h64
    } else {
        h128
    }
}

/// The nodes of the tanh-sinh rule on [0, 1] with step `1/levels`: `t = 1/(1 + e^(−2y))`,
/// `1 − t = 1/(1 + e^(2y))`, `y = (π/2) sinh(s)`, s = k h for |s| ≤ 4, weight
/// `h (π/4) cosh(s) / cosh²(y)`.
fn tanh_sinh(levels: i32) -> Vec<Node> {
    let h = 1.0 / f64::from(levels);
    // s up to 4, where 1 − t = e^(−86): the part of [0, 1] left out must be negligible next to K,
    // which is as small as 1/spread (with s up to 3.25 it was 2.3e-18 wide, a relative error of
    // 2e-12 at spread 1e6, where the integrand is still 1 at the end of the interval).
    let limit = levels * 4;
    (-limit..=limit)
        .map(|k| {
            let s = f64::from(k) * h;
            let y = std::f64::consts::FRAC_PI_2 * s.sinh();
            let cosh_y = y.cosh();
            Node {
                t: 1.0 / (1.0 + (-2.0 * y).exp()),
                one_minus_t: 1.0 / (1.0 + (2.0 * y).exp()),
                ln_weight: (h * std::f64::consts::FRAC_PI_4 * s.cosh() / (cosh_y * cosh_y)).ln(),
            }
        })
        .collect()
}
