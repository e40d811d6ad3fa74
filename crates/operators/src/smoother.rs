//! The Rauch-Tung-Striebel smoother for the Gaussian on a manifold: the densities of the states given
//! every measurement, past and future, from one forward filtering pass and one backward pass.
//!
//! **Forward.** [`RtsSmoother`] takes the filter's steps, in the Propagate/Condition style, and
//! records for each epoch k the filtered density `N(μ_f,k, P_f,k)`, and for each transition
//! `k → k+1` the predicted density `N(μ_p,k+1, P_p,k+1)`, the cross-covariance
//! `C_k = Cov(δ_k, δ_k+1)` of the linearisation and the noise `Ω_k` it does not explain
//! ([`GaussianTransition`]): `C_k = P_f,k F_kᵀ` and `Ω_k = Q_k` for the EKF (F_k the right Jacobian
//! of the motion at μ_f,k), and for the UKF `C_k = Σ wᵢᶜ dᵢ (Yᵢ ⊟ μ_p,k+1)ᵀ` (the statistical
//! linearisation of the unscented transform, Särkkä's unscented RTS smoother) and `Ω_k` its
//! residual, `P_p,k+1 − F̂_k P_f,k F̂_kᵀ` with `F̂_k = C_kᵀ P_f,k⁻¹`.
//!
//! **Backward** ([`RtsSmoother::smooth`]), from the last filtered density, for k = K−1 down to 0:
//!
//! * gain `G_k = C_k P_p,k+1⁻¹` (by the Cholesky factor of P_p,k+1, never inverted; for the EKF
//!   `G_k = P_f,k F_kᵀ P_p,k+1⁻¹`);
//! * mean `μ_s,k = μ_f,k ⊞ G_k (μ_s,k+1 ⊟ μ_p,k+1)`;
//! * covariance in Joseph's form, `P_s,k = A_k P_f,k A_kᵀ + G_k (Ω_k + P_s,k+1) G_kᵀ` with
//!   `A_k = I − G_k F̂_k` and `F̂_k = C_kᵀ P_f,k⁻¹` (the EKF's F_k), summed as the Gram matrices of
//!   `A_k L_f,k = L_f,k − G_k (L_f,k⁻¹ C_k)ᵀ` (one triangular solve with the Cholesky factor of
//!   P_f,k) and of `G_k` times a factor of `Ω_k + P_s,k+1`.
//!   It equals the textbook `P_f,k + G_k (P_s,k+1 − P_p,k+1) G_kᵀ` in exact arithmetic, but sums
//!   positive semi-definite terms where the textbook form subtracts: that difference cancels when
//!   the process noise and the later information are below ε of P_f,k (a diffuse prior of 1e17
//!   with unit noises smoothed to 32 where 5/3 is exact, and to 1.875 at 1e15), and Joseph's form
//!   gives 5/3 at every prior up to the densities' limit. When that sum is singular to its
//!   rounding (a diffuse prior, or a singular Q such as a constant-velocity model's `Γ Γᵀ σ²`,
//!   leaves variances below the rounding of its largest), the step is made once more with
//!   `64 D ε max |P_s,kᵢᵢ| I` added, as the filters' steps are: the smoothed covariance is then
//!   slightly wider than the exact one.
//!
//! On Rⁿ with a linear model this is the classical RTS smoother, equal to the batch least-squares
//! solution (the tests check it to 1e-9). On a manifold it is the error-state smoother of the EKF:
//! `μ_s,k+1 ⊟ μ_p,k+1` is a tangent vector at μ_p,k+1, mapped by G_k into the tangent space at μ_f,k;
//! P_s,k+1 lives in the tangent space at μ_s,k+1 and P_p,k+1 in that at μ_p,k+1, and their difference
//! is taken without transporting one to the other. The omitted parallel transport (as in the EKF's
//! update, see [`ekf`](crate::ekf)) is of first order in `|μ_s,k+1 ⊟ μ_p,k+1|` times the curvature;
//! on Rⁿ and SO(2) it is exactly zero. The smoother inherits the linearisation error of the filter
//! that recorded it.
//!
//! Per step the recorder pushes one record (amortised allocation of its two vectors, none with
//! [`RtsSmoother::with_capacity`]); the backward pass allocates its result once.

use crate::error::{all_finite, check_size, reserve, with_capacity};
use crate::kalman::joseph_from_spread;
use crate::numerics::{Produced, checked_gaussian_above_rounding, cholesky_solve};
use crate::{Condition, Conditioned, OperatorError};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::SMatrix;
use std::collections::VecDeque;

