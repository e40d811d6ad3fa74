//! The iterated (Gauss-Newton) smoother: the maximum a posteriori trajectory of a Gaussian
//! state-space model on any [`Manifold`], with the marginal covariances of the Laplace
//! approximation at it.
//!
//! For the model `x_{k+1} = f(x_k, u_k) ⊞ w_k`, `w_k ~ N(0, Q_k)`, `z_j = h(x_{k_j}) + n_j`,
//! `n_j ~ N(0, R_j)`, and the prior `x_0 = μ₀ ⊞ δ`, `δ ~ N(0, P₀)`, the smoother minimises over the
//! whole trajectory `x_0, …, x_K`
//!
//! `J = ½‖x₀ ⊟ μ₀‖²_{P₀} + ½ Σ_k ‖x_{k+1} ⊟ f(x_k, u_k)‖²_{Q_k} + ½ Σ_j ‖z_j ⊟ h(x_{k_j})‖²_{R_j}`
//!
//! (`‖r‖²_C = rᵀ C⁻¹ r`; Q_k and R_j are the models' noise at the current iterate, held fixed within
//! a step), by Gauss-Newton relinearised over the whole trajectory:
//!
//! * start from the RTS smoother of the EKF's forward pass ([`RtsSmoother`]);
//! * linearise every residual in the right perturbations `x_k ⊞ δ_k`: the prior's and the
//!   process's through the Jacobians of `⊟` (central differences with Richardson extrapolation, an
//!   error of O(10⁻¹²)), the process's through the model's F, the measurements' through the model's
//!   H (`z ⊟ h(x ⊞ δ) ≈ z ⊟ h(x) − H δ`, as the EKF);
//! * solve the normal equations `Λ δ = −g` (`Λ = Σ Jᵀ C⁻¹ J`, `g = Σ Jᵀ C⁻¹ r`): Λ is
//!   block-tridiagonal with K + 1 blocks of D × D, factored in O(K D³) from its square root, the
//!   whitened Jacobian ([`BlockJacobian`]), by block QR with row pivoting, never formed: forming
//!   Λ squares the condition number, and a track whose marginal covariances span more than about
//!   1e15 of its noise (process noise 1e-10 over 300 unmeasured epochs, or 1e-30 against unit
//!   readings) has a Λ that rounding leaves indefinite. The solves and the marginal covariances
//!   run the block recursion of [`BlockTridiagonal`] on nalgebra's fixed-size blocks, on faer's
//!   dense ones from [`FAER_FROM_DIMENSION`] on;
//! * step control: the step `x_k ⊞ α δ_k` is taken with α = 1, halved while it raises J (at most
//!   [`GaussNewton::max_halvings`] times);
//! * stop when the Gauss-Newton decrement `δᵀ Λ δ = −gᵀ δ` (twice the decrease the linearised cost
//!   promises) is at most [`GaussNewton::tolerance`], after [`GaussNewton::max_iterations`] steps, or
//!   when no halving lowers J.
//!
//! The result holds, per epoch, the MAP mean and the covariance `Σ_k` = the k-th diagonal block of
//! `Λ⁻¹` at the solution (from the block recursion, never a dense inverse), in the tangent space at
//! the mean. On Rⁿ with a linear model the first step lands on the minimum, and the result equals
//! the RTS smoother; on a nonlinear model it removes the RTS smoother's linearisation error about the
//! filtered means.
//!
//! The recorder [`IteratedSmoother`] runs the EKF forward pass (with [`RtsSmoother`]) and keeps the
//! inputs and the measurements, which the relinearisation evaluates the models on again.

mod block_tridiagonal;

pub use block_tridiagonal::{
    Backend, BlockCholesky, BlockJacobian, BlockTridiagonal, FAER_FROM_DIMENSION,
};

use crate::error::{all_finite, check_size, reserve, with_capacity};
use crate::models::{MeasurementModel, ProcessModel};
use crate::numerics::{Produced, checked_gaussian, model_noise, symmetric_part};
use crate::smoother::RtsSmoother;
use crate::{Conditioned, Ekf, Innovation, OperatorError};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::{Cholesky, Const, DMatrix, SMatrix, SVector};

/// What the recorder names when its records cannot grow.
const RECORDS: &str = "number of iterated smoother records";

