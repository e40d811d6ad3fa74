//! The particle filter, generic over the state space: weighted samples with log weights, Bayes by
//! reweighting (with the log evidence), propagation by sampling, and four resampling schemes.

use crate::OperatorError;
use crate::error::{check_size, reserve, with_capacity};
use crate::numerics::LogWeights;
use liebayes_manifolds::{Manifold, MeanSettings, weighted_mean};
use rand::Rng;

/// What a failed Bayes step of a particle set names.
const LIKELIHOOD: &str = "particle log-likelihood";
/// What a particle count names.
const PARTICLES: &str = "number of particles";

/// How to resample N particles from normalised weights wᵢ. All four are unbiased (each particle's
/// expected number of copies is N wᵢ); they differ in variance and cost:
///
/// * `Multinomial`: N independent draws; the highest variance.
/// * `Stratified`: one uniform draw in each of the N strata [k/N, (k+1)/N).
/// * `Systematic`: one uniform offset u, points (k + u)/N; each particle gets ⌊N wᵢ⌋ or ⌈N wᵢ⌉ copies.
/// * `Residual`: ⌊N wᵢ⌋ copies each, then the remainder multinomially from the residual weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Resampling {
    /// Independent draws.
    Multinomial,
    /// One draw per stratum.
    Stratified,
    /// One offset for all strata.
    Systematic,
    /// Deterministic floors, then multinomial on the residuals.
    Residual,
}

/// Weighted particles `Σ wᵢ δ(x − xᵢ)`, weights kept as logarithms so that no likelihood underflows.
#[derive(Clone, Debug)]
pub struct ParticleSet<X> {
    particles: Vec<X>,
    /// The normalised log weights, with the buffer a Bayes step fills (also the weights' buffer when
    /// resampling), so that no step allocates.
    weights: LogWeights,
    /// The resampled indices.
    indices: Vec<usize>,
    /// The resampling's other buffers.
    work: Workspace,
    /// The stepped or resampled particles, swapped with `particles`.
    spare: Vec<X>,
}

impl<X: Clone> ParticleSet<X> {
    /// Equally weighted particles (samples of the prior).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for an empty set, [`OperatorError::TooLarge`] for more than
    /// [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) particles or when the set's buffers cannot be
    /// allocated.
    pub fn from_samples(particles: Vec<X>) -> Result<Self, OperatorError> {
        let n = particles.len();
        if n == 0 {
            return Err(OperatorError::OutOfRange {
                what: PARTICLES,
                value: 0.0,
                range: "at least 1",
            });
        }
        Ok(Self {
            weights: LogWeights::uniform(PARTICLES, n)?,
            indices: with_capacity(PARTICLES, n)?,
            work: Workspace::default(),
            spare: with_capacity(PARTICLES, n)?,
            particles,
        })
    }