/// A Gaussian prediction `x′ ~ N(μ′, P′)` with what the smoother needs of the transition: the
/// cross-covariance `C = Cov(δ, δ′)` of the state before (tangent at the prior mean) and after
/// (tangent at μ′), and the noise Ω that the linearisation `δ′ ≈ F̂ δ`, `F̂ = Cᵀ P⁻¹`, leaves:
/// `P′ = F̂ P F̂ᵀ + Ω`.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction<X, const D: usize> {
    /// `N(μ′, P′)`.
    pub density: ManifoldGaussian<X, D>,
    /// `C = Cov(δ, δ′)`: `P Fᵀ` for the EKF, the sigma-point cross-covariance for the UKF.
    pub cross_covariance: SMatrix<f64, D, D>,
    /// `Ω = P′ − F̂ P F̂ᵀ`, recorded as it was summed rather than as that difference (which
    /// cancels): the process noise Q for the EKF; for the UKF, Q plus the sigma points' spread
    /// that no linear map explains, `w₀ᶜ e₀ e₀ᵀ + (wᵢ/2) Σ (eᵢ⁺ + eᵢ⁻)(eᵢ⁺ + eᵢ⁻)ᵀ`.
    pub noise: SMatrix<f64, D, D>,
}

/// A Gaussian filter's prediction step with its cross-covariance: [`Ekf`](crate::Ekf) and
/// [`Ukf`](crate::Ukf) of a [`ProcessModel`](crate::ProcessModel). Their
/// [`Propagate`](crate::Propagate) is this step without the cross-covariance.
pub trait GaussianTransition<X: Manifold<D, Scalar = f64>, const D: usize> {
    /// What drives the process.
    type Input;

    /// The predicted density and `Cov(δ, δ′)`.
    ///
    /// # Errors
    /// As the filter's propagation: a predicted covariance that is not positive definite.
    fn predict_with_cross(
        &self,
        prior: &ManifoldGaussian<X, D>,
        input: &Self::Input,
    ) -> Result<Prediction<X, D>, OperatorError>;
}

/// What a smoother names when its record cannot grow.
const RECORDS: &str = "number of smoother records";

/// One step of the backward pass: the smoothed density of epoch k from the filtered density of
/// epoch k, the transition `k → k+1` recorded from it, and the smoothed density of epoch k+1
/// (see the module docs for the formulas).
///
/// # Errors
/// [`OperatorError::NotPositiveDefinite`] when the smoothed covariance is not positive definite,
/// also once raised to its rounding (a transition whose noise Ω is not positive semi-definite, or
/// filtered covariances ill-conditioned far beyond 1/ε),
/// [`OperatorError::NonFinitePoint`] for a smoothed mean that is not finite.
pub(crate) fn smooth_back<X: Manifold<D, Scalar = f64>, const D: usize>(
    filtered: &ManifoldGaussian<X, D>,
    transition: &Prediction<X, D>,
    next: &ManifoldGaussian<X, D>,
) -> Result<ManifoldGaussian<X, D>, OperatorError> {
    let predicted = &transition.density;
    let cross = &transition.cross_covariance;
    // Gᵀ = P_p⁻¹ Cᵀ and F̂ = Cᵀ P_f⁻¹ by the two densities' Cholesky factors.
    let gain = cholesky_solve(predicted.cholesky_factor(), &cross.transpose()).transpose();
    let mean = filtered
        .mean()
        .retract(&(gain * predicted.mean().local(next.mean())));
    // `A_k L_f = L_f − G F̂ L_f` with `F̂ L_f = Cᵀ L_f⁻ᵀ = (L_f⁻¹ C)ᵀ`: one triangular solve, and
    // no product by `I − G F̂`.
    let factor = filtered.cholesky_factor();
    let spread = factor - gain * factor.solve_lower_triangular_unchecked(cross).transpose();
    let covariance = joseph_from_spread(&spread, &gain, &(transition.noise + next.covariance()));
    // A sum of positive semi-definite terms when Ω is: a covariance that fails is singular to
    // its rounding, or Ω is not positive semi-definite (and the floor does not rescue it).
    checked_gaussian_above_rounding(
        &mean,
        &covariance,
        Produced {
            mean: "the smoothed mean mu_f ⊞ G (mu_s ⊟ mu_p)",
            covariance: "smoothed covariance A P_f A^T + G (Omega + P_s) G^T (a recorded \
                         transition noise Omega that is not positive semi-definite, or filtered \
                         covariances too ill-conditioned for f64)",
        },
    )
    .map(|(density, _)| density)
}

