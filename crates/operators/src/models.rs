//! The model traits the EKF and the UKF linearise or sample, their use by reference, and models
//! written from closures.
//!
//! * [`ProcessModel`]: `x′ = f(x, u) ⊞ w`, `w ~ N(0, Q)`;
//! * [`MeasurementModel`]: `z = h(x) + n`, `n ~ N(0, R)`, with a residual that may wrap;
//! * a shared reference to a model is a model (`density.propagate(&Ekf(&model), &u)`), so a filter
//!   loop builds its models once;
//! * [`ProcessFn`] and [`MeasurementFn`] make a model of closures (transition and noise, prediction
//!   and noise; optionally the Jacobian and the residual) in a few lines.

use liebayes_manifolds::Manifold;
use nalgebra::{SMatrix, SVector};
use std::marker::PhantomData;

/// A process `x′ = f(x, u) ⊞ w`, `w ~ N(0, Q)` with w in the tangent space at f(x, u).
pub trait ProcessModel<X: Manifold<D, Scalar = f64>, const D: usize> {
    /// What drives the process (a velocity and a time step, …).
    type Input;

    /// The noise-free motion f(x, u).
    fn transition(&self, x: &X, input: &Self::Input) -> X;

    /// Q, the covariance of w in the tangent space at f(x, u).
    fn noise(&self, x: &X, input: &Self::Input) -> SMatrix<f64, D, D>;

    /// `F = ∂ [f(x ⊞ δ, u) ⊟ f(x, u)] / ∂δ` at δ = 0 (a right Jacobian). The default is a central
    /// difference with step 1e-6 in each tangent direction: its error is about 1e-10 times the size of
    /// f's coordinates (rounding) plus 1e-12 times f's third derivative (truncation). Override it with
    /// the analytic form for accuracy far from the origin and for speed on a hot path.
    fn jacobian(&self, x: &X, input: &Self::Input) -> SMatrix<f64, D, D> {
        numeric_process_jacobian(self, x, input)
    }

    /// `(F P Fᵀ, P Fᵀ)` for the covariance P of a prior with mean x: the EKF's propagated
    /// covariance before the noise, and the cross-covariance `Cov(δ, δ′)` the smoothers keep. The
    /// default multiplies by the dense [`jacobian`](Self::jacobian); a model whose Jacobian is
    /// sparse (the identity and a few entries, as most strapdown models') overrides it to skip the
    /// zeros on a hot path, with the same result up to rounding.
    fn propagate_covariance(
        &self,
        x: &X,
        input: &Self::Input,
        p: &SMatrix<f64, D, D>,
    ) -> (SMatrix<f64, D, D>, SMatrix<f64, D, D>) {
        let f = self.jacobian(x, input);
        let cross = p * f.transpose();
        (f * cross, cross)
    }
}

/// A measurement `z = h(x) + n`, `n ~ N(0, R)`, with z in R^M and an innovation `z ⊟ ẑ` that may wrap
/// (an angle measured as one coordinate, say).
pub trait MeasurementModel<X: Manifold<D, Scalar = f64>, const D: usize, const M: usize> {
    /// The predicted measurement h(x).
    fn predict(&self, x: &X) -> SVector<f64, M>;

    /// R.
    fn noise(&self, x: &X) -> SMatrix<f64, M, M>;

    /// z ⊟ ẑ: `z − ẑ` unless a coordinate lives on a circle, where the override wraps it.
    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        z - predicted
    }

    /// `H = ∂ [h(x ⊞ δ) ⊟ h(x)] / ∂δ` at δ = 0. Default: central differences, as
    /// [`ProcessModel::jacobian`].
    fn jacobian(&self, x: &X) -> SMatrix<f64, M, D> {
        numeric_measurement_jacobian(self, x)
    }

    /// The dimension of the manifold the measurement lives on: the degrees of freedom of the NIS
    /// ([`Innovation::dof`](crate::Innovation::dof)). M for a measurement in R^M (the default);
    /// fewer when the M coordinates are constrained: a model stacking n unit vectors of S² as 3n
    /// coordinates returns 2n, since the component of `z − ẑ` along ẑ is of second order in the
    /// angle and adds nothing to the NIS's distribution to first order.
    fn dof(&self) -> usize {
        M
    }
}

