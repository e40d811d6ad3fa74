//! The models weighted containers step with: a process to draw from ([`SampledProcess`], carried
//! with its generator and resampling rule by [`Sampled`]), a likelihood to reweight by
//! ([`Likelihood`], through [`Reweight`]), and the model of a payload given its label ([`Given`]),
//! with closure adapters ([`SampleFn`], [`LikelihoodFn`]).

use super::Resampling;
use crate::OperatorError;
use liebayes_manifolds::Manifold;
use rand::RngCore;
use std::cell::RefCell;
use std::marker::PhantomData;

/// A process to sample: a draw of `x′ ~ p(x′ | x, u)`.
///
/// The model validates what it draws: a point it cannot produce (a coordinate that overflowed, a
/// payload density that cannot be built) is an error, never a particle. For points of a manifold,
/// [`finite_point`] is that check.
pub trait SampledProcess<X> {
    /// What drives the process besides the state (a control, a measured rate and a time step …).
    type Input: ?Sized;

    /// One draw of `x′ ~ p(x′ | x, u)` with `rng`.
    ///
    /// # Errors
    /// When the draw is not a valid state ([`OperatorError::NonFinitePoint`] for a point that is not
    /// finite) or the input is invalid.
    fn sample<G: RngCore>(
        &self,
        x: &X,
        input: &Self::Input,
        rng: &mut G,
    ) -> Result<X, OperatorError>;
}

/// A process used by reference is the process.
impl<X, P: SampledProcess<X> + ?Sized> SampledProcess<X> for &P {
    type Input = P::Input;

    fn sample<G: RngCore>(&self, x: &X, input: &P::Input, rng: &mut G) -> Result<X, OperatorError> {
        (**self).sample(x, input, rng)
    }
}

/// `x` if every coordinate is finite ([`Manifold::is_finite`]), else
/// [`OperatorError::NonFinitePoint`]: the check a [`SampledProcess`] on a manifold makes of its draw.
///
/// # Errors
/// [`OperatorError::NonFinitePoint`] for a point with a NaN or infinite coordinate.
pub fn finite_point<X: Manifold<D>, const D: usize>(x: X) -> Result<X, OperatorError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(OperatorError::NonFinitePoint {
            what: "a particle drawn by the sampled process",
        })
    }
}

/// A [`SampledProcess`] from a closure `sample(x, u, rng) -> Result<x′, OperatorError>`; U is the
/// input type.
///
/// # Example
/// A random walk on the circle, `θ′ = θ + u + w`, `w ~ N(0, 0.1²)`:
/// ```
/// use liebayes_operators::manifolds::{Manifold, So2};
/// use liebayes_operators::particle::{ParticleSet, SampleFn, Sampled, finite_point};
/// use liebayes_operators::{OperatorError, Propagate};
/// use nalgebra::Vector1;
/// use rand::{RngCore, SeedableRng};
/// use rand_distr::{Distribution, StandardNormal};
///
/// let walk = SampleFn::new(|x: &So2<f64>, u: &f64, rng: &mut dyn RngCore| {
///     let w: f64 = StandardNormal.sample(rng);
///     finite_point(x.retract(&Vector1::new(u + 0.1 * w)))
/// });
/// let model = Sampled::new(walk, rand_chacha::ChaCha8Rng::seed_from_u64(7));
/// let mut set = ParticleSet::from_samples(vec![So2::from_angle_unchecked(0.0); 100])?;
/// set.propagate_in_place(&model, &0.5)?;
/// assert!((set.mean()?.angle() - 0.5).abs() < 0.05);
/// # Ok::<(), OperatorError>(())
/// ```
pub struct SampleFn<F, U: ?Sized> {
    sample: F,
    input: PhantomData<fn(&U)>,
}

impl<F: Clone, U: ?Sized> Clone for SampleFn<F, U> {
    fn clone(&self) -> Self {
        Self {
            sample: self.sample.clone(),
            input: PhantomData,
        }
    }
}

impl<F: Copy, U: ?Sized> Copy for SampleFn<F, U> {}