    /// Weighted particles from linear weights `wᵢ ≥ 0` (any positive total; normalised here).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for an empty set, for a number of weights different from the
    /// number of particles, or for a negative weight; [`OperatorError::NonFinite`] for a NaN or
    /// infinite weight or when every weight is zero.
    pub fn from_weighted_samples(
        particles: Vec<X>,
        weights: &[f64],
    ) -> Result<Self, OperatorError> {
        if let Some(&w) = weights.iter().find(|w| !w.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "particle weight",
                value: w,
            });
        }
        if let Some(&w) = weights.iter().find(|w| **w < 0.0) {
            return Err(OperatorError::OutOfRange {
                what: "particle weight",
                value: w,
                range: "[0, infinity)",
            });
        }
        Self::with_log_weights(particles, weights.len(), weights.iter().map(|w| w.ln()))
    }

    /// Weighted particles from log weights `ln wᵢ` (any finite offset; −∞ is a zero weight),
    /// normalised here without leaving the log domain, so weights below the smallest f64 are kept.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for an empty set or a number of log weights different from the
    /// number of particles; [`OperatorError::NonFinite`] for a NaN or +∞ log weight or when every
    /// weight is zero.
    pub fn from_log_weighted_samples(
        particles: Vec<X>,
        log_weights: &[f64],
    ) -> Result<Self, OperatorError> {
        Self::with_log_weights(particles, log_weights.len(), log_weights.iter().copied())
    }

    /// The particles with the given log weights (unnormalised), checked and normalised.
    fn with_log_weights(
        particles: Vec<X>,
        count: usize,
        log_weights: impl Iterator<Item = f64>,
    ) -> Result<Self, OperatorError> {
        if count != particles.len() {
            return Err(OperatorError::OutOfRange {
                what: "number of weights",
                value: count as f64,
                range: "equal to the number of particles",
            });
        }
        let mut set = Self::from_samples(particles)?;
        let pending = set.weights.pending();
        pending.clear();
        pending.extend(log_weights);
        set.weights.replace_with_pending("particle log weight")?;
        Ok(set)
    }

    /// The particles.
    pub fn particles(&self) -> &[X] {
        &self.particles
    }

    /// The normalised log weights `ln wᵢ` (`Σ wᵢ = 1` is kept after every step).
    pub fn log_weights(&self) -> &[f64] {
        self.weights.values()
    }

    /// The normalised weights (allocates; for reporting, not per step).
    pub fn weights(&self) -> Vec<f64> {
        self.log_weights().iter().map(|l| l.exp()).collect()
    }

    /// The effective sample size `1 / Σ wᵢ²` of the normalised weights, in [1, N].
    pub fn effective_sample_size(&self) -> f64 {
        1.0 / self
            .log_weights()
            .iter()
            .map(|l| (2.0 * l).exp())
            .sum::<f64>()
    }

    /// Chapman-Kolmogorov by sampling: each particle moves to a draw of `transition(x, rng)`, checked
    /// with [`Manifold::is_finite`].
    ///
    /// # Errors
    /// [`OperatorError::NonFinitePoint`] when a moved particle is not finite; the set is then
    /// unchanged (the draws already taken from `rng` are not given back).
    pub fn propagate<R: Rng + ?Sized, const D: usize>(
        &mut self,
        rng: &mut R,
        mut transition: impl FnMut(&X, &mut R) -> X,
    ) -> Result<(), OperatorError>
    where
        X: Manifold<D>,
    {
        self.spare.clear();
        for x in &self.particles {
            let moved = transition(x, rng);
            if !moved.is_finite() {
                return Err(OperatorError::NonFinitePoint {
                    what: "a particle moved by the transition",
                });
            }
            self.spare.push(moved);
        }
        std::mem::swap(&mut self.particles, &mut self.spare);
        Ok(())
    }

    /// Propagation where each particle carries a density of its own (the marginalized particle filter):
    /// `step(x)` returns the moved particle and may fail. For particles that are not points of a
    /// manifold the step is where they are validated (a density payload checks itself when it is
    /// built); points of a manifold move with [`propagate`](Self::propagate), which checks them.
    ///
    /// # Errors
    /// The first error of `step`; the set is then unchanged.
    pub fn try_propagate(
        &mut self,
        mut step: impl FnMut(&X) -> Result<X, OperatorError>,
    ) -> Result<(), OperatorError> {
        self.spare.clear();
        for x in &self.particles {
            self.spare.push(step(x)?);
        }
        std::mem::swap(&mut self.particles, &mut self.spare);
        Ok(())
    }

    /// Bayes by reweighting: `ln wᵢ += ln p(z | xᵢ)`, then normalisation. Returns the log evidence
    /// estimate `ln Σ wᵢ p(z | xᵢ)` (wᵢ normalised before the update), unbiased for p(z) in the linear
    /// domain.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a log-likelihood is NaN or +∞, or when every particle has
    /// likelihood zero (the measurement is impossible under the particles: resample from a wider prior),
    /// or when the log evidence is below −f64::MAX. The weights are then left unchanged.
    pub fn condition(&mut self, log_likelihood: impl Fn(&X) -> f64) -> Result<f64, OperatorError> {
        let pending = self.weights.pending();
        pending.clear();
        pending.extend(self.particles.iter().map(log_likelihood));
        self.weights.add_pending(LIKELIHOOD)
    }

    /// Bayes for particles that carry a density of their own (the marginalized particle filter):
    /// `step(x)` returns the particle's conditioned payload and its log-likelihood, typically the log
    /// evidence of an exact conditioning (see [`crate::rao_blackwell::condition_marginalized`]).
    ///
    /// # Errors
    /// The first error of `step`, or as [`condition`](Self::condition); the set is then unchanged.
    pub fn condition_with(
        &mut self,
        mut step: impl FnMut(&X) -> Result<(X, f64), OperatorError>,
    ) -> Result<f64, OperatorError> {
        self.spare.clear();
        let pending = self.weights.pending();
        pending.clear();
        for x in &self.particles {
            let (next, ll) = step(x)?;
            self.spare.push(next);
            pending.push(ll);
        }
        let evidence = self.weights.add_pending(LIKELIHOOD)?;
        std::mem::swap(&mut self.particles, &mut self.spare);
        Ok(evidence)
    }

    /// [`condition`](Self::condition) with the likelihoods evaluated in parallel by rayon (feature
    /// `rayon`); worth it from a few thousand particles or for costly likelihoods.
    ///
    /// # Errors
    /// As [`condition`](Self::condition).
    #[cfg(feature = "rayon")]
    pub fn condition_parallel(
        &mut self,
        log_likelihood: impl Fn(&X) -> f64 + Sync + Send,
    ) -> Result<f64, OperatorError>
    where
        X: Sync,
    {
        use rayon::prelude::*;
        self.particles
            .par_iter()
            .map(log_likelihood)
            .collect_into_vec(self.weights.pending());
        self.weights.add_pending(LIKELIHOOD)
    }

    /// Resamples to N equally weighted particles with `scheme`.
    pub fn resample<R: Rng + ?Sized>(&mut self, scheme: Resampling, rng: &mut R) {
        let n = self.particles.len();
        // The weights are normalised, finite and not all zero (kept so by every step), and the
        // buffers have room for n: nothing here can fail.
        resample_into(
            self.weights.linear(),
            n,
            scheme,
            rng,
            &mut self.work,
            &mut self.indices,
        );
        self.spare.clear();
        self.spare
            .extend(self.indices.iter().map(|&i| self.particles[i].clone()));
        std::mem::swap(&mut self.particles, &mut self.spare);
        self.weights.reset_uniform();
    }

    /// Resamples when the effective sample size falls below `fraction · N` (0.5 is the usual choice);
    /// returns whether it did (never for a NaN fraction).
    pub fn resample_if_degenerate<R: Rng + ?Sized>(
        &mut self,
        fraction: f64,
        scheme: Resampling,
        rng: &mut R,
    ) -> bool {
        let degenerate = self.effective_sample_size() < fraction * self.particles.len() as f64;
        if degenerate {
            self.resample(scheme, rng);
        }
        degenerate
    }

    /// `Σ wᵢ f(xᵢ)`.
    pub fn expectation<T>(&self, f: impl Fn(&X) -> T) -> T
    where
        T: std::ops::Mul<f64, Output = T> + std::iter::Sum,
    {
        self.log_weights()
            .iter()
            .zip(&self.particles)
            .map(|(l, x)| f(x) * l.exp())
            .sum()
    }
}