/// Checks a record read back (a checkpoint): one more filtered density than transitions, at most
/// [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) of them, every cross-covariance and noise finite.
pub(crate) fn check_records<X, const D: usize>(
    filtered: &[ManifoldGaussian<X, D>],
    transitions: &[Prediction<X, D>],
) -> Result<(), OperatorError> {
    check_size(RECORDS, transitions.len())?;
    if filtered.len() != transitions.len() + 1 {
        return Err(OperatorError::OutOfRange {
            what: "number of filtered densities of a smoother record",
            value: filtered.len() as f64,
            range: "one more than the number of transitions",
        });
    }
    for t in transitions {
        all_finite(
            "cross-covariance of a smoother record",
            t.cross_covariance.iter(),
        )?;
        all_finite("transition noise of a smoother record", t.noise.iter())?;
    }
    Ok(())
}

/// The forward pass of the RTS smoother: a Gaussian filter on a manifold that records what the
/// backward pass needs (see the module docs for the math).
///
/// # Example
/// A heading with a gyroscope and a compass, smoothed:
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::manifolds::{Manifold, So2};
/// use liebayes_operators::smoother::RtsSmoother;
/// use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// let gyro = ProcessFn::new(
///     |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
///     |_, _| Matrix1::new(1e-3),
/// );
/// let compass = MeasurementFn::new(|x: &So2<f64>| Vector1::new(x.angle()), |_| Matrix1::new(0.01));
/// let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(1.0)).unwrap();
/// let mut rts = RtsSmoother::with_capacity(prior, 3).unwrap();
/// for (rate, reading) in [(0.1, 0.12), (0.1, 0.19), (0.1, 0.33)] {
///     rts.propagate(&Ekf(&gyro), &rate).unwrap();
///     let step = rts.condition(&Ekf(&compass), &Vector1::new(reading)).unwrap();
///     assert!(step.report.nis() < 10.0);
/// }
/// let smoothed = rts.smooth().unwrap();
/// assert_eq!(smoothed.len(), 4); // the prior's epoch and three steps
/// // The first epoch has seen every reading: far tighter than its prior.
/// assert!(smoothed[0].covariance()[0] < 0.1);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RtsSmoother<X, const D: usize> {
    /// The filtered density of every epoch so far; the last is the current one.
    filtered: Vec<ManifoldGaussian<X, D>>,
    /// `transitions[k]` leads from epoch k to epoch k + 1.
    transitions: Vec<Prediction<X, D>>,
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> RtsSmoother<X, D> {
    /// The recorder at epoch 0, holding the prior.
    pub fn new(prior: ManifoldGaussian<X, D>) -> Self {
        Self {
            filtered: vec![prior],
            transitions: Vec::new(),
        }
    }

    /// The recorder with room for `steps` propagations reserved, so that recording them allocates
    /// nothing.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] for more than [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) steps or
    /// when their records cannot be allocated.
    pub fn with_capacity(
        prior: ManifoldGaussian<X, D>,
        steps: usize,
    ) -> Result<Self, OperatorError> {
        check_size(RECORDS, steps)?;
        let mut filtered = with_capacity(RECORDS, steps + 1)?;
        filtered.push(prior);
        Ok(Self {
            filtered,
            transitions: with_capacity(RECORDS, steps)?,
        })
    }

    /// The recorder from a record read back (a checkpoint): the filtered density of every epoch
    /// and the transitions between them, as [`filtered`](Self::filtered) and
    /// [`transitions`](Self::transitions) gave them. Continuing it continues the recorded run bit
    /// for bit.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] unless there is exactly one more filtered density than
    /// transitions, [`OperatorError::NonFinite`] for a cross-covariance or noise entry that is not
    /// finite, [`OperatorError::TooLarge`] for more than [`MAX_ELEMENTS`](crate::MAX_ELEMENTS)
    /// transitions.
    /// (The densities are valid by their own constructors.)
    pub fn from_records(
        filtered: Vec<ManifoldGaussian<X, D>>,
        transitions: Vec<Prediction<X, D>>,
    ) -> Result<Self, OperatorError> {
        check_records(&filtered, &transitions)?;
        Ok(Self {
            filtered,
            transitions,
        })
    }

    /// The current filtered density (the last epoch's).
    ///
    /// # Panics
    /// Never: the recorder holds at least the prior's epoch.
    pub fn current(&self) -> &ManifoldGaussian<X, D> {
        self.filtered
            .last()
            .expect("the prior's epoch is never removed")
    }

    /// The filtered densities, one per epoch (epoch 0 the prior, then one per propagation).
    pub fn filtered(&self) -> &[ManifoldGaussian<X, D>] {
        &self.filtered
    }

    /// The recorded transitions: `transitions()[k]` leads from epoch k to epoch k + 1 (the
    /// predicted density of epoch k + 1 and the cross-covariance).
    pub fn transitions(&self) -> &[Prediction<X, D>] {
        &self.transitions
    }

    /// Propagates the current density to a new epoch with a Gaussian filter's prediction
    /// (`&Ekf(&model)` or `&Ukf::new(&model)`), recording the prediction and its cross-covariance.
    ///
    /// # Errors
    /// The prediction's, or [`OperatorError::TooLarge`] when the record is full
    /// ([`MAX_ELEMENTS`](crate::MAX_ELEMENTS) epochs) or cannot grow; the recorder is then unchanged.
    pub fn propagate<W>(&mut self, model: &W, input: &W::Input) -> Result<(), OperatorError>
    where
        W: GaussianTransition<X, D>,
    {
        let step = model.predict_with_cross(self.current(), input)?;
        reserve(&mut self.filtered, RECORDS, 1)?;
        reserve(&mut self.transitions, RECORDS, 1)?;
        self.filtered.push(step.density.clone());
        self.transitions.push(step);
        Ok(())
    }

    /// Conditions the current epoch's density on a measurement (any model the density conditions
    /// with, `&Ekf(&model)` or `&Ukf::new(&model)`; several measurements per epoch are allowed).
    /// Returns the step with the new current density, its log evidence and the filter's report.
    ///
    /// # Errors
    /// The conditioning's; the recorder is then unchanged.
    pub fn condition<M, Z, R>(
        &mut self,
        model: &M,
        z: &Z,
    ) -> Result<Conditioned<&ManifoldGaussian<X, D>, R>, OperatorError>
    where
        Z: ?Sized,
        ManifoldGaussian<X, D>: Condition<M, Measurement = Z, Report = R>,
    {
        let step = self.current().condition(model, z)?;
        let last = self.filtered.len() - 1;
        self.filtered[last] = step.posterior;
        Ok(Conditioned {
            posterior: &self.filtered[last],
            log_evidence: step.log_evidence,
            report: step.report,
        })
    }

    /// The backward pass: the smoothed density of every epoch, in order (the last equals the last
    /// filtered density).
    ///
    /// # Errors
    /// [`OperatorError::NotPositiveDefinite`] when a smoothed covariance is not positive definite
    /// (a recorded transition noise that is not positive semi-definite, or filtered covariances
    /// ill-conditioned far beyond 1/ε).
    pub fn smooth(&self) -> Result<Vec<ManifoldGaussian<X, D>>, OperatorError> {
        smooth_records(&self.filtered, &self.transitions)
    }
}

