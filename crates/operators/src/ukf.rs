//! The unscented Kalman filter on any [`Manifold`]: sigma points by retraction, means on the manifold.
//!
//! With `x = μ ⊞ δ`, `δ ~ N(0, P)` and the lower Cholesky factor L of P, the 2D + 1 sigma points are
//! `χ₀ = μ`, `χ±ᵢ = μ ⊞ (±γ Lᵢ)` with `γ = √(D + λ)`, `λ = α² (D + κ) − D`, and the weights
//! `w₀ᵐ = λ/(D + λ)`, `w₀ᶜ = w₀ᵐ + 1 − α² + β`, `wᵢ = 1/(2(D + λ))` (Wan and van der Merwe's scaled
//! unscented transform).
//!
//! * **propagate**: `Yᵢ = f(χᵢ, u)`; the mean m is the weighted mean *on the manifold*, the fixed point
//!   of `m ← m ⊞ Σ wᵢᵐ (Yᵢ ⊟ m)` ([`weighted_mean`] from Y₀, never an average of coordinates, so sigma
//!   points on both sides of ±π average correctly); `P′ = Σ wᵢᶜ (Yᵢ ⊟ m)(Yᵢ ⊟ m)ᵀ + Q`; for the
//!   [smoother](crate::smoother), the cross-covariance `C = Σ wᵢᶜ dᵢ (Yᵢ ⊟ m)ᵀ` with dᵢ the sigma
//!   offsets.
//! * **condition**: `Zᵢ = h(χᵢ)`, ẑ the fixed point of `ẑ ← ẑ + Σ wᵢᵐ (Zᵢ ⊟ ẑ)` (the same
//!   [`weighted_mean`], with the model's residual, which may wrap, as ⊟), `S = Σ wᵢᶜ rᵢ rᵢᵀ + R`,
//!   `C = Σ wᵢᶜ dᵢ rᵢᵀ` with dᵢ the sigma offsets, `K = C S⁻¹`, `μ⁺ = μ ⊞ K (z ⊟ ẑ)`,
//!   `P⁺ = P − K S Kᵀ` (in the tangent space at μ, as the [EKF](crate::ekf)'s); log evidence
//!   `ln N(z ⊟ ẑ; 0, S)`; the report is the [`Innovation`] (ν, S, K, NIS). When S or P⁺ loses
//!   positive definiteness to rounding (R below the rounding of the sigma points' spread), the
//!   update is made once more with S raised by `64 M ε max |Sᵢᵢ| I`, as the EKF's; a prediction
//!   whose covariance rounding leaves singular, once more with Q raised by `64 D ε max |P′ᵢᵢ| I`.
//! * **check**: as the [EKF](crate::ekf)'s, for the line the update was made with, the statistical
//!   linearisation `z ≈ ẑ + Ĥ δ` (`Ĥ = Cᵀ P⁻¹`): the reading predicted at μ⁺ may miss `ẑ + Ĥ K ν`
//!   by at most [`LINEARISATION_LIMIT`](crate::ekf::LINEARISATION_LIMIT) in the squared standard
//!   deviations of `Ĥ P⁺ Ĥᵀ + R + Ω`, Ω what Ĥ leaves unexplained of the sigma points' spread
//!   (their curvature, so a correction within that spread is never refused), plus what the rounding
//!   of the sigma points can make Ĥ miss by. A correction far beyond the sigma points, where the
//!   model bends away from their regression, is refused ([`OperatorError::Linearisation`]) for the
//!   [iterated UKF](crate::iterated) to take. One more evaluation of h; Ω, a factorisation and D
//!   round trips `(μ ⊞ dᵢ) ⊟ μ` only when the bound by R alone cannot keep the update.
//!
//! Every image Yᵢ and Zᵢ is checked with [`Manifold::is_finite`] before it is averaged, and a mean that
//! does not converge (sigma points spread over more than half the injectivity radius) is an
//! [`OperatorError::Manifold`]: the step is refused, and the density it was applied to is untouched.
//!
//! Exact for linear models on Rⁿ (it then equals the Kalman filter). Nothing is allocated: the sigma
//! points live in arrays of size D.

