//! The fixed-lag smoother for the Gaussian on a manifold: online, after each epoch k, the density
//! of epoch k − L given the measurements up to epoch k, in memory bounded by the lag L.
//!
//! [`FixedLagSmoother`] records the filter's steps as [`RtsSmoother`](crate::smoother::RtsSmoother)
//! does (the filtered density of each epoch, the predicted density and cross-covariance of each
//! transition, through [`GaussianTransition`]), but keeps only the last L + 1 epochs, in ring
//! buffers reserved when it is built: once they are full a step evicts the oldest epoch and
//! allocates nothing. [`FixedLagSmoother::smooth`] runs the RTS backward pass over the window,
//! from the current filtered density down to epoch k − L:
//!
//! `G_j = C_j P_p,j+1⁻¹`, `μ_s,j = μ_f,j ⊞ G_j (μ_s,j+1 ⊟ μ_p,j+1)`,
//! `P_s,j = P_f,j + G_j (P_s,j+1 − P_p,j+1) G_jᵀ`, for j = k − 1 down to max(k − L, 0).
//!
//! The RTS recursion for epoch j given the measurements up to k uses only the filtered densities
//! of epochs j … k and the transitions between them: so the window's smoothed densities are
//! exactly those of the RTS smoother run on the measurements up to k (the same operations in the
//! same order; the tests check it to 1e-9 on Rⁿ and on SO(3)), and on Rⁿ with linear models they are
//! the exact fixed-lag posteriors. A pass costs L backward steps (a D × D Cholesky solve and a few
//! D × D products each): O(L D³) per epoch, against O((L D)³) for the augmented-state form.

use crate::error::{check_size, with_capacity};
use crate::smoother::{GaussianTransition, Prediction, check_records, smooth_back};
use crate::{Condition, Conditioned, OperatorError};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use std::collections::VecDeque;

/// What a fixed-lag smoother names when its window cannot be allocated.
const WINDOW: &str = "fixed-lag smoother window (lag + 1 epochs)";

/// A ratio of lag to step within this relative distance of an integer is that integer (so that a
/// lag of 0.3 s at 0.1 s per step is 3 epochs, whatever the rounding of 0.3 / 0.1).
const WHOLE_EPOCHS: f64 = 1e-9;

/// The largest epoch index a fixed-lag smoother counts to: 2⁵³, so that every epoch is exact as an
/// `f64` too (at a million epochs a second, 285 years of them).
pub const MAX_EPOCH: u64 = 1 << 53;

/// [`OperatorError::OutOfRange`] for an epoch past [`MAX_EPOCH`].
fn check_epoch(epoch: u64) -> Result<(), OperatorError> {
    if epoch > MAX_EPOCH {
        return Err(OperatorError::OutOfRange {
            what: "epoch of a fixed-lag smoother",
            value: epoch as f64,
            range: "0 to 2^53",
        });
    }
    Ok(())
}

