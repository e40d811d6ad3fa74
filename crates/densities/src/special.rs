//! Special functions: modified Bessel functions of the first kind in log form and as ratios, the
//! inverse of A(κ) = I₁(κ)/I₀(κ), and the von Mises-Fisher functions on S².
//!
//! **Domain.** Every function takes κ ∈ [0, f64::MAX] (−0 counts as 0) and returns
//! [`DensityError::NonFinite`] for NaN or ±∞ and [`DensityError::OutOfRange`] for κ < 0, before any
//! series is summed; orders n of [`bessel_ratio`] go up to [`MAX_ORDER`]. Inside the domain every
//! result is finite (ln I₁(0) = −∞ is the one exact infinity) and every loop has a fixed bound.
//!
//! **Accuracy.** A few ulp (relative error ≤ 1e-13, most values within 4 ulp, checked against
//! 50-digit reference values) from κ = 0 (and subnormal κ) to 1e6 and beyond. No function overflows:
//! the Bessel functions themselves (I₀(1e6) ≈ e^(10⁶)) are never formed.
//!
//! Methods, by range:
//!
//! * κ ≤ 30: the power series `I_ν(κ) = (κ/2)^ν Σ_k (κ²/4)^k / (k! (k+ν)!)`. Its terms are positive,
//!   so it has no cancellation; log I₀ is taken as `ln_1p` of the series minus its first term, which
//!   keeps full relative accuracy as κ → 0 (log I₀(κ) ≈ κ²/4).
//! * κ > 30: the Hankel asymptotic expansion
//!   `I_ν(κ) = e^κ / √(2πκ) · Σ_k c_k(ν) κ^(−k)`, `c_k/c_(k−1) = ((2k−1)² − 4ν²) / (8k)`, summed until
//!   the terms fall below machine precision (they do long before the series starts to diverge, near
//!   k ≈ 2κ). Ratios I_n/I₀ are ratios of these sums, so e^κ cancels exactly.
//! * `In/I₀` for κ > 30 and orders with 2n² > κ (where the asymptotic expansion is slow): Miller's
//!   backward recurrence, normalised by the asymptotic ratio at the highest order it handles (forward
//!   recurrence would amplify errors by e^(n²/κ)).
//! * [`one_minus_a1`], [`a1_derivative`], [`log_i0_scaled`] and [`scaled_i0_i1`]: polynomial pieces
//!   to 64 and 16 Hankel terms beyond, for the combinations that cancel when formed from A
//!   (1 − A, 1 − A/κ − A², ln I₀ − κ); about 10 ns each.
//! * [`bingham_log_normalizer_and_moments`]: the Bingham normaliser on S³ and its gradient, a
//!   one-dimensional integral of these (see `Bingham`).
//!
//! **The standard normal distribution.** [`normal_cdf`] Φ and [`log_normal_mass`]
//! `ln[Φ(b) − Φ(a)]` take any x on the extended real line (Φ(−∞) = 0, Φ(∞) = 1) and are infallible
//! (a hot path of the particle filters); like f64's own functions they return NaN for a NaN
//! argument. Φ is `erfc(−x/√2)/2` (libm's erfc), so its lower tail never forms 1 − small: relative
//! error below `2e-16 (1 + x²)` down to Φ(−37.5) ≈ 4.6e-308, the smallest normal f64 (the rounding
//! of x/√2 times Φ's condition number x²; measured 1.4e-13 at −37.5, 8.9e-15 at −10, 1.8e-16 at
//! −1), checked against 50-digit values.

use crate::error::{DensityError, finite};
use crate::scaled_bessel;
use std::f64::consts::PI;

/// The highest order [`bessel_ratio`] accepts (and [`VonMises::trigonometric_moment`](crate::VonMises)
/// with it): the backward recurrence it may run costs about one step per order, so the bound keeps a
/// call under a millisecond.
pub const MAX_ORDER: u32 = 100_000;

/// Largest κ for which the power series is used.
const SERIES_LIMIT: f64 = 30.0;

/// The factor by which a growing power series is scaled down.
const RESCALE: f64 = 1e280;

/// Bound on the terms of every series here: each converges in far fewer (the power series in about 60
/// terms at κ = 30, the Hankel sums in under 60 above 30).
const MAX_TERMS: u32 = 500;

/// Checks that κ is a finite non-negative number (−0 becomes 0).
pub(crate) fn concentration(what: &'static str, kappa: f64) -> Result<f64, DensityError> {
    finite(what, kappa)?;
    if kappa < 0.0 {
        return Err(DensityError::OutOfRange {
            what,
            value: kappa,
            range: "[0, f64::MAX]",
        });
    }
    Ok(kappa.abs())
}

/// Power series of `I_ν(κ) / ((κ/2)^ν / ν!)`, that is `Σ_k (κ²/4)^k ν! / (k! (k+ν)!)`, minus its first
/// term (which is 1), returned as `(sum − 1, rescalings)`: the sum is divided by [`RESCALE`] whenever
/// it grows past it, so that for large κ only its logarithm, `ln(tail) + rescalings · ln(RESCALE)`,
/// is meaningful. For 0 ≤ κ ≤ 30.
fn power_series_tail(nu: u32, kappa: f64) -> (f64, i32) {
    let q = kappa * kappa / 4.0;
    let nu = f64::from(nu);
    let mut term = 1.0;
    let mut tail = 0.0;
    let mut rescalings = 0;
    for k in 1..=MAX_TERMS {
        let k = f64::from(k);
        term *= q / (k * (k + nu));
        tail += term;
        if term <= f64::EPSILON * 0.25 * (1.0 + tail) {
            break;
        }
        if tail > RESCALE {
            tail /= RESCALE;
            term /= RESCALE;
            rescalings += 1;
        }
    }
    (tail, rescalings)
}

