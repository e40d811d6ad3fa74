//! The particle filter, generic over the state space: weighted samples with log weights, stepped
//! through [`Propagate`] and [`Condition`] like every density of the crate.
//!
//! * **propagate** with [`Sampled`] (a [`SampledProcess`] with its generator and resampling rule):
//!   the set is resampled first when its effective sample size is below the rule's threshold, then
//!   every particle moves to a draw of `x′ ~ p(x′ | x, u)`;
//! * **condition** with [`Reweight`] (a [`Likelihood`]): `ln wᵢ += ln p(z | xᵢ)`, normalised, with
//!   the log evidence estimate `ln Σ wᵢ p(z | xᵢ)`; `ReweightInParallel` (feature `rayon`) the
//!   same with the likelihoods of [`PARALLEL_MIN_PARTICLES`] or more particles on every core;
//! * **condition** with [`Given`] for particles `(y, p(x | y))` that carry a density (the
//!   marginalized particle filter): each payload conditioned exactly with the model of its label,
//!   reweighted by that conditioning's log evidence;
//! * four resampling schemes ([`Resampling`]), by hand with [`ParticleSet::resample`] or as part of
//!   a propagation; a [`Resampler`] (or its one-off form [`resample_indices`]) for weights held
//!   elsewhere.
//!
//! Every step is all or nothing (a failed step leaves particles and weights as they were) and,
//! through the in-place methods, allocates nothing: the set keeps its buffers between steps.

mod models;
mod resampling;

pub use models::{
    Given, LabelModel, Likelihood, LikelihoodFn, Reweight, SampleFn, Sampled, SampledProcess,
    finite_point,
};
pub use resampling::{Resampler, Resampling, resample_indices};

use crate::error::with_capacity;
use crate::numerics::{LogWeights, Passes};
use crate::traits::{condition_clone, propagate_clone};
use crate::{Condition, Conditioned, Evidence, OperatorError, Propagate};
use liebayes_manifolds::{Manifold, MeanSettings, weighted_mean};
use rand::{Rng, RngCore};
use resampling::Weights;

/// What a failed Bayes step of a particle set names.
const LIKELIHOOD: &str = "particle log-likelihood";
/// What a particle count names.
const PARTICLES: &str = "number of particles";

/// With the `rayon` feature, `ReweightInParallel` evaluates the likelihoods of a set of at least this
/// many particles in parallel (fewer are evaluated serially, where the threads would cost more than
/// they save). The weights and the log evidence are the same bit for bit either way: the
/// likelihoods and the passes of the normalisation run in parallel, the normalisation's sums added
/// in fixed chunks of 4096 in the same order as the serial step. Chosen where the threads
/// start to pay for a cheap likelihood (the Gaussian log density of a scalar) on two cores; a
/// costly likelihood would gain from fewer. Without the feature every set is evaluated serially.
pub const PARALLEL_MIN_PARTICLES: usize = 4096;

/// Weighted particles `Σ wᵢ δ(x − xᵢ)`, weights kept as logarithms so that no likelihood underflows.
#[derive(Clone, Debug)]
///
/// # Example
/// ```
/// use liebayes_operators::manifolds::So2;
/// use liebayes_operators::particle::{LikelihoodFn, ParticleSet, Reweight};
/// use liebayes_operators::{Condition, OperatorError};
///
/// let particles = vec![So2::from_angle_unchecked(-0.2), So2::from_angle_unchecked(0.2)];
/// let set = ParticleSet::from_samples(particles)?;
/// assert_eq!(set.effective_sample_size(), 2.0);
/// // A likelihood twice as large at the second particle: weights 1/3 and 2/3.
/// let likelihood = LikelihoodFn::new(|x: &So2<f64>, _: &()| if x.angle() > 0.0 { 2f64.ln() } else { 0.0 });
/// let step = set.condition(&Reweight(likelihood), &())?;
/// let w = step.posterior.weights();
/// assert!((w[1] - 2.0 / 3.0).abs() < 1e-15);
/// // The evidence is the prior mean of the likelihood, (1 + 2)/2.
/// assert!((step.log_evidence - 1.5f64.ln()).abs() < 1e-15);
/// # Ok::<(), OperatorError>(())
/// ```
pub struct ParticleSet<X> {
    particles: Vec<X>,
    /// The normalised log weights, with the buffer a Bayes step fills (also the weights' buffer when
    /// resampling), so that no step allocates.
    weights: LogWeights,
    /// The resampling's buffers.
    resampler: Resampler,
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
            resampler: Resampler::with_capacity(n)?,
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