/// The fixed-lag smoother: a Gaussian filter on a manifold that keeps the last L + 1 epochs of
/// its record and smooths them on request (see the module docs for the math).
///
/// # Example
/// A heading with a gyroscope and a compass, smoothed two epochs behind:
/// ```
/// use liebayes_operators::densities::ManifoldGaussian;
/// use liebayes_operators::fixed_lag::FixedLagSmoother;
/// use liebayes_operators::manifolds::{Manifold, So2};
/// use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
/// use nalgebra::{Matrix1, Vector1};
///
/// let gyro = ProcessFn::new(
///     |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
///     |_, _| Matrix1::new(1e-3),
/// );
/// let compass = MeasurementFn::new(|x: &So2<f64>| Vector1::new(x.angle()), |_| Matrix1::new(0.01));
/// let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(1.0)).unwrap();
/// let mut smoother = FixedLagSmoother::new(prior, 2).unwrap();
/// for (rate, reading) in [(0.1, 0.12), (0.1, 0.19), (0.1, 0.33)] {
///     smoother.propagate(&Ekf(&gyro), &rate).unwrap();
///     smoother.condition(&Ekf(&compass), &Vector1::new(reading)).unwrap();
/// }
/// assert_eq!(smoother.epoch(), 3);
/// let window = smoother.smooth().unwrap();
/// // Epochs 1, 2 and 3 are in the window; epoch 1 has seen the readings of epochs 2 and 3.
/// assert_eq!(window.first_epoch(), 1);
/// let lagged = window.lagged().unwrap();
/// assert!(lagged.covariance()[0] < smoother.filtered(1).unwrap().covariance()[0]);
/// ```
#[derive(Clone, Debug)]
pub struct FixedLagSmoother<X, const D: usize> {
    /// L.
    lag: usize,
    /// The index of the current epoch (0: the prior's).
    epoch: u64,
    /// The filtered densities of the epochs in the window, oldest first; the last is the current.
    filtered: VecDeque<ManifoldGaussian<X, D>>,
    /// `transitions[j]` leads from `filtered[j]` to `filtered[j + 1]`.
    transitions: VecDeque<Prediction<X, D>>,
    /// The last backward pass's result (a buffer; refilled by every [`smooth`](Self::smooth)).
    smoothed: VecDeque<ManifoldGaussian<X, D>>,
}

/// Two smoothers are equal when their states are: the lag, the epoch, the window's filtered
/// densities and transitions. The buffer of the last [`smooth`](FixedLagSmoother::smooth) is
/// scratch space, not state: a smoothing, failed or not, leaves a smoother equal to itself before.
impl<X, const D: usize> PartialEq for FixedLagSmoother<X, D>
where
    ManifoldGaussian<X, D>: PartialEq,
    Prediction<X, D>: PartialEq,
{
    fn eq(&self, other: &Self) -> bool {
        self.lag == other.lag
            && self.epoch == other.epoch
            && self.filtered == other.filtered
            && self.transitions == other.transitions
    }
}

/// The smoothed densities of the window, from [`FixedLagSmoother::smooth`]: epoch
/// [`first_epoch`](Self::first_epoch) up to the current one, each given every measurement up to the
/// current epoch.
#[derive(Clone, Copy, Debug)]
pub struct Window<'a, X, const D: usize> {
    first: u64,
    lag: usize,
    densities: &'a VecDeque<ManifoldGaussian<X, D>>,
}

impl<'a, X, const D: usize> Window<'a, X, D> {
    /// The oldest epoch of the window: `max(k − L, 0)` at epoch k.
    pub fn first_epoch(&self) -> u64 {
        self.first
    }

    /// The number of epochs in the window: `min(k, L) + 1`.
    pub fn len(&self) -> usize {
        self.densities.len()
    }

    /// Never true: the window holds at least the current epoch.
    pub fn is_empty(&self) -> bool {
        self.densities.is_empty()
    }

    /// The smoothed density of `epoch`, if it is in the window.
    pub fn get(&self, epoch: u64) -> Option<&'a ManifoldGaussian<X, D>> {
        let offset = usize::try_from(epoch.checked_sub(self.first)?).ok()?;
        self.densities.get(offset)
    }

    /// The smoothed density of epoch k − L, the smoother's output at lag L; `None` before epoch L.
    pub fn lagged(&self) -> Option<&'a ManifoldGaussian<X, D>> {
        (self.densities.len() == self.lag + 1)
            .then(|| self.densities.front())
            .flatten()
    }

    /// The smoothed densities, oldest first.
    pub fn iter(&self) -> std::collections::vec_deque::Iter<'a, ManifoldGaussian<X, D>> {
        self.densities.iter()
    }
}

impl<'a, X, const D: usize> IntoIterator for &Window<'a, X, D> {
    type Item = &'a ManifoldGaussian<X, D>;
    type IntoIter = std::collections::vec_deque::Iter<'a, ManifoldGaussian<X, D>>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> FixedLagSmoother<X, D> {
    /// The smoother at epoch 0, holding the prior, with lag `lag` epochs: its three ring buffers
    /// of `lag + 1` densities are allocated here, and no step allocates after.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] for a lag of [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) epochs or
    /// more, or when the window cannot be allocated.
    pub fn new(prior: ManifoldGaussian<X, D>, lag: usize) -> Result<Self, OperatorError> {
        let mut smoother = Self::empty(lag)?;
        smoother.filtered.push_back(prior);
        Ok(smoother)
    }

