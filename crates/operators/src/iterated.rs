//! Iterated updates on any [`Manifold`]: the iterated EKF ([`IteratedEkf`], Gauss-Newton on the
//! MAP cost) and the iterated posterior linearisation ([`IteratedUkf`], sigma points of the current
//! posterior approximation), both on [`ManifoldGaussian`].
//!
//! With the prior `x = μ ⊞ δ`, `δ ~ N(0, P)`, and the measurement `z = h(x) + n`, `n ~ N(0, R)`, the
//! posterior of δ (in the tangent space at μ) is approximated around iterates δᵢ:
//!
//! * **iterated EKF**: the minimiser of the MAP cost
//!   `J(δ) = ½ δᵀ P⁻¹ δ + ½ r(δ)ᵀ R⁻¹ r(δ)`, `r(δ) = z ⊟ h(μ ⊞ δ)`, by Gauss-Newton: h is linearised at
//!   `xᵢ = μ ⊞ δᵢ`, `r(δ) ≈ rᵢ − Hᵢ (δ − δᵢ)` with `Hᵢ = H(xᵢ) J(δᵢ)` (the model's Jacobian chained
//!   with the retraction's, [`Manifold::j_retract_tangent`]), and the Kalman update of the prior with that
//!   linear model proposes `δ̂ = Kᵢ νᵢ`, `νᵢ = rᵢ + Hᵢ δᵢ`, `Kᵢ = P Hᵢᵀ (Hᵢ P Hᵢᵀ + R)⁻¹`;
//! * **iterated posterior linearisation** (García-Fernández, Svensson, Morelande and Särkkä, 2015):
//!   h is linearised statistically, `h(μ ⊞ δ) ≈ A δ + b` with error covariance Ω, by the UKF's sigma
//!   points of the current approximation `N(δᵢ, Pᵢ)`: `A = Ψᵀ Pᵢ⁻¹`, `b = ẑ − A δᵢ`,
//!   `Ω = Φ − A Pᵢ Aᵀ` (ẑ, Φ, Ψ the sigma-point mean, covariance and cross-covariance); the Kalman
//!   update of the prior with it proposes `δ̂ = K ν`, `ν = (z ⊟ ẑ) + A δᵢ`, `S = A P Aᵀ + Ω + R`,
//!   and the next covariance `Pᵢ₊₁`. The sigma points' spread is raised, axis by axis, where one
//!   round trip `(x ⊞ s) ⊟ x` at the iterate x shows it below the rounding of x (there the points
//!   would all land on one value and give the model's slope as zero); the result's covariance is
//!   still the Joseph form of the prior's update.
//!
//! **Step control**: a proposed step that would increase the merit, or whose end the model
//! cannot be linearised at (a non-finite prediction or Jacobian, an update that is not positive
//! definite), is halved, at most [`MAX_HALVINGS`] times, so the merit never increases from iterate
//! to iterate; when no halving decreases it, the iteration stops ([`Stop::NoDescent`]), as it does
//! when even the shortest trial's update is not positive definite (rounding next to an iterate
//! whose update is). When even the shortest trial step fails in the model, the update is that
//! error. The iterated EKF's step is `Δ = δ̂ − δᵢ` and its merit the cost J. The posterior
//! linearisation's iterate is the pair `(δᵢ, Pᵢ)` and its step `(Δ, Pᵢ₊₁ − Pᵢ)`; its fixed point is
//! not J's minimum, so its merit is the length of its own proposed step,
//! `(|L⁻¹ Δ|² + ‖L⁻¹ (Pᵢ₊₁ − Pᵢ) L⁻ᵀ‖²_F)^½` with `P = L Lᵀ`.
//! **Stopping**: when the proposed step's length in the standard deviations of the posterior of
//! the update linearised at the iterate (`|L⁻¹ Δ|` with `Pᵢ₊₁ = L Lᵀ` for the iterated EKF, taken
//! from the factors of P and R as `Pᵢ₊₁⁻¹ = P⁻¹ + Hᵀ R⁻¹ H`; the joint length above in that L for
//! the posterior linearisation) is at most the tolerance ([`Stop::Converged`]), or after
//! [`IterationSettings::max_iterations`] steps ([`Stop::IterationLimit`]). The posterior's
//! deviations, not the prior's: under a diffuse prior (a variance of 1e15 against a unit reading)
//! the first step is 1e-8 prior σ long, and stopping there kept the prior mean.
//!
//! **The result**, at the final iterate δ* and its linearisation: the mean `μ ⊞ δ*`; the covariance of
//! that linearisation's update (Joseph form `(I − K H) P (I − K H)ᵀ + K R Kᵀ` for the EKF, with
//! `Ω + R` for R in the posterior linearisation), transported from the tangent space at μ to the one
//! at the new mean, `J(δ*) P⁺ J(δ*)ᵀ` (first order: `(μ ⊞ δ) ⊟ (μ ⊞ δ*) ≈ J(δ*) (δ − δ*)`; see
//! [`IterationSettings::with_transport`]); the log evidence `ln N(ν; 0, S)` of the final linear(ised)
//! model, the Laplace-type approximation of `ln p(z)` at δ*; and an [`Iterated`] report (ν, S, K and
//! the NIS of the final linearisation, the number of steps and why the iteration stopped).
//!
//! R is the model's noise at the prior mean, fixed over the iterations so that J is one function.
//! On Rⁿ with a linear model both equal the Kalman update after one step. The math, with when to use
//! which, is in `docs/operators/iterated.md`.