/// The Hankel asymptotic sum `Σ_k c_k(ν) κ^(−k)` (c₀ = 1), for κ > 30 and 2ν² ≤ κ.
fn asymptotic_sum(nu: u32, kappa: f64) -> f64 {
    let four_nu2 = 4.0 * f64::from(nu) * f64::from(nu);
    let mut term = 1.0_f64;
    let mut sum = 1.0;
    for k in 1..=MAX_TERMS {
        let k = f64::from(k);
        let next = term * ((2.0 * k - 1.0).powi(2) - four_nu2) / (8.0 * k * kappa);
        if next.abs() >= term.abs() && k > 1.0 {
            break; // smallest term reached: the expansion's best value
        }
        term = next;
        sum += term;
        if term.abs() <= f64::EPSILON * 0.25 * sum.abs() {
            break;
        }
    }
    sum
}

/// `ln(√(2πκ))` without forming 2πκ (which overflows past 2.8e307).
fn log_sqrt_two_pi(kappa: f64) -> f64 {
    0.5 * ((2.0 * PI).ln() + kappa.ln())
}

/// `ln I₀(κ)` for valid κ.
pub(crate) fn ln_i0(kappa: f64) -> f64 {
    if kappa <= SERIES_LIMIT {
        power_series_tail(0, kappa).0.ln_1p()
    } else {
        kappa - log_sqrt_two_pi(kappa) + asymptotic_sum(0, kappa).ln()
    }
}

/// `ln I₀(κ)`: `κ²/4 + O(κ⁴)` near 0 (to full relative accuracy), `κ − ½ ln(2πκ) + O(1/κ)` for large κ.
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX] (see the module docs).
///
/// # Example
/// ```
/// use liebayes_densities::special::log_i0;
/// // I₀(0) = 1; I₀(1) = 1.2660658777520084 (Abramowitz & Stegun table 9.8).
/// assert_eq!(log_i0(0.0).unwrap(), 0.0);
/// assert!((log_i0(1.0).unwrap() - 1.266_065_877_752_008_4_f64.ln()).abs() < 1e-15);
/// // No overflow where I₀ itself would: ln I₀(κ) ≈ κ − ½ ln(2πκ).
/// let k = 1e6;
/// assert!((log_i0(k).unwrap() - (k - 0.5 * (2.0 * std::f64::consts::PI * k).ln())).abs() < 1e-6);
/// assert!(log_i0(-1.0).is_err());
/// ```
pub fn log_i0(kappa: f64) -> Result<f64, DensityError> {
    concentration("kappa", kappa).map(ln_i0)
}

/// `ln I₀(κ) − κ = ln(e^(−κ) I₀(κ))`, to a few ulp **absolute** (it lies in [−½ ln(2πκ) − …, 0]):
/// the part of the von Mises log normaliser left once κ is taken out, so that log densities
/// `κ (cos d − 1) − ln 2π − (ln I₀(κ) − κ)` never subtract numbers of size κ.
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn log_i0_scaled(kappa: f64) -> Result<f64, DensityError> {
    concentration("kappa", kappa).map(scaled_bessel::log_scaled_i0)
}

/// `ln I₁(κ)`; `−∞` at κ = 0 (the one exact infinity of this module), `ln(κ/2)` for subnormal κ.
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn log_i1(kappa: f64) -> Result<f64, DensityError> {
    let kappa = concentration("kappa", kappa)?;
    Ok(if kappa == 0.0 {
        f64::NEG_INFINITY
    } else if kappa <= SERIES_LIMIT {
        // ln κ − ln 2, not ln(κ/2): κ/2 rounds to 0 for κ = 5e-324.
        kappa.ln() - std::f64::consts::LN_2 + power_series_tail(1, kappa).0.ln_1p()
    } else {
        kappa - log_sqrt_two_pi(kappa) + asymptotic_sum(1, kappa).ln()
    })
}

/// `A(κ) = I₁(κ)/I₀(κ)` for valid κ.
pub(crate) fn mean_resultant(kappa: f64) -> f64 {
    ratio(1, kappa)
}

/// `A(κ) = I₁(κ)/I₀(κ)`, the mean resultant length of a von Mises distribution: κ/2 − κ³/16 + … near
/// 0, 1 − 1/(2κ) − … for large κ. Where 1 − A matters (large κ), use [`one_minus_a1`].
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
///
/// # Example
/// ```
/// use liebayes_densities::special::a1;
/// // A(κ) = I₁(κ)/I₀(κ): κ/2 for small κ, 1 − 1/(2κ) for large κ.
/// assert!((a1(1e-4).unwrap() - 5e-5).abs() < 1e-12);
/// assert!((a1(1e4).unwrap() - (1.0 - 0.5e-4)).abs() < 1e-8);
/// ```
pub fn a1(kappa: f64) -> Result<f64, DensityError> {
    concentration("kappa", kappa).map(mean_resultant)
}

/// `1 − A(κ) = (I₀ − I₁)/I₀`, the circular variance of a von Mises distribution, to a few ulp relative
/// at every κ (1/(2κ) + 1/(8κ²) + … for large κ, where `1 − a1(κ)` keeps only 16 − log₁₀(2κ) digits).
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn one_minus_a1(kappa: f64) -> Result<f64, DensityError> {
    concentration("kappa", kappa).map(scaled_bessel::one_minus_a1)
}

/// `I₂(κ)/I₀(κ)`: κ²/8 near 0, 1 − 2/κ + … for large κ.
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn a2(kappa: f64) -> Result<f64, DensityError> {
    bessel_ratio(2, kappa)
}

/// `I_n(κ)/I₀(κ)` for κ ≥ 0 and orders n ≤ [`MAX_ORDER`]: the n-th trigonometric moment
/// `E[cos n(θ − μ)]` of a von Mises distribution. It underflows to 0 where it is below 1e-308
/// (orders far beyond √κ and κ).
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX]; [`DensityError::OutOfRange`] for n > [`MAX_ORDER`].
pub fn bessel_ratio(n: u32, kappa: f64) -> Result<f64, DensityError> {
    let kappa = concentration("kappa", kappa)?;
    check_order(n)?;
    Ok(ratio(n, kappa))
}

