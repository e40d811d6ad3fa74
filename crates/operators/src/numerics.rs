//! Small numerical helpers shared by the weighted-sample operators.

/// `ln Σ exp(lᵢ)`, computed as `m + ln Σ exp(lᵢ − m)` with m the largest term so that nothing
/// overflows or underflows; −∞ for no terms or all terms −∞.
pub(crate) fn log_sum_exp(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return max;
    }
    max + values.map(|l| (l - max).exp()).sum::<f64>().ln()
}