/// The largest [`GaussNewton::max_iterations`] accepted.
pub const MAX_ITERATIONS: usize = 10_000;

/// The largest [`GaussNewton::max_halvings`] accepted: 2⁻⁶⁰ ≈ 1e-18 is below f64's resolution of a
/// step relative to the point it starts from.
pub const MAX_HALVINGS: usize = 60;

/// The stopping rules of the Gauss-Newton iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussNewton {
    /// Converged when the Gauss-Newton decrement `δᵀ Λ δ` (in units of the cost J, which is half a
    /// χ² statistic) is at most this; default 1e-10, a step of 1e-5 standard deviations. Range
    /// [0, ∞), finite.
    pub tolerance: f64,
    /// The most steps taken; default 50. Range [0, [`MAX_ITERATIONS`]] (0 returns the RTS means
    /// with the covariances of Λ at them).
    pub max_iterations: usize,
    /// The most halvings of a step that raises J; default 30. Range [0, [`MAX_HALVINGS`]].
    pub max_halvings: usize,
}

impl Default for GaussNewton {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_iterations: 50,
            max_halvings: 30,
        }
    }
}

impl GaussNewton {
    /// Checks the settings against their ranges.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] (or [`OperatorError::NonFinite`] for the tolerance) naming the
    /// setting.
    pub fn validate(&self) -> Result<(), OperatorError> {
        all_finite("Gauss-Newton tolerance", [&self.tolerance])?;
        if self.tolerance < 0.0 {
            return Err(OperatorError::OutOfRange {
                what: "Gauss-Newton tolerance",
                value: self.tolerance,
                range: "[0, ∞)",
            });
        }
        if self.max_iterations > MAX_ITERATIONS {
            return Err(OperatorError::OutOfRange {
                what: "Gauss-Newton max_iterations",
                value: self.max_iterations as f64,
                range: "[0, 10000]",
            });
        }
        if self.max_halvings > MAX_HALVINGS {
            return Err(OperatorError::OutOfRange {
                what: "Gauss-Newton max_halvings",
                value: self.max_halvings as f64,
                range: "[0, 60]",
            });
        }
        Ok(())
    }
}

/// Why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The decrement is at most the tolerance.
    Converged,
    /// [`GaussNewton::max_iterations`] steps were taken.
    IterationLimit,
    /// No halving of the step lowered J (the iterate is at the minimum to rounding, or the model's
    /// Jacobians are wrong).
    NoDecrease,
}

/// What the iteration did.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The number of steps taken.
    pub iterations: usize,
    /// The cost J at the start (the RTS means) and after every step: never increasing.
    pub costs: Vec<f64>,
    /// The Gauss-Newton decrement `δᵀ Λ δ` at the final iterate (the step not taken).
    pub decrement: f64,
    /// Why it stopped.
    pub stop: Stop,
}

impl Report {
    /// The final cost J: the last of [`costs`](Self::costs), which the smoother always starts
    /// with (`None` only for a report whose costs were emptied by hand).
    pub fn cost(&self) -> Option<f64> {
        self.costs.last().copied()
    }

    /// Whether the decrement reached the tolerance.
    pub fn converged(&self) -> bool {
        self.stop == Stop::Converged
    }
}

/// The smoothed densities of every epoch and the iteration's report.
#[derive(Clone, Debug)]
pub struct Smoothed<X, const D: usize> {
    /// Per epoch: the MAP mean and the marginal covariance (a diagonal block of `Λ⁻¹`), in the
    /// tangent space at the mean.
    pub densities: Vec<ManifoldGaussian<X, D>>,
    /// What the iteration did.
    pub report: Report,
}