/// Checks an order against [`MAX_ORDER`].
pub(crate) fn check_order(n: u32) -> Result<(), DensityError> {
    if n > MAX_ORDER {
        return Err(DensityError::OutOfRange {
            what: "order n",
            value: f64::from(n),
            range: "[0, 100000] (special::MAX_ORDER)",
        });
    }
    Ok(())
}

/// `I_n(κ)/I₀(κ)` for valid κ and n ≤ [`MAX_ORDER`].
pub(crate) fn ratio(n: u32, kappa: f64) -> f64 {
    if n == 0 {
        return 1.0;
    }
    if kappa == 0.0 {
        return 0.0;
    }
    if kappa > SERIES_LIMIT {
        // Largest order the asymptotic expansion handles fast and exactly: 2n² ≤ κ.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let top = (kappa / 2.0).sqrt().floor().min(f64::from(MAX_ORDER)) as u32;
        if n <= top {
            return asymptotic_sum(n, kappa) / asymptotic_sum(0, kappa);
        }
        return backward_recurrence_ratio(n, top, kappa);
    }
    // (κ/2)^n / n! · (1 + tail_n) / (1 + tail_0), in logarithms: each factor can over- or underflow
    // where the ratio does not.
    let (tail_n, rescalings_n) = power_series_tail(n, kappa);
    let (tail_0, rescalings_0) = power_series_tail(0, kappa);
    if rescalings_n == 0 && n <= 32 {
        // No overflow (the prefactor is at most 15³²/32! ≈ 160), and an underflow of the decreasing
        // product is that of the result (the series ratio is at most 1): the product directly,
        // without the eps · |ln(κ/2)| that exp(ln …) would add for small κ (1.5e-13 at κ = 1e-300).
        let prefactor: f64 = (1..=n).map(|k| kappa / 2.0 / f64::from(k)).product();
        return prefactor * (1.0 + tail_n) / (1.0 + tail_0);
    }
    // ln((κ/2)^n / n!), stopping once it is so negative that the ratio underflows (the series factor
    // is below e^(κ²/4) ≤ e^225 here): at most a few hundred terms for κ ≤ 30.
    let log_half = (kappa / 2.0).ln();
    let mut log_prefactor = 0.0;
    for k in 1..=n {
        log_prefactor += log_half - f64::from(k).ln();
        if log_prefactor < -1000.0 {
            return 0.0;
        }
    }
    let log_series = |tail: f64, rescalings: i32| {
        if rescalings == 0 {
            tail.ln_1p()
        } else {
            // Rescaled sums: the leading 1 is negligible next to tails past 1e280.
            tail.ln() + f64::from(rescalings) * RESCALE.ln()
        }
    };
    (log_prefactor + log_series(tail_n, rescalings_n) - log_series(tail_0, rescalings_0)).exp()
}

/// `Aₙ` for κ > 30 and n above `top` (the highest order with 2·top² ≤ κ), by Miller's backward
/// recurrence `v_(k−1) = v_(k+1) + (2k/κ) v_k` from `v_(N+1) = 0, v_N = 1`, normalised by the asymptotic
/// `A_top`. The recurrence is stable downwards (I_k is its minimal solution); the error of the arbitrary
/// start decays like e^(−(N² − n²)/κ), so N = √(n² + 40κ) + 10 leaves less than e^(−40). With
/// n ≤ [`MAX_ORDER`] and κ < 2n², N − top is below 7n: a bounded number of steps.
fn backward_recurrence_ratio(n: u32, top: u32, kappa: f64) -> f64 {
    let nf = f64::from(n);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let start = ((nf * nf + 40.0 * kappa).sqrt().ceil() + 10.0) as u32;
    let (mut above, mut current) = (0.0_f64, 1.0_f64); // v_(k+1), v_k with k = start
    let mut at_n = if start == n { 1.0 } else { 0.0 };
    for k in (top + 1..=start).rev() {
        let below = above + 2.0 * f64::from(k) / kappa * current;
        above = current;
        current = below;
        if k - 1 == n {
            at_n = current;
        }
        if current > 1e250 {
            above *= 1e-250;
            current *= 1e-250;
            at_n *= 1e-250;
        }
    }
    // `current` is now v_top.
    at_n / current * (asymptotic_sum(top, kappa) / asymptotic_sum(0, kappa))
}

/// `A′(κ) = dA/dκ = 1 − A/κ − A²` (½ at κ = 0, 1/(2κ²) + 1/(4κ³) + … for large κ): the variance of
/// cos(θ − μ) under a von Mises distribution and its Fisher information in κ. Accurate to a few ulp at
/// every κ (the formula itself cancels: it was 220x wrong at κ = 1e9); see [`scaled_i0_i1`]'s methods.
/// The value is below the smallest normal number (and then loses relative accuracy, down to 0) for
/// κ above about 1.5e154.
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn a1_derivative(kappa: f64) -> Result<f64, DensityError> {
    concentration("kappa", kappa).map(scaled_bessel::a1_derivative)
}

/// The κ ≥ 0 with `A(κ) = I₁(κ)/I₀(κ) = r`, for r in [0, 1): the maximum-likelihood concentration of a
/// von Mises distribution whose sample mean resultant length is r. Finite for every r < 1: the largest
/// f64 below 1 gives κ ≈ 4.5e15.
///
/// Newton's method, at most 60 steps (it takes 3 to 6): for r < ½ on `A(κ) = r` from
/// `r (2 − r²)/(1 − r²)`; for r ≥ ½ on `1/(1 − A(κ)) = 1/d`, d = 1 − r (exact there), a nearly linear
/// function (2κ + ½ + O(1/κ)), from Best and Fisher's `1/(r d (2 + d))`, and for d < 1e-9
/// (κ above about 5e8) the asymptotic inverse `1/(2d) + ¼`, exact to rounding there. All use the
/// accurate 1 − A and A′, so the result is accurate to a few ulp **given r**: its relative condition
/// number with respect to d is close to 1, while with respect to r it is about 2κ (so an r rounded
/// from a decimal value carries that error).
///
/// # Errors
/// [`DensityError::OutOfRange`] unless `0 ≤ r < 1`.
///
/// # Example
/// ```
/// use liebayes_densities::special::{a1, a1_inverse};
/// // A⁻¹ inverts A = I₁/I₀, the von Mises mean resultant length.
/// for kappa in [0.01, 1.0, 30.0, 1e4] {
///     let r = a1(kappa).unwrap();
///     assert!((a1_inverse(r).unwrap() / kappa - 1.0).abs() < 1e-9);
/// }
/// assert!(a1_inverse(1.0).is_err());
/// ```
pub fn a1_inverse(r: f64) -> Result<f64, DensityError> {
    if !(0.0..1.0).contains(&r) {
        return Err(DensityError::OutOfRange {
            what: "mean resultant length r",
            value: r,
            range: "[0, 1)",
        });
    }
    Ok(a1_inverse_valid(r))
}

