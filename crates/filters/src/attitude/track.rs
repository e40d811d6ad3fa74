//! [`AttitudeTrack`]: what every attitude filter of this module returns for a log, one entry per
//! sample: the orientation and its reported heading and tilt standard deviations.

use nalgebra::{Matrix3, UnitQuaternion};

/// A filter's output for a log: per sample, the orientation of the IMU frame with respect to ENU
/// (scalar first) and the filter's own standard deviations of its error (rad) split as BROAD's
/// metric splits it: about the vertical (heading) and about a horizontal axis (tilt, the RMS of the
/// two horizontal components). `None` sigmas for a filter that reports no uncertainty.
#[derive(Clone, Debug, PartialEq)]
pub struct AttitudeTrack {
    /// The estimates, one per sample.
    pub orientations: Vec<UnitQuaternion<f64>>,
    /// The reported heading standard deviation per sample (rad), if the filter has one.
    pub heading_sigma: Option<Vec<f64>>,
    /// The reported tilt standard deviation per sample (rad): `√(Σ_xx + Σ_yy)` of the world-frame
    /// error covariance, if the filter has one.
    pub tilt_sigma: Option<Vec<f64>>,
}

impl AttitudeTrack {
    /// A track without uncertainty.
    pub fn without_sigma(orientations: Vec<UnitQuaternion<f64>>) -> Self {
        Self {
            orientations,
            heading_sigma: None,
            tilt_sigma: None,
        }
    }

    /// `(heading σ, tilt σ)` (rad) of a world-frame error covariance Σ (rad², the error `e` in
    /// `R_true = exp([e]ₓ) R_est`): `√Σ_zz` and `√(Σ_xx + Σ_yy)`; negative diagonal entries (from
    /// rounding) read as zero.
    pub fn sigmas_of_world_covariance(covariance: &Matrix3<f64>) -> (f64, f64) {
        let d = covariance.diagonal().map(|v| v.max(0.0));
        (d[2].sqrt(), (d[0] + d[1]).sqrt())
    }
}