use crate::error::all_finite;
use crate::innovation::Innovation;
use crate::kalman::joseph;
use crate::models::MeasurementModel;
use crate::numerics::{
    Produced, above_rounding, checked_gaussian, model_noise, rounding_scale, slope,
};
use crate::ukf::Ukf;
use crate::{Condition, Conditioned, Ekf, OperatorError};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::{Cholesky, SMatrix, SVector};

/// The most halvings of one step before the iteration stops ([`Stop::NoDescent`]): the last step
/// tried is 2⁻³⁰ ≈ 1e-9 of the proposed one.
pub const MAX_HALVINGS: usize = 30;

/// The largest accepted [`IterationSettings::max_iterations`].
pub const MAX_ITERATIONS: usize = 1000;

/// When an iteration stops: a tolerance on the step, a bound on the steps, and whether the
/// covariance is transported to the posterior mean.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterationSettings {
    tolerance: f64,
    max_iterations: usize,
    transport: bool,
    linearity_check: bool,
}

impl Default for IterationSettings {
    /// Tolerance 1e-6 posterior standard deviations, at most 20 steps, covariance transported, no
    /// linearity check. A step of 1e-6 σ changes J by about 1e-12, well above its rounding; much
    /// tighter tolerances can end the iterated EKF in [`Stop::NoDescent`] when the cost's rounding
    /// hides the last decrease.
    fn default() -> Self {
        Self {
            tolerance: 1e-6,
            max_iterations: 20,
            transport: true,
            linearity_check: false,
        }
    }
}

impl IterationSettings {
    /// Stop when a step `Δ` is at most `tolerance` posterior standard deviations (`|L⁻¹ Δ|`, with
    /// `P⁺ = L Lᵀ` the update linearised at the iterate) or after `max_iterations` steps; the
    /// covariance is transported (see
    /// [`with_transport`](Self::with_transport)).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a NaN or infinite tolerance, [`OperatorError::OutOfRange`]
    /// for a negative one or `max_iterations` outside `1..=`[`MAX_ITERATIONS`].
    pub fn new(tolerance: f64, max_iterations: usize) -> Result<Self, OperatorError> {
        all_finite("iteration tolerance", std::iter::once(&tolerance))?;
        if tolerance < 0.0 {
            return Err(OperatorError::OutOfRange {
                what: "iteration tolerance",
                value: tolerance,
                range: "[0, infinity) posterior standard deviations",
            });
        }
        if !(1..=MAX_ITERATIONS).contains(&max_iterations) {
            return Err(OperatorError::OutOfRange {
                what: "maximum number of iterations",
                value: max_iterations as f64,
                range: "1 to 1000",
            });
        }
        Ok(Self {
            tolerance,
            max_iterations,
            transport: true,
            linearity_check: false,
        })
    }

    /// The same settings with the posterior covariance transported to the tangent space at the new
    /// mean, `J(δ*) P⁺ J(δ*)ᵀ` (`true`, the default), or left in the one at the prior mean
    /// (`false`, as the one-pass [`Ekf`] does).
    #[must_use]
    pub fn with_transport(mut self, transport: bool) -> Self {
        self.transport = transport;
        self
    }

    /// The tolerance on a step, in posterior standard deviations.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// The most steps.
    pub fn max_iterations(&self) -> usize {
        self.max_iterations
    }

    /// Whether the covariance is transported to the posterior mean.
    pub fn transport(&self) -> bool {
        self.transport
    }