/// [`a1_inverse`] for r in [0, 1).
pub(crate) fn a1_inverse_valid(r: f64) -> f64 {
    if r == 0.0 {
        return 0.0;
    }
    if r >= 0.5 {
        return a1_inverse_of_complement(1.0 - r);
    }
    newton(r * (2.0 - r * r) / (1.0 - r * r), |kappa| {
        (mean_resultant(kappa) - r) / scaled_bessel::a1_derivative(kappa)
    })
}

/// Below this d = 1 − A(κ) (κ above about 5e8), [`a1_inverse_of_complement`] takes the asymptotic
/// inverse `1/(2d) + ¼`, whose relative error `3/(16κ²)` is then below 7.5e-19, far below rounding.
/// (Newton's step has the denominator `d A′(κ) ≈ 1/(2κ³)`, which underflows from κ ≈ 1e103 on: it
/// returned κ twice too large at 1e110 and 1e18 times too small at 1e300.)
const ASYMPTOTIC_COMPLEMENT: f64 = 1e-9;

/// The κ with `1 − A(κ) = d`, for d in (0, ½]:
///
/// * d < 1e-9: `κ = 1/(2d) + ¼`, from inverting `d = 1/(2κ) + 1/(8κ²) + 1/(8κ³) + …`
///   (`κ = 1/(2d) + ¼ + 3/(16κ) + …`), exact to rounding there;
/// * above: Newton's method on the nearly linear `1/(1 − A(κ))` from `1/(r d (2 + d))`, r = 1 − d
///   (Best and Fisher's approximation), at most 60 steps.
///
/// Both are accurate to a few ulp given d, so the switch leaves no step beyond rounding. Finite for
/// d above 2.8e-309 (the result's limit f64::MAX).
pub(crate) fn a1_inverse_of_complement(d: f64) -> f64 {
    if d < ASYMPTOTIC_COMPLEMENT {
        return 0.5 / d + 0.25;
    }
    let r = 1.0 - d;
    newton(1.0 / (r * d * (2.0 + d)), |kappa| {
        // h(κ) = 1/D(κ) with D = 1 − A, h′ = A′/D²: the step (h − 1/d)/h′ = D (d − D)/(d A′).
        let big_d = scaled_bessel::one_minus_a1(kappa);
        big_d * (d - big_d) / (d * scaled_bessel::a1_derivative(kappa))
    })
}

/// Newton's method on a positive κ from `start`, `κ ← κ − step(κ)` (kept positive by
/// [`newton_next`]), until a step changes κ by at most 2ε relative, at most 60 steps.
fn newton(start: f64, step: impl Fn(f64) -> f64) -> f64 {
    let mut kappa = start;
    for _ in 0..60 {
        let next = newton_next(kappa, step(kappa));
        let done = (next - kappa).abs() <= 2.0 * f64::EPSILON * next;
        kappa = next;
        if done {
            break;
        }
    }
    kappa
}

/// A Newton step kept positive: halving instead of stepping past 0.
fn newton_next(kappa: f64, step: f64) -> f64 {
    if kappa - step > 0.0 {
        kappa - step
    } else {
        kappa / 2.0
    }
}

/// `coth κ − 1/κ` for valid κ.
pub(crate) fn vmf_mean_resultant_valid(kappa: f64) -> f64 {
    if kappa < 0.25 {
        // 2^(2n) B_(2n) / (2n)!, n = 1..=8
        const C: [f64; 8] = [
            1.0 / 3.0,
            -1.0 / 45.0,
            2.0 / 945.0,
            -1.0 / 4725.0,
            2.0 / 93555.0,
            -1382.0 / 638_512_875.0,
            4.0 / 18_243_225.0,
            -3617.0 / 162_820_783_125.0,
        ];
        let k2 = kappa * kappa;
        let poly = C.iter().rev().fold(0.0, |acc, c| acc * k2 + c);
        kappa * poly
    } else {
        1.0 / kappa.tanh() - 1.0 / kappa
    }
}

/// `coth κ − 1/κ`: the mean resultant length `E[μ·x]` of a von Mises-Fisher distribution on S², κ/3
/// near 0, 1 − 1/κ for large κ.
///
/// Below κ = 0.25 the series `Σ 2^(2n) B_(2n) κ^(2n−1) / (2n)!` (ratio ≈ (κ/π)², eight terms reach
/// 1e-18); above, the closed form loses at most `3/κ² · eps` ≤ 48 eps to cancellation.
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn vmf_mean_resultant(kappa: f64) -> Result<f64, DensityError> {
    concentration("kappa", kappa).map(vmf_mean_resultant_valid)
}

/// `d/dκ (coth κ − 1/κ) = 1/κ² − 1/sinh² κ` for valid κ, in (0, ⅓]: the series differentiated term by
/// term below κ = 0.25 (where the closed form cancels), the closed form above (0 past κ ≈ 1e154).
fn vmf_mean_resultant_derivative(kappa: f64) -> f64 {
    if kappa < 0.25 {
        // (2n − 1) 2^(2n) B_(2n) / (2n)!, n = 1..=8
        const C: [f64; 8] = [
            1.0 / 3.0,
            -3.0 / 45.0,
            10.0 / 945.0,
            -7.0 / 4725.0,
            18.0 / 93555.0,
            -11.0 * 1382.0 / 638_512_875.0,
            52.0 / 18_243_225.0,
            -15.0 * 3617.0 / 162_820_783_125.0,
        ];
        let k2 = kappa * kappa;
        C.iter().rev().fold(0.0, |acc, c| acc * k2 + c)
    } else {
        let s = kappa.sinh();
        1.0 / (kappa * kappa) - 1.0 / (s * s)
    }
}

