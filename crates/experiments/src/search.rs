//! Searching a size: the smallest particle count (grid size, iteration count …) at which a filter
//! meets a target, by doubling then bisection.

use crate::ExperimentError;

/// The smallest `n` in `[low, high]` for which `passes(n)` holds, for a `passes` that is false below
/// some threshold and true from it on (a study's figure against a target, for example "the particle
/// filter's RMSE is within 5 % of the exact filter's"). Doubles from `low` until a pass (or `high`),
/// then bisects the last interval until its ends are within `resolution` of each other (relative:
/// 0.05 stops at 5 %), and returns its upper end; `None` if `high` itself does not pass.
///
/// `passes` is called at most about `log₂(high/low) + log₂(1/resolution) + 2` times; its first error
/// stops the search and is returned.
///
/// # Errors
/// [`ExperimentError::OutOfRange`] for `low` = 0, `low > high` or a resolution outside (0, 1];
/// the error of `passes`, converted, otherwise.
pub fn smallest_passing<E: From<ExperimentError>>(
    low: u64,
    high: u64,
    resolution: f64,
    mut passes: impl FnMut(u64) -> Result<bool, E>,
) -> Result<Option<u64>, E> {
    if low == 0 || low > high {
        return Err(ExperimentError::OutOfRange {
            what: "search interval [low, high]",
            value: format!("[{low}, {high}]"),
            range: "1 <= low <= high",
        }
        .into());
    }
    if !(resolution > 0.0 && resolution <= 1.0) {
        return Err(ExperimentError::OutOfRange {
            what: "search resolution",
            value: resolution.to_string(),
            range: "(0, 1]",
        }
        .into());
    }
    // Doubling: the first passing n, and the last failing one below it.
    let (mut fail, mut pass) = (None, low);
    loop {
        if passes(pass)? {
            break;
        }
        if pass == high {
            return Ok(None);
        }
        fail = Some(pass);
        pass = pass.saturating_mul(2).min(high);
    }
    let Some(mut fail) = fail else {
        return Ok(Some(pass));
    };
    // Bisection: fail < threshold <= pass; at most 64 halvings of a u64 interval.
    while pass - fail > 1 && (pass - fail) as f64 > resolution * pass as f64 {
        let middle = fail + (pass - fail) / 2;
        if passes(middle)? {
            pass = middle;
        } else {
            fail = middle;
        }
    }
    Ok(Some(pass))
}