    /// The effective sample size `1 / Σ wᵢ²` of the normalised weights, in [1, N] (kept with the
    /// weights: no work at the call).
    pub fn effective_sample_size(&self) -> f64 {
        self.weights.effective_size()
    }

    /// Resamples to N equally weighted particles with `scheme`, by hand (a propagation with
    /// [`Sampled`] resamples by its own rule). Allocates nothing.
    pub fn resample<R: Rng + ?Sized>(&mut self, scheme: Resampling, rng: &mut R) {
        self.draw_indices(scheme, rng);
        self.spare.clear();
        self.spare.extend(
            self.resampler
                .indices()
                .iter()
                .map(|&i| self.particles[i].clone()),
        );
        std::mem::swap(&mut self.particles, &mut self.spare);
        self.weights.reset_uniform();
    }

    /// The indices of a resampling with `scheme` into the resampler, the particles untouched.
    fn draw_indices<R: Rng + ?Sized>(&mut self, scheme: Resampling, rng: &mut R) {
        let n = self.particles.len();
        // The weights are normalised, finite and not all zero (kept so by every step), and the
        // buffers have room for n: nothing here can fail.
        self.resampler
            .draw_checked(Weights::normalised(self.weights.linear()), n, scheme, rng);
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

impl<X, P, R> Propagate<Sampled<P, R>> for ParticleSet<X>
where
    X: Clone,
    P: SampledProcess<X>,
    R: RngCore + Clone,
{
    type Input = P::Input;

    /// A clone of the set, propagated in place.
    fn propagate(&self, model: &Sampled<P, R>, input: &P::Input) -> Result<Self, OperatorError> {
        propagate_clone(self, model, input)
    }

    /// Chapman-Kolmogorov by sampling. When the effective sample size is below the model's
    /// threshold, the resampled indices are drawn first (the particles untouched); then each
    /// particle (each resampled one) moves to a draw `x′ ~ p(x′ | x, u)` written into the spare
    /// buffer. Only when every draw succeeded do the particles change, and after a resampling the
    /// weights become uniform.
    ///
    /// # Errors
    /// The first error of the process; the set and the generator are then unchanged (the
    /// generator is restored to its state before the step, so that a failed step does not change
    /// the draws of the next: a run is reproducible from its seed whatever steps failed).
    /// [`OperatorError::InUse`] when the process steps a set through this same model.
    fn propagate_in_place(
        &mut self,
        model: &Sampled<P, R>,
        input: &P::Input,
    ) -> Result<(), OperatorError> {
        let mut rng = model.rng()?;
        let rng: &mut R = &mut rng;
        let before = rng.clone();
        let (fraction, scheme) = model.resampling();
        let resample = self.effective_sample_size() < fraction * self.particles.len() as f64;
        if resample {
            self.draw_indices(scheme, rng);
        }
        let process = model.process();
        self.spare.clear();
        let drawn = if resample {
            self.resampler.indices().iter().try_for_each(|&i| {
                self.spare
                    .push(process.sample(&self.particles[i], input, rng)?);
                Ok(())
            })
        } else {
            self.particles.iter().try_for_each(|x| {
                self.spare.push(process.sample(x, input, rng)?);
                Ok(())
            })
        };
        if let Err(error) = drawn {
            *rng = before;
            return Err(error);
        }
        std::mem::swap(&mut self.particles, &mut self.spare);
        if resample {
            self.weights.reset_uniform();
        }
        Ok(())
    }
}

impl<X, L> Condition<Reweight<L>> for ParticleSet<X>
where
    X: Clone,
    L: Likelihood<X>,
{
    type Measurement = L::Measurement;
    type Report = ();

    /// A clone of the set, conditioned in place.
    fn condition(
        &self,
        model: &Reweight<L>,
        z: &L::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_clone::<Self, Reweight<L>>(self, model, z)
    }

    /// Bayes by reweighting: `ln wᵢ += ln p(z | xᵢ)`, then normalisation, the particles unchanged.
    /// Returns the log evidence estimate `ln Σ wᵢ p(z | xᵢ)` (wᵢ normalised before the update),
    /// unbiased for p(z) in the linear domain. Serial; `ReweightInParallel` (feature `rayon`)
    /// evaluates the likelihoods on every core.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a log-likelihood is NaN or +∞, when every particle has
    /// likelihood zero (the measurement is impossible under the particles: start from a wider
    /// prior), or when the log evidence is below −f64::MAX. The weights are then unchanged.
    fn condition_in_place(
        &mut self,
        model: &Reweight<L>,
        z: &L::Measurement,
    ) -> Result<Evidence, OperatorError> {
        self.log_likelihoods(&model.0, z);
        Ok(Evidence {
            log_evidence: self.weights.add_pending(LIKELIHOOD, Passes::Serial)?,
            report: (),
        })
    }
}

/// [`Reweight`] with the likelihoods and the normalisation of [`PARALLEL_MIN_PARTICLES`] or more
/// particles computed in parallel by rayon (feature `rayon`), with the same result bit for bit.
/// Worth it for one filter with many particles or a costly likelihood (the angle-of-arrival
/// likelihood of four anchors at 10⁶ particles: 53 M particle-updates per second on 2 cores against
/// 35 M serial); not inside a study that already runs one filter per core, where the nested
/// threads only compete with the serial steps, nor for small sets (at 10⁴ particles the serial
/// step is faster).
#[cfg(feature = "rayon")]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReweightInParallel<L>(pub L);

#[cfg(feature = "rayon")]
impl<X, L> Condition<ReweightInParallel<L>> for ParticleSet<X>
where
    X: Clone + Sync,
    L: Likelihood<X> + Sync,
    L::Measurement: Sync,
{
    type Measurement = L::Measurement;
    type Report = ();

    /// A clone of the set, conditioned in place.
    fn condition(
        &self,
        model: &ReweightInParallel<L>,
        z: &L::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_clone::<Self, ReweightInParallel<L>>(self, model, z)
    }

    /// As [`Reweight`]'s step, the likelihoods evaluated in parallel from
    /// [`PARALLEL_MIN_PARTICLES`] particles on.
    ///
    /// # Errors
    /// As [`Reweight`]'s step.
    fn condition_in_place(
        &mut self,
        model: &ReweightInParallel<L>,
        z: &L::Measurement,
    ) -> Result<Evidence, OperatorError> {
        let passes = if self.particles.len() >= PARALLEL_MIN_PARTICLES {
            self.parallel_log_likelihoods(&model.0, z);
            Passes::Parallel
        } else {
            self.log_likelihoods(&model.0, z);
            Passes::Serial
        };
        Ok(Evidence {
            log_evidence: self.weights.add_pending(LIKELIHOOD, passes)?,
            report: (),
        })
    }
}

impl<X> ParticleSet<X> {
    /// `ln p(z | xᵢ)` into the pending buffer (whose capacity is N: nothing is allocated).
    fn log_likelihoods<L: Likelihood<X>>(&mut self, likelihood: &L, z: &L::Measurement) {
        let pending = self.weights.pending();
        pending.clear();
        pending.extend(
            self.particles
                .iter()
                .map(|x| likelihood.log_likelihood(x, z)),
        );
    }

    /// [`log_likelihoods`](Self::log_likelihoods) evaluated in parallel by rayon, each value the
    /// same as the serial one.
    #[cfg(feature = "rayon")]
    fn parallel_log_likelihoods<L>(&mut self, likelihood: &L, z: &L::Measurement)
    where
        X: Sync,
        L: Likelihood<X> + Sync,
        L::Measurement: Sync,
    {
        use rayon::prelude::*;
        self.particles
            .par_iter()
            .map(|x| likelihood.log_likelihood(x, z))
            .collect_into_vec(self.weights.pending());
    }
}

impl<Y, G, F> Condition<Given<F>> for ParticleSet<(Y, G)>
where
    Y: Clone,
    F: LabelModel<Y>,
    G: Condition<F::Model> + Clone,
{
    type Measurement = G::Measurement;
    type Report = ();

    /// A clone of the set, conditioned in place.
    fn condition(
        &self,
        model: &Given<F>,
        z: &G::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_clone::<Self, Given<F>>(self, model, z)
    }

    /// The marginalized particle filter's Bayes step: each particle `(yᵢ, p(x | yᵢ))` conditions
    /// its density with the model `F(yᵢ)`, giving `p(x | yᵢ, z)` and `p(z | yᵢ, past)` (exact given
    /// yᵢ), and is reweighted by it, `ln wᵢ += ln p(z | yᵢ, past)`. Returns the log evidence estimate
    /// `ln Σ wᵢ p(z | yᵢ, past)`. The payloads' reports are not kept.
    ///
    /// # Errors
    /// The first error of `F` or of a payload's conditioning, or as [`Reweight`]'s step; the set is
    /// then unchanged.
    fn condition_in_place(
        &mut self,
        model: &Given<F>,
        z: &G::Measurement,
    ) -> Result<Evidence, OperatorError> {
        self.spare.clear();
        let pending = self.weights.pending();
        pending.clear();
        for (y, payload) in &self.particles {
            let step = payload.condition(&model.0.at(y)?, z)?;
            self.spare.push((y.clone(), step.posterior));
            pending.push(step.log_evidence);
        }
        let log_evidence = self.weights.add_pending(LIKELIHOOD, Passes::Serial)?;
        std::mem::swap(&mut self.particles, &mut self.spare);
        Ok(Evidence {
            log_evidence,
            report: (),
        })
    }
}

#[cfg(all(test, feature = "rayon"))]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The parallel reweighting (above the threshold) equals the serial evaluation of the same
    /// likelihoods followed by the same normalisation, bit for bit, weights and log evidence; and a
    /// NaN found by a worker thread is the same error, with the weights unchanged.
    #[test]
    fn parallel_reweighting_equals_serial_bit_for_bit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        // Several chunks of the weight sums and a partial one.
        let samples: Vec<f64> = (0..5 * PARALLEL_MIN_PARTICLES + 17)
            .map(|_| rng.random::<f64>() * 10.0)
            .collect();
        let weights: Vec<f64> = (0..samples.len()).map(|_| rng.random::<f64>()).collect();
        let prior = ParticleSet::from_weighted_samples(samples, &weights).unwrap();
        let likelihood = LikelihoodFn::new(|x: &f64, z: &f64| -0.5 * (x - z) * (x - z) + x.sin());
        let mut parallel = prior.clone();
        let mut serial = prior.clone();
        let step = parallel
            .condition_in_place(&ReweightInParallel(&likelihood), &3.0)
            .unwrap();
        serial.log_likelihoods(&likelihood, &3.0);
        let serial_evidence = serial
            .weights
            .add_pending(LIKELIHOOD, Passes::Serial)
            .unwrap();
        assert_eq!(step.log_evidence.to_bits(), serial_evidence.to_bits());
        assert!(
            parallel
                .log_weights()
                .iter()
                .zip(serial.log_weights())
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        let last = parallel.particles()[parallel.particles().len() - 1];
        let nan_at_last =
            LikelihoodFn::new(|x: &f64, (): &()| if *x == last { f64::NAN } else { 0.0 });
        let before = parallel.log_weights().to_vec();
        assert!(matches!(
            parallel.condition_in_place(&ReweightInParallel(nan_at_last), &()),
            Err(OperatorError::NonFinite { .. })
        ));
        assert_eq!(parallel.log_weights(), &before[..]);
    }
}
