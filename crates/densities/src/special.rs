//! Special functions: modified Bessel functions of the first kind in log form and as ratios, the
//! inverse of A(κ) = I₁(κ)/I₀(κ), and the von Mises-Fisher functions on S².
//!
//! All are for κ ≥ 0 and accurate to a few ulp (relative error ≤ 1e-13, checked against 50-digit
//! reference values) from κ = 0 (and 1e-300) to 1e6 and beyond. No function overflows: the Bessel
//! functions themselves (I₀(1e6) ≈ e^(10⁶)) are never formed.
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
//! * [`scaled_i0_i1`], `e^(−x) I₀(x)` and `e^(−x) I₁(x)` for inner loops: piecewise polynomials to 64,
//!   12 Hankel terms beyond (about 10 ns for the pair).
//! * [`bingham_log_normalizer_and_moments`]: the Bingham normaliser on S³ and its gradient, a
//!   one-dimensional integral of these (see `Bingham`).

pub use crate::bingham_normalizer::log_normalizer_and_moments as bingham_log_normalizer_and_moments;
use crate::error::DensityError;
pub use crate::scaled_bessel::scaled_i0_i1;
use std::f64::consts::PI;

/// Largest κ for which the power series is used.
const SERIES_LIMIT: f64 = 30.0;

/// The factor by which a growing power series is scaled down.
const RESCALE: f64 = 1e280;

/// Power series of `I_ν(κ) / ((κ/2)^ν / ν!)`, that is `Σ_k (κ²/4)^k ν! / (k! (k+ν)!)`, minus its first
/// term (which is 1), returned as `(sum − 1, rescalings)`: the sum is divided by [`RESCALE`] whenever
/// it grows past it, so that for large κ only its logarithm, `ln(tail) + rescalings · ln(RESCALE)`,
/// is meaningful.
fn power_series_tail(nu: u32, kappa: f64) -> (f64, i32) {
    let q = kappa * kappa / 4.0;
    let nu = f64::from(nu);
    let mut term = 1.0;
    let mut tail = 0.0;
    let mut rescalings = 0;
    let mut k = 0.0;
    loop {
        k += 1.0;
        term *= q / (k * (k + nu));
        tail += term;
        if term <= f64::EPSILON * 0.25 * (1.0 + tail) {
            return (tail, rescalings);
        }
        if tail > RESCALE {
            tail /= RESCALE;
            term /= RESCALE;
            rescalings += 1;
        }
    }
}

/// The Hankel asymptotic sum `Σ_k c_k(ν) κ^(−k)` (c₀ = 1), for κ > 30.
fn asymptotic_sum(nu: u32, kappa: f64) -> f64 {
    let four_nu2 = 4.0 * f64::from(nu) * f64::from(nu);
    let mut term = 1.0_f64;
    let mut sum = 1.0;
    let mut k = 0.0_f64;
    loop {
        k += 1.0;
        let next = term * ((2.0 * k - 1.0).powi(2) - four_nu2) / (8.0 * k * kappa);
        if next.abs() >= term.abs() && k > 1.0 {
            return sum; // smallest term reached: the expansion's best value
        }
        term = next;
        sum += term;
        if term.abs() <= f64::EPSILON * 0.25 * sum.abs() {
            return sum;
        }
    }
}

/// `ln I₀(κ)` for κ ≥ 0 (`ln I₀(κ) = κ²/4 + O(κ⁴)` near 0, `κ − ½ ln(2πκ) + O(1/κ)` for large κ).
///
/// Returns NaN only for NaN input; for κ < 0 it returns `ln I₀(|κ|)` (I₀ is even).
pub fn log_i0(kappa: f64) -> f64 {
    let kappa = kappa.abs();
    if kappa <= SERIES_LIMIT {
        power_series_tail(0, kappa).0.ln_1p()
    } else {
        kappa - 0.5 * (2.0 * PI * kappa).ln() + asymptotic_sum(0, kappa).ln()
    }
}

/// `ln I₁(κ)` for κ ≥ 0; `−∞` at κ = 0.
pub fn log_i1(kappa: f64) -> f64 {
    if kappa == 0.0 {
        return f64::NEG_INFINITY;
    }
    if kappa <= SERIES_LIMIT {
        (kappa / 2.0).ln() + power_series_tail(1, kappa).0.ln_1p()
    } else {
        kappa - 0.5 * (2.0 * PI * kappa).ln() + asymptotic_sum(1, kappa).ln()
    }
}

/// `A(κ) = I₁(κ)/I₀(κ)`, the mean resultant length of a von Mises distribution: κ/2 − κ³/16 + … near
/// 0, 1 − 1/(2κ) − … for large κ.
pub fn a1(kappa: f64) -> f64 {
    bessel_ratio(1, kappa)
}

/// `I₂(κ)/I₀(κ)`: κ²/8 near 0, 1 − 2/κ + … for large κ.
pub fn a2(kappa: f64) -> f64 {
    bessel_ratio(2, kappa)
}