    /// The same settings with the iterated EKF's result checked against the model (`true`) or not
    /// (`false`, the default): at the posterior `N(x*, P*)` the iteration ends at, the model's
    /// prediction at each of the 2D points `x* ⊞ (±cᵢ)`, cᵢ the columns of P*'s Cholesky factor,
    /// must agree with its linearisation at x* to within [`LINEARITY_BOUND`] = ½ noise standard
    /// deviations, `|L_R⁻¹ [r(x* ⊞ s) − (r(x*) − H(x*) s)]| ≤ ½` (L_R the factor of R). Otherwise
    /// the Gaussian at the mode does not describe the posterior, and the result is the one-pass
    /// EKF's update ([`Stop::Nonlinear`]). That is the case at a model's singularity: a bearing's
    /// Jacobian grows as 1/r next to its origin, Gauss-Newton's curvature with it, and with a
    /// coarse reading and a wide prior the iterates converge onto the origin with a covariance of
    /// nothing. The check costs 2D model evaluations and one Jacobian; the posterior
    /// linearisation ([`IteratedUkf`]), whose linearisation error Ω already spans its spread, does
    /// not make it.
    #[must_use]
    pub fn with_linearity_check(mut self, check: bool) -> Self {
        self.linearity_check = check;
        self
    }

    /// Whether the iterated EKF's result is checked against the model
    /// ([`with_linearity_check`](Self::with_linearity_check)).
    pub fn linearity_check(&self) -> bool {
        self.linearity_check
    }
}

/// The linearisation error e, in noise standard deviations, that the linearity check
/// ([`IterationSettings::with_linearity_check`]) accepts at one posterior standard deviation
/// from the mode. The cost there departs from the Gaussian's quadratic by about e times the
/// whitened residual (of order one): with e ≤ ½ the log density one standard deviation out is
/// within about ½ of the Gaussian's.
///
/// Measured on the angle-of-arrival track study (bearings of 30°, the filters' own random walk,
/// 100 runs): the iterated EKF's mean final NEES (3 degrees of freedom) was 1.9e18 unchecked, 8.8
/// with a bound of 1, 5.9 with ½, 5.3 with ¼ (the one-pass EKF's 3.9); at 0.01° every bound left
/// it consistent.
pub const LINEARITY_BOUND: f64 = 0.5;

/// Why an iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The proposed step was within the tolerance: the iterate is a fixed point.
    Converged,
    /// [`IterationSettings::max_iterations`] steps were taken.
    IterationLimit,
    /// No halving of the proposed step ([`MAX_HALVINGS`]) decreased the merit: the iterate is a
    /// minimum of J to rounding (a tolerance below J's rounding), or the posterior linearisation's
    /// fixed-point iteration does not contract there.
    NoDescent,
    /// The model is not linear over the posterior the iteration ended at (the linearity check of
    /// [`IterationSettings::with_linearity_check`]): the result is the one-pass EKF's update.
    Nonlinear,
}

/// The report of an iterated update: the [`Innovation`] (ν, S, K, NIS) of the final linearisation,
/// the number of steps taken and why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iterated<const N: usize, const M: usize> {
    innovation: Innovation<N, M>,
    iterations: usize,
    stop: Stop,
}

impl<const N: usize, const M: usize> Iterated<N, M> {
    /// ν, S, K and the NIS of the final linearisation: `ν = z ⊟ h(μ ⊞ δ*) + H δ*` (the innovation
    /// of the linearised model against the prior), `K ν ≈ δ*` at convergence.
    pub fn innovation(&self) -> &Innovation<N, M> {
        &self.innovation
    }

    /// The NIS `νᵀ S⁻¹ ν` of the final linearisation.
    pub fn nis(&self) -> f64 {
        self.innovation.nis()
    }

    /// The steps taken (0 when the prior mean is already a fixed point).
    pub fn iterations(&self) -> usize {
        self.iterations
    }

    /// Why the iteration stopped.
    pub fn stop(&self) -> Stop {
        self.stop
    }
}

/// A measurement model used by the iterated EKF: `density.condition(&IteratedEkf::new(&model), &z)`.
/// M, the measurement dimension, is inferred from z. The retraction's Jacobian is the state's
/// [`Manifold::j_retract_tangent`] (closed form on every space of the library).
///
/// # Example
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::Rn;
/// use liebayes_operators::iterated::{IteratedEkf, Stop};
/// use liebayes_operators::{Condition, MeasurementFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// // A range z = x² + n read as 9 from a prior at 2: the MAP is near 3, beyond one EKF step.
/// let range = MeasurementFn::new(|x: &Rn<f64, 1>| Vector1::new(x.coords()[0].powi(2)), |_| {
///     Matrix1::new(1e-4)
/// });
/// let prior = ManifoldGaussian::new(Rn::new(Vector1::new(2.0)).unwrap(), Matrix1::new(1.0)).unwrap();
/// let step = prior.condition(&IteratedEkf::new(&range), &Vector1::new(9.0)).unwrap();
/// assert!((step.posterior.mean().coords()[0] - 3.0).abs() < 1e-3);
/// assert_eq!(step.report.stop(), Stop::Converged);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IteratedEkf<Model, const M: usize = 0> {
    /// The measurement model.
    pub model: Model,
    /// When to stop.
    pub settings: IterationSettings,
}

