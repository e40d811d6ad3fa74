//! `e^(−x) I₀(x)` and `e^(−x) I₁(x)` together, fast, for the Bingham normaliser's inner loop.
//!
//! Below 64 the two are polynomials of degree 15 on pieces: [0, 1] and the half octaves
//! [2ᵉ, 1.5·2ᵉ], [1.5·2ᵉ, 2ᵉ⁺¹] (e = 0..5), each in its local variable ξ ∈ [−1, 1] (x itself on
//! [0, 1]). The piece and ξ
//! come from the bits of x: with x = m·2ᵉ, m ∈ [1, 2), the piece is 1 + 2e + (m ≥ 1.5) and
//! ξ = 4m − 5 (or 4m − 7). The coefficients are Chebyshev interpolants computed in 50-digit arithmetic by
//! `tools/fit_scaled_bessel.py`, which also prints their worst relative error in f64 (at most 1.1e-15,
//! most pieces 2e-16). Above 64, the Hankel expansion `√(2πx) e^(−x) I_ν(x) = Σ c_k(ν) x^(−k)` with 16
//! terms (relative error below 1e-16 there). Both are evaluated by Estrin's scheme.

use crate::scaled_bessel_coefficients::{HANKEL_0, HANKEL_0_MINUS_1, I0, I1_OVER_X};
use std::f64::consts::PI;

/// Where the Hankel expansion takes over.
const TAIL: f64 = 64.0;

/// `(e^(−|x|) I₀(x), e^(−|x|) I₁(x))`: both are at most 1 and never overflow; I₁ is odd. NaN gives NaN.
pub fn scaled_i0_i1(x: f64) -> (f64, f64) {
    let a = x.abs();
    let (i0, i1) = if a < TAIL {
        polynomial_pieces(a)
    } else {
        // I₁ is close to I₀ here, so forming it from the difference loses nothing.
        let (i0, difference) = scaled_i0_and_difference(a);
        (i0, i0 - difference)
    };
    (i0, i1.copysign(x))
}

/// `(e^(−a) I₀(a), e^(−a) (I₀(a) − I₁(a)))` for a ≥ 0, the difference to full relative accuracy even
/// where it is a small part of I₀ (it falls like I₀/(2a)): the Hankel tail sums it from exactly
/// differenced coefficients, and below 64 it loses at most 2a ≤ 128 ulp to cancellation.
pub(crate) fn scaled_i0_and_difference(a: f64) -> (f64, f64) {
    if a < TAIL {
        let (i0, i1) = polynomial_pieces(a);
        (i0, i0 - i1)
    } else if a.is_finite() {
        let y = 1.0 / a;
        let scale = 1.0 / (2.0 * PI * a).sqrt();
        (
            scale * estrin(&HANKEL_0, y),
            scale * estrin(&HANKEL_0_MINUS_1, y),
        )
    } else if a.is_nan() {
        (f64::NAN, f64::NAN)
    } else {
        (0.0, 0.0)
    }
}

/// `(e^(−a) I₀(a), e^(−a) I₁(a))` for 0 ≤ a < 64 from the polynomial pieces.
fn polynomial_pieces(a: f64) -> (f64, f64) {
    let (piece, xi) = piece_of(a);
    (estrin(&I0[piece], xi), a * estrin(&I1_OVER_X[piece], xi))
}

/// The polynomial piece holding `a` (0 ≤ a < 64) and the local variable in it: ξ ∈ [−1, 1], or a
/// itself on [0, 1] (so that tiny arguments sum no cancelling terms).
fn piece_of(a: f64) -> (usize, f64) {
    if a < 1.0 {
        return (0, a);
    }
    let bits = a.to_bits();
    // Exponent e ∈ 0..=5 and mantissa m = a / 2ᵉ ∈ [1, 2), both exact.
    #[allow(clippy::cast_possible_truncation)]
    let e = ((bits >> 52) as usize) - 1023;
    let m = f64::from_bits((bits & ((1 << 52) - 1)) | (1023 << 52));
    if m < 1.5 {
        (1 + 2 * e, 4.0 * m - 5.0)
    } else {
        (2 + 2 * e, 4.0 * m - 7.0)
    }
}