use crate::ekf::{Line, check_linearisation};
use crate::error::all_finite;
use crate::kalman::joseph;
use crate::models::{MeasurementModel, ProcessModel};
use crate::numerics::{
    Produced, above_rounding, checked_gaussian, checked_gaussian_above_rounding, model_noise, slope,
};
use crate::smoother::{GaussianTransition, Prediction};
use crate::{Condition, Conditioned, Innovation, OperatorError, Propagate};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::{Manifold, MeanSettings, weighted_mean};
use nalgebra::{SMatrix, SVector};
use std::fmt;
use std::iter::once;
use std::marker::PhantomData;

/// The ranges of the scaling parameters (see [`Ukf::with_scaling`]).
const ALPHA_RANGE: (f64, f64) = (1e-6, 1e6);
const KAPPA_MAX: f64 = 1e6;
const BETA_MAX: f64 = 1e6;
/// The smallest `α² (1 + κ)`: the spread `D + λ = α² (D + κ)` of the sigma points at D = 1, below
/// which the weights `1/(2(D + λ))` exceed 5e11 and the mean is lost to cancellation.
const MIN_SPREAD: f64 = 1e-12;

/// A model to be used through the unscented transform: `density.propagate(&Ukf::new(process), &u)`,
/// `density.condition(&Ukf::new(measurement), &z)`. M, the measurement dimension, is inferred from z
/// (and is 0, unused, for a process).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ukf<Model, const M: usize = 0> {
    model: Model,
    alpha: f64,
    beta: f64,
    kappa: f64,
    root: SquareRoot,
}

/// Which square root of P spreads the sigma points `μ ⊞ ±γ sⱼ`: any S with `S Sᵀ = P` gives the
/// same mean and covariance for linear models, but not for nonlinear ones, so results depend on the
/// choice (and two implementations agree only if they make the same one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SquareRoot {
    /// The columns of the lower Cholesky factor L, `P = L Lᵀ` (the default: computed once with
    /// the density).
    #[default]
    Cholesky,
    /// The principal axes `√dⱼ vⱼ` of the eigendecomposition `P = V diag(d) Vᵀ` (cyclic Jacobi
    /// rotations, at most 64 sweeps): the sigma points do not depend on the order of the
    /// coordinates.
    Eigen,
}

impl<Model, const M: usize> Ukf<Model, M> {
    /// The model with α = 1, β = 2, κ = 0: sigma points at `±√D` standard deviations, no negative
    /// mean weight.
    ///
    /// # Example
    /// ```
    /// use liebayes_operators::densities::ManifoldGaussian;
    /// use liebayes_operators::manifolds::{Manifold, Rn};
    /// use liebayes_operators::{Condition, MeasurementFn, Ukf};
    /// use nalgebra::{Matrix1, Vector1};
    ///
    /// // On a linear model the unscented transform is exact: the Kalman update.
    /// let linear = MeasurementFn::new(|x: &Rn<f64, 1>| Vector1::new(3.0 * x.coords()[0]), |_| {
    ///     Matrix1::new(1.0)
    /// });
    /// let prior = ManifoldGaussian::new(Rn::new(Vector1::new(0.0)).unwrap(), Matrix1::new(1.0)).unwrap();
    /// let step = prior.condition(&Ukf::new(&linear), &Vector1::new(3.0)).unwrap();
    /// // K = 3/(9 + 1): mean 0.9, variance 1 − 0.9 · 3 = 0.1.
    /// assert!((step.posterior.mean().coords()[0] - 0.9).abs() < 1e-12);
    /// assert!((step.posterior.covariance()[0] - 0.1).abs() < 1e-12);
    /// ```
    pub fn new(model: Model) -> Self {
        Self {
            model,
            alpha: 1.0,
            beta: 2.0,
            kappa: 0.0,
            root: SquareRoot::Cholesky,
        }
    }