impl<Model, const M: usize> IteratedEkf<Model, M> {
    /// The model with the default [`IterationSettings`].
    pub fn new(model: Model) -> Self {
        Self {
            model,
            settings: IterationSettings::default(),
        }
    }
}

/// A measurement model used by the iterated posterior linearisation, with the sigma points of a
/// [`Ukf`] (its scaling and square root): `density.condition(&IteratedUkf::new(&model), &z)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IteratedUkf<Model, const M: usize = 0> {
    /// The model and the sigma points' parameters.
    pub ukf: Ukf<Model, M>,
    /// When to stop.
    pub settings: IterationSettings,
}

impl<Model, const M: usize> IteratedUkf<Model, M> {
    /// The model with the default sigma points ([`Ukf::new`]) and [`IterationSettings`].
    pub fn new(model: Model) -> Self {
        Self {
            ukf: Ukf::new(model),
            settings: IterationSettings::default(),
        }
    }
}

/// The Kalman update of the prior by the model linearised at one iterate.
struct Linearised<const D: usize, const M: usize> {
    innovation: Innovation<D, M>,
    log_evidence: f64,
    /// `P⁺`, in the tangent space at μ.
    covariance: SMatrix<f64, D, D>,
    /// The length of the proposed step in the standard deviations of this update's posterior
    /// (`P⁺ = L Lᵀ`): `|L⁻¹ Δ|` for the iterated EKF; for the posterior linearisation, whose
    /// iterate is the pair (δ, P), the joint `(|L⁻¹ Δ|² + ‖L⁻¹ (P⁺ − Pᵢ) L⁻ᵀ‖²_F)^½`. What the
    /// tolerance is compared with.
    step: f64,
    /// What a step must not increase, at the iterate: J for the iterated EKF, the joint step for
    /// the posterior linearisation (its fixed point is not J's minimum) in the prior's standard
    /// deviations (`P = L Lᵀ` above), the same scale for every trial.
    merit: f64,
}

/// How an iterate's merit is measured (see [`Linearised::merit`]).
#[derive(Clone, Copy)]
enum Merit<'a, const D: usize> {
    /// The MAP cost J at the iterate.
    Cost(f64),
    /// The joint step from the iterate `(δᵢ, Pᵢ)`, given `Pᵢ`.
    Step(&'a SMatrix<f64, D, D>),
}

impl<const D: usize, const M: usize> Linearised<D, M> {
    /// `δ̂ = K ν`, the proposed iterate.
    fn proposal(&self) -> SVector<f64, D> {
        self.innovation.gain() * self.innovation.innovation()
    }
}

/// One conditioning problem: the prior, the model, the reading and the fixed noise R.
struct Problem<'a, X: Manifold<D, Scalar = f64>, H, const D: usize, const M: usize> {
    prior: &'a ManifoldGaussian<X, D>,
    model: &'a H,
    z: &'a SVector<f64, M>,
    noise: SMatrix<f64, M, M>,
    noise_factor: Cholesky<f64, nalgebra::Const<M>>,
}

