//! Scoring an estimate against the truth, through the manifold: named metrics written into a slice
//! (no allocation per epoch), each with the rule that summarises it over runs.

use crate::RunningStats;
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use liebayes_operators::evaluation::{Z_975, average_nees_band};
use serde::{Deserialize, Serialize};

/// How the values of a metric over the runs of a study are summarised at an epoch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reduction {
    /// An error (signed, or a norm) or a reported standard deviation: its root mean square over
    /// runs `√(Σ xᵢ² / n)`, the RMSE.
    RootMeanSquare,
    /// Its mean, with the 95 % band of the mean from the sample variance, `x̄ ± 1.96 s / √n`.
    Mean,
    /// A normalised squared error (NEES, NIS) with `dof` degrees of freedom: its mean, beside the
    /// 95 % band of the mean of n independent χ²(dof) values (where a consistent filter's mean
    /// falls).
    ChiSquare {
        /// The degrees of freedom.
        dof: usize,
    },
    /// An indicator (0 or 1): its mean, as a rate.
    Rate,
}

impl Reduction {
    /// The figure a table reports for statistics `stats` over the runs at one epoch:
    /// `RootMeanSquare` → `√(Σx²/n)`; `Mean` → `x̄` with `x̄ ± 1.96 s/√n` (n ≥ 2); `ChiSquare { dof }`
    /// → `x̄` with the exact two-sided 95 % band of the mean of n χ²(dof) values
    /// ([`average_nees_band`]); `Rate` → `100 x̄` (percent). [`Figure::Empty`] without a finite value,
    /// and for a `Rate` whose percent is beyond f64's range (a mean above about 1.8e306, which
    /// values of a rate, 0 or 1, never reach).
    ///
    /// # Example
    /// ```
    /// use liebayes_experiments::{Figure, Reduction, RunningStats};
    ///
    /// let mut stats = RunningStats::new();
    /// for v in [3.0, 4.0] {
    ///     stats.add(v);
    /// }
    /// assert_eq!(Reduction::RootMeanSquare.figure(&stats), Figure::Rms(12.5_f64.sqrt()));
    /// assert!(matches!(Reduction::Mean.figure(&stats), Figure::Mean(m, Some(_)) if m == 3.5));
    /// ```
    pub fn figure(self, stats: &RunningStats) -> Figure {
        let (Some(mean), Some(rms)) = (stats.mean(), stats.root_mean_square()) else {
            return Figure::Empty;
        };
        let n = stats.count();
        match self {
            Reduction::RootMeanSquare => Figure::Rms(rms),
            Reduction::Mean => {
                let half = stats
                    .variance()
                    .map(|v| Z_975 * (v / n as f64).sqrt())
                    .filter(|h| h.is_finite());
                Figure::Mean(mean, half.map(|h| (mean - h, mean + h)))
            }
            Reduction::ChiSquare { dof } => {
                let band = usize::try_from(n)
                    .ok()
                    .and_then(|n| average_nees_band(dof, n).ok());
                Figure::Mean(mean, band)
            }
            Reduction::Rate => {
                let percent = 100.0 * mean;
                if percent.is_finite() {
                    Figure::Percent(percent)
                } else {
                    Figure::Empty
                }
            }
        }
    }
}

/// What a table reports of a metric at an epoch ([`Reduction::figure`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Figure {
    /// No finite value at that epoch (or a rate whose percent is not finite).
    Empty,
    /// A root mean square `√(Σx²/n)`.
    Rms(f64),
    /// A mean with its 95 % band, when it has one (a mean of one value has none).
    Mean(f64, Option<(f64, f64)>),
    /// A rate, in percent.
    Percent(f64),
}

/// A named metric with its summary rule and its unit (for tables and plots).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Metric {
    /// The name, unique within a scorer: a CSV column and a key of the summary.
    pub name: &'static str,
    /// How it is summarised over runs.
    pub reduction: Reduction,
    /// Its unit (`"deg"`, `"m"`, `""` for a pure number).
    pub unit: &'static str,
    /// Whether a summary keeps each run's value of this metric, its reduction over the run's
    /// epochs (see [`per_run`](Self::per_run)).
    pub per_run: bool,
}

impl Metric {
    /// A metric, summarised per epoch only.
    pub const fn new(name: &'static str, reduction: Reduction, unit: &'static str) -> Self {
        Self {
            name,
            reduction,
            unit,
            per_run: false,
        }
    }

    /// The same metric, with each run's value kept as well: a summary then keeps, for each of its
    /// runs with index below [`MAX_KEPT_RUNS`](crate::MAX_KEPT_RUNS), the metric reduced over
    /// that run's epochs with a finite value, the root mean square `√(Σₖ xₖ² / n)` for
    /// [`Reduction::RootMeanSquare`] (the run's RMSE) and the mean `Σₖ xₖ / n` otherwise; NaN if
    /// the run had no finite value ([`RunValues`](crate::RunValues)). For the quantiles of a
    /// per-run error over the runs, or its per-run difference from a reference filter on the same
    /// runs ([`relative_differences`](crate::relative_differences)).
    #[must_use]
    pub const fn per_run(self) -> Self {
        Self {
            per_run: true,
            ..self
        }
    }
}

/// Named metrics of an estimate `E` against a true state `T`.
pub trait Scorer<T, E>: Sync {
    /// The metrics, in the order [`score`](Self::score) writes them (asked once per run).
    fn metrics(&self) -> Vec<Metric>;

    /// Writes one value per metric into `values` (whose length is `metrics().len()`); NaN for a
    /// value the estimate does not have (it is then left out of that metric's statistics).
    fn score(&self, truth: &T, estimate: &E, values: &mut [f64]);
}

/// The scores of a Gaussian on a manifold against a true point x, through the manifold's `local`:
/// the error `e = μ ⊟ x` seen from the estimate (`local(μ, x)`, in the estimate's tangent space),
///
/// * `error`: `|e|`, summarised as its root mean square, the RMSE;
/// * `nees`: `eᵀ P⁻¹ e`, χ² with D degrees of freedom for a consistent filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ManifoldScorer;

impl<X: Manifold<D, Scalar = f64>, const D: usize> Scorer<X, ManifoldGaussian<X, D>>
    for ManifoldScorer
{
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("error", Reduction::RootMeanSquare, ""),
            Metric::new("nees", Reduction::ChiSquare { dof: D }, ""),
        ]
    }

    fn score(&self, truth: &X, estimate: &ManifoldGaussian<X, D>, values: &mut [f64]) {
        values[0] = estimate.mean().local(truth).norm();
        values[1] = estimate.mahalanobis_squared(truth);
    }
}