impl<X> ParticleSet<X> {
    /// The weighted mean on the manifold, the fixed point of `m ← m ⊞ Σ wᵢ (xᵢ ⊟ m)`, by the
    /// manifolds crate's [`weighted_mean`] from the heaviest particle (default [`MeanSettings`]).
    /// Never an average of coordinates, so particles on both sides of ±π average correctly. The fixed
    /// point is unique while the particles lie within a ball of radius below half the injectivity
    /// radius; for particles spread over the whole space (a uniform angle) the mean is not defined.
    ///
    /// # Errors
    /// [`OperatorError::Manifold`] when the iteration does not converge (particles spread over the
    /// whole space) or the weights are degenerate.
    pub fn mean<const D: usize>(&self) -> Result<X, OperatorError>
    where
        X: Manifold<D, Scalar = f64>,
    {
        let heaviest = self
            .log_weights()
            .iter()
            .zip(&self.particles)
            .max_by(|a, b| a.0.total_cmp(b.0))
            .map_or(&self.particles[0], |(_, x)| x);
        weighted_mean(
            heaviest,
            self.particles
                .iter()
                .zip(self.log_weights())
                .map(|(x, l)| (x, l.exp())),
            MeanSettings::default(),
        )
        .map_err(|source| OperatorError::Manifold {
            what: "the weighted mean of the particles",
            source,
        })
    }
}