impl<'a, X, H, const D: usize, const M: usize> Problem<'a, X, H, D, M>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    /// The problem, with z and R (at the prior mean) checked finite and R positive definite.
    fn new(
        prior: &'a ManifoldGaussian<X, D>,
        model: &'a H,
        z: &'a SVector<f64, M>,
    ) -> Result<Self, OperatorError> {
        all_finite("measurement z", z.iter())?;
        let noise = model_noise("measurement noise R", model.noise(prior.mean()))?;
        let noise_factor = Cholesky::new(noise).ok_or(OperatorError::NotPositiveDefinite {
            what: "measurement noise R (the iterated update's cost needs R^-1)",
        })?;
        Ok(Self {
            prior,
            model,
            z,
            noise,
            noise_factor,
        })
    }

    /// [`solve`](Self::solve), made once more with R raised above the rounding of the update when
    /// rounding loses its positive definiteness ([`above_rounding`], as the EKF's update: the
    /// scale is that of `H P Hᵀ + R` and of `|H|²_F max |Pᵢⱼ|`, H at the prior mean).
    fn solve_above_rounding<L: Linearisation<X, H, D, M>>(
        &self,
        linearisation: &L,
        settings: &IterationSettings,
    ) -> Result<Conditioned<ManifoldGaussian<X, D>, Iterated<D, M>>, OperatorError> {
        let scale = || {
            let h = self.model.jacobian(self.prior.mean());
            rounding_scale(&h, self.prior.covariance(), &self.noise)
        };
        above_rounding::<_, M>(scale, |floor| {
            if floor == 0.0 {
                return self.solve(linearisation, settings);
            }
            let noise = self.noise + SMatrix::<f64, M, M>::identity() * floor;
            let raised = Problem {
                prior: self.prior,
                model: self.model,
                z: self.z,
                noise,
                noise_factor: Cholesky::new(noise).ok_or(OperatorError::NotPositiveDefinite {
                    what: "measurement noise R raised above rounding",
                })?,
            };
            raised.solve(linearisation, settings)
        })
    }

    /// `μ ⊞ δ`, checked finite.
    fn point(&self, delta: &SVector<f64, D>) -> Result<X, OperatorError> {
        let x = self.prior.mean().retract(delta);
        if x.is_finite() {
            Ok(x)
        } else {
            Err(OperatorError::NonFinitePoint {
                what: "an iterate mu ⊞ delta of the iterated update",
            })
        }
    }

    /// `r = z ⊟ h(x)`, checked finite.
    fn residual(&self, x: &X) -> Result<SVector<f64, M>, OperatorError> {
        let r = self.model.residual(self.z, &self.model.predict(x));
        all_finite(
            "residual z - h(x) at an iterate (the measurement model predicted a non-finite value)",
            r.iter(),
        )?;
        Ok(r)
    }

    /// `J(δ) = ½ |L_P⁻¹ δ|² + ½ |L_R⁻¹ r|²` for the residual `r = r(δ)` (+∞ when it overflows).
    fn cost(&self, delta: &SVector<f64, D>, residual: &SVector<f64, M>) -> f64 {
        let data = self
            .noise_factor
            .l_dirty()
            .solve_lower_triangular_unchecked(residual)
            .norm_squared();
        0.5 * (whitened(self.prior.cholesky_factor(), delta, None).powi(2) + data)
    }

    /// The first of the iterates `(δ + t Δ, (1 − t) P + t P⁺)`, t = 1, ½, ¼, … (at most
    /// [`MAX_HALVINGS`] halvings; a convex combination of covariances is one) whose linearisation
    /// succeeds with a merit of at most the current one, with that linearisation; `None` if there
    /// is none. A trial whose linearisation fails (the model is non-finite there, or its update is
    /// not positive definite) is a step too long, halved like one that raises the merit. When even
    /// the shortest step, 2⁻³⁰ of the proposal, has an update that is not positive definite, that
    /// is rounding next to an iterate whose update is (S ill-conditioned there): `None` too, so
    /// the iteration ends at the iterate.
    ///
    /// # Errors
    /// The last trial's error when even the shortest step fails in the model (a non-finite
    /// prediction or Jacobian): the model fails next to an iterate where it succeeded.
    fn descend<L: Linearisation<X, H, D, M>>(
        &self,
        linearisation: &L,
        iterate: &Iterate<D>,
        current: &Linearised<D, M>,
    ) -> Result<Option<(Iterate<D>, Linearised<D, M>)>, OperatorError> {
        let step = current.proposal() - iterate.delta;
        let mut t = 1.0;
        let mut last = Ok(None);
        for _ in 0..=MAX_HALVINGS {
            // The spread as the convex combination itself: `Pᵢ + t (P⁺ − Pᵢ)` cancels to zero
            // when P⁺ is below the rounding of Pᵢ (a prior of 1e50 updated to 1).
            let candidate = Iterate {
                delta: iterate.delta + step * t,
                spread: iterate.spread * (1.0 - t) + current.covariance * t,
            };
            match linearisation.linearise(self, &candidate) {
                Ok(linearised) if linearised.merit <= current.merit => {
                    return Ok(Some((candidate, linearised)));
                }
                Ok(_) => last = Ok(None),
                Err(error) => last = Err(error),
            }
            t *= 0.5;
        }
        match last {
            Err(OperatorError::NotPositiveDefinite { .. }) => Ok(None),
            last => last,
        }
    }

    /// The Kalman update of the prior by `z ≈ A δ + b + e`, `e ~ N(0, Ω)`, with `ν = (z ⊟ ẑ) + A δᵢ`
    /// given as `residual + A δᵢ` (`Ω = 0` for the EKF), with the iterate's step and merit.
    fn update(
        &self,
        residual: SVector<f64, M>,
        slope: &SMatrix<f64, M, D>,
        delta: &SVector<f64, D>,
        error: &SMatrix<f64, M, M>,
        merit: Merit<'_, D>,
    ) -> Result<Linearised<D, M>, OperatorError> {
        all_finite("linearised measurement model (slope)", slope.iter())?;
        let p = self.prior.covariance();
        let pat = p * slope.transpose();
        let noise = error + self.noise;
        let (innovation, log_evidence) = Innovation::new(
            residual + slope * delta,
            &(slope * pat + noise),
            &pat,
            self.model.dof(),
        )?;
        let covariance = joseph(
            self.prior.cholesky_factor(),
            innovation.gain(),
            slope,
            &noise,
        );
        all_finite("updated covariance of an iterate", covariance.iter())?;
        // The stop test measures steps in the standard deviations of this update's posterior (in
        // the prior's, a step of 0.5 under a prior of 1e15 was 1.6e-8 σ and ended the iteration
        // before its first step); the posterior linearisation's merit keeps the prior's, one
        // scale for every trial.
        let mean_step = innovation.gain() * innovation.innovation() - delta;
        // P⁺ is positive definite in exact arithmetic; an iterate at which rounding loses that (S
        // ill-conditioned there) is one the update cannot end at: an error here, so that a step
        // to it is halved.
        let posterior = Cholesky::new(covariance).ok_or(OperatorError::NotPositiveDefinite {
            what: "updated covariance of an iterate (Joseph form; check R)",
        })?;
        let (step, merit) = match merit {
            Merit::Cost(cost) => {
                // With Ω = 0 the posterior's information is `P⁻¹ + Hᵀ R⁻¹ H`: the step's length in
                // its deviations from the factors of P and R.
                let data = self
                    .noise_factor
                    .l_dirty()
                    .solve_lower_triangular_unchecked(&(slope * mean_step))
                    .norm();
                let prior = whitened(self.prior.cholesky_factor(), &mean_step, None);
                (prior.hypot(data), cost)
            }
            Merit::Step(spread) => {
                let spread_step = covariance - spread;
                (
                    whitened(posterior.l_dirty(), &mean_step, Some(&spread_step)),
                    whitened(self.prior.cholesky_factor(), &mean_step, Some(&spread_step)),
                )
            }
        };
        Ok(Linearised {
            innovation,
            log_evidence,
            covariance,
            step,
            merit,
        })
    }
}

