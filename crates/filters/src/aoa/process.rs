//! [`RandomWalk`]: the filters' motion model, the paper's equation (13).

use super::model::Position;
use liebayes_operators::particle::{SampledProcess, finite_point};
use liebayes_operators::{OperatorError, ProcessModel};
use nalgebra::{Matrix3, Vector3};
use rand::RngCore;
use rand_distr::{Distribution, StandardNormal};

/// The largest process noise parameter (m/√s).
pub const Q_LIMIT: f64 = 1e6;

/// The smallest nonzero process noise parameter (m/√s): q² = 1e-200, so that a step's variance
/// `δ q²` stays a normal number for every track step δ ≥ [`DELTA_MIN`] (a smaller q squared to a
/// subnormal or to 0, a process noise no step can tell from none; q = 0 itself is accepted).
pub const Q_MIN: f64 = 1e-100;

/// The largest time step (s).
pub const DELTA_LIMIT: f64 = 1e6;

/// The smallest time step δ of a track's settings (s): a rate of 1 MHz, the smallest IMU step of
/// the inertial and attitude filters too.
pub const DELTA_MIN: f64 = 1e-6;

/// `θₖ = θₖ₋₁ + w`, `w ~ N(0, δ diag(q_xy², q_xy², q_z²))` over a time step δ (the input, s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RandomWalk {
    q_xy: f64,
    q_z: f64,
}

impl RandomWalk {
    /// The walk with horizontal and vertical noise parameters q_xy, q_z each 0 (no noise on that
    /// axis) or in [[`Q_MIN`], [`Q_LIMIT`]] = [1e-100, 1e6] m/√s.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] (NaN included), naming the parameter.
    pub fn new(q_xy: f64, q_z: f64) -> Result<Self, OperatorError> {
        for (what, value) in [
            ("horizontal process noise q_xy (m/sqrt(s))", q_xy),
            ("vertical process noise q_z (m/sqrt(s))", q_z),
        ] {
            if !(value == 0.0 || (Q_MIN..=Q_LIMIT).contains(&value)) {
                return Err(OperatorError::OutOfRange {
                    what,
                    value,
                    range: "0 or [1e-100, 1e6] (a smaller q squares to a variance that underflows)",
                });
            }
        }
        Ok(Self { q_xy, q_z })
    }

    /// `(q_xy, q_z)`.
    pub fn parameters(&self) -> (f64, f64) {
        (self.q_xy, self.q_z)
    }

    /// Checks a time step δ ∈ [0, [`DELTA_LIMIT`]].
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`].
    pub fn check_step(delta: f64) -> Result<f64, OperatorError> {
        if !(0.0..=DELTA_LIMIT).contains(&delta) {
            return Err(OperatorError::OutOfRange {
                what: "time step delta (s)",
                value: delta,
                range: "[0, 1e6]",
            });
        }
        Ok(delta)
    }

    /// The standard deviations `√δ (q_xy, q_xy, q_z)`.
    fn steps(&self, delta: f64) -> Vector3<f64> {
        Vector3::new(self.q_xy, self.q_xy, self.q_z) * delta.sqrt()
    }
}

/// F = I, `Q = δ diag(q_xy², q_xy², q_z²)`.
impl ProcessModel<Position, 3> for RandomWalk {
    type Input = f64;

    fn transition(&self, x: &Position, _: &f64) -> Position {
        *x
    }

    fn noise(&self, _: &Position, delta: &f64) -> Matrix3<f64> {
        // A negative or NaN step makes Q invalid, which the Kalman step refuses.
        Matrix3::from_diagonal(&self.steps(*delta).map(|s| s * s))
    }

    fn jacobian(&self, _: &Position, _: &f64) -> Matrix3<f64> {
        Matrix3::identity()
    }
}

/// `θ + √δ diag(q_xy, q_xy, q_z) n`, `n ~ N(0, I)`.
impl SampledProcess<Position> for RandomWalk {
    type Input = f64;

    /// # Errors
    /// As [`RandomWalk::check_step`].
    fn sample<G: RngCore>(
        &self,
        x: &Position,
        delta: &f64,
        rng: &mut G,
    ) -> Result<Position, OperatorError> {
        let s = self.steps(Self::check_step(*delta)?);
        let n = Vector3::from_fn(|_, _| StandardNormal.sample(rng));
        finite_point(Position::new_unchecked(x.coords() + s.component_mul(&n)))
    }
}