/// The indices of n draws from `weights` by `scheme`, in increasing order (empty for n = 0). The
/// weights need not be normalised: they are divided by their largest value and then by their sum
/// before anything is drawn, so that any finite non-negative weights with a positive sum (1e300,
/// subnormals) give draws in proportion to them. Allocates its result;
/// [`ParticleSet::resample`] reuses buffers instead.
///
/// # Errors
/// [`OperatorError::OutOfRange`] for no weights (with n > 0) or a negative weight,
/// [`OperatorError::NonFinite`] for a NaN or infinite weight or weights that are all zero,
/// [`OperatorError::TooLarge`] for n above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the result
/// cannot be allocated; all checked before anything is allocated.
pub fn resample_indices<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
) -> Result<Vec<usize>, OperatorError> {
    const DRAWS: &str = "number of resampled draws";
    check_size(DRAWS, n)?;
    if n == 0 {
        return Ok(Vec::new());
    }
    if weights.is_empty() {
        return Err(OperatorError::OutOfRange {
            what: "number of weights to resample from",
            value: 0.0,
            range: "at least 1",
        });
    }
    if let Some(&w) = weights.iter().find(|w| !w.is_finite()) {
        return Err(OperatorError::NonFinite {
            what: "resampling weight",
            value: w,
        });
    }
    if let Some(&w) = weights.iter().find(|w| **w < 0.0) {
        return Err(OperatorError::OutOfRange {
            what: "resampling weight",
            value: w,
            range: "[0, infinity)",
        });
    }
    let largest = weights.iter().copied().fold(0.0, f64::max);
    if largest == 0.0 {
        return Err(OperatorError::NonFinite {
            what: "total resampling weight (every weight is zero)",
            value: 0.0,
        });
    }
    let mut work = Workspace::default();
    reserve(
        &mut work.normalised,
        "number of weights to resample from",
        weights.len(),
    )?;
    work.normalised.extend(weights.iter().map(|w| w / largest));
    let total: f64 = work.normalised.iter().sum();
    for w in &mut work.normalised {
        *w /= total;
    }
    let mut indices = with_capacity(DRAWS, n)?;
    reserve(&mut work.points, DRAWS, n)?;
    reserve(
        &mut work.residual,
        "number of weights to resample from",
        weights.len(),
    )?;
    let normalised = std::mem::take(&mut work.normalised);
    resample_into(&normalised, n, scheme, rng, &mut work, &mut indices);
    Ok(indices)
}

/// Buffers reused from one resampling to the next.
#[derive(Clone, Debug, Default)]
struct Workspace {
    points: Vec<f64>,
    residual: Vec<f64>,
    /// The weights of [`resample_indices`], normalised.
    normalised: Vec<f64>,
}

/// n draws from normalised, finite, non-negative `weights` (at least one, not all zero) into `out`
/// (cleared first), with the workspace's buffers.
fn resample_into<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
    work: &mut Workspace,
    out: &mut Vec<usize>,
) {
    out.clear();
    if n == 0 {
        return;
    }
    let nf = n as f64;
    let points = &mut work.points;
    points.clear();
    match scheme {
        Resampling::Multinomial => {
            points.extend((0..n).map(|_| rng.random::<f64>()));
            points.sort_by(f64::total_cmp);
            select(weights, points, out);
        }
        Resampling::Stratified => {
            points.extend((0..n).map(|k| (k as f64 + rng.random::<f64>()) / nf));
            select(weights, points, out);
        }
        Resampling::Systematic => {
            let u = rng.random::<f64>();
            points.extend((0..n).map(|k| (k as f64 + u) / nf));
            select(weights, points, out);
        }
        Resampling::Residual => {
            // With normalised weights ⌊N wᵢ⌋ ≤ N wᵢ, so the floors sum to at most N (up to the
            // rounding of N wᵢ, which the bound below absorbs).
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            for (i, w) in weights.iter().enumerate() {
                let copies = ((nf * w).floor() as usize).min(n - out.len());
                out.extend(std::iter::repeat_n(i, copies));
            }
            let rest = n - out.len();
            if rest > 0 {
                let residual = &mut work.residual;
                residual.clear();
                residual.extend(weights.iter().map(|w| nf * w - (nf * w).floor()));
                let total: f64 = residual.iter().sum();
                if total > 0.0 {
                    for r in residual.iter_mut() {
                        *r /= total;
                    }
                    points.extend((0..rest).map(|_| rng.random::<f64>()));
                    points.sort_by(f64::total_cmp);
                    select(residual, points, out);
                } else {
                    // Every N wᵢ was an integer up to rounding: the floors fell short of N only by
                    // that rounding, and the heaviest particle takes the rest.
                    let heaviest = weights
                        .iter()
                        .enumerate()
                        .max_by(|a, b| a.1.total_cmp(b.1))
                        .map_or(0, |(i, _)| i);
                    out.extend(std::iter::repeat_n(heaviest, rest));
                }
                out.sort_unstable();
            }
        }
    }
}

/// For sorted points in [0, 1), appends the index whose cumulative-weight interval holds each point;
/// a point past the rounded total goes to the last particle of positive weight, never to a trailing
/// particle of weight zero.
fn select(weights: &[f64], sorted_points: &[f64], out: &mut Vec<usize>) {
    let last = weights.iter().rposition(|w| *w > 0.0).unwrap_or(0);
    let mut cumulative = weights[0];
    let mut i = 0;
    for &p in sorted_points {
        while p >= cumulative && i < last {
            i += 1;
            cumulative += weights[i];
        }
        out.push(i);
    }
}