    /// The smoother with a lag of at least `lag_seconds` for epochs `step_seconds` apart:
    /// `L = ⌈lag / step⌉` epochs (a ratio within 1e-9, relative, of an integer is that integer).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a lag or step that is not finite,
    /// [`OperatorError::OutOfRange`] for a negative lag or a step that is not positive,
    /// [`OperatorError::TooLarge`] for a lag of [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) epochs or
    /// more.
    pub fn with_lag_seconds(
        prior: ManifoldGaussian<X, D>,
        lag_seconds: f64,
        step_seconds: f64,
    ) -> Result<Self, OperatorError> {
        for (what, value) in [
            ("fixed-lag smoother lag (s)", lag_seconds),
            ("fixed-lag smoother step (s)", step_seconds),
        ] {
            if !value.is_finite() {
                return Err(OperatorError::NonFinite { what, value });
            }
        }
        if lag_seconds < 0.0 || step_seconds <= 0.0 {
            return Err(OperatorError::OutOfRange {
                what: "fixed-lag smoother lag and step (s)",
                value: lag_seconds.min(step_seconds),
                range: "lag >= 0 and step > 0",
            });
        }
        let ratio = lag_seconds / step_seconds;
        let nearest = ratio.round();
        let epochs = if (ratio - nearest).abs() <= WHOLE_EPOCHS * nearest.max(1.0) {
            nearest
        } else {
            ratio.ceil()
        };
        if epochs >= crate::MAX_ELEMENTS as f64 {
            return Err(OperatorError::TooLarge {
                what: WINDOW,
                value: usize::MAX,
                max: crate::MAX_ELEMENTS,
            });
        }
        // In [0, 2³⁰): the conversion is exact.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Self::new(prior, epochs as usize)
    }

    /// The smoother from a record read back (a checkpoint): its lag, its current epoch, and the
    /// filtered densities and transitions of its window, as [`lag`](Self::lag),
    /// [`epoch`](Self::epoch), [`window_filtered`](Self::window_filtered) and
    /// [`window_transitions`](Self::window_transitions) gave them. Continuing it continues the
    /// recorded run bit for bit.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for an epoch past [`MAX_EPOCH`] or unless the window holds
    /// `min(epoch, lag) + 1` filtered densities and one transition fewer,
    /// [`OperatorError::NonFinite`] for a cross-covariance or noise entry that is not finite,
    /// [`OperatorError::TooLarge`] as [`new`](Self::new).
    pub fn from_records(
        lag: usize,
        epoch: u64,
        filtered: Vec<ManifoldGaussian<X, D>>,
        transitions: Vec<Prediction<X, D>>,
    ) -> Result<Self, OperatorError> {
        check_records(&filtered, &transitions)?;
        check_epoch(epoch)?;
        let expected = epoch.min(lag as u64).saturating_add(1);
        if filtered.len() as u64 != expected {
            return Err(OperatorError::OutOfRange {
                what: "number of filtered densities in a fixed-lag smoother's window",
                value: filtered.len() as f64,
                range: "min(epoch, lag) + 1",
            });
        }
        let mut smoother = Self::empty(lag)?;
        smoother.epoch = epoch;
        smoother.filtered.extend(filtered);
        smoother.transitions.extend(transitions);
        Ok(smoother)
    }

    /// The smoother of lag `lag` with its buffers allocated and nothing in them.
    fn empty(lag: usize) -> Result<Self, OperatorError> {
        check_size(WINDOW, lag.saturating_add(1))?;
        let ring = || -> Result<VecDeque<_>, OperatorError> {
            Ok(VecDeque::from(with_capacity(WINDOW, lag + 1)?))
        };
        Ok(Self {
            lag,
            epoch: 0,
            filtered: ring()?,
            transitions: VecDeque::from(with_capacity(WINDOW, lag)?),
            smoothed: ring()?,
        })
    }

