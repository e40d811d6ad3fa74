//! The weighted mean on any [`Manifold`]: [`weighted_mean`] and its [`MeanSettings`].

use crate::constants::{MEAN_ITERATION_LIMIT, MEAN_MAX_ITERATIONS};
use crate::error::ManifoldError;
use crate::manifold::{Manifold, Tangent};
use crate::real::Real;

/// How [`weighted_mean`] iterates: at most `max_iterations` Gauss-Newton steps, converged when a
/// step's tangent norm is at most `tolerance`.
///
/// The default is [`MEAN_MAX_ITERATIONS`] iterations and
/// [`MEAN_TOLERANCE`](crate::constants::Thresholds::MEAN_TOLERANCE) (1e-10 in f64, 1e-5 in f32). A
/// tolerance below the rounding of the coordinates is harmless: a stalled step ends the iteration too
/// (see [`weighted_mean`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanSettings<T> {
    max_iterations: usize,
    tolerance: T,
}

impl<T: Real> MeanSettings<T> {
    /// The settings, checked.
    ///
    /// # Errors
    /// [`ManifoldError::OutOfRange`] unless `max_iterations` is in 1..=[`MEAN_ITERATION_LIMIT`]
    /// and `tolerance` is finite and positive.
    pub fn new(max_iterations: usize, tolerance: T) -> Result<Self, ManifoldError> {
        if !(1..=MEAN_ITERATION_LIMIT).contains(&max_iterations) {
            return Err(ManifoldError::OutOfRange {
                what: "the iteration bound of the mean",
                value: max_iterations as f64,
                range: "1 to 10 000",
            });
        }
        if !(tolerance.is_finite() && tolerance > T::zero()) {
            return Err(ManifoldError::OutOfRange {
                what: "the tolerance of the mean",
                value: tolerance.to_f64(),
                range: "finite and positive (a tangent norm)",
            });
        }
        Ok(Self {
            max_iterations,
            tolerance,
        })
    }

    /// The largest number of Gauss-Newton steps.
    pub const fn max_iterations(&self) -> usize {
        self.max_iterations
    }

    /// The step norm at which the iteration stops.
    pub const fn tolerance(&self) -> T {
        self.tolerance
    }
}

impl<T: Real> Default for MeanSettings<T> {
    fn default() -> Self {
        Self {
            max_iterations: MEAN_MAX_ITERATIONS,
            tolerance: T::MEAN_TOLERANCE,
        }
    }
}