/// The iterated smoother's recorder: the EKF forward pass of an [`RtsSmoother`], and the inputs and
/// the measurements of the run (see the module docs for the math).
///
/// One process model type (input `U`) and one measurement model type (dimension M) per run; the
/// models given to [`smooth`](Self::smooth) must be those of the forward pass.
///
/// # Example
/// A unicycle heading with a turn-rate input and a compass that reads `sin θ` (nonlinear):
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::iterated_smoother::IteratedSmoother;
/// use liebayes_operators::manifolds::{Manifold, So2};
/// use liebayes_operators::{MeasurementFn, ProcessFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// let turn = ProcessFn::new(
///     |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
///     |_, _| Matrix1::new(1e-3),
/// );
/// let sine = MeasurementFn::new(|x: &So2<f64>| Vector1::new(x.angle().sin()), |_| {
///     Matrix1::new(0.01)
/// });
/// let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.3), Matrix1::new(0.5)).unwrap();
/// let mut smoother = IteratedSmoother::with_capacity(prior, 3, 4).unwrap();
/// smoother.condition(&sine, &Vector1::new(0.05)).unwrap();
/// for reading in [0.15, 0.24, 0.36] {
///     smoother.propagate(&turn, &0.1).unwrap();
///     smoother.condition(&sine, &Vector1::new(reading)).unwrap();
/// }
/// let smoothed = smoother.smooth(&turn, &sine).unwrap();
/// assert!(smoothed.report.converged());
/// // Never above the cost of the RTS means it starts from.
/// assert!(smoothed.report.cost() <= Some(smoothed.report.costs[0]));
/// assert_eq!(smoothed.densities.len(), 4);
/// ```
#[derive(Clone, Debug)]
pub struct IteratedSmoother<X, U, const D: usize, const M: usize> {
    prior: ManifoldGaussian<X, D>,
    forward: RtsSmoother<X, D>,
    /// `inputs[k]` drives the transition from epoch k to k + 1.
    inputs: Vec<U>,
    /// (epoch, z), in the order recorded.
    measurements: Vec<(usize, SVector<f64, M>)>,
}

