//! The particle filter, generic over the state space: weighted samples with log weights, Bayes by
//! reweighting (with the log evidence), propagation by sampling, and four resampling schemes.

use crate::OperatorError;
use crate::numerics::{LogWeights, manifold_mean};
use liebayes_manifolds::Manifold;
use rand::Rng;

/// What a failed Bayes step of a particle set names.
const LIKELIHOOD: &str = "particle log-likelihood";

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
    /// [`OperatorError::OutOfRange`] for an empty set.
    pub fn from_samples(particles: Vec<X>) -> Result<Self, OperatorError> {
        if particles.is_empty() {
            return Err(OperatorError::OutOfRange {
                what: "number of particles",
                value: 0.0,
                range: "at least 1",
            });
        }
        Ok(Self {
            weights: LogWeights::uniform(particles.len()),
            indices: Vec::with_capacity(particles.len()),
            work: Workspace::default(),
            spare: Vec::with_capacity(particles.len()),
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

    /// Chapman-Kolmogorov by sampling: each particle moves to a draw of `transition(x, rng)`.
    pub fn propagate<R: Rng + ?Sized>(
        &mut self,
        rng: &mut R,
        mut transition: impl FnMut(&X, &mut R) -> X,
    ) {
        for x in &mut self.particles {
            *x = transition(x, rng);
        }
    }

    /// Propagation where each particle carries a density of its own (the marginalized particle filter):
    /// `step(x)` returns the moved particle and may fail.
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
    /// likelihood zero (the measurement is impossible under the particles: resample from a wider prior).
    /// The weights are then left unchanged.
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
    /// returns whether it did.
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
    /// The weighted mean on the manifold, the fixed point of `m ← m ⊞ Σ wᵢ (xᵢ ⊟ m)`, by Gauss-Newton
    /// from the heaviest particle (at most 50 iterations, stopping at a step below 1e-12; the same
    /// function as the UKF's sigma-point mean). Never an average of coordinates, so particles on both
    /// sides of ±π average correctly. The fixed point is unique while the particles lie within a ball
    /// of radius below half the injectivity radius; for particles spread over the whole space (a
    /// uniform angle) the mean is not defined and the result is the last iterate.
    pub fn mean<const D: usize>(&self) -> X
    where
        X: Manifold<D, Scalar = f64>,
    {
        let heaviest = self
            .log_weights()
            .iter()
            .zip(&self.particles)
            .max_by(|a, b| a.0.total_cmp(b.0))
            .map_or(&self.particles[0], |(_, x)| x);
        manifold_mean(
            heaviest,
            &self
                .log_weights()
                .iter()
                .zip(&self.particles)
                .map(|(l, x)| (l.exp(), x)),
        )
    }
}

/// The indices of n draws from normalised `weights` by `scheme`, in increasing order (empty when n or
/// the weights are). Allocates its result; [`ParticleSet::resample`] reuses buffers instead.
pub fn resample_indices<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
) -> Vec<usize> {
    let mut indices = Vec::with_capacity(n);
    resample_into(
        weights,
        n,
        scheme,
        rng,
        &mut Workspace::default(),
        &mut indices,
    );
    indices
}

/// Buffers reused from one resampling to the next.
#[derive(Clone, Debug, Default)]
struct Workspace {
    points: Vec<f64>,
    residual: Vec<f64>,
}

/// [`resample_indices`] into `out` (cleared first), with the workspace's buffers.
fn resample_into<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
    work: &mut Workspace,
    out: &mut Vec<usize>,
) {
    out.clear();
    if weights.is_empty() || n == 0 {
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
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            for (i, w) in weights.iter().enumerate() {
                let copies = (nf * w).floor() as usize;
                out.extend(std::iter::repeat_n(i, copies));
            }
            let rest = n - out.len().min(n);
            if rest > 0 {
                let residual = &mut work.residual;
                residual.clear();
                residual.extend(weights.iter().map(|w| nf * w - (nf * w).floor()));
                let total: f64 = residual.iter().sum();
                for r in residual.iter_mut() {
                    *r /= total;
                }
                points.extend((0..rest).map(|_| rng.random::<f64>()));
                points.sort_by(f64::total_cmp);
                select(residual, points, out);
                out.sort_unstable();
            }
            out.truncate(n);
        }
    }
}

/// For sorted points in [0, 1), appends the index whose cumulative-weight interval holds each point.
fn select(weights: &[f64], sorted_points: &[f64], out: &mut Vec<usize>) {
    let mut cumulative = weights[0];
    let mut i = 0;
    for &p in sorted_points {
        while p >= cumulative && i + 1 < weights.len() {
            i += 1;
            cumulative += weights[i];
        }
        out.push(i);
    }
}
