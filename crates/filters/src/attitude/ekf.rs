//! PLACEHOLDER for the lead's attitude EKF (this file is replaced on merge): the API only, backed
//! by Madgwick's filter with constant sigmas, so that the command-line program compiles.

use super::data::{DataError, ImuLog};
use super::madgwick::{BROAD_BETA, run_madgwick};
use super::track::AttitudeTrack;

/// Which sensors the filter uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sensors {
    /// Gyroscope, accelerometer and magnetometer.
    NineD,
    /// Gyroscope and accelerometer; the magnetometer is ignored.
    SixD,
}

/// The filter's settings (placeholder: none).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct AttitudeParams {}

impl AttitudeParams {
    /// Checks the settings.
    ///
    /// # Errors
    /// None in the placeholder.
    pub fn validate(&self) -> Result<(), DataError> {
        Ok(())
    }
}

/// Placeholder: Madgwick's filter with constant sigmas (2° heading, 1° tilt).
///
/// # Errors
/// As [`run_madgwick`].
pub fn run_attitude_ekf(
    log: &ImuLog,
    params: &AttitudeParams,
    sensors: Sensors,
) -> Result<AttitudeTrack, DataError> {
    params.validate()?;
    let orientations = match sensors {
        Sensors::NineD => run_madgwick(log, BROAD_BETA)?,
        Sensors::SixD => run_madgwick(&log.clone().without_magnetometer(), BROAD_BETA)?,
    };
    let n = orientations.len();
    Ok(AttitudeTrack {
        orientations,
        heading_sigma: Some(vec![2f64.to_radians(); n]),
        tilt_sigma: Some(vec![1f64.to_radians(); n]),
    })
}