impl<F, U: ?Sized> std::fmt::Debug for SampleFn<F, U> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SampleFn").finish_non_exhaustive()
    }
}

impl<F, U: ?Sized> SampleFn<F, U> {
    /// The process that draws with `sample`.
    pub fn new<X>(sample: F) -> Self
    where
        F: Fn(&X, &U, &mut dyn RngCore) -> Result<X, OperatorError>,
    {
        Self {
            sample,
            input: PhantomData,
        }
    }
}

impl<X, U: ?Sized, F> SampledProcess<X> for SampleFn<F, U>
where
    F: Fn(&X, &U, &mut dyn RngCore) -> Result<X, OperatorError>,
{
    type Input = U;

    fn sample<G: RngCore>(&self, x: &X, input: &U, rng: &mut G) -> Result<X, OperatorError> {
        (self.sample)(x, input, rng)
    }
}

/// A [`SampledProcess`] with the generator it draws from and the resampling rule: before each
/// propagation of a particle set, when its effective sample size `1 / Σ wᵢ²` is below
/// `fraction · N`, the set is resampled with `scheme` (and its weights reset to 1/N) as part of the
/// same all-or-nothing step.
///
/// Resampling at the start of a propagation means that an estimate taken after a conditioning step
/// is the weighted one, before resampling (the mean is taken before resampling, which adds
/// variance and nothing else).
///
/// The generator is held in a [`RefCell`], because the stepping traits take the model by shared
/// reference: one `Sampled` is one random stream, shared by whatever it propagates.
#[derive(Clone, Debug)]
pub struct Sampled<P, R> {
    process: P,
    rng: RefCell<R>,
    fraction: f64,
    scheme: Resampling,
}

impl<P, R> Sampled<P, R> {
    /// The process with its generator, resampling systematically when the effective sample size is
    /// below half the number of particles.
    pub fn new(process: P, rng: R) -> Self {
        Self {
            process,
            rng: RefCell::new(rng),
            fraction: 0.5,
            scheme: Resampling::Systematic,
        }
    }

    /// The process with its generator, resampling with `scheme` when the effective sample size is
    /// below `fraction · N`, fraction in [0, 1]: 0 never resamples, 1 resamples at every step
    /// (uniform weights may be resampled too, by rounding, which changes nothing in distribution).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for a fraction outside [0, 1] or NaN.
    pub fn with_resampling(
        process: P,
        rng: R,
        fraction: f64,
        scheme: Resampling,
    ) -> Result<Self, OperatorError> {
        if !(0.0..=1.0).contains(&fraction) {
            return Err(OperatorError::OutOfRange {
                what: "resampling threshold (fraction of the number of particles)",
                value: fraction,
                range: "[0, 1] (0 never resamples)",
            });
        }
        Ok(Self {
            process,
            rng: RefCell::new(rng),
            fraction,
            scheme,
        })
    }

    /// The process.
    pub fn process(&self) -> &P {
        &self.process
    }

    /// The threshold fraction and the scheme.
    pub(crate) fn resampling(&self) -> (f64, Resampling) {
        (self.fraction, self.scheme)
    }

    /// The generator, mutably for one step.
    ///
    /// # Errors
    /// [`OperatorError::InUse`] when a step is already drawing from it (a process that steps a set
    /// through the very model it is part of).
    pub(crate) fn rng(&self) -> Result<std::cell::RefMut<'_, R>, OperatorError> {
        self.rng.try_borrow_mut().map_err(|_| OperatorError::InUse {
            what: "the random number generator of a Sampled model",
        })
    }
}

/// A measurement's log-likelihood `ln p(z | x)` as a function of the state.
pub trait Likelihood<X> {
    /// The measurement's type.
    type Measurement: ?Sized;

    /// `ln p(z | x)`, in (−∞, ∞) or −∞ (an impossible measurement at x); NaN and +∞ make the step
    /// that evaluates it fail.
    fn log_likelihood(&self, x: &X, z: &Self::Measurement) -> f64;
}

/// A likelihood used by reference is the likelihood.
impl<X, L: Likelihood<X> + ?Sized> Likelihood<X> for &L {
    type Measurement = L::Measurement;