/// A model used by reference is the model: every method, the Jacobian included, is the referent's.
impl<X, P, const D: usize> ProcessModel<X, D> for &P
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D> + ?Sized,
{
    type Input = P::Input;

    fn transition(&self, x: &X, input: &P::Input) -> X {
        (**self).transition(x, input)
    }

    fn noise(&self, x: &X, input: &P::Input) -> SMatrix<f64, D, D> {
        (**self).noise(x, input)
    }

    fn jacobian(&self, x: &X, input: &P::Input) -> SMatrix<f64, D, D> {
        (**self).jacobian(x, input)
    }

    fn propagate_covariance(
        &self,
        x: &X,
        input: &P::Input,
        p: &SMatrix<f64, D, D>,
    ) -> (SMatrix<f64, D, D>, SMatrix<f64, D, D>) {
        (**self).propagate_covariance(x, input, p)
    }
}

/// A model used by reference is the model: every method, the Jacobian and the residual included, is
/// the referent's.
impl<X, H, const D: usize, const M: usize> MeasurementModel<X, D, M> for &H
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M> + ?Sized,
{
    fn predict(&self, x: &X) -> SVector<f64, M> {
        (**self).predict(x)
    }

    fn noise(&self, x: &X) -> SMatrix<f64, M, M> {
        (**self).noise(x)
    }

    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        (**self).residual(z, predicted)
    }

    fn jacobian(&self, x: &X) -> SMatrix<f64, M, D> {
        (**self).jacobian(x)
    }

    fn dof(&self) -> usize {
        (**self).dof()
    }
}

/// The central-difference step of the default Jacobians.
const JACOBIAN_STEP: f64 = 1e-6;

/// `∂ g(x ⊞ δ) / ∂δ` at 0 by central differences with step 1e-6 (g(x) is assumed to be 0).
fn numeric_jacobian<X: Manifold<D, Scalar = f64>, const D: usize, const K: usize>(
    x: &X,
    g: impl Fn(&X) -> SVector<f64, K>,
) -> SMatrix<f64, K, D> {
    SMatrix::<f64, K, D>::from_columns(&std::array::from_fn::<_, D, _>(|j| {
        let mut e = SVector::<f64, D>::zeros();
        e[j] = JACOBIAN_STEP;
        (g(&x.retract(&e)) - g(&x.retract(&-e))) / (2.0 * JACOBIAN_STEP)
    }))
}

/// The default [`ProcessModel::jacobian`]: central differences of `f(x ⊞ δ) ⊟ f(x)`.
fn numeric_process_jacobian<X, P, const D: usize>(
    model: &P,
    x: &X,
    input: &P::Input,
) -> SMatrix<f64, D, D>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D> + ?Sized,
{
    let centre = model.transition(x, input);
    numeric_jacobian(x, |y| centre.local(&model.transition(y, input)))
}

/// The default [`MeasurementModel::jacobian`]: central differences of `h(x ⊞ δ) ⊟ h(x)`.
fn numeric_measurement_jacobian<X, H, const D: usize, const M: usize>(
    model: &H,
    x: &X,
) -> SMatrix<f64, M, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M> + ?Sized,
{
    let centre = model.predict(x);
    numeric_jacobian(x, |y| model.residual(&model.predict(y), &centre))
}

/// The Jacobian of a closure model that has none of its own: central differences, as the traits'
/// defaults ([`ProcessModel::jacobian`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NumericJacobian;

/// The residual `z ⊟ ẑ` of a [`MeasurementFn`]: [`Difference`] (`z − ẑ`, the default) or a closure
/// `Fn(&z, &ẑ) -> z ⊟ ẑ` that wraps the coordinates that live on a circle.
pub trait Residual<const M: usize> {
    /// `z ⊟ ẑ`.
    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M>;
}

/// The plain residual `z − ẑ`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Difference;

impl<const M: usize> Residual<M> for Difference {
    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        z - predicted
    }
}

impl<F, const M: usize> Residual<M> for F
where
    F: Fn(&SVector<f64, M>, &SVector<f64, M>) -> SVector<f64, M>,
{
    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        self(z, predicted)
    }
}