/// The inverse of [`vmf_mean_resultant`]: the κ ≥ 0 with `coth κ − 1/κ = r`, the maximum-likelihood
/// concentration of a von Mises-Fisher distribution on S² whose samples have mean resultant length
/// r. Newton's method from Banerjee et al.'s approximation `r (3 − r²)/(1 − r²)` below r = ½; above,
/// on the nearly linear `1/(1 − A₃(κ))` against `1/(1 − r)` (so that r near 1, κ up to 4.5e15, keeps
/// its digits), at most 60 steps each. Relative error below 1e-13 over κ from 1e-300 to 4.5e15.
///
/// # Errors
/// [`DensityError::OutOfRange`] unless `0 ≤ r < 1`.
///
/// # Example
/// ```
/// use liebayes_densities::special::{vmf_mean_resultant, vmf_mean_resultant_inverse};
/// for kappa in [1e-3, 1.0, 30.0, 1e6] {
///     let r = vmf_mean_resultant(kappa).unwrap();
///     assert!((vmf_mean_resultant_inverse(r).unwrap() / kappa - 1.0).abs() < 1e-9);
/// }
/// assert!(vmf_mean_resultant_inverse(1.0).is_err());
/// ```
pub fn vmf_mean_resultant_inverse(r: f64) -> Result<f64, DensityError> {
    if !(0.0..1.0).contains(&r) {
        return Err(DensityError::OutOfRange {
            what: "mean resultant length r",
            value: r,
            range: "[0, 1)",
        });
    }
    if r == 0.0 {
        return Ok(0.0);
    }
    if r < 0.5 {
        return Ok(newton(r * (3.0 - r * r) / (1.0 - r * r), |kappa| {
            (vmf_mean_resultant_valid(kappa) - r) / vmf_mean_resultant_derivative(kappa)
        }));
    }
    let d = 1.0 - r;
    Ok(newton(1.0 / d, |kappa| {
        // h(κ) = 1/D(κ) with D = 1 − A₃, h′ = A₃′/D²: the step (h − 1/d)/h′ = D (d − D)/(d A₃′).
        let big_d = vmf_one_minus_mean_resultant(kappa);
        big_d * (d - big_d) / (d * vmf_mean_resultant_derivative(kappa))
    }))
}

/// `1 − (coth κ − 1/κ)` for valid κ, without cancellation: `1 − A₃` below κ = 1 (where A₃ < 0.32),
/// `1/κ − 2/(e^(2κ) − 1)` above (the second term is at most 0.32 of the first).
pub(crate) fn vmf_one_minus_mean_resultant(kappa: f64) -> f64 {
    if kappa < 1.0 {
        1.0 - vmf_mean_resultant_valid(kappa)
    } else {
        1.0 / kappa - 2.0 / (2.0 * kappa).exp_m1()
    }
}

/// `ln(κ / (4π sinh κ)) + κ` for valid κ: the von Mises-Fisher log normaliser with κ taken out, at
/// most `ln(κ/2π)` in size, so that log densities `… − κ |x − μ|²/2` never subtract numbers of size κ.
/// Below κ = 1, `−ln 4π − ln_1p(Σ_(k≥1) κ^(2k)/(2k+1)!) + κ`; above, `ln κ − ln 2π − ln_1p(−e^(−2κ))`.
pub(crate) fn vmf_log_normalizer_plus_kappa(kappa: f64) -> f64 {
    if kappa < 1.0 {
        let k2 = kappa * kappa;
        let mut term = 1.0;
        let mut tail = 0.0;
        for k in 1..=30 {
            let k = f64::from(k);
            term *= k2 / ((2.0 * k) * (2.0 * k + 1.0));
            tail += term;
            if term <= f64::EPSILON * 0.25 * (1.0 + tail) {
                break;
            }
        }
        -(4.0 * PI).ln() - tail.ln_1p() + kappa
    } else {
        kappa.ln() - (2.0 * PI).ln() - (-(-2.0 * kappa).exp()).ln_1p()
    }
}

/// `ln(κ / (4π sinh κ))`: the log normaliser of the von Mises-Fisher density on S² with respect to the
/// surface measure (−ln 4π at κ = 0). Never forms sinh κ; for log densities prefer the form with κ
/// taken out (`VonMisesFisher::log_pdf` does).
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
///
/// # Example
/// ```
/// use liebayes_densities::special::vmf_log_normalizer;
/// // ln(κ / (4π sinh κ)): at κ → 0 the uniform density 1/(4π) on the unit sphere.
/// assert!((vmf_log_normalizer(0.0).unwrap() + (4.0 * std::f64::consts::PI).ln()).abs() < 1e-15);
/// let k: f64 = 2.0;
/// assert!((vmf_log_normalizer(k).unwrap() - (k / (4.0 * std::f64::consts::PI * k.sinh())).ln()).abs() < 1e-14);
/// ```
pub fn vmf_log_normalizer(kappa: f64) -> Result<f64, DensityError> {
    let kappa = concentration("kappa", kappa)?;
    Ok(vmf_log_normalizer_plus_kappa(kappa) - kappa)
}

/// `(e^(−κ) I₀(κ), e^(−κ) I₁(κ))`, both in (0, 1] and never overflowing, from polynomial pieces below
/// 64 and 16 Hankel terms above (about 10 ns for the pair; A = I₁/I₀ from it within 8 ulp).
///
/// # Errors
/// Unless κ ∈ [0, f64::MAX].
pub fn scaled_i0_i1(kappa: f64) -> Result<(f64, f64), DensityError> {
    concentration("kappa", kappa).map(scaled_bessel::scaled_i0_i1)
}