    fn log_likelihood(&self, x: &X, z: &L::Measurement) -> f64 {
        (**self).log_likelihood(x, z)
    }
}

/// A [`Likelihood`] from a closure `log_likelihood(x, z)`; Z is the measurement type.
///
/// # Example
/// ```
/// use liebayes_operators::particle::{LikelihoodFn, ParticleSet, Reweight};
/// use liebayes_operators::{Condition, OperatorError};
///
/// // z = x + n, n ~ N(0, 1), up to the constant −ln √(2π).
/// let gauss = LikelihoodFn::new(|x: &f64, z: &f64| -0.5 * (z - x) * (z - x));
/// let mut set = ParticleSet::from_samples(vec![0.0, 1.0, 2.0])?;
/// let step = set.condition_in_place(&Reweight(gauss), &1.0)?;
/// assert!((set.weights()[1] - 1.0 / (1.0 + 2.0 * (-0.5_f64).exp())).abs() < 1e-15);
/// assert!(step.log_evidence < 0.0);
/// # Ok::<(), OperatorError>(())
/// ```
pub struct LikelihoodFn<F, Z: ?Sized> {
    log_likelihood: F,
    measurement: PhantomData<fn(&Z)>,
}

impl<F: Clone, Z: ?Sized> Clone for LikelihoodFn<F, Z> {
    fn clone(&self) -> Self {
        Self {
            log_likelihood: self.log_likelihood.clone(),
            measurement: PhantomData,
        }
    }
}

impl<F: Copy, Z: ?Sized> Copy for LikelihoodFn<F, Z> {}

impl<F, Z: ?Sized> std::fmt::Debug for LikelihoodFn<F, Z> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LikelihoodFn").finish_non_exhaustive()
    }
}

impl<F, Z: ?Sized> LikelihoodFn<F, Z> {
    /// The likelihood with log density `log_likelihood(x, z)`.
    pub fn new<X>(log_likelihood: F) -> Self
    where
        F: Fn(&X, &Z) -> f64,
    {
        Self {
            log_likelihood,
            measurement: PhantomData,
        }
    }
}

impl<X, Z: ?Sized, F> Likelihood<X> for LikelihoodFn<F, Z>
where
    F: Fn(&X, &Z) -> f64,
{
    type Measurement = Z;

    fn log_likelihood(&self, x: &X, z: &Z) -> f64 {
        (self.log_likelihood)(x, z)
    }
}

/// Bayes by reweighting with a likelihood: `ln wᵢ += ln p(z | xᵢ)`, then normalisation, the points
/// (or the payloads) unchanged. The measurement model of a particle set and of a grid (whose cells
/// are given to the likelihood as their rotation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reweight<L>(pub L);

/// The payload's model given the label: for weighted pairs `(label, payload density)` (a particle
/// set of `(y, p(x | y))`, or a grid whose labels are its cells' rotations), `F::at(label)` builds
/// the model the payload is stepped with ([`LabelModel`]: a closure `Fn(&Y) -> Result<M,
/// OperatorError>`, or a model type of the application's). The marginalized (Rao-Blackwellized)
/// particle filter and the bank of filters on a grid are this model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Given<F>(pub F);

/// The model of a payload given its label y (a particle's label, a grid cell's rotation): what
/// [`Given`] steps each payload with. Closures `Fn(&Y) -> Result<M, OperatorError>` are label
/// models; an application's own model type can be one too (a named, cloneable type, where a closure
/// cannot be named).
pub trait LabelModel<Y: ?Sized> {
    /// The payload's model.
    type Model;

    /// The model at label y.
    ///
    /// # Errors
    /// When no valid model exists at y.
    fn at(&self, y: &Y) -> Result<Self::Model, OperatorError>;
}

impl<Y: ?Sized, M, F: Fn(&Y) -> Result<M, OperatorError>> LabelModel<Y> for F {
    type Model = M;

    fn at(&self, y: &Y) -> Result<M, OperatorError> {
        self(y)
    }
}