impl<X, U, const D: usize, const M: usize> IteratedSmoother<X, U, D, M>
where
    X: Manifold<D, Scalar = f64>,
    U: Clone,
{
    /// The recorder at epoch 0, holding the prior.
    pub fn new(prior: ManifoldGaussian<X, D>) -> Self {
        Self {
            forward: RtsSmoother::new(prior.clone()),
            prior,
            inputs: Vec::new(),
            measurements: Vec::new(),
        }
    }

    /// The recorder with room for `steps` propagations and `measurements` conditionings.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the records
    /// cannot be allocated.
    pub fn with_capacity(
        prior: ManifoldGaussian<X, D>,
        steps: usize,
        measurements: usize,
    ) -> Result<Self, OperatorError> {
        check_size(RECORDS, steps)?;
        check_size(RECORDS, measurements)?;
        Ok(Self {
            forward: RtsSmoother::with_capacity(prior.clone(), steps)?,
            prior,
            inputs: with_capacity(RECORDS, steps)?,
            measurements: with_capacity(RECORDS, measurements)?,
        })
    }

    /// The EKF forward pass: its filtered densities and its RTS smoother.
    pub fn forward(&self) -> &RtsSmoother<X, D> {
        &self.forward
    }

    /// Propagates to a new epoch by the EKF, recording the input.
    ///
    /// # Errors
    /// [`OperatorError::NotPositiveDefinite`] (or [`OperatorError::NonFinite`]) when the model's Q
    /// at the current mean is not symmetric positive definite, the EKF prediction's errors, and
    /// [`OperatorError::TooLarge`] when the records cannot grow; the recorder is then unchanged.
    pub fn propagate<P>(&mut self, model: &P, input: &U) -> Result<(), OperatorError>
    where
        P: ProcessModel<X, D, Input = U>,
    {
        whitening(
            &model.noise(self.forward.current().mean(), input),
            "process noise Q",
        )?;
        reserve(&mut self.inputs, RECORDS, 1)?;
        self.forward.propagate(&Ekf(model), input)?;
        self.inputs.push(input.clone());
        Ok(())
    }

    /// Conditions the current epoch on a measurement by the EKF, recording it (several per epoch
    /// are allowed). Returns the EKF's step.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a NaN or infinite z, [`OperatorError::NotPositiveDefinite`]
    /// when the model's R at the current mean is not symmetric positive definite, the EKF update's
    /// errors, and [`OperatorError::TooLarge`] when the records cannot grow; the recorder is then
    /// unchanged.
    pub fn condition<H>(
        &mut self,
        model: &H,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<&ManifoldGaussian<X, D>, Innovation<D, M>>, OperatorError>
    where
        H: MeasurementModel<X, D, M>,
    {
        all_finite("measurement z", z.iter())?;
        whitening(
            &model.noise(self.forward.current().mean()),
            "measurement noise R",
        )?;
        reserve(&mut self.measurements, RECORDS, 1)?;
        let epoch = self.inputs.len();
        let step = self.forward.condition(&Ekf(model), z)?;
        self.measurements.push((epoch, *z));
        Ok(step)
    }

    /// The iterated smoother with the default [`GaussNewton`] settings.
    ///
    /// # Errors
    /// As [`Self::smooth_with`].
    pub fn smooth<P, H>(
        &self,
        process: &P,
        measurement: &H,
    ) -> Result<Smoothed<X, D>, OperatorError>
    where
        P: ProcessModel<X, D, Input = U>,
        H: MeasurementModel<X, D, M>,
    {
        self.smooth_with(process, measurement, &GaussNewton::default())
    }

    /// The MAP trajectory by Gauss-Newton from the RTS means, with the marginal covariances at it.
    ///
    /// # Errors
    /// The settings' [`GaussNewton::validate`]; the RTS smoother's errors; at an iterate,
    /// [`OperatorError::NotPositiveDefinite`] for a noise covariance or a normal matrix that is not
    /// positive definite, [`OperatorError::NonFinite`] for a residual or a Jacobian that is not
    /// finite, [`OperatorError::NonFinitePoint`] for a model returning a point that is not.
    pub fn smooth_with<P, H>(
        &self,
        process: &P,
        measurement: &H,
        settings: &GaussNewton,
    ) -> Result<Smoothed<X, D>, OperatorError>
    where
        P: ProcessModel<X, D, Input = U>,
        H: MeasurementModel<X, D, M>,
    {
        settings.validate()?;
        let problem = Problem {
            recorder: self,
            process,
            measurement,
        };
        // Started from the RTS smoother's means, or from the filtered ones where its backward pass
        // fails (Gauss-Newton needs only a starting point).
        let mut states: Vec<X> = match self.forward.smooth() {
            Ok(smoothed) => smoothed
                .into_iter()
                .map(|density| density.mean().clone())
                .collect(),
            Err(_) => self
                .forward
                .filtered()
                .iter()
                .map(|density| density.mean().clone())
                .collect(),
        };
        let mut linearised = problem.linearise(&states)?;
        let mut costs = with_capacity("iterated smoother costs", settings.max_iterations + 1)?;
        costs.push(linearised.cost);
        let mut iterations = 0;
        let (stop, factor, decrement) = loop {
            let factor = linearised.jacobian.factor()?;
            let step = factor.solve(&linearised.descent)?;
            let decrement: f64 = step
                .iter()
                .zip(&linearised.descent)
                .map(|(d, g)| d.dot(g))
                .sum();
            if decrement <= settings.tolerance {
                break (Stop::Converged, factor, decrement);
            }
            if iterations == settings.max_iterations {
                break (Stop::IterationLimit, factor, decrement);
            }
            let Some(next) = problem.line_search(&states, &step, linearised.cost, settings) else {
                break (Stop::NoDecrease, factor, decrement);
            };
            states = next;
            linearised = problem.linearise(&states)?;
            costs.push(linearised.cost);
            iterations += 1;
        };
        let densities = states
            .into_iter()
            .zip(factor.marginal_covariances()?)
            .map(|(mean, covariance)| {
                checked_gaussian(
                    mean,
                    &covariance,
                    Produced {
                        mean: "the iterated smoother's mean (a model returned a point that is not \
                               finite)",
                        covariance: "iterated smoother's marginal covariance (a diagonal block of \
                                     the inverse normal matrix; rounding on an ill-conditioned model)",
                    },
                )
            })
            .collect::<Result<_, _>>()?;
        Ok(Smoothed {
            densities,
            report: Report {
                iterations,
                costs,
                decrement,
                stop,
            },
        })
    }
}

/// The Cholesky factor of a noise covariance, for whitening residuals (`L⁻¹ r`).
fn whitening<const N: usize>(
    covariance: &SMatrix<f64, N, N>,
    what: &'static str,
) -> Result<Cholesky<f64, Const<N>>, OperatorError> {
    let covariance = model_noise(what, *covariance)?;
    Cholesky::new(symmetric_part(&covariance)).ok_or(OperatorError::NotPositiveDefinite { what })
}

/// `L⁻¹ m` for the Cholesky factor L of a noise covariance.
fn whiten<const N: usize, const C: usize>(
    factor: &Cholesky<f64, Const<N>>,
    m: &SMatrix<f64, N, C>,
) -> SMatrix<f64, N, C> {
    // L has a positive diagonal: the triangular solve succeeds.
    factor.l_dirty().solve_lower_triangular_unchecked(m)
}

/// The central-difference step of [`local_jacobians`], before Richardson's halving.
const LOCAL_STEP: f64 = 1e-3;

/// `(∂ (b ⊟ (a ⊞ ε))/∂ε, ∂ ((b ⊞ ε) ⊟ a)/∂ε)` at ε = 0: the Jacobians of `b ⊟ a` in a and in b, by
/// central differences with steps h = 1e-3 and h/2 combined by Richardson extrapolation,
/// `(4 D(h/2) − D(h))/3`, whose truncation error is O(h⁴) and rounding error about 1e-13 times the
/// points' coordinates.
fn local_jacobians<X: Manifold<D, Scalar = f64>, const D: usize>(
    a: &X,
    b: &X,
) -> (SMatrix<f64, D, D>, SMatrix<f64, D, D>) {
    let derivative = |g: &dyn Fn(&SVector<f64, D>) -> SVector<f64, D>| {
        SMatrix::<f64, D, D>::from_columns(&std::array::from_fn::<_, D, _>(|j| {
            let central = |h: f64| {
                let mut e = SVector::<f64, D>::zeros();
                e[j] = h;
                (g(&e) - g(&-e)) / (2.0 * h)
            };
            (central(LOCAL_STEP / 2.0) * 4.0 - central(LOCAL_STEP)) / 3.0
        }))
    };
    (
        derivative(&|e| a.retract(e).local(b)),
        derivative(&|e| a.local(&b.retract(e))),
    )
}

/// The Gauss-Newton system at one iterate.
struct Linearised<const D: usize> {
    /// The whitened Jacobian, whose normal matrix is Λ.
    jacobian: BlockJacobian<D>,
    /// `−g`, block by block.
    descent: Vec<SVector<f64, D>>,
    cost: f64,
}

/// A whitened residual `L⁻¹ r` with its whitened Jacobians `L⁻¹ J` in the states it involves.
struct Term<const D: usize, const N: usize> {
    residual: SVector<f64, N>,
    jacobians: Option<(SMatrix<f64, N, D>, Option<SMatrix<f64, N, D>>)>,
}

/// A recorded run with its models.
struct Problem<'a, X, U, P, H, const D: usize, const M: usize> {
    recorder: &'a IteratedSmoother<X, U, D, M>,
    process: &'a P,
    measurement: &'a H,
}