/// The backward pass over a record kept by a filter of its own (a filter whose state is more than
/// the Gaussian, such as one that must undo a failed step, keeps the densities the forward pass of
/// [`RtsSmoother`] would have kept): `filtered[k]` the filtered density of epoch k,
/// `transitions[k]` the transition from epoch k to k + 1 recorded from it. Returns the smoothed
/// density of every epoch, in order (the last equals the last filtered density).
///
/// # Errors
/// [`OperatorError::OutOfRange`] unless there is exactly one more filtered density than
/// transitions, [`OperatorError::NonFinite`] for a cross-covariance or noise entry that is not
/// finite; otherwise as [`RtsSmoother::smooth`].
pub fn smooth_records<X: Manifold<D, Scalar = f64>, const D: usize>(
    filtered: &[ManifoldGaussian<X, D>],
    transitions: &[Prediction<X, D>],
) -> Result<Vec<ManifoldGaussian<X, D>>, OperatorError> {
    check_records(filtered, transitions)?;
    let Some((last, earlier)) = filtered.split_last() else {
        return Ok(Vec::new());
    };
    // Filled from the back, each density written once: with room for exactly every epoch the
    // queue ends where its buffer starts, and becomes the vector without a copy.
    let mut smoothed = VecDeque::new();
    smoothed
        .try_reserve_exact(filtered.len())
        .map_err(|_| OperatorError::TooLarge {
            what: RECORDS,
            value: filtered.len(),
            max: crate::MAX_ELEMENTS,
        })?;
    smoothed.push_front(last.clone());
    for (filtered, transition) in earlier.iter().zip(transitions).rev() {
        let previous = smooth_back(filtered, transition, &smoothed[0])?;
        smoothed.push_front(previous);
    }
    Ok(Vec::from(smoothed))
}