    /// The scaling parameters α (spread of the sigma points, γ = α √(D + κ) standard deviations),
    /// β (2 is optimal for Gaussians) and κ.
    ///
    /// Valid ranges: α in [1e-6, 1e6], κ in (−1, 1e6], β in [−1e6, 1e6], and `α² (1 + κ) ≥ 1e-12`.
    /// Then for every dimension D the spread `D + λ = α² (D + κ)` is at least 1e-12 and finite, so the
    /// weights `1/(2(D + λ))` and `w₀ᵐ = 1 − D/(α² (D + κ))` are finite (the usual choices, α from
    /// 1e-3 to 1, κ = 0 or 3 − D, β = 2, are well inside).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a NaN or infinite parameter, [`OperatorError::OutOfRange`]
    /// outside the ranges above, naming the parameter.
    pub fn with_scaling(
        model: Model,
        alpha: f64,
        beta: f64,
        kappa: f64,
    ) -> Result<Self, OperatorError> {
        crate::error::all_finite(
            "unscented scaling (alpha, beta, kappa)",
            [alpha, beta, kappa].iter(),
        )?;
        let out_of_range =
            |what, value, range| Err(OperatorError::OutOfRange { what, value, range });
        if !(ALPHA_RANGE.0..=ALPHA_RANGE.1).contains(&alpha) {
            return out_of_range("unscented scaling alpha", alpha, "[1e-6, 1e6]");
        }
        if !(kappa > -1.0 && kappa <= KAPPA_MAX) {
            return out_of_range("unscented scaling kappa", kappa, "(-1, 1e6]");
        }
        if beta.abs() > BETA_MAX {
            return out_of_range("unscented scaling beta", beta, "[-1e6, 1e6]");
        }
        let spread = alpha * alpha * (1.0 + kappa);
        if spread < MIN_SPREAD {
            return out_of_range(
                "unscented spread alpha^2 (1 + kappa)",
                spread,
                "[1e-12, infinity): raise alpha or kappa",
            );
        }
        Ok(Self {
            model,
            alpha,
            beta,
            kappa,
            root: SquareRoot::Cholesky,
        })
    }

    /// The same filter with the sigma points spread by `root` (see [`SquareRoot`]).
    #[must_use]
    pub fn with_square_root(mut self, root: SquareRoot) -> Self {
        self.root = root;
        self
    }

    /// The model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// `(γ, w₀ᵐ, w₀ᶜ, wᵢ)` for dimension d.
    fn weights(&self, d: usize) -> (f64, f64, f64, f64) {
        let d = d as f64;
        let lambda = self.alpha * self.alpha * (d + self.kappa) - d;
        let w0 = lambda / (d + lambda);
        (
            (d + lambda).sqrt(),
            w0,
            w0 + 1.0 - self.alpha * self.alpha + self.beta,
            0.5 / (d + lambda),
        )
    }
}

/// The sigma offsets `γ sⱼ` of the square root `root` of the density's covariance (the −γ sⱼ side
/// is their negation).
fn sigma_offsets<X, const D: usize>(
    density: &ManifoldGaussian<X, D>,
    gamma: f64,
    root: SquareRoot,
) -> [SVector<f64, D>; D]
where
    X: Manifold<D, Scalar = f64>,
{
    let s = match root {
        SquareRoot::Cholesky => *density.cholesky_factor(),
        SquareRoot::Eigen => principal_axes(density.covariance()),
    } * gamma;
    std::array::from_fn(|j| s.column(j).into_owned())
}

/// The most sweeps of the Jacobi iteration (it converges quadratically: a handful suffice).
const JACOBI_SWEEPS: usize = 64;