/// `Σ cₖ xᵏ` (k < 16) by Estrin's scheme: pairs, then quadruples, then octets, combined with x², x⁴
/// and x⁸, so the additions form a tree four deep instead of Horner's chain of fifteen (2.5x faster
/// here, where every call waits on the previous one's latency). For |x| ≤ 1 and coefficients that
/// decay, as here, its rounding error is that of Horner's rule.
fn estrin(c: &[f64; 16], x: f64) -> f64 {
    let x2 = x * x;
    let x4 = x2 * x2;
    let pair = |i: usize| c[i] + c[i + 1] * x;
    let quad = |i: usize| pair(i) + pair(i + 2) * x2;
    let octet = |i: usize| quad(i) + quad(i + 4) * x4;
    octet(0) + octet(8) * (x4 * x4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::special::{a1, log_i0};

    #[test]
    fn pieces_cover_zero_to_sixty_four() {
        for a in [0.0, 0.5, 1.0, 1.49, 1.5, 1.99, 2.0, 3.0, 47.9, 48.0, 63.99] {
            let (piece, xi) = piece_of(a);
            assert!(
                piece < I0.len() && (-1.0..=1.0).contains(&xi),
                "{a}: {piece} {xi}"
            );
        }
    }

    /// Against the independent power series (to 30) and the summed-to-convergence Hankel expansion,
    /// at 3000 log-spaced points from 1e-8 to 1e6 and at every piece boundary. I₀ is compared through
    /// `exp(ln I₀(x) − x)`, which carries eps·x of error itself; A = I₁/I₀ directly. Measured: worst A
    /// error 1.5e-15, from the fit (up to 1.1e-15) and the evaluation's rounding.
    #[test]
    fn matches_the_series_and_ratio_functions() {
        let boundaries = [
            1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0, 64.0,
        ];
        let logspaced = (0..3000).map(|k| 10f64.powf(-8.0 + 14.0 * f64::from(k) / 2999.0));
        let mut worst_ratio = 0.0_f64;
        for x in logspaced.chain(boundaries) {
            let (i0e, i1e) = scaled_i0_i1(x);
            let expected = (log_i0(x) - x).exp();
            let tolerance = 8.0 * f64::EPSILON * (1.0 + x);
            assert!(((i0e - expected) / expected).abs() <= tolerance, "I0e({x})");
            let relative = (i1e / i0e - a1(x)).abs() / a1(x);
            assert!(relative <= 12.0 * f64::EPSILON, "A({x:e}): {relative:e}");
            worst_ratio = worst_ratio.max(relative);
        }
        eprintln!("scaled_i0_i1: worst relative error of A = I1/I0 {worst_ratio:.1e}");
    }

    #[test]
    fn edges() {
        assert_eq!(scaled_i0_i1(0.0), (1.0, 0.0));
        let (p0, p1) = scaled_i0_i1(3.0);
        let (n0, n1) = scaled_i0_i1(-3.0);
        assert!(p0 == n0 && p1 == -n1);
        assert_eq!(scaled_i0_i1(f64::INFINITY), (0.0, 0.0));
        assert!(scaled_i0_i1(f64::NAN).0.is_nan());
        assert!(scaled_i0_i1(1e300).0 > 0.0);
    }

    /// `1 − A(x)` from the difference keeps its relative accuracy where `1 − a1(x)` cancels; the
    /// values are 1 − I₁(x)/I₀(x) by mpmath at 40 digits.
    #[test]
    fn difference_is_accurate_for_large_arguments() {
        for (x, expected) in [
            (64.0, 0.007_843_506_451_188_803),
            (100.0, 0.005_012_626_994_831_235),
            (1000.0, 0.000_500_125_125_195_719_8),
            (1e4, 0.000_050_001_250_125_019_54),
            (1e6, 5.000_001_250_001_25e-7),
        ] {
            let (i0, difference) = scaled_i0_and_difference(x);
            let relative = (difference / i0 - expected).abs() / expected;
            assert!(relative <= 4.0 * f64::EPSILON, "{x}: {relative:e}");
        }
    }
}
