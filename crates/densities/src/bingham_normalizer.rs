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
/// rule resolves with its double-exponentially clustered nodes (113 to 881 of them, by the
/// eigenvalue spread; up to a spread of 64, where the integrand is smooth, Gauss-Legendre with 12
/// to 36 nodes; see `LADDER`); Ĩ and A come from [`scaled_i0_i1`](crate::special::scaled_i0_i1)'s
/// polynomial pieces, with `1 − A` summed without cancellation. Every reference case is within 2e-13
/// (ln K) and 1.4e-14 (moments, relative).
pub(crate) fn log_normalizer_and_moments(z: &[f64; 4]) -> (f64, [f64; 4]) {
    let spread = z.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - z.iter().copied().fold(f64::INFINITY, f64::min);
    with_nodes(z, nodes_for_spread(spread))
}

/// [`log_normalizer_and_moments`] by the given rule.
fn with_nodes(z: &[f64; 4], nodes: &[Node]) -> (f64, [f64; 4]) {
    // Sort descending, remembering where each eigenvalue came from.
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&i, &j| z[j].total_cmp(&z[i]));
    let s: [f64; 4] = std::array::from_fn(|k| z[order[k]]);
    let d01 = (s[0] - s[1]) / 2.0;
    let d23 = (s[2] - s[3]) / 2.0;
    let d02 = s[2] - s[0];

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

/// A node of a rule on [0, 1], with `1 − t` formed without cancellation and the log of its weight.
struct Node {
    t: f64,
    one_minus_t: f64,
    ln_weight: f64,
}

/// A rule of the ladder: Gauss-Legendre with this many nodes, or tanh-sinh with step `1/levels`.
#[derive(Clone, Copy, Debug)]
enum Rule {
    GaussLegendre(usize),
    TanhSinh(i32),
}

/// The rule for each range of the eigenvalue spread `z_max − z_min` (up to the first entry's spread),
/// each the cheapest whose ln K and moments were measured, in a double-precision Python model of this
/// integral (scipy's Bessel functions), within 1e-14 of a tanh-sinh rule with step 1/512 over 200
/// random eigenvalue sets and nine fixed shapes per spread (one, two or three large gaps, unit gaps,
/// equal pairs), with a margin of a few nodes; the unit test below checks every rule here.
///
/// Up to a spread of 64 the integrand is an entire function of t growing at most like
/// `e^(spread · |Re t|)` off [0, 1], so Gauss-Legendre converges geometrically: 9, 15 and about 30
/// nodes were enough at spreads 4, 16 and 64. Beyond, the boundary layers of width 1/spread need
/// the tanh-sinh rule's clustering; the layer at t = 1 sits where sinh s ≈ ln(spread)/π in the
/// rule's variable, so the step shrinks slowly as the spread grows: the levels measured as enough
/// were 13 at 1e2, 20 at 1e3, 28 at 1e4, 36 at 1e5, 44 at 1e6, 52 at 1e7, 62 at 1e8, 70 at 1e9,
/// 80 at 1e10, 88 at 1e11 and 100 at 1e12.
const LADDER: [(f64, Rule); 14] = [
    (4.0, Rule::GaussLegendre(12)),
    (16.0, Rule::GaussLegendre(20)),
    (64.0, Rule::GaussLegendre(36)),
    (1e2, Rule::TanhSinh(14)),
    (1e3, Rule::TanhSinh(22)),
    (1e4, Rule::TanhSinh(30)),
    (1e5, Rule::TanhSinh(40)),
    (1e6, Rule::TanhSinh(48)),
    (1e7, Rule::TanhSinh(56)),
    (1e8, Rule::TanhSinh(68)),
    (1e9, Rule::TanhSinh(76)),
    (1e10, Rule::TanhSinh(88)),
    (1e11, Rule::TanhSinh(96)),
    (f64::INFINITY, Rule::TanhSinh(110)),
];

/// The nodes for a spread, each rule built once, on first use.
fn nodes_for_spread(spread: f64) -> &'static [Node] {
    static RULES: [OnceLock<Vec<Node>>; LADDER.len()] = [const { OnceLock::new() }; LADDER.len()];
    let index = LADDER
        .iter()
        .position(|&(limit, _)| spread <= limit)
        .unwrap_or(LADDER.len() - 1);
    RULES[index].get_or_init(|| LADDER[index].1.nodes())
}

impl Rule {
    fn nodes(self) -> Vec<Node> {
        match self {
            Rule::GaussLegendre(n) => gauss_legendre(n),
            Rule::TanhSinh(levels) => tanh_sinh(levels),
        }
    }
}

/// The n-point Gauss-Legendre rule mapped to [0, 1]: `t = (1 + x)/2`, `1 − t = (1 − x)/2` (each
/// without cancellation: the sum is exact near x = −1, the difference near 1), weight `w/2`.
fn gauss_legendre(n: usize) -> Vec<Node> {
    crate::quadrature::legendre_rule(n)
        .into_iter()
        .map(|(x, w)| Node {
            t: 0.5 * (1.0 + x),
            one_minus_t: 0.5 * (1.0 - x),
            ln_weight: (0.5 * w).ln(),
        })
        .collect()
}

/// The nodes of the tanh-sinh rule on [0, 1] with step `1/levels`: `t = 1/(1 + e^(−2y))`,
/// `1 − t = 1/(1 + e^(2y))`, `y = (π/2) sinh(s)`, s = k h for |s| ≤ 4 (`8 levels + 1` nodes),
/// weight `h (π/4) cosh(s) / cosh²(y)`.
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every rule of the ladder, at the top of its range of spreads (1e12, the largest accepted, for
    /// the last), agrees with the tanh-sinh rule of step 1/256 (2 049 nodes) on eigenvalues
    /// `(0, −a, −b, −1) × spread` for a grid of a ≤ b that includes unit gaps, equal pairs and the
    /// extremes: ln K within 1e-14 (relative where |ln K| > 1), every moment within 2e-14 relative.
    #[test]
    fn every_rule_agrees_with_a_fine_rule_at_the_top_of_its_range() {
        let fine = tanh_sinh(256);
        for &(limit, rule) in &LADDER {
            let spread = limit.min(1e12);
            let nodes = rule.nodes();
            let fractions = [
                0.0,
                1.0 / spread,
                1e-3,
                0.1,
                0.37,
                0.5,
                0.61,
                0.9,
                1.0 - 1.0 / spread,
                1.0,
            ];
            for (i, &a) in fractions.iter().enumerate() {
                for &b in &fractions[i..] {
                    let z = [0.0, -a * spread, -b * spread, -spread];
                    let (log_k, moments) = with_nodes(&z, &nodes);
                    let (fine_log_k, fine_moments) = with_nodes(&z, &fine);
                    let log_error = (log_k - fine_log_k).abs() / fine_log_k.abs().max(1.0);
                    assert!(
                        log_error < 1e-14,
                        "{rule:?} at {z:?}: ln K off by {log_error:e}"
                    );
                    for (m, f) in moments.iter().zip(fine_moments) {
                        let error = (m / f - 1.0).abs();
                        assert!(
                            error < 2e-14,
                            "{rule:?} at {z:?}: a moment off by {error:e}"
                        );
                    }
                }
            }
        }
    }
}