/// The Bingham normaliser `ln K(z)` on S³ (against the uniform probability measure) and its gradient
/// `E[xₖ²] = ∂ ln K/∂zₖ`, for eigenvalues z whose spread `max z − min z` is at most
/// [`Bingham::MAX_SPREAD`](crate::Bingham::MAX_SPREAD). Method and accuracy: see `Bingham`.
///
/// # Errors
/// [`DensityError::NonFinite`] for a non-finite eigenvalue, [`DensityError::OutOfRange`] for a spread
/// beyond the limit.
pub fn bingham_log_normalizer_and_moments(z: &[f64; 4]) -> Result<(f64, [f64; 4]), DensityError> {
    for &v in z {
        finite("Bingham eigenvalue", v)?;
    }
    crate::bingham::check_spread(z)?;
    let (log_normalizer_minus_max, moments) =
        crate::bingham_normalizer::log_normalizer_and_moments(z);
    let max = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Ok((max + log_normalizer_minus_max, moments))
}

/// The standard normal CDF `Φ(x) = erfc(−x/√2)/2`, accurate in both tails: relative error below
/// `2e-16 (1 + x²)` down to Φ(−37.5) ≈ 4.6e-308 (the lower tail never forms 1 − small), and
/// `1 − Φ(x)` is `normal_cdf(−x)` to the same accuracy. NaN for NaN.
///
/// # Example
/// ```
/// use liebayes_densities::special::normal_cdf;
/// assert_eq!(normal_cdf(0.0), 0.5);
/// // Φ(−10) = 7.6198530241605261e-24, to 9e-15 relative (the tail is conditioned by x²).
/// assert!((normal_cdf(-10.0) / 7.619_853_024_160_526e-24 - 1.0).abs() < 2e-14);
/// ```
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// Beyond this many standard deviations the normal's tail mass (below 1.2e-19) is lost to rounding
/// in `ln(1 − tail)`.
const NEGLIGIBLE_TAIL: f64 = 9.0;

/// `ln[Φ(b) − Φ(a)]`, the log probability of `a < Z < b` for a standard normal Z, on the extended
/// real line (−∞ for an empty interval, `a ≥ b`, and only there), computed from the side where it
/// does not cancel:
///
/// * for a narrow interval, `(b − a)(1 + max(|a|, |b|)) < 1`, where every difference of Φ values
///   or of their logarithms cancels (to 0 for adjacent doubles), as `ln(b − a) + ln φ(m) + ln M`
///   with m the midpoint and M the mean of `φ(x)/φ(m)` over [a, b] (see `log_narrow_mass`);
/// * beyond [`DEEP_TAIL`] standard deviations (both bounds on one side), where Φ underflows, through
///   the logarithm of the tail's asymptotic series;
/// * `ln1p(−Φ(−b))` or `ln1p(−Φ(a))` when one bound is beyond 9 standard deviations (0 without any
///   erfc when both are);
/// * the complementary tails when both bounds lie on one side of 0 and beyond the quartile ±0.674;
/// * `ln((erf(b/√2) − erf(a/√2))/2)` otherwise.
///
/// Error below `1e-14 (1 + |ln mass|)` in the log over the whole extended line (checked against
/// 50-digit values; measured within 0.06 of the bound over 34 000 random intervals of every width
/// from one ulp up, with bounds up to ±1e8); NaN for a NaN bound.
pub fn log_normal_mass(a: f64, b: f64) -> f64 {
    use std::f64::consts::SQRT_2;
    if a.is_nan() || b.is_nan() {
        return f64::NAN;
    }
    if a >= b {
        return f64::NEG_INFINITY;
    }
    if (b - a) * (1.0 + a.abs().max(b.abs())) < NARROW_INTERVAL {
        return log_narrow_mass(a, b);
    }
    if a >= DEEP_TAIL {
        return log_upper_tail_mass(a, b);
    }
    if b <= -DEEP_TAIL {
        return log_upper_tail_mass(-b, -a);
    }
    if a <= -NEGLIGIBLE_TAIL && b >= NEGLIGIBLE_TAIL {
        0.0
    } else if a <= -NEGLIGIBLE_TAIL && b >= 0.0 {
        // Φ(b) − Φ(a) = 1 − Φ(−b) to rounding: one erfc, and ln1p keeps the small tail.
        (-normal_cdf(-b)).ln_1p()
    } else if b >= NEGLIGIBLE_TAIL && a <= 0.0 {
        (-normal_cdf(a)).ln_1p()
    } else if a >= ERF_CROSSOVER {
        // Both in the upper tail: Φ(b) − Φ(a) = Φ(−a) − Φ(−b).
        (normal_cdf(-a) - normal_cdf(-b)).ln()
    } else if b <= -ERF_CROSSOVER {
        (normal_cdf(b) - normal_cdf(a)).ln()
    } else {
        (0.5 * (libm::erf(b / SQRT_2) - libm::erf(a / SQRT_2))).ln()
    }
}

/// Below this `(b − a)(1 + max(|a|, |b|))` an interval is narrow: Φ changes across it by less than
/// a factor of about e, so the differences of Φ values would lose up to `ln(1/(b − a))` digits (and
/// cancel to 0 for adjacent doubles), while the exponent of `φ(x)/φ(m)` varies by at most 1 over it.
const NARROW_INTERVAL: f64 = 1.0;