/// A [`ProcessModel`] from closures: `transition(x, u) = f(x, u)`, `noise(x, u) = Q`, and optionally
/// `jacobian(x, u) = F` ([`with_jacobian`](Self::with_jacobian); central differences otherwise). U is
/// the input type.
///
/// # Example
/// A heading integrating a gyroscope rate, `θ′ = θ + ω dt + w`, `w ~ N(0, q² dt)`:
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::{Manifold, So2};
/// use liebayes_operators::{Ekf, ProcessFn, Propagate};
/// use nalgebra::{Matrix1, Vector1};
///
/// let q2 = 0.01;
/// let gyro = ProcessFn::new(
///     |x: &So2<f64>, &(rate, dt): &(f64, f64)| x.retract(&Vector1::new(rate * dt)),
///     move |_, &(_, dt)| Matrix1::new(q2 * dt),
/// )
/// .with_jacobian(|_, _| Matrix1::new(1.0));
/// let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(0.1)).unwrap();
/// let next = prior.propagate(&Ekf(&gyro), &(0.5, 2.0)).unwrap();
/// assert!((next.mean().angle() - 1.0).abs() < 1e-15);
/// assert!((next.covariance()[0] - 0.12).abs() < 1e-15);
/// ```
pub struct ProcessFn<U, F, Q, J = NumericJacobian> {
    transition: F,
    noise: Q,
    jacobian: J,
    input: PhantomData<fn(&U)>,
}

impl<U, F, Q> ProcessFn<U, F, Q> {
    /// The model with transition f and noise covariance Q (closures of the state and the input);
    /// its Jacobian is by central differences until [`with_jacobian`](Self::with_jacobian) gives one.
    pub fn new<X, const D: usize>(transition: F, noise: Q) -> Self
    where
        X: Manifold<D, Scalar = f64>,
        F: Fn(&X, &U) -> X,
        Q: Fn(&X, &U) -> SMatrix<f64, D, D>,
    {
        Self {
            transition,
            noise,
            jacobian: NumericJacobian,
            input: PhantomData,
        }
    }

    /// The same model with the analytic right Jacobian `F = ∂[f(x ⊞ δ, u) ⊟ f(x, u)]/∂δ`.
    pub fn with_jacobian<X, J, const D: usize>(self, jacobian: J) -> ProcessFn<U, F, Q, J>
    where
        X: Manifold<D, Scalar = f64>,
        J: Fn(&X, &U) -> SMatrix<f64, D, D>,
    {
        ProcessFn {
            transition: self.transition,
            noise: self.noise,
            jacobian,
            input: PhantomData,
        }
    }
}

impl<X, U, F, Q, const D: usize> ProcessModel<X, D> for ProcessFn<U, F, Q>
where
    X: Manifold<D, Scalar = f64>,
    F: Fn(&X, &U) -> X,
    Q: Fn(&X, &U) -> SMatrix<f64, D, D>,
{
    type Input = U;

    fn transition(&self, x: &X, input: &U) -> X {
        (self.transition)(x, input)
    }

    fn noise(&self, x: &X, input: &U) -> SMatrix<f64, D, D> {
        (self.noise)(x, input)
    }
}

impl<X, U, F, Q, J, const D: usize> ProcessModel<X, D> for ProcessFn<U, F, Q, J>
where
    X: Manifold<D, Scalar = f64>,
    F: Fn(&X, &U) -> X,
    Q: Fn(&X, &U) -> SMatrix<f64, D, D>,
    J: Fn(&X, &U) -> SMatrix<f64, D, D>,
{
    type Input = U;

    fn transition(&self, x: &X, input: &U) -> X {
        (self.transition)(x, input)
    }

    fn noise(&self, x: &X, input: &U) -> SMatrix<f64, D, D> {
        (self.noise)(x, input)
    }

    fn jacobian(&self, x: &X, input: &U) -> SMatrix<f64, D, D> {
        (self.jacobian)(x, input)
    }
}

