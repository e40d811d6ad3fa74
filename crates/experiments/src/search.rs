//! Searching a size: the smallest particle count (grid size, iteration count …) at which a filter
//! meets a target, by doubling then bisection ([`smallest_passing`]), and the search every
//! application runs with it: the smallest count at which a filter's score over a study comes within
//! a tolerance of a reference filter's ([`smallest_to_match`]).

use crate::{ExperimentError, Summary};
use liebayes_manifolds::Readable;

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
    check_interval(low, high, resolution)?;
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

/// Checks [`smallest_passing`]'s interval and resolution.
fn check_interval(low: u64, high: u64, resolution: f64) -> Result<(), ExperimentError> {
    if low == 0 || low > high {
        return Err(ExperimentError::OutOfRange {
            what: "search interval [low, high]",
            value: format!("[{low}, {high}]"),
            range: "1 <= low <= high",
        });
    }
    if !(resolution > 0.0 && resolution <= 1.0) {
        return Err(ExperimentError::OutOfRange {
            what: "search resolution",
            value: Readable(resolution).to_string(),
            range: "(0, 1]",
        });
    }
    Ok(())
}

/// How [`smallest_to_match`] searches: within `(1 + tolerance)` of the target, counts from `low`
/// to `high`, stopping when the bracket is within the relative `resolution`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchSettings {
    /// The tolerance on the score, in (0, 10] (0.05: within 5 %).
    pub tolerance: f64,
    /// The smallest count tried, at least 1.
    pub low: u64,
    /// The largest count tried, at most [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS).
    pub high: u64,
    /// The relative width at which the bisection stops, in (0, 1].
    pub resolution: f64,
}

impl SearchSettings {
    /// Checks every field against its range, so that a search that runs studies before its own
    /// (a reference filter's, say) can refuse bad settings before any work.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] for a tolerance outside (0, 10] (NaN included), `low` = 0,
    /// `low > high`, `high` above [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS) or a
    /// resolution outside (0, 1].
    pub fn check(&self) -> Result<(), ExperimentError> {
        if !(self.tolerance > 0.0 && self.tolerance <= 10.0) {
            return Err(ExperimentError::OutOfRange {
                what: "tolerance",
                value: Readable(self.tolerance).to_string(),
                range: "(0, 10]",
            });
        }
        let limit = u64::try_from(liebayes_operators::MAX_ELEMENTS).unwrap_or(u64::MAX);
        if self.high > limit {
            return Err(ExperimentError::OutOfRange {
                what: "largest count",
                value: self.high.to_string(),
                range: "at most 2^30",
            });
        }
        check_interval(self.low, self.high, self.resolution)
    }
}

/// One count a search tried: its study's score (+∞ when the study gave none), failed runs and
/// mean filter time per step (s; NaN without a timed step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tried {
    /// The count.
    pub count: u64,
    /// The study's score.
    pub score: f64,
    /// Its failed runs.
    pub failures: u64,
    /// Its mean filter time per step (s).
    pub seconds_per_step: f64,
}

/// What [`smallest_to_match`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct SizeSearch {
    /// The target score (the reference filter's).
    pub target: f64,
    /// Every count tried, in the order tried.
    pub tried: Vec<Tried>,
    /// The smallest count found whose score is within the tolerance with no failed run, `None`
    /// if `high` is not.
    pub count: Option<u64>,
}

/// The smallest count in `[low, high]` whose study (`study(count)`) has no failed run and a
/// `score` (an RMSE, say: smaller is better) at most `(1 + tolerance)` times `target`, to the
/// relative `resolution`, by [`smallest_passing`]: about `log₂(high/low) + log₂(1/resolution) + 2`
/// studies. The studies should read the same data (the same seed and runs), so that the counts are
/// compared with the target on equal terms; a study without a score, or with a score that is not
/// finite, counts as +∞ and never passes.
///
/// # Example
/// A "filter" whose error falls as 1/√n matches a target of 0.01 within 5 % from about 9 070:
/// ```
/// use liebayes_experiments::search::{SearchSettings, smallest_to_match};
/// use liebayes_experiments::{ExperimentError, Metric, Reduction, RunScores, StudyLabel, Summary};
///
/// let study = |n: u64| -> Result<Summary, ExperimentError> {
///     let label = StudyLabel { name: format!("PF {n}"), seed: 0, runs: 1 };
///     let mut s = Summary::new(label, 0..1)?;
///     let scores = RunScores {
///         metrics: vec![Metric::new("error", Reduction::RootMeanSquare, "")],
///         times: vec![1.0],
///         values: vec![1.0 / (n as f64).sqrt()],
///         seconds_per_step: 1e-6,
///     };
///     s.add_run(0, &scores)?;
///     Ok(s)
/// };
/// let rmse = |s: &Summary| s.series("error")?.epochs()[0].root_mean_square();
/// let settings = SearchSettings { tolerance: 0.05, low: 100, high: 1_000_000, resolution: 0.01 };
/// let found = smallest_to_match(0.01, settings, study, rmse)?;
/// let n = found.count.unwrap();
/// assert!((9070..9170).contains(&n), "{n}");
/// # Ok::<(), ExperimentError>(())
/// ```
///
/// # Errors
/// [`ExperimentError::OutOfRange`] for a target that is not finite and positive or settings that
/// [`SearchSettings::check`] refuses, before any study; the first study's error otherwise.
pub fn smallest_to_match<E: From<ExperimentError>>(
    target: f64,
    settings: SearchSettings,
    mut study: impl FnMut(u64) -> Result<Summary, E>,
    score: impl Fn(&Summary) -> Option<f64>,
) -> Result<SizeSearch, E> {
    let SearchSettings {
        tolerance,
        low,
        high,
        resolution,
    } = settings;
    if !(target.is_finite() && target > 0.0) {
        return Err(ExperimentError::OutOfRange {
            what: "target score",
            value: Readable(target).to_string(),
            range: "finite and positive",
        }
        .into());
    }
    settings.check()?;
    let mut tried = Vec::new();
    let count = smallest_passing(low, high, resolution, |n| {
        let summary = study(n)?;
        let score = score(&summary).unwrap_or(f64::INFINITY);
        let failures = summary.failure_count();
        tried.push(Tried {
            count: n,
            score,
            failures,
            seconds_per_step: summary.timing().mean().unwrap_or(f64::NAN),
        });
        // As a ratio, so that a target near f64::MAX does not overflow to +inf and let a study
        // without a score (+inf) pass.
        Ok::<_, E>(failures == 0 && score.is_finite() && score / target <= 1.0 + tolerance)
    })?;
    Ok(SizeSearch {
        target,
        tried,
        count,
    })
}