/// The weighted mean of `samples` on the manifold, from `start`.
///
/// The weighted mean of points `xᵢ` with weights `wᵢ` is the point m where the weighted tangent
/// residuals balance, `Σ wᵢ (xᵢ ⊟ m) = 0`: on Rⁿ the arithmetic mean, on a Riemannian manifold whose
/// `local` is the Riemannian logarithm (every space of this crate) a stationary point of
/// `Σ wᵢ d(m, xᵢ)²`, the Karcher (Fréchet) mean. It is computed by the Gauss-Newton iteration
///
/// ```text
/// m ← m ⊞ Σ wᵢ (xᵢ ⊟ m) / Σ wᵢ
/// ```
///
/// from a given start, until the tangent norm of the step is at most the tolerance (the last step is
/// applied), or until the step has stalled at the rounding of the computation: it is below the
/// rounding of the sum that computes it, `n eps` times the size of the residuals it sums,
/// `Σ |wᵢ/Σw| |xᵢ ⊟ m|` in the max norm (n samples; that step, rounding and nothing more, is not
/// taken), or it no longer shrinks and is below √eps times that size (points far from the origin
/// of Rⁿ, large normalised weights), or the coordinates no longer resolve it (retracted and taken
/// back with `local`, it changes by half its length or more: points of Rⁿ 1e9 from the origin
/// whose spread is 1e-3); the mean is then as accurate as the coordinates
/// allow. A step that stops shrinking while still large is not a stall (it does not
/// converge). On Rⁿ one step is exact; on the curved spaces the iteration converges linearly, at a
/// rate that shrinks with the spread of the samples (Pennec, "Intrinsic statistics on Riemannian
/// manifolds", 2006; Manton, "A globally convergent numerical algorithm for computing the centre of
/// mass on compact Lie groups", 2004).
///
/// **Uniqueness.** With positive weights and all samples inside a geodesic ball of radius below half
/// the injectivity radius (π/2 on SO(2), SO(3) and S², π on SU(2), unbounded on Rⁿ), the mean is
/// unique and the iteration converges to it from any start inside the ball (Karcher, "Riemannian
/// center of mass and mollifier smoothing", 1977; Afsari, "Riemannian Lᵖ center of mass: existence,
/// uniqueness, and convexity", 2011). Outside that condition it may converge to another stationary
/// point (two points π apart on the circle, started half-way, stay there) or not converge, which is
/// reported as an error; start at a representative sample (the heaviest, or the previous estimate).
///
/// **Conventions.** Because it only uses `retract` and `local`, the same function averages in either
/// error convention ([`Left`](crate::Left)) and on products ([`ProductManifold`](crate::ProductManifold),
/// block by block). On the rotation groups the mean is bi-invariant: the mean of `g xᵢ` is `g m` and
/// the mean of `xᵢ g` is `m g`.
///
/// **Weights** may be negative (the centre weight of an unscented transform can be), must be finite,
/// and must have a finite sum larger in magnitude than its rounding error, `n · eps · Σ|wᵢ|`; they are
/// normalised by their sum. Large normalised weights amplify the rounding of the samples: the mean is
/// accurate to about `eps · Σ |wᵢ/Σw|` times the size of the coordinates (4e-10 rad for the unscented
/// weights with α = 1e-3 in three dimensions).
///
/// `samples` yields `(&point, weight)` pairs and is cloned once per iteration (plus once to check the
/// weights), so it must be a finite iterator that repeats the same sequence: a slice zipped with its
/// weights, a chain of sigma points, particles zipped with `exp(log_weight)`. Nothing is allocated.
///
/// # Errors
/// * [`ManifoldError::EmptyInput`]: no samples.
/// * [`ManifoldError::NonFiniteWeight`]: a weight is NaN or infinite.
/// * [`ManifoldError::DegenerateWeights`]: the weights' sum is not finite, or zero up to its rounding.
/// * [`ManifoldError::MeanNotConverged`]: the step was still above the tolerance, and not stalled at
///   the rounding, after `settings.max_iterations()` steps (or it was not finite); the error holds
///   the last step's norm.
///
/// # Example
/// ```
/// use liebayes_manifolds::{weighted_mean, LieGroup, MeanSettings, So2};
/// use nalgebra::Vector1;
///
/// // Two angles on either side of ±π: their mean is π, not 0.
/// let a = So2::<f64>::exp(&Vector1::new(3.0));
/// let b = So2::<f64>::exp(&Vector1::new(-3.0));
/// let m = weighted_mean(&a, [(&a, 1.0), (&b, 1.0)], MeanSettings::default())?;
/// assert!((m.angle().abs() - std::f64::consts::PI).abs() < 1e-12);
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
pub fn weighted_mean<'a, X, I, const D: usize>(
    start: &X,
    samples: I,
    settings: MeanSettings<X::Scalar>,
) -> Result<X, ManifoldError>
where
    X: Manifold<D> + 'a,
    I: IntoIterator<Item = (&'a X, X::Scalar)>,
    I::IntoIter: Clone,
{
    gauss_newton(start, &samples.into_iter(), settings)
}

/// The iteration of [`weighted_mean`], with the scalar named.
fn gauss_newton<'a, T, X, I, const D: usize>(
    start: &X,
    samples: &I,
    settings: MeanSettings<T>,
) -> Result<X, ManifoldError>
where
    T: Real,
    X: Manifold<D, Scalar = T> + 'a,
    I: Iterator<Item = (&'a X, T)> + Clone,
{
    let (total, count) = weight_sum(samples.clone())?;
    let stall = T::default_epsilon().sqrt();
    // The rounding of a sum of `count` terms, per unit of the terms' magnitudes.
    let rounding = T::lit(count as f64) * T::default_epsilon();
    let mut mean = start.clone();
    let mut last_step = T::max_finite();
    for _ in 0..settings.max_iterations {
        // The step, and the size of what it sums (Σ |w̃ᵢ| max |rᵢ|), which its rounding scales with.
        let (step, size) = samples.clone().fold(
            (Tangent::<T, D>::zeros(), T::zero()),
            |(sum, size), (x, w)| {
                let (w, r) = (w / total, mean.local(x));
                (sum + r * w, size + w.abs() * r.amax())
            },
        );
        // Without overflow: the squares of a step beyond 1e154 would end the iteration.
        let norm = crate::real::stable_norm(&step);
        if !norm.is_finite() {
            last_step = norm;
            break;
        }
        // Below the rounding of the sum that computes it, a step is that rounding and nothing
        // more: it is not taken.
        if norm <= rounding * size {
            return Ok(mean);
        }
        // Only a step above the tolerance needs the test (a retraction and a `local` more).
        let unresolved = norm > settings.tolerance && unresolved(&mean, &step, norm);
        mean = mean.retract(&step);
        let stalled = norm >= last_step && norm <= stall * size;
        last_step = norm;
        if norm <= settings.tolerance || stalled || unresolved {
            return Ok(mean);
        }
    }
    Err(ManifoldError::MeanNotConverged {
        iterations: settings.max_iterations,
        last_step: last_step.to_f64(),
        tolerance: settings.tolerance.to_f64(),
    })
}

/// Whether the coordinates of `mean` are too coarse to resolve `step` (of norm `norm`): retracted
/// and taken back with `local`, it changes by half its length or more, and so does a thousandth of
/// it (a step beyond the injectivity radius also comes back changed, but a thousandth of it does
/// not). Points of Rⁿ whose spread is below about 1e-7 of their distance from the origin end the
/// iteration here, their residuals too small for the stall test.
fn unresolved<T: Real, X: Manifold<D, Scalar = T>, const D: usize>(
    mean: &X,
    step: &Tangent<T, D>,
    norm: T,
) -> bool {
    let changed = |v: &Tangent<T, D>, length: T| {
        let held = crate::real::stable_norm(&(mean.local(&mean.retract(v)) - v));
        held + held >= length
    };
    let fraction = T::lit(1e-3);
    changed(step, norm) && changed(&(step * fraction), norm * fraction)
}

/// The sum of the weights, checked: at least one, all finite, and a finite sum larger in magnitude
/// than its rounding error `n eps Σ|wᵢ|`.
fn weight_sum<'a, X: 'a, T: Real>(
    samples: impl Iterator<Item = (&'a X, T)>,
) -> Result<(T, usize), ManifoldError> {
    let (mut count, mut sum, mut absolute_sum) = (0_usize, T::zero(), T::zero());
    for (index, (_, w)) in samples.enumerate() {
        if !w.is_finite() {
            return Err(ManifoldError::NonFiniteWeight {
                index,
                value: w.to_f64(),
            });
        }
        count += 1;
        sum += w;
        absolute_sum += w.abs();
    }
    if count == 0 {
        return Err(ManifoldError::EmptyInput {
            what: "the weighted mean",
        });
    }
    let rounding = T::lit(count as f64) * T::default_epsilon() * absolute_sum;
    if !(sum.is_finite() && absolute_sum.is_finite() && sum.abs() > rounding) {
        return Err(ManifoldError::DegenerateWeights {
            sum: sum.to_f64(),
            absolute_sum: absolute_sum.to_f64(),
        });
    }
    Ok((sum, count))
}