/// The length of a step `(Δ, X)` in the standard deviations of `S = L Lᵀ` (L with a positive
/// diagonal): `|L⁻¹ Δ|`, or with a covariance step X the joint `(|L⁻¹ Δ|² + ‖L⁻¹ X L⁻ᵀ‖²_F)^½`,
/// each by triangular solves.
fn whitened<const D: usize>(
    l: &SMatrix<f64, D, D>,
    mean: &SVector<f64, D>,
    spread: Option<&SMatrix<f64, D, D>>,
) -> f64 {
    let length = l.solve_lower_triangular_unchecked(mean).norm();
    spread.map_or(length, |x| {
        let half = l.solve_lower_triangular_unchecked(x);
        length.hypot(l.solve_lower_triangular_unchecked(&half.transpose()).norm())
    })
}

/// The relative error of a round trip `(x ⊞ v) ⊟ x` within which a tangent offset v is resolved
/// by the arithmetic of the point x.
const RESOLUTION: f64 = 1e-4;

/// The most raisings of one axis's spread in [`resolved`], each by a factor of at least
/// 1/[`RESOLUTION`].
const MAX_RAISINGS: usize = 4;

/// A spread P whose sigma points about x the arithmetic of x resolves. With `sⱼ = √Pⱼⱼ`, one
/// round trip `e = (x ⊞ s) ⊟ x − s` (zero in exact arithmetic) gives each axis's rounding; an
/// axis with `|eⱼ| > 10⁻⁴ sⱼ` has Pⱼⱼ alone raised (which keeps P positive definite) to the first
/// of `s' = max(error, s)·10⁴`, … whose own round trip along that axis is resolved, at most
/// [`MAX_RAISINGS`] times; an axis that no raising resolves (a round trip that wraps, not rounds)
/// is kept. On Rⁿ the error is the rounding of x's coordinates: a spread of 1e-15 about a point at
/// 1e5 (whose rounding is 1.5e-11) is all rounding, and sigma points there give the model's slope
/// as zero. Only such spreads are raised: a step of the posterior linearisation linearises the
/// model over them, and a model smooth at 10⁴ times the rounding of its argument is linear there.
fn resolved<X: Manifold<D, Scalar = f64>, const D: usize>(
    x: &X,
    spread: &SMatrix<f64, D, D>,
) -> SMatrix<f64, D, D> {
    let round_trip_error = |v: SVector<f64, D>| x.local(&x.retract(&v)) - v;
    let deviations = spread.diagonal().map(f64::sqrt);
    let errors = round_trip_error(deviations);
    let mut raised = *spread;
    for (j, (&s, &error)) in deviations.iter().zip(&errors).enumerate() {
        let (mut trial, mut error) = (s, error.abs());
        for _ in 0..MAX_RAISINGS {
            if error.is_nan() || error <= RESOLUTION * trial {
                break;
            }
            trial = error.max(trial) / RESOLUTION;
            error =
                round_trip_error(SVector::from_fn(|i, _| if i == j { trial } else { 0.0 })).norm();
            if error <= RESOLUTION * trial && (trial * trial).is_finite() {
                raised[(j, j)] = trial * trial;
                break;
            }
        }
    }
    raised
}

