//! `e^(−x) I₀(x)`, `e^(−x) I₁(x)`, and the two combinations that cancel when formed from them,
//! `e^(−x) (I₀ − I₁)` (the numerator of 1 − A, A = I₁/I₀) and `e^(−2x) (I₀² − I₁² − I₀ I₁ / x)` (the
//! numerator of A′ = 1 − A/x − A²), fast, for the Bingham normaliser's inner loop and the von Mises
//! moments.
//!
//! Below 64 each is a polynomial of degree 15 on a piece: [0, ½] (in x itself), [½, 1] and the quarter
//! octaves [2ᵉ(1 + j/4), 2ᵉ(1 + (j+1)/4)] (e = 0..5, j = 0..3), each in its local variable ξ ∈ [−1, 1].
//! The piece and ξ come from the bits of x: with x = m·2ᵉ, m ∈ [1, 2), the piece is
//! 2 + 4e + ⌊4(m − 1)⌋ and ξ = 8m − 9 − 2⌊4(m − 1)⌋, both exact. The coefficients are Chebyshev
//! interpolants computed in 50-digit arithmetic by `tools/fit_scaled_bessel.py`, which also prints
//! their worst relative error in f64 (at most 3.4e-16 for every table and piece). Above 64, the Hankel
//! expansion `√(2πx) e^(−x) I_ν(x) = Σ c_k(ν) x^(−k)` with 16 terms, and its exact products and
//! differences for the two combinations (relative error below 1e-19 there). All are evaluated by
//! Estrin's scheme.

use crate::scaled_bessel_coefficients::{
    DERIVATIVE_NUMERATOR, HANKEL_0, HANKEL_0_MINUS_1, HANKEL_DERIVATIVE_NUMERATOR, I0, I0_MINUS_I1,
    I1_OVER_X,
};
use std::f64::consts::PI;

/// Where the Hankel expansion takes over.
const TAIL: f64 = 64.0;

/// `(e^(−a) I₀(a), e^(−a) I₁(a))` for finite a ≥ 0: both at most 1, never overflowing.
pub(crate) fn scaled_i0_i1(a: f64) -> (f64, f64) {
    if a < TAIL {
        let (piece, xi) = piece_of(a);
        (estrin(&I0[piece], xi), a * estrin(&I1_OVER_X[piece], xi))
    } else {
        // I₁ is close to I₀ here, so forming it from the difference loses nothing.
        let (i0, difference) = scaled_i0_and_difference(a);
        (i0, i0 - difference)
    }
}

/// `(e^(−a) I₀(a), e^(−a) (I₀(a) − I₁(a)))` for finite a ≥ 0, the difference to full relative accuracy
/// even where it is a small part of I₀ (it falls like I₀/(2a)): it has its own polynomial pieces below
/// 64, and the Hankel tail sums it from exactly differenced coefficients.
pub(crate) fn scaled_i0_and_difference(a: f64) -> (f64, f64) {
    if a < TAIL {
        let (piece, xi) = piece_of(a);
        (estrin(&I0[piece], xi), estrin(&I0_MINUS_I1[piece], xi))
    } else {
        let y = 1.0 / a;
        // √(2π) √a, not √(2πa): 2πa overflows past 2.8e307.
        let scale = 1.0 / ((2.0 * PI).sqrt() * a.sqrt());
        (
            scale * estrin(&HANKEL_0, y),
            scale * estrin(&HANKEL_0_MINUS_1, y),
        )
    }
}

/// `1 − A(a)`, `A = I₁/I₀`, for finite a ≥ 0, to a few ulp (1 − 1/(2a) − … is never formed).
pub(crate) fn one_minus_a1(a: f64) -> f64 {
    if a < TAIL {
        let (i0, difference) = scaled_i0_and_difference(a);
        difference / i0
    } else {
        // The common factor 1/√(2πa) left out: with it the difference underflows past a ≈ 1e200.
        let y = 1.0 / a;
        estrin(&HANKEL_0_MINUS_1, y) / estrin(&HANKEL_0, y)
    }
}

/// `A′(a) = 1 − A/a − A²` for finite a ≥ 0, to a few ulp: the numerator `I₀² − I₁² − I₀ I₁/a` has its
/// own pieces (its power series, ½ Σ_k (2k)!/(k!² (k+1)!²) (a/2)^(2k), has positive terms) and, above
/// 64, its Hankel expansion `y²/2 + 3y³/8 + …` (y = 1/a), whose leading terms cancel exactly in the
/// coefficients instead of in floating point. Below 1e-154 the result is subnormal (A′ ≈ 1/(2a²)).
pub(crate) fn a1_derivative(a: f64) -> f64 {
    if a < TAIL {
        let (piece, xi) = piece_of(a);
        let i0 = estrin(&I0[piece], xi);
        estrin(&DERIVATIVE_NUMERATOR[piece], xi) / (i0 * i0)
    } else {
        let y = 1.0 / a;
        let p0 = estrin(&HANKEL_0, y);
        (y * estrin(&HANKEL_DERIVATIVE_NUMERATOR, y)) * y / (p0 * p0)
    }
}

/// `ln(e^(−a) I₀(a)) = ln I₀(a) − a` for finite a ≥ 0, to a few ulp absolute (−½ ln(2πa) + ln(1 + 1/(8a)
/// + …) above 64): the part of the von Mises log normaliser that is left once κ is taken out.
pub(crate) fn log_scaled_i0(a: f64) -> f64 {
    if a < TAIL {
        let (piece, xi) = piece_of(a);
        estrin(&I0[piece], xi).ln()
    } else {
        -0.5 * ((2.0 * PI).ln() + a.ln()) + estrin(&HANKEL_0, 1.0 / a).ln()
    }
}