/// `ln √(2π)`.
const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// `ln[Φ(b) − Φ(a)]` for a narrow interval, `(b − a)(1 + max(|a|, |b|)) < 1` (so the bounds are
/// finite and |a|, |b| < 1e8, as b − a is at least an ulp of them or, across 0, their size).
///
/// With m the midpoint (rounded: any m near it will do) and `t = x − m`,
/// `Φ(b) − Φ(a) = φ(m) ∫ e^(−t (m + t/2)) dt` over [a − m, b − m] (both ends exact), so it is
/// `ln(b − a) + ln φ(m) + ln M`, `ln φ(m) = −m²/2 − ln √(2π)`, with M the mean of `e^(−t (m + t/2))`
/// over that interval by the 20-point Gauss-Legendre rule. There `|t (m + t/2)| < ½`, so the rule's
/// error is below 1e-50 and M lies in [e^(−½), e^(½)]: nothing cancels, and the error is the
/// rounding of b − a, m² and the sum, a few ulp of `m²/2 + 1`.
fn log_narrow_mass(a: f64, b: f64) -> f64 {
    let m = 0.5 * (a + b);
    let centre = 0.5 * ((a - m) + (b - m));
    let half = 0.5 * (b - a);
    let sum: f64 = crate::quadrature::gauss_legendre()
        .iter()
        .map(|&(x, w)| {
            let t = centre + half * x;
            w * (-t * (m + 0.5 * t)).exp()
        })
        .sum();
    (b - a).ln() - 0.5 * m * m - LN_SQRT_2PI + (0.5 * sum).ln()
}

/// Where erf(x/√2) = erfc(x/√2): from here on the tails' difference (erfc) is the more accurate,
/// below it the difference of erf (an interval near 0 on one side of it, such as [1e-300, 2e-300],
/// cancelled to 0 in the tails' form).
const ERF_CROSSOVER: f64 = 0.674_489_750_196_081_7;

/// Beyond this many standard deviations the tails are taken through their logarithm: Φ(−30) is
/// 4.9e-198, and Φ(−x) becomes subnormal (losing digits) from x ≈ 37.5.
pub const DEEP_TAIL: f64 = 30.0;

/// `ln[Φ(−a) − Φ(−b)]` for `DEEP_TAIL ≤ a < b ≤ ∞` and an interval that is not narrow,
/// `(b − a)(1 + b) ≥ 1`: with `ln Φ(−x) = −x²/2 − ln(x √(2π)) + ln S(x)` and the asymptotic series
/// `S(x) = Σₖ (−1)ᵏ (2k − 1)!! / x²ᵏ` (ten terms: the eleventh is below 1e-20 at x = 30), it is
/// `ln Φ(−a) + ln(−expm1(d))` with the difference
/// `d = ln Φ(−b) − ln Φ(−a) = −(b − a)(b + a)/2 − ln1p((b − a)/a) + ln S(b) − ln S(a)`, formed
/// from b − a. `ln S(b) − ln S(a)` carries an absolute rounding of a few eps, which is a relative
/// one only because |d| ≥ (b − a)(b + a)/2 is about ½ or more here (for narrower intervals it was
/// 1e-3 of d at adjacent doubles; those take `log_narrow_mass`).
fn log_upper_tail_mass(a: f64, b: f64) -> f64 {
    let log_series = |x: f64| {
        let u = 1.0 / (x * x);
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..=10 {
            term *= -f64::from(2 * k - 1) * u;
            sum += term;
        }
        sum.ln()
    };
    let log_tail_a = -0.5 * a * a - a.ln() - LN_SQRT_2PI + log_series(a);
    if b == f64::INFINITY {
        return log_tail_a;
    }
    let gap = b - a;
    let d = -0.5 * gap * (b + a) - (gap / a).ln_1p() + (log_series(b) - log_series(a));
    log_tail_a + (-d.exp_m1()).ln()
}

#[cfg(test)]
mod tests {
    use super::{MAX_ORDER, SERIES_LIMIT, power_series_tail};

    // The functions on valid arguments, unwrapped.
    fn log_i0(k: f64) -> f64 {
        super::log_i0(k).unwrap()
    }
    fn log_i1(k: f64) -> f64 {
        super::log_i1(k).unwrap()
    }
    fn a1(k: f64) -> f64 {
        super::a1(k).unwrap()
    }
    fn a2(k: f64) -> f64 {
        super::a2(k).unwrap()
    }
    fn a1_derivative(k: f64) -> f64 {
        super::a1_derivative(k).unwrap()
    }
    fn bessel_ratio(n: u32, k: f64) -> f64 {
        super::bessel_ratio(n, k).unwrap()
    }

    #[test]
    fn branches_meet_at_the_series_limit() {
        // The power series (below) and the asymptotic expansion (above) must agree where they hand
        // over, once the change of each function across the gap (its derivative times the gap) is
        // taken out.
        fn handover(switch: f64, f: impl Fn(f64) -> f64, derivative: f64) {
            let (below, above) = (switch * (1.0 - 1e-12), switch * (1.0 + 1e-12));
            let jump = f(above) - f(below) - derivative * (above - below);
            assert!(
                jump.abs() <= 1e-13 * f(above).abs(),
                "jump {jump:e} at {switch}"
            );
        }
        let k = SERIES_LIMIT;
        let (r1, r2, r3) = (a1(k), a2(k), bessel_ratio(3, k));
        handover(k, log_i0, r1);
        handover(k, log_i1, 1.0 / r1 - 1.0 / k);
        handover(k, a1, a1_derivative(k));
        handover(k, a2, f64::midpoint(r1, r3) - r2 * r1);
        let k9 = 2.0 * 9.0 * 9.0; // order 9 switches at 162
        let d9 =
            f64::midpoint(bessel_ratio(8, k9), bessel_ratio(10, k9)) - bessel_ratio(9, k9) * a1(k9);
        handover(k9, |x| bessel_ratio(9, x), d9);
    }

    #[test]
    fn recurrence_holds_across_orders() {
        // I_(n−1) − I_(n+1) = (2n/κ) I_n, divided by I_0, across every method's range and hand-overs.
        // Rounding is relative to the subtracted terms, and the log-space prefactor of the series adds
        // about n (|ln(κ/2)| + ln n) eps.
        for kappa in [0.3, 5.0, 29.0, 31.0, 80.0, 700.0, 1e4, 1e5] {
            for n in 1..3000 {
                let (below, above) = (bessel_ratio(n - 1, kappa), bessel_ratio(n + 1, kappa));
                let rhs = 2.0 * f64::from(n) / kappa * bessel_ratio(n, kappa);
                if rhs < 1e-250 {
                    break;
                }
                let nf = f64::from(n);
                let logs = nf * ((kappa / 2.0).ln().abs() + nf.ln()) + 1.0;
                let error = (below - above - rhs).abs();
                let tolerance = 8.0 * f64::EPSILON * logs * (below + above);
                assert!(
                    error <= tolerance,
                    "n {n}, κ {kappa}: error {error:e} > {tolerance:e}"
                );
            }
        }
    }