/// A [`MeasurementModel`] from closures: `predict(x) = h(x)`, `noise(x) = R`, optionally the
/// residual `z ⊟ ẑ` ([`with_residual`](Self::with_residual); `z − ẑ` otherwise) and the Jacobian H
/// ([`with_jacobian`](Self::with_jacobian); central differences of `h(x ⊞ δ) ⊟ h(x)` otherwise).
///
/// # Example
/// A compass reading of a heading in (−π, π], the residual wrapped:
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::{Manifold, So2};
/// use liebayes_operators::{Condition, Ekf, MeasurementFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// let compass = MeasurementFn::new(|x: &So2<f64>| Vector1::new(x.angle()), |_| {
///     Matrix1::new(0.01)
/// })
/// // z ⊟ ẑ through SO(2): the angle difference wrapped to (−π, π].
/// .with_residual(|z: &Vector1<f64>, p: &Vector1<f64>| {
///     So2::from_angle_unchecked(p[0]).local(&So2::from_angle_unchecked(z[0]))
/// });
/// let prior = ManifoldGaussian::new(So2::from_angle_unchecked(3.1), Matrix1::new(0.01)).unwrap();
/// // A reading across the cut, 0.1 rad from the mean: the posterior is half-way, past π, not near 0.
/// let reading = 3.2 - 2.0 * std::f64::consts::PI;
/// let posterior = prior.condition(&Ekf(&compass), &Vector1::new(reading)).unwrap().posterior;
/// assert!(posterior.mean().distance(&So2::from_angle_unchecked(3.15)) < 1e-9);
/// ```
pub struct MeasurementFn<H, R, E = Difference, J = NumericJacobian> {
    predict: H,
    noise: R,
    residual: E,
    jacobian: J,
}

impl<H, R> MeasurementFn<H, R> {
    /// The model with prediction h and noise covariance R (closures of the state).
    pub fn new<X, const D: usize, const M: usize>(predict: H, noise: R) -> Self
    where
        X: Manifold<D, Scalar = f64>,
        H: Fn(&X) -> SVector<f64, M>,
        R: Fn(&X) -> SMatrix<f64, M, M>,
    {
        Self {
            predict,
            noise,
            residual: Difference,
            jacobian: NumericJacobian,
        }
    }
}

impl<H, R, E, J> MeasurementFn<H, R, E, J> {
    /// The same model with the residual `z ⊟ ẑ` of a closure (to wrap angle coordinates).
    pub fn with_residual<E2, const M: usize>(self, residual: E2) -> MeasurementFn<H, R, E2, J>
    where
        E2: Fn(&SVector<f64, M>, &SVector<f64, M>) -> SVector<f64, M>,
    {
        MeasurementFn {
            predict: self.predict,
            noise: self.noise,
            residual,
            jacobian: self.jacobian,
        }
    }

    /// The same model with the analytic Jacobian `H = ∂[h(x ⊞ δ) ⊟ h(x)]/∂δ`.
    pub fn with_jacobian<X, J2, const D: usize, const M: usize>(
        self,
        jacobian: J2,
    ) -> MeasurementFn<H, R, E, J2>
    where
        X: Manifold<D, Scalar = f64>,
        J2: Fn(&X) -> SMatrix<f64, M, D>,
    {
        MeasurementFn {
            predict: self.predict,
            noise: self.noise,
            residual: self.residual,
            jacobian,
        }
    }
}

impl<X, H, R, E, const D: usize, const M: usize> MeasurementModel<X, D, M>
    for MeasurementFn<H, R, E>
where
    X: Manifold<D, Scalar = f64>,
    H: Fn(&X) -> SVector<f64, M>,
    R: Fn(&X) -> SMatrix<f64, M, M>,
    E: Residual<M>,
{
    fn predict(&self, x: &X) -> SVector<f64, M> {
        (self.predict)(x)
    }

    fn noise(&self, x: &X) -> SMatrix<f64, M, M> {
        (self.noise)(x)
    }

    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        self.residual.residual(z, predicted)
    }
}

impl<X, H, R, E, J, const D: usize, const M: usize> MeasurementModel<X, D, M>
    for MeasurementFn<H, R, E, J>
where
    X: Manifold<D, Scalar = f64>,
    H: Fn(&X) -> SVector<f64, M>,
    R: Fn(&X) -> SMatrix<f64, M, M>,
    E: Residual<M>,
    J: Fn(&X) -> SMatrix<f64, M, D>,
{
    fn predict(&self, x: &X) -> SVector<f64, M> {
        (self.predict)(x)
    }

    fn noise(&self, x: &X) -> SMatrix<f64, M, M> {
        (self.noise)(x)
    }

    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        self.residual.residual(z, predicted)
    }

    fn jacobian(&self, x: &X) -> SMatrix<f64, M, D> {
        (self.jacobian)(x)
    }
}