/// `V diag(√d)` for a symmetric positive definite P = V diag(d) Vᵀ, by cyclic Jacobi rotations
/// (no allocation; bounded sweeps; eigenvalues rounded below zero are taken as zero).
fn principal_axes<const D: usize>(p: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    let mut a = *p;
    let mut v = SMatrix::<f64, D, D>::identity();
    let scale = a.norm();
    for _ in 0..JACOBI_SWEEPS {
        let off: f64 = (0..D)
            .flat_map(|i| (0..D).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[(i, j)] * a[(i, j)])
            .sum();
        if off.sqrt() <= f64::EPSILON * scale {
            break;
        }
        for i in 0..D {
            for j in i + 1..D {
                let apq = a[(i, j)];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[(j, j)] - a[(i, i)]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + theta.hypot(1.0));
                let c = 1.0 / t.hypot(1.0);
                let s = t * c;
                for k in 0..D {
                    let (aki, akj) = (a[(k, i)], a[(k, j)]);
                    a[(k, i)] = c * aki - s * akj;
                    a[(k, j)] = s * aki + c * akj;
                }
                for k in 0..D {
                    let (aik, ajk) = (a[(i, k)], a[(j, k)]);
                    a[(i, k)] = c * aik - s * ajk;
                    a[(j, k)] = s * aik + c * ajk;
                }
                for k in 0..D {
                    let (vki, vkj) = (v[(k, i)], v[(k, j)]);
                    v[(k, i)] = c * vki - s * vkj;
                    v[(k, j)] = s * vki + c * vkj;
                }
            }
        }
    }
    for j in 0..D {
        let root = a[(j, j)].max(0.0).sqrt();
        v.column_mut(j).scale_mut(root);
    }
    v
}

impl<X, P, const D: usize> GaussianTransition<X, D> for Ukf<P>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    /// The unscented prediction (see the module docs), with the cross-covariance
    /// `C = Σ wᵢᶜ dᵢ (Yᵢ ⊟ m)ᵀ` of the sigma offsets dᵢ and the images' deviations, and the noise
    /// its linearisation leaves, `Ω = Q + w₀ᶜ e₀ e₀ᵀ + (wᵢ/2) Σ (eᵢ⁺ + eᵢ⁻)(eᵢ⁺ + eᵢ⁻)ᵀ`. That is
    /// `P′ − F̂ P F̂ᵀ` with `F̂ = Cᵀ P⁻¹`: the offsets are `±γ sᵢ` with `S Sᵀ = P` and `2 wᵢ γ² = 1`,
    /// so `F̂ P F̂ᵀ = (wᵢ/2) Σ (eᵢ⁺ − eᵢ⁻)(eᵢ⁺ − eᵢ⁻)ᵀ`, and `P′`'s sum of `eᵢ⁺ eᵢ⁺ᵀ + eᵢ⁻ eᵢ⁻ᵀ`
    /// splits into that and the sum kept here, with no difference taken.
    fn predict_with_cross(
        &self,
        prior: &ManifoldGaussian<X, D>,
        input: &P::Input,
    ) -> Result<Prediction<X, D>, OperatorError> {
        let (gamma, w0m, w0c, w) = self.weights(D);
        let offsets = sigma_offsets(prior, gamma, self.root);
        let mu = prior.mean();
        let centre = self.model.transition(mu, input);
        let plus = offsets.map(|d| self.model.transition(&mu.retract(&d), input));
        let minus = offsets.map(|d| self.model.transition(&mu.retract(&-d), input));
        if !(centre.is_finite() && plus.iter().chain(&minus).all(Manifold::is_finite)) {
            return Err(OperatorError::NonFinitePoint {
                what: "a sigma point's image f(chi, u) under the process model",
            });
        }
        let mean = weighted_mean(
            &centre,
            once((&centre, w0m)).chain(plus.iter().chain(&minus).map(|y| (y, w))),
            MeanSettings::default(),
        )
        .map_err(|source| OperatorError::Manifold {
            what: "the mean of the propagated sigma points",
            source,
        })?;
        let e0 = mean.local(&centre);
        let mut covariance = e0 * e0.transpose() * w0c
            + model_noise("process noise Q", self.model.noise(mu, input))?;
        let mut noise = covariance;
        let mut cross = SMatrix::<f64, D, D>::zeros();
        for (d, (yp, ym)) in offsets.iter().zip(plus.iter().zip(&minus)) {
            let (ep, em) = (mean.local(yp), mean.local(ym));
            covariance += (ep * ep.transpose() + em * em.transpose()) * w;
            let curved = ep + em;
            noise += curved * curved.transpose() * (0.5 * w);
            cross += d * (ep - em).transpose() * w;
        }
        let (density, floor) = checked_gaussian_above_rounding(
            &mean,
            &covariance,
            Produced {
                mean: "the mean of the propagated sigma points",
                covariance: "predicted covariance (sigma points plus Q; check the process noise Q)",
            },
        )?;
        let noise = noise + SMatrix::<f64, D, D>::identity() * floor;
        all_finite("transition noise of the unscented prediction", noise.iter())?;
        Ok(Prediction {
            density,
            cross_covariance: cross,
            noise,
        })
    }
}