/// The polynomial piece holding `a` (0 ≤ a < 64) and the local variable in it: ξ ∈ [−1, 1], or a
/// itself on [0, ½] (so that tiny arguments sum no cancelling terms).
fn piece_of(a: f64) -> (usize, f64) {
    if a < 0.5 {
        return (0, a);
    }
    if a < 1.0 {
        return (1, 4.0 * a - 3.0);
    }
    let bits = a.to_bits();
    // Exponent e ∈ 0..=5 and mantissa m = a / 2ᵉ ∈ [1, 2), both exact; quarter j = ⌊4(m − 1)⌋.
    #[allow(clippy::cast_possible_truncation)]
    let e = ((bits >> 52) as usize) - 1023;
    let m = f64::from_bits((bits & ((1 << 52) - 1)) | (1023 << 52));
    let eight_m = 8.0 * m;
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let j = ((eight_m - 8.0) * 0.5) as usize; // ⌊4(m − 1)⌋ ∈ 0..=3
    (2 + 4 * e + j, eight_m - 9.0 - 2.0 * j as f64)
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
        let mut edges = vec![0.0, 0.25, 0.5, 0.75, 1.0];
        for e in 0..6 {
            for j in 0..4 {
                let lo = f64::from(1 << e) * (1.0 + f64::from(j) / 4.0);
                edges.extend([lo, lo * (1.0 + 1e-15), lo * (1.0 - 1e-15)]);
            }
        }
        edges.push(63.999_999_999_999);
        for a in edges {
            let (piece, xi) = piece_of(a);
            assert!(piece < I0.len(), "{a}: piece {piece}");
            assert!(
                (-1.0..=1.0).contains(&xi) || (piece == 0 && (0.0..0.5).contains(&xi)),
                "{a}: {piece} {xi}"
            );
        }
    }

    /// Against the independent power series (to 30) and the summed-to-convergence Hankel expansion,
    /// at 3000 log-spaced points from 1e-8 to 1e6 and at every piece boundary. I₀ is compared through
    /// `exp(ln I₀(x) − x)`, which carries eps·x of error itself; A = I₁/I₀ directly.
    #[test]
    fn matches_the_series_and_ratio_functions() {
        let boundaries = (0..26).map(|k| {
            if k < 2 {
                0.5 * f64::from(k)
            } else {
                let (e, j) = ((k - 2) / 4, (k - 2) % 4);
                f64::from(1 << e) * (1.0 + f64::from(j) / 4.0)
            }
        });
        let logspaced = (0..3000).map(|k| 10f64.powf(-8.0 + 14.0 * f64::from(k) / 2999.0));
        let mut worst_ratio = 0.0_f64;
        for x in logspaced.chain(boundaries).filter(|&x| x > 0.0) {
            let (i0e, i1e) = scaled_i0_i1(x);
            let expected = (log_i0(x).unwrap() - x).exp();
            let tolerance = 8.0 * f64::EPSILON * (1.0 + x);
            assert!(((i0e - expected) / expected).abs() <= tolerance, "I0e({x})");
            let a = a1(x).unwrap();
            let relative = (i1e / i0e - a).abs() / a;
            assert!(relative <= 8.0 * f64::EPSILON, "A({x:e}): {relative:e}");
            worst_ratio = worst_ratio.max(relative);
        }
        eprintln!("scaled_i0_i1: worst relative error of A = I1/I0 {worst_ratio:.1e}");
    }

    #[test]
    fn edges() {
        assert_eq!(scaled_i0_i1(0.0), (1.0, 0.0));
        assert_eq!(scaled_i0_and_difference(0.0), (1.0, 1.0));
        assert_eq!(a1_derivative(0.0), 0.5);
        assert!(scaled_i0_i1(f64::MAX).0 > 0.0);
        assert!(one_minus_a1(1e300) > 0.0);
        assert!(log_scaled_i0(f64::MAX).is_finite());
    }

    /// `1 − A(x)` and `A′(x)` against mpmath (40 digits, kept to 17) across every method: the first
    /// stays accurate where `1 − a1(x)` cancels, the second where `1 − A/x − A²` does (220x wrong at
    /// 1e9 before).
    #[test]
    #[allow(clippy::excessive_precision)]
    fn difference_and_derivative_are_accurate() {
        for (x, one_minus, derivative) in [
            (1e-3, 0.999_500_000_062_499_99, 0.499_999_812_500_052_08),
            (10.0, 0.051_400_174_045_154_041, 0.005_298_387_602_951_359),
            (
                40.0,
                0.012_580_158_663_649_342,
                0.000_316_560_901_887_325_03,
            ),
            (
                64.0,
                0.007_843_506_451_188_804_1,
                0.000_123_047_097_227_592_82,
            ),
            (
                1000.0,
                0.000_500_125_125_195_719_8,
                5.002_503_757_832_875_6e-7,
            ),
            (1e6, 5.000_001_250_001_25e-7, 5.000_002_500_003_75e-13),
            (1e9, 5.000_000_001_25e-10, 5.000_000_002_5e-19),
        ] {
            let got = one_minus_a1(x);
            assert!(
                ((got - one_minus) / one_minus).abs() <= 4.0 * f64::EPSILON,
                "1 - A({x}) = {got:e}"
            );
            let got = a1_derivative(x);
            assert!(
                ((got - derivative) / derivative).abs() <= 4.0 * f64::EPSILON,
                "A'({x}) = {got:e}, expected {derivative:e}"
            );
        }
    }
}