impl<X, U, P, H, const D: usize, const M: usize> Problem<'_, X, U, P, H, D, M>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D, Input = U>,
    H: MeasurementModel<X, D, M>,
{
    /// The prior's term `x₀ ⊟ μ₀`.
    fn prior_term(&self, x: &X, jacobians: bool) -> Term<D, D> {
        let prior = &self.recorder.prior;
        let factor = Cholesky::pack_dirty(*prior.cholesky_factor());
        let residual = whiten(&factor, &prior.mean().local(x));
        Term {
            residual,
            jacobians: jacobians
                .then(|| (whiten(&factor, &local_jacobians(prior.mean(), x).1), None)),
        }
    }

    /// The process term `x_{k+1} ⊟ f(x_k, u_k)`, with the Jacobians in x_k and x_{k+1}.
    fn process_term(
        &self,
        x: &X,
        next: &X,
        input: &U,
        jacobians: bool,
    ) -> Result<Term<D, D>, OperatorError> {
        let predicted = self.process.transition(x, input);
        if !predicted.is_finite() {
            return Err(OperatorError::NonFinitePoint {
                what: "the transition f(x, u) of the process model",
            });
        }
        let factor = whitening(&self.process.noise(x, input), "process noise Q")?;
        let residual = whiten(&factor, &predicted.local(next));
        let jacobians = jacobians.then(|| {
            let (in_predicted, in_next) = local_jacobians(&predicted, next);
            (
                whiten(&factor, &(in_predicted * self.process.jacobian(x, input))),
                Some(whiten(&factor, &in_next)),
            )
        });
        Ok(Term {
            residual,
            jacobians,
        })
    }

    /// The measurement term `z ⊟ h(x)`, with its Jacobian `−H`.
    fn measurement_term(
        &self,
        x: &X,
        z: &SVector<f64, M>,
        jacobians: bool,
    ) -> Result<Term<D, M>, OperatorError> {
        let factor = whitening(&self.measurement.noise(x), "measurement noise R")?;
        let residual = whiten(
            &factor,
            &self.measurement.residual(z, &self.measurement.predict(x)),
        );
        Ok(Term {
            residual,
            jacobians: jacobians.then(|| (whiten(&factor, &-self.measurement.jacobian(x)), None)),
        })
    }

    /// The cost J at a trajectory (`None` when a model fails there).
    fn cost(&self, states: &[X]) -> Option<f64> {
        self.visit(states, false, |_, _| Ok(())).ok()
    }

    /// Calls `add(k, term)` for every term at epoch k (the process term of the transition k → k + 1
    /// at k) and returns J.
    fn visit(
        &self,
        states: &[X],
        jacobians: bool,
        mut add: impl FnMut(usize, Contribution<D>) -> Result<(), OperatorError>,
    ) -> Result<f64, OperatorError> {
        let mut twice_cost = 0.0;
        let term = self.prior_term(&states[0], jacobians);
        twice_cost += term.residual.norm_squared();
        if jacobians {
            add(0, Contribution::own(&term))?;
        }
        for (k, input) in self.recorder.inputs.iter().enumerate() {
            let term = self.process_term(&states[k], &states[k + 1], input, jacobians)?;
            twice_cost += term.residual.norm_squared();
            if jacobians {
                add(k, Contribution::transition(&term))?;
            }
        }
        for (k, z) in &self.recorder.measurements {
            let term = self.measurement_term(&states[*k], z, jacobians)?;
            twice_cost += term.residual.norm_squared();
            if jacobians {
                add(*k, Contribution::own(&term))?;
            }
        }
        let cost = 0.5 * twice_cost;
        all_finite(
            "iterated smoother cost J (a residual is not finite)",
            [&cost],
        )?;
        Ok(cost)
    }

    /// The whitened Jacobian and the gradient at a trajectory.
    fn linearise(&self, states: &[X]) -> Result<Linearised<D>, OperatorError> {
        let n = states.len();
        let mut jacobian = BlockJacobian::new(n)?;
        let mut descent = with_capacity("blocks of the gradient", n)?;
        descent.resize(n, SVector::zeros());
        let cost = self.visit(states, true, |k, term| {
            match term.rows {
                Rows::Own(rows) => jacobian.add_rows(k, rows.as_view())?,
                Rows::Transition(first, second) => jacobian.set_transition(k, first, second)?,
            }
            descent[k] -= term.first_gradient;
            if let Some(gradient) = term.second_gradient {
                descent[k + 1] -= gradient;
            }
            Ok(())
        })?;
        Ok(Linearised {
            jacobian,
            descent,
            cost,
        })
    }

    /// The first `x ⊞ α δ` with α = 1, ½, ¼, … that does not raise J, with its cost.
    fn line_search(
        &self,
        states: &[X],
        step: &[SVector<f64, D>],
        cost: f64,
        settings: &GaussNewton,
    ) -> Option<Vec<X>> {
        let mut scale = 1.0;
        for _ in 0..=settings.max_halvings {
            let trial: Vec<X> = states
                .iter()
                .zip(step)
                .map(|(x, d)| x.retract(&(d * scale)))
                .collect();
            if trial.iter().all(Manifold::is_finite)
                && self
                    .cost(&trial)
                    .is_some_and(|trial_cost| trial_cost <= cost)
            {
                return Some(trial);
            }
            scale *= 0.5;
        }
        None
    }
}