impl<X, P, const D: usize> Propagate<Ukf<P>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    P: ProcessModel<X, D>,
{
    type Input = P::Input;

    fn propagate(&self, ukf: &Ukf<P>, input: &P::Input) -> Result<Self, OperatorError> {
        ukf.predict_with_cross(self, input).map(|p| p.density)
    }
}

impl<X, H, const D: usize, const M: usize> Condition<Ukf<H, M>> for ManifoldGaussian<X, D>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Measurement = SVector<f64, M>;
    type Report = Innovation<D, M>;

    fn condition(
        &self,
        ukf: &Ukf<H, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self, Innovation<D, M>>, OperatorError> {
        crate::error::all_finite("measurement z", z.iter())?;
        let (mu, h) = (self.mean(), &ukf.model);
        let noise = model_noise("measurement noise R", h.noise(mu))?;
        let moments = ukf.measurement_moments(self, None, noise)?;
        let residual = h.residual(z, &moments.predicted);
        let linear = slope(self.cholesky_factor(), &moments.cross);
        above_rounding::<_, M>(
            || moments.covariance.diagonal().amax(),
            |floor| {
                let raised = SMatrix::<f64, M, M>::identity() * floor;
                let (report, log_evidence) = Innovation::new(
                    residual,
                    &(moments.covariance + raised),
                    &moments.cross,
                    h.dof(),
                )?;
                // P⁺ = P − K S Kᵀ in Joseph's form, with S = Ĥ P Ĥᵀ + R + Ω for the statistical
                // linearisation Ĥ: (I − K Ĥ) P (I − K Ĥ)ᵀ + K (R + Ω) Kᵀ. The difference cancels
                // for a diffuse prior (a variance of 1e17 updated by a unit reading kept 1456 where
                // 1 is exact), the sum of positive terms does not.
                let gain = report.gain();
                let posterior = checked_gaussian(
                    mu.retract(&report.correction()),
                    &(joseph(self.cholesky_factor(), gain, &linear, &(noise + raised))
                        + moments.unexplained_through(gain)),
                    Produced {
                        mean: "the posterior mean mu ⊞ K nu",
                        covariance: "posterior covariance (I - K H) P (I - K H)^T + \
                                     K (R + Omega) K^T of the statistical linearisation H (it \
                                     lost positive definiteness; check R)",
                    },
                )?;
                let step = Conditioned {
                    posterior,
                    log_evidence,
                    report,
                };
                // The line the update was made with, `z ≈ ẑ + Ĥ δ`; what Ĥ leaves unexplained and
                // the sigma points' rounding are formed only when R alone cannot keep the update.
                let line = Line {
                    intercept: &moments.predicted,
                    slope: &linear,
                    noise: &(noise + raised),
                };
                check_linearisation(h, z, &line, &step, || {
                    (
                        moments.unexplained_spread(),
                        ukf.line_rounding(self, &moments, &linear, &step.report.correction()),
                    )
                })?;
                Ok(step)
            },
        )
    }
}