    /// The lag L (epochs).
    pub fn lag(&self) -> usize {
        self.lag
    }

    /// The index of the current epoch (0 for the prior's, then one more per propagation).
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// The current filtered density.
    ///
    /// # Panics
    /// Never: the window holds at least the current epoch.
    pub fn current(&self) -> &ManifoldGaussian<X, D> {
        self.filtered
            .back()
            .expect("the current epoch is never evicted")
    }

    /// The filtered density of `epoch`, if it is in the window.
    pub fn filtered(&self, epoch: u64) -> Option<&ManifoldGaussian<X, D>> {
        let first = self.epoch - (self.filtered.len() as u64 - 1);
        let offset = usize::try_from(epoch.checked_sub(first)?).ok()?;
        self.filtered.get(offset)
    }

    /// The filtered densities of the window, oldest first (what a checkpoint saves).
    pub fn window_filtered(&self) -> &VecDeque<ManifoldGaussian<X, D>> {
        &self.filtered
    }

    /// The transitions of the window, oldest first: the j-th leads from the j-th filtered density
    /// of the window to the next (what a checkpoint saves).
    pub fn window_transitions(&self) -> &VecDeque<Prediction<X, D>> {
        &self.transitions
    }

    /// Propagates the current density to a new epoch with a Gaussian filter's prediction
    /// (`&Ekf(&model)` or `&Ukf::new(&model)`), recording the prediction and its cross-covariance,
    /// and evicting the oldest epoch once the window holds L + 1.
    ///
    /// # Errors
    /// The prediction's, and [`OperatorError::OutOfRange`] past epoch [`MAX_EPOCH`]; the smoother
    /// is then unchanged.
    pub fn propagate<W>(&mut self, model: &W, input: &W::Input) -> Result<(), OperatorError>
    where
        W: GaussianTransition<X, D>,
    {
        check_epoch(self.epoch + 1)?;
        let step = model.predict_with_cross(self.current(), input)?;
        if self.filtered.len() > self.lag {
            self.filtered.pop_front();
            if self.lag > 0 {
                self.transitions.pop_front();
            }
        }
        self.filtered.push_back(step.density.clone());
        if self.lag > 0 {
            self.transitions.push_back(step);
        }
        self.epoch += 1;
        Ok(())
    }

    /// Conditions the current epoch's density on a measurement (any model the density conditions
    /// with; several measurements per epoch are allowed). Returns the step with the new current
    /// density, its log evidence and the filter's report.
    ///
    /// # Errors
    /// The conditioning's; the smoother is then unchanged.
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

    /// The backward pass over the window: the smoothed density of every epoch in it given the
    /// measurements up to the current epoch (the current one is its filtered density). Allocates
    /// nothing: the result is written into the smoother's own buffer and borrowed.
    ///
    /// # Errors
    /// [`OperatorError::NotPositiveDefinite`] when a smoothed covariance is not positive definite
    /// (a recorded transition noise that is not positive semi-definite, or filtered covariances
    /// ill-conditioned far beyond 1/ε); the smoother's state is unchanged.
    pub fn smooth(&mut self) -> Result<Window<'_, X, D>, OperatorError> {
        self.smoothed.clear();
        self.smoothed.push_front(self.current().clone());
        let back = self.filtered.iter().rev().skip(1);
        for (filtered, transition) in back.zip(self.transitions.iter().rev()) {
            match smooth_back(filtered, transition, &self.smoothed[0]) {
                Ok(previous) => self.smoothed.push_front(previous),
                Err(error) => {
                    // No partial window is left behind.
                    self.smoothed.clear();
                    return Err(error);
                }
            }
        }
        Ok(Window {
            first: self.epoch - (self.smoothed.len() as u64 - 1),
            lag: self.lag,
            densities: &self.smoothed,
        })
    }
}