/// `I_n(κ)/I₀(κ)` for κ ≥ 0 and any order n: the n-th trigonometric moment `E[cos n(θ − μ)]` of a von
/// Mises distribution.
pub fn bessel_ratio(n: u32, kappa: f64) -> f64 {
    if n == 0 {
        return 1.0;
    }
    if kappa == 0.0 {
        return 0.0;
    }
    let nf = f64::from(n);
    if kappa > SERIES_LIMIT {
        // Largest order the asymptotic expansion handles fast and exactly: 2n² ≤ κ.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let top = (kappa / 2.0).sqrt().floor().min(f64::from(u32::MAX - 1)) as u32;
        if n <= top {
            return asymptotic_sum(n, kappa) / asymptotic_sum(0, kappa);
        }
        return backward_recurrence_ratio(n, top, kappa);
    }
    // (κ/2)^n / n! · (1 + tail_n) / (1 + tail_0), in logarithms: each factor can over- or underflow
    // where the ratio does not.
    let (tail_n, rescalings_n) = power_series_tail(n, kappa);
    let (tail_0, rescalings_0) = power_series_tail(0, kappa);
    if rescalings_n == 0 && n <= 32 && nf * (kappa / 2.0).ln() > -600.0 {
        // No over- or underflow: the product directly, without the eps · |ln(κ/2)| that exp(ln …)
        // would add for small κ.
        let prefactor: f64 = (1..=n).map(|k| kappa / 2.0 / f64::from(k)).product();
        return prefactor * (1.0 + tail_n) / (1.0 + tail_0);
    }
    let log_factorial: f64 = (2..=n).map(|k| f64::from(k).ln()).sum();
    let log_prefactor = nf * (kappa / 2.0).ln() - log_factorial;
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
/// start decays like e^(−(N² − n²)/κ), so N = √(n² + 40κ) + 10 leaves less than e^(−40).
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

/// `dA/dκ = 1 − A/κ − A²` (½ at κ = 0).
pub fn a1_derivative(kappa: f64) -> f64 {
    if kappa == 0.0 {
        return 0.5;
    }
    let a = a1(kappa);
    1.0 - a / kappa - a * a
}

/// The κ ≥ 0 with `A(κ) = I₁(κ)/I₀(κ) = r`, for r in [0, 1): the maximum-likelihood concentration of a
/// von Mises distribution whose sample mean resultant length is r.
///
/// Newton's method from the starting value `r (2 − r²)/(1 − r²)`, to full precision. The result is as
/// accurate as r allows: its relative condition number is `r / (κ A'(κ))`, about 2κ for large κ.
///
/// # Errors
/// [`DensityError::OutOfRange`] unless `0 ≤ r < 1`.
pub fn a1_inverse(r: f64) -> Result<f64, DensityError> {
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
    let mut kappa = r * (2.0 - r * r) / (1.0 - r * r);
    for _ in 0..100 {
        let step = (a1(kappa) - r) / a1_derivative(kappa);
        let next = if kappa - step > 0.0 {
            kappa - step
        } else {
            kappa / 2.0
        };
        if (next - kappa).abs() <= 2.0 * f64::EPSILON * next {
            return Ok(next);
        }
        kappa = next;
    }
    Ok(kappa)
}

/// `coth κ − 1/κ`: the mean resultant length `E[μ·x]` of a von Mises-Fisher distribution on S², κ/3
/// near 0, 1 − 1/κ for large κ.
///
/// Below κ = 0.25 the series `Σ 2^(2n) B_(2n) κ^(2n−1) / (2n)!` (ratio ≈ (κ/π)², eight terms reach
/// 1e-18); above, the closed form loses at most `3/κ² · eps` ≤ 48 eps to cancellation.
pub fn vmf_mean_resultant(kappa: f64) -> f64 {
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

/// `ln(κ / (4π sinh κ))`: the log normaliser of the von Mises-Fisher density on S² with respect to the
/// surface measure (−ln 4π at κ = 0).
///
/// Below κ = 1, `−ln 4π − ln_1p(Σ_(k≥1) κ^(2k)/(2k+1)!)`; above, `ln κ − ln 2π − κ − ln_1p(−e^(−2κ))`,
/// which never forms sinh κ.
pub fn vmf_log_normalizer(kappa: f64) -> f64 {
    if kappa < 1.0 {
        let k2 = kappa * kappa;
        let mut term = 1.0;
        let mut tail = 0.0;
        let mut k = 1.0;
        loop {
            term *= k2 / ((2.0 * k) * (2.0 * k + 1.0));
            tail += term;
            if term <= f64::EPSILON * 0.25 * (1.0 + tail) {
                break;
            }
            k += 1.0;
        }
        -(4.0 * PI).ln() - tail.ln_1p()
    } else {
        kappa.ln() - (2.0 * PI).ln() - kappa - (-(-2.0 * kappa).exp()).ln_1p()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