/// The unscented moments of a measurement model, the statistical linearisation a sigma-point
/// update is made of (the UKF's, and the iterated posterior linearisation's at each iterate).
#[derive(Clone, Copy, Debug)]
pub(crate) struct MeasurementMoments<const D: usize, const M: usize> {
    /// ẑ, the weighted mean of the `h(χᵢ)` (the fixed point with the model's residual as ⊟).
    pub(crate) predicted: SVector<f64, M>,
    /// `Σ wᵢᶜ rᵢ rᵢᵀ` plus the noise the caller passed, `rᵢ = h(χᵢ) ⊟ ẑ`.
    pub(crate) covariance: SMatrix<f64, M, M>,
    /// `Σ wᵢᶜ dᵢ rᵢᵀ`, dᵢ the sigma offsets.
    pub(crate) cross: SMatrix<f64, D, M>,
    /// What the linearisation `Ĥ = crossᵀ P⁻¹` leaves of the covariance, `covariance − Ĥ P Ĥᵀ`,
    /// is `noise + w₀ᶜ r₀ r₀ᵀ + (wᵢ/2) Σ cᵢ cᵢᵀ` with `cᵢ = rᵢ⁺ + rᵢ⁻` (the pairs'
    /// `rᵢ⁺ rᵢ⁺ᵀ + rᵢ⁻ rᵢ⁻ᵀ` split into that and `½ (rᵢ⁺ − rᵢ⁻)(rᵢ⁺ − rᵢ⁻)ᵀ`, whose weighted sum is
    /// `Ĥ P Ĥᵀ` because `2 wᵢ γ² = 1`): kept as its vectors r₀ and cᵢ (zero for a linear model),
    /// so that it is summed with no difference taken, in whatever space the caller needs it.
    centre: SVector<f64, M>,
    curved: [SVector<f64, M>; D],
    /// `w₀ᶜ` and `wᵢ / 2`.
    weights: (f64, f64),
    /// The largest |h(χ)| over the sigma points.
    size: f64,
}

impl<const D: usize, const M: usize> MeasurementMoments<D, M> {
    /// `Ω = w₀ᶜ r₀ r₀ᵀ + (wᵢ/2) Σ cᵢ cᵢᵀ`: the covariance less `Ĥ P Ĥᵀ` and less the noise the
    /// moments were given.
    pub(crate) fn unexplained(&self) -> SMatrix<f64, M, M> {
        self.unexplained_with(self.weights.0)
    }

    /// Ω with its centre's weight taken as `|w₀ᶜ|`: positive semi-definite for every scaling (w₀ᶜ
    /// is negative for α well below 1), the spread the linearisation check allows beside R.
    fn unexplained_spread(&self) -> SMatrix<f64, M, M> {
        self.unexplained_with(self.weights.0.abs())
    }

    /// `c r₀ r₀ᵀ + (wᵢ/2) Σ cᵢ cᵢᵀ`.
    fn unexplained_with(&self, centre: f64) -> SMatrix<f64, M, M> {
        let mut sum = self.centre * self.centre.transpose() * centre;
        for c in &self.curved {
            sum += c * c.transpose() * self.weights.1;
        }
        sum
    }

    /// `K Ω Kᵀ` for that Ω, as D × D outer products of the mapped vectors `K r₀` and `K cᵢ` (no
    /// M × M sum formed).
    fn unexplained_through(&self, gain: &SMatrix<f64, D, M>) -> SMatrix<f64, D, D> {
        let (centre, pair) = self.weights;
        let mapped = gain * self.centre;
        let mut sum = mapped * mapped.transpose() * centre;
        for c in &self.curved {
            let mapped = gain * c;
            sum += mapped * mapped.transpose() * pair;
        }
        sum
    }
}