/// An iterate `N(δᵢ, Pᵢ)` in the tangent space at the prior mean (the iterated EKF uses δᵢ only).
struct Iterate<const D: usize> {
    delta: SVector<f64, D>,
    spread: SMatrix<f64, D, D>,
}

/// How an iterated update linearises the model at an iterate.
trait Linearisation<X: Manifold<D, Scalar = f64>, H, const D: usize, const M: usize> {
    /// The Kalman update of the prior by the model linearised at the iterate.
    fn linearise(
        &self,
        problem: &Problem<'_, X, H, D, M>,
        iterate: &Iterate<D>,
    ) -> Result<Linearised<D, M>, OperatorError>;
}

/// The iterated EKF's: `Hᵢ = H(μ ⊞ δᵢ) J(δᵢ)`, Ω = 0 (the spread is not used).
impl<X, H, const D: usize, const M: usize> Linearisation<X, H, D, M> for IteratedEkf<H, M>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    fn linearise(
        &self,
        problem: &Problem<'_, X, H, D, M>,
        iterate: &Iterate<D>,
    ) -> Result<Linearised<D, M>, OperatorError> {
        let delta = &iterate.delta;
        let x = problem.point(delta)?;
        let residual = problem.residual(&x)?;
        let jacobian = self.model.jacobian(&x);
        all_finite("measurement Jacobian H at an iterate", jacobian.iter())?;
        let chain = problem.prior.mean().j_retract_tangent(delta);
        all_finite("retraction Jacobian J(delta) at an iterate", chain.iter())?;
        let cost = problem.cost(delta, &residual);
        problem.update(
            residual,
            &(jacobian * chain),
            delta,
            &SMatrix::zeros(),
            Merit::Cost(cost),
        )
    }
}

/// The posterior linearisation's: the UKF's sigma-point moments of `N(δᵢ, Pᵢ)`.
impl<X, H, const D: usize, const M: usize> Linearisation<X, H, D, M> for IteratedUkf<H, M>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    fn linearise(
        &self,
        problem: &Problem<'_, X, H, D, M>,
        iterate: &Iterate<D>,
    ) -> Result<Linearised<D, M>, OperatorError> {
        let delta = &iterate.delta;
        let spread = ManifoldGaussian::new(
            problem.prior.mean().clone(),
            resolved(&problem.point(delta)?, &iterate.spread),
        )?;
        let moments = self
            .ukf
            .measurement_moments(&spread, Some(delta), SMatrix::zeros())?;
        // A = Ψᵀ Pᵢ⁻¹, and Ω = Φ − A Pᵢ Aᵀ as the moments summed it (no difference taken).
        let slope = slope(spread.cholesky_factor(), &moments.cross);
        let residual = problem.residual_from(&moments.predicted)?;
        problem.update(
            residual,
            &slope,
            delta,
            &moments.unexplained(),
            Merit::Step(&iterate.spread),
        )
    }
}