/// A term's whitened Jacobian rows and its gradient `Jᵀr` in the states it involves (none for a
/// term built without Jacobians).
struct Contribution<const D: usize> {
    rows: Rows<D>,
    first_gradient: SVector<f64, D>,
    /// In the next epoch's state, for a transition.
    second_gradient: Option<SVector<f64, D>>,
}

/// A term's rows: in one state, or a transition's in x_k and x_{k+1}.
enum Rows<const D: usize> {
    Own(DMatrix<f64>),
    Transition(SMatrix<f64, D, D>, SMatrix<f64, D, D>),
}

impl<const D: usize> Contribution<D> {
    /// A term in one state (the prior's, a measurement's).
    fn own<const N: usize>(term: &Term<D, N>) -> Self {
        let (rows, first_gradient) = match &term.jacobians {
            Some((first, _)) => (
                DMatrix::from_column_slice(N, D, first.as_slice()),
                first.tr_mul(&term.residual),
            ),
            None => (DMatrix::zeros(0, D), SVector::zeros()),
        };
        Self {
            rows: Rows::Own(rows),
            first_gradient,
            second_gradient: None,
        }
    }

    /// A transition's term, in x_k and x_{k+1}.
    fn transition(term: &Term<D, D>) -> Self {
        match &term.jacobians {
            Some((first, second)) => {
                let second = second.unwrap_or_else(SMatrix::zeros);
                Self {
                    rows: Rows::Transition(*first, second),
                    first_gradient: first.tr_mul(&term.residual),
                    second_gradient: Some(second.tr_mul(&term.residual)),
                }
            }
            None => Self {
                rows: Rows::Transition(SMatrix::zeros(), SMatrix::zeros()),
                first_gradient: SVector::zeros(),
                second_gradient: None,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{MeasurementFn, ProcessFn};
    use liebayes_manifolds::{GroupAction, LieGroup, So3};
    use nalgebra::{Matrix3, Vector3};

    /// Against the analytic `J_local_self = −Jl⁻¹` and `J_local_other = Jr⁻¹` of SO(3), far from
    /// the identity.
    #[test]
    fn local_jacobians_match_the_analytic_ones() {
        let a = So3::exp(&Vector3::new(0.4, -1.1, 2.0));
        for v in [Vector3::new(0.3, 0.2, -0.5), Vector3::new(1.0, -2.0, 0.5)] {
            let b = a.retract(&v);
            let (in_a, in_b) = local_jacobians(&a, &b);
            assert!((in_a - a.j_local_self(&b)).amax() < 1e-9, "{in_a}");
            assert!((in_b - a.j_local_other(&b)).amax() < 1e-9, "{in_b}");
        }
    }

    /// The gradient `g = Σ Jᵀ C⁻¹ r` of the linearisation against central differences of J along
    /// every tangent direction of every epoch, on SO(3) with a vector reading.
    #[test]
    fn gradient_matches_finite_differences_of_the_cost() {
        let increment = So3::exp(&Vector3::new(0.1, -0.2, 0.05));
        let process = ProcessFn::new(
            move |x: &So3<f64>, (): &()| x.compose(&increment),
            |_, ()| Matrix3::identity() * 0.02,
        );
        let reading = MeasurementFn::new(
            |x: &So3<f64>| x.inverse().act(&Vector3::new(0.0, 0.6, 0.8)),
            |_| Matrix3::identity() * 0.01,
        );
        let prior = ManifoldGaussian::new(
            So3::exp(&Vector3::new(1.0, 0.5, -0.3)),
            Matrix3::identity() * 0.3,
        )
        .unwrap();
        let mut smoother = IteratedSmoother::new(prior);
        for z in [Vector3::new(0.3, 0.5, 0.8), Vector3::new(-0.2, 0.7, 0.6)] {
            smoother.propagate(&process, &()).unwrap();
            smoother.condition(&reading, &z).unwrap();
        }
        let problem = Problem {
            recorder: &smoother,
            process: &process,
            measurement: &reading,
        };
        // A trajectory away from the minimum, so that every residual is nonzero.
        let states: Vec<So3<f64>> = (0..3_u8)
            .map(|k: u8| {
                So3::exp(&Vector3::new(
                    0.2 * f64::from(k),
                    -0.4,
                    1.0 - 0.3 * f64::from(k),
                ))
            })
            .collect();
        let linearised = problem.linearise(&states).unwrap();
        let h = 1e-5;
        for k in 0..states.len() {
            for j in 0..3 {
                let shifted = |s: f64| {
                    let mut moved = states.clone();
                    moved[k] = moved[k].retract(&(Vector3::ith(j, s)));
                    problem.cost(&moved).unwrap()
                };
                let derivative = (shifted(h) - shifted(-h)) / (2.0 * h);
                let gradient = -linearised.descent[k][j];
                assert!(
                    (derivative - gradient).abs() < 1e-6 * (1.0 + gradient.abs()),
                    "epoch {k}, direction {j}: {derivative} against {gradient}"
                );
            }
        }
    }
}