impl<H, const M: usize> Ukf<H, M> {
    /// What the rounding of the sigma points can make the line `ẑ + Ĥ δ` miss by at the
    /// correction δ. Column j of `Ĥ S` (S the square root the points were spread by) is a
    /// difference of two images over 2γ, wrong by up to `(ε_h + |Ĥ|_F e) / γ`, with
    /// `ε_h = 64 M ε max |h(χ)|` the images' rounding and e the largest round-trip error
    /// `|(μ ⊞ sⱼ) ⊟ μ − sⱼ|` of a point's offset (D round trips); so `Ĥ δ = (Ĥ S)(S⁻¹ δ)` is wrong by
    /// up to `√D |L⁻¹ δ| (ε_h + |Ĥ|_F e) / γ`.
    fn line_rounding<X, const D: usize>(
        &self,
        prior: &ManifoldGaussian<X, D>,
        moments: &MeasurementMoments<D, M>,
        slope: &SMatrix<f64, M, D>,
        correction: &SVector<f64, D>,
    ) -> f64
    where
        X: Manifold<D, Scalar = f64>,
    {
        let gamma = self.weights(D).0;
        let mu = prior.mean();
        let resolution = sigma_offsets(prior, gamma, self.root)
            .iter()
            .map(|s| (mu.local(&mu.retract(s)) - s).norm())
            .fold(0.0, f64::max);
        let deviations = prior
            .cholesky_factor()
            .solve_lower_triangular_unchecked(correction)
            .norm();
        let images = 64.0 * M as f64 * f64::EPSILON * moments.size;
        (D as f64).sqrt() * deviations * (images + slope.norm() * resolution) / gamma
    }

    /// The moments of `h(μ ⊞ δ)` for `δ ~ N(c, P)`, μ and P the mean and covariance of `spread`
    /// and c the `centre` (zero, the UKF's case, when `None`): sigma points `μ ⊞ c` and
    /// `μ ⊞ (c ± γ sⱼ)`, the images checked finite, ẑ their [`weighted_mean`], and the covariance
    /// accumulated onto `noise` (R for an update, zero for a bare linearisation).
    ///
    /// # Errors
    /// [`OperatorError::NonFinitePoint`] for an image that is not finite, [`OperatorError::Manifold`]
    /// when their mean does not converge.
    pub(crate) fn measurement_moments<X, const D: usize>(
        &self,
        spread: &ManifoldGaussian<X, D>,
        centre: Option<&SVector<f64, D>>,
        noise: SMatrix<f64, M, M>,
    ) -> Result<MeasurementMoments<D, M>, OperatorError>
    where
        X: Manifold<D, Scalar = f64>,
        H: MeasurementModel<X, D, M>,
    {
        let (gamma, w0m, w0c, w) = self.weights(D);
        let offsets = sigma_offsets(spread, gamma, self.root);
        let (mu, h) = (spread.mean(), &self.model);
        let image = |v: SVector<f64, D>| {
            let offset = centre.map_or(v, |c| c + v);
            Measured::new(h.predict(&mu.retract(&offset)), h)
        };
        let centre_image = Measured::new(
            h.predict(&centre.map_or_else(|| mu.clone(), |c| mu.retract(c))),
            h,
        );
        let plus = offsets.map(image);
        let minus = offsets.map(|d| image(-d));
        if !(centre_image.is_finite() && plus.iter().chain(&minus).all(Manifold::is_finite)) {
            return Err(OperatorError::NonFinitePoint {
                what: "a sigma point's predicted measurement h(chi)",
            });
        }
        let predicted = weighted_mean(
            &centre_image,
            once((&centre_image, w0m)).chain(plus.iter().chain(&minus).map(|y| (y, w))),
            MeanSettings::default(),
        )
        .map_err(|source| OperatorError::Manifold {
            what: "the mean of the sigma points' predicted measurements",
            source,
        })?;
        let r0 = predicted.local(&centre_image);
        let mut covariance = r0 * r0.transpose() * w0c + noise;
        let mut cross = SMatrix::<f64, D, M>::zeros();
        let mut curved = [SVector::<f64, M>::zeros(); D];
        for ((d, (zp, zm)), c) in offsets.iter().zip(plus.iter().zip(&minus)).zip(&mut curved) {
            let (rp, rm) = (predicted.local(zp), predicted.local(zm));
            covariance += (rp * rp.transpose() + rm * rm.transpose()) * w;
            cross += d * (rp - rm).transpose() * w;
            *c = rp + rm;
        }
        let size = plus
            .iter()
            .chain(&minus)
            .map(|y| y.z.amax())
            .fold(centre_image.z.amax(), f64::max);
        Ok(MeasurementMoments {
            predicted: predicted.z,
            covariance,
            cross,
            centre: r0,
            curved,
            weights: (w0c, 0.5 * w),
            size,
        })
    }
}