    /// Values that satisfy the recurrence can still be wrong (any solution of it does): compare the
    /// backward recurrence with the power series, an independent method, where both apply.
    #[test]
    fn backward_recurrence_matches_the_power_series() {
        for kappa in [31.0, 100.0, 400.0] {
            for n in 1..400 {
                let (tail_n, r_n) = power_series_tail(n, kappa);
                let (tail_0, r_0) = power_series_tail(0, kappa);
                assert_eq!((r_n, r_0), (0, 0), "no rescaling below κ = 700");
                let log_factorial: f64 = (2..=n).map(|k| f64::from(k).ln()).sum();
                let series = (f64::from(n) * (kappa / 2.0).ln() - log_factorial + tail_n.ln_1p()
                    - tail_0.ln_1p())
                .exp();
                if series < 1e-250 {
                    break;
                }
                let got = bessel_ratio(n, kappa);
                let relative = ((got - series) / series).abs();
                let logs = f64::from(n) * ((kappa / 2.0).ln() + f64::from(n).ln()) + kappa;
                assert!(
                    relative <= 8.0 * f64::EPSILON * logs,
                    "n {n}, κ {kappa}: {got:e} vs {series:e} ({relative:e})"
                );
            }
        }
    }

    #[test]
    fn huge_orders_and_arguments_stay_finite() {
        assert!(bessel_ratio(400, 2000.0).is_finite());
        assert!(bessel_ratio(50, 1e6) > 0.99);
        assert!(log_i0(1e300).is_finite());
        assert_eq!(bessel_ratio(3, 0.0), 0.0);
        // 2π κ overflowed here: ln I₀(1e308) was −∞.
        for k in [1e308, f64::MAX] {
            let expected = k - 0.5 * ((2.0 * std::f64::consts::PI).ln() + k.ln());
            assert_eq!(log_i0(k), expected, "{k:e}");
            assert!(log_i1(k).is_finite() && super::log_i0_scaled(k).unwrap().is_finite());
        }
        assert_eq!(log_i1(0.0), f64::NEG_INFINITY);
        assert_eq!(log_i1(5e-324), 5e-324_f64.ln() - std::f64::consts::LN_2);
    }

    /// These never returned (NaN fell through every stopping test; κ = −1e16 summed 5e15 terms) or
    /// took seconds (order u32::MAX ran the recurrence 4e9 steps): each is now refused at once.
    #[test]
    fn bad_arguments_are_refused_before_any_series() {
        for k in [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -1e16,
            -1.0,
            -5e-324,
        ] {
            assert!(super::log_i0(k).is_err(), "log_i0({k})");
            assert!(super::log_i1(k).is_err(), "log_i1({k})");
            assert!(super::a1(k).is_err(), "a1({k})");
            assert!(super::bessel_ratio(3, k).is_err(), "bessel_ratio(3, {k})");
            assert!(super::a1_derivative(k).is_err() && super::one_minus_a1(k).is_err());
            assert!(super::vmf_log_normalizer(k).is_err() && super::vmf_mean_resultant(k).is_err());
            assert!(super::scaled_i0_i1(k).is_err() && super::log_i0_scaled(k).is_err());
        }
        let error = super::bessel_ratio(u32::MAX, 1.0).unwrap_err();
        assert!(error.to_string().contains("100000"), "{error}");
        assert!(super::bessel_ratio(MAX_ORDER + 1, 1e6).is_err());
        assert_eq!(super::log_i0(-0.0), Ok(0.0));
    }

    /// The highest order at every κ regime is a ratio in [0, 1] (its time is in the `densities`
    /// benchmark: the recurrence is bounded by construction).
    #[test]
    fn the_highest_order_is_in_range_at_every_regime() {
        for kappa in [1e-300, 1.0, 30.0, 31.0, 1e4, 2e10, 1e300, f64::MAX] {
            let value = bessel_ratio(MAX_ORDER, kappa);
            assert!((0.0..=1.0).contains(&value), "{kappa:e}: {value}");
        }
        assert_eq!(bessel_ratio(MAX_ORDER, 1.0), 0.0);
        assert!(bessel_ratio(MAX_ORDER, 1e300) > 0.999_999);
    }

    /// A⁻¹ is finite for every r < 1 (it was +∞ from 1 − 1e-8 on) and inverts the accurate 1 − A to a
    /// few ulp: checked through D(A⁻¹(r)) = 1 − r, whose condition number is about 1.
    #[test]
    fn inverse_is_finite_and_accurate_up_to_one() {
        let below_one = 1.0 - f64::EPSILON / 2.0;
        for r in [
            1e-300,
            5e-324,
            0.1,
            0.49,
            0.5,
            0.9,
            0.99,
            1.0 - 1e-8,
            1.0 - 1e-12,
            below_one,
        ] {
            let kappa = super::a1_inverse(r).unwrap();
            assert!(kappa.is_finite() && kappa > 0.0, "A^-1({r}) = {kappa}");
            let (target, got) = if r < 0.5 {
                (r, a1(kappa))
            } else {
                (1.0 - r, super::one_minus_a1(kappa).unwrap())
            };
            let error = ((got - target) / target).abs();
            assert!(
                error <= 6.0 * f64::EPSILON,
                "A^-1({r}) = {kappa:e}: residual {error:e}"
            );
        }
        let top = super::a1_inverse(below_one).unwrap();
        assert!((top * f64::EPSILON - 1.0).abs() < 1e-3, "{top:e}"); // κ ≈ 1/(2d) = 1/eps
    }
}