impl<X, H, const D: usize, const M: usize> Problem<'_, X, H, D, M>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    /// Whether the model is linear over `posterior` (a Gaussian whose covariance is in the tangent
    /// space at its mean) to within [`LINEARITY_BOUND`] noise standard deviations at each of the
    /// points `x* ⊞ (±cᵢ)`, cᵢ the columns of its Cholesky factor (see
    /// [`IterationSettings::with_linearity_check`]). A model that fails at one of the points (a
    /// non-finite prediction or Jacobian) is not linear there.
    fn linear_over(&self, posterior: &ManifoldGaussian<X, D>) -> bool {
        let x = posterior.mean();
        let (Ok(residual), jacobian) = (self.residual(x), self.model.jacobian(x)) else {
            return false;
        };
        let factor = posterior.cholesky_factor();
        let whitened = |error: SVector<f64, M>| {
            self.noise_factor
                .l_dirty()
                .solve_lower_triangular_unchecked(&error)
                .norm()
        };
        factor.column_iter().all(|column| {
            [1.0, -1.0].into_iter().all(|sign| {
                let s = column * sign;
                let point = x.retract(&s);
                point.is_finite()
                    && self.residual(&point).is_ok_and(|moved| {
                        // NaN (a non-finite Jacobian) fails the comparison.
                        whitened(moved - (residual - jacobian * s)) <= LINEARITY_BOUND
                    })
            })
        })
    }

    /// `z ⊟ ẑ` for a predicted ẑ, checked finite.
    fn residual_from(&self, predicted: &SVector<f64, M>) -> Result<SVector<f64, M>, OperatorError> {
        let r = self.model.residual(self.z, predicted);
        all_finite("residual z - z_hat of the sigma points", r.iter())?;
        Ok(r)
    }

    /// The iteration (module docs): the final iterate δ*, its linearisation, the steps and the stop.
    fn solve<L: Linearisation<X, H, D, M>>(
        &self,
        linearisation: &L,
        settings: &IterationSettings,
    ) -> Result<Conditioned<ManifoldGaussian<X, D>, Iterated<D, M>>, OperatorError> {
        let mut iterate = Iterate {
            delta: SVector::<f64, D>::zeros(),
            spread: *self.prior.covariance(),
        };
        let mut current = linearisation.linearise(self, &iterate)?;
        let mut iterations = 0;
        let mut stop = Stop::IterationLimit;
        while iterations < settings.max_iterations {
            if current.step <= settings.tolerance {
                stop = Stop::Converged;
                break;
            }
            let Some((next, linearised)) = self.descend(linearisation, &iterate, &current)? else {
                stop = Stop::NoDescent;
                break;
            };
            (iterate, current) = (next, linearised);
            iterations += 1;
        }
        let delta = iterate.delta;
        let mean = self.point(&delta)?;
        let covariance = if settings.transport {
            let j = self.prior.mean().j_retract_tangent(&delta);
            j * current.covariance * j.transpose()
        } else {
            current.covariance
        };
        let posterior = checked_gaussian(
            mean,
            &covariance,
            Produced {
                mean: "the posterior mean mu ⊞ delta* of the iterated update",
                covariance: "posterior covariance of the iterated update (check the measurement \
                             noise R and the Jacobian H)",
            },
        )?;
        Ok(Conditioned {
            posterior,
            log_evidence: current.log_evidence,
            report: Iterated {
                innovation: current.innovation,
                iterations,
                stop,
            },
        })
    }
}

impl<X, H, const D: usize, const M: usize> Condition<IteratedEkf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;
    type Report = Iterated<D, M>;

    /// Gauss-Newton on the MAP cost (module docs), and with the linearity check
    /// ([`IterationSettings::with_linearity_check`]) the one-pass EKF's update where the model is
    /// not linear over the result.
    fn condition(
        &self,
        iterated: &IteratedEkf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self, Iterated<D, M>>, OperatorError> {
        let problem = Problem::new(self, &iterated.model, z)?;
        let step = problem.solve_above_rounding(iterated, &iterated.settings)?;
        if !iterated.settings.linearity_check || problem.linear_over(&step.posterior) {
            return Ok(step);
        }
        let one_pass = self.condition(&Ekf(&iterated.model), z)?;
        Ok(Conditioned {
            posterior: one_pass.posterior,
            log_evidence: one_pass.log_evidence,
            report: Iterated {
                innovation: one_pass.report,
                iterations: step.report.iterations,
                stop: Stop::Nonlinear,
            },
        })
    }
}

impl<X, H, const D: usize, const M: usize> Condition<IteratedUkf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;
    type Report = Iterated<D, M>;

    /// The iterated posterior linearisation (module docs).
    fn condition(
        &self,
        iterated: &IteratedUkf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self, Iterated<D, M>>, OperatorError> {
        Problem::new(self, iterated.ukf.model(), z)?
            .solve_above_rounding(iterated, &iterated.settings)
    }
}