/// A predicted measurement with the model's residual as its ⊟, `ẑ′ ⊟ ẑ = residual(ẑ′, ẑ)`, and
/// `ẑ ⊞ v = ẑ + v`: the measurement space as a manifold, so that the UKF's ẑ is the same
/// [`weighted_mean`] as its state mean.
struct Measured<'a, H, X, const D: usize, const M: usize> {
    z: SVector<f64, M>,
    model: &'a H,
    state: PhantomData<fn(&X)>,
}

impl<'a, H, X, const D: usize, const M: usize> Measured<'a, H, X, D, M> {
    fn new(z: SVector<f64, M>, model: &'a H) -> Self {
        Self {
            z,
            model,
            state: PhantomData,
        }
    }
}

impl<H, X, const D: usize, const M: usize> Clone for Measured<'_, H, X, D, M> {
    fn clone(&self) -> Self {
        Self::new(self.z, self.model)
    }
}

impl<H, X, const D: usize, const M: usize> fmt::Debug for Measured<'_, H, X, D, M> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("Measured").field(&self.z).finish()
    }
}

impl<H, X, const D: usize, const M: usize> Manifold<M> for Measured<'_, H, X, D, M>
where
    X: Manifold<D, Scalar = f64>,
    H: MeasurementModel<X, D, M>,
{
    type Scalar = f64;

    fn retract(&self, v: &SVector<f64, M>) -> Self {
        Self::new(self.z + v, self.model)
    }

    fn local(&self, other: &Self) -> SVector<f64, M> {
        self.model.residual(&other.z, &self.z)
    }

    fn is_finite(&self) -> bool {
        self.z.iter().all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `S Sᵀ = P` for the principal axes of well and badly conditioned, diagonal and full P.
    #[test]
    fn principal_axes_are_a_square_root() {
        let cases = [
            SMatrix::<f64, 3, 3>::new(4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 2.0),
            SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::new(1e-12, 1.0, 1e6)),
            SMatrix::<f64, 3, 3>::new(1.0, 0.999_999, 0.0, 0.999_999, 1.0, 0.0, 0.0, 0.0, 1e-8),
        ];
        for p in cases {
            let s = principal_axes(&p);
            let error = (s * s.transpose() - p).abs().max();
            assert!(error <= 1e-14 * p.abs().max(), "{p}: error {error}");
            // The columns are orthogonal: principal axes.
            let gram = s.transpose() * s;
            for i in 0..3 {
                for j in 0..3 {
                    if i != j {
                        assert!(gram[(i, j)].abs() <= 1e-12 * p.abs().max());
                    }
                }
            }
        }
    }
}
