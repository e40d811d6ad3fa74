//! The BROAD error metric: total, heading and inclination errors of an orientation estimate against
//! its reference ([`sample_errors`]), and a trial's root mean square errors ([`TrialErrors`]).

use nalgebra::UnitQuaternion;

/// One sample's errors (rad) of an estimate against its reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleErrors {
    /// Total error `2 acos(|e_w|)`, in [0, π].
    pub total: f64,
    /// Heading error `2 atan(|e_z / e_w|)`, in [0, π] (π when `e_w = 0`).
    pub heading: f64,
    /// Inclination error `2 acos(√(e_w² + e_z²))`, in [0, π].
    pub inclination: f64,
}

/// A trial's root mean square errors (degrees) over its scored samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrialErrors {
    /// RMSE of the total error (deg).
    pub total: f64,
    /// RMSE of the heading error (deg).
    pub heading: f64,
    /// RMSE of the inclination error (deg).
    pub inclination: f64,
    /// The number of samples scored.
    pub samples: usize,
}

/// The errors of `estimate` against `reference`, both the IMU frame with respect to an earth frame
/// whose z axis is vertical (ENU): with the error quaternion in the earth frame
/// `e = q_est ⊗ q_ref*` (a rotation of the earth frame taking the reference onto the estimate),
///
/// * total `2 acos(|e_w|)`: the angle of e;
/// * heading `2 atan(|e_z / e_w|)` (π when `e_w = 0`): the angle of the rotation about the
///   vertical in the decomposition `e = e_heading ⊗ e_tilt` with `e_tilt` about a horizontal axis;
/// * inclination `2 acos(√(e_w² + e_z²))`: the angle of `e_tilt`.
///
/// Computed in the equal forms (for a unit e) `2 atan2(√(e_x² + e_y² + e_z²), |e_w|)`,
/// `2 atan2(|e_z|, |e_w|)` and `2 atan2(√(e_x² + e_y²), √(e_w² + e_z²))`: they do not depend on
/// the rounding of e's norm and stay accurate near zero, where acos loses half the digits (an
/// error of 1e-8 rad would otherwise read as anything up to 3e-8 rad). Valid for any unit
/// quaternions (q and −q give the same errors). Where `e_w = e_z = 0` (a tilt of 180°) the heading
/// is undefined: it is 0 there, and any value close to it.
pub fn sample_errors(
    estimate: &UnitQuaternion<f64>,
    reference: &UnitQuaternion<f64>,
) -> SampleErrors {
    let e = (estimate * reference.conjugate()).into_inner();
    let (w, z) = (e.w.abs(), e.k.abs());
    let horizontal = e.i.hypot(e.j);
    SampleErrors {
        total: 2.0 * horizontal.hypot(z).atan2(w),
        heading: 2.0 * z.atan2(w),
        inclination: 2.0 * horizontal.atan2(w.hypot(z)),
    }
}
