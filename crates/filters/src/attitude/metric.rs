//! The BROAD error metric: total, heading and inclination errors of an orientation estimate against
//! its reference, per sample ([`sample_errors`], [`per_sample_errors`]) and as a trial's RMSE
//! ([`trial_errors`]); and the consistency of a filter's reported σ over the same samples
//! ([`track_nees`]).

use super::data::{DataError, ImuLog, check_length};
use super::track::AttitudeTrack;
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

/// The errors at every sample of `log`: `None` where the log's reference is unknown (NaN rows);
/// the movement mask is not applied.
///
/// # Errors
/// [`DataError::NothingToScore`] when the log has no reference, [`DataError::Length`] unless there
/// is one estimate per sample.
pub fn per_sample_errors(
    estimates: &[UnitQuaternion<f64>],
    log: &ImuLog,
) -> Result<Vec<Option<SampleErrors>>, DataError> {
    let reference = reference_of(estimates, log, "per_sample_errors")?;
    Ok(estimates
        .iter()
        .zip(reference)
        .map(|(q, r)| r.as_ref().map(|r| sample_errors(q, r)))
        .collect())
}

/// The BROAD score of a trial: the RMSE (degrees) of each error over the samples of the movement
/// mask (every sample when the log has no mask) whose reference is known,
/// `RMSE = √(Σ e_k² / n)`.
///
/// # Errors
/// [`DataError::NothingToScore`] when the log has no reference or no sample is scored,
/// [`DataError::Length`] unless there is one estimate per sample.
pub fn trial_errors(
    estimates: &[UnitQuaternion<f64>],
    log: &ImuLog,
) -> Result<TrialErrors, DataError> {
    const ORIGIN: &str = "trial_errors";
    let (mut total, mut heading, mut inclination, mut samples) = (0.0, 0.0, 0.0, 0_usize);
    for (_, e) in scored(estimates, log, ORIGIN)? {
        total += e.total * e.total;
        heading += e.heading * e.heading;
        inclination += e.inclination * e.inclination;
        samples += 1;
    }
    if samples == 0 {
        return Err(nothing_scored(ORIGIN));
    }
    let rmse = |sum: f64| (sum / samples as f64).sqrt().to_degrees();
    Ok(TrialErrors {
        total: rmse(total),
        heading: rmse(heading),
        inclination: rmse(inclination),
        samples,
    })
}

/// Sums of the normalised estimation error squared over scored samples: heading
/// `Σ (e_h / σ_h)²` (one degree of freedom per sample) and tilt `Σ e_t² / σ_t²` (two: `e_t` is the
/// length of the horizontal error vector and `σ_t² = Σ_xx + Σ_yy` its expected square). A
/// consistent filter has means near 1; above 1 it is over-confident, below 1 cautious. Sums, so
/// that trials pool by [`add`](Self::add).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NeesSums {
    /// `Σ (e_h / σ_h)²`.
    pub heading: f64,
    /// `Σ e_t² / σ_t²`.
    pub tilt: f64,
    /// The number of samples summed.
    pub samples: usize,
}

impl NeesSums {
    /// The mean heading NEES (NaN over no samples).
    pub fn heading_mean(&self) -> f64 {
        self.heading / self.samples as f64
    }

    /// The mean tilt NEES (NaN over no samples).
    pub fn tilt_mean(&self) -> f64 {
        self.tilt / self.samples as f64
    }

    /// Pools another trial's sums into these.
    pub fn add(&mut self, other: &Self) {
        self.heading += other.heading;
        self.tilt += other.tilt;
        self.samples += other.samples;
    }
}

/// The NEES of a track's reported σ over the samples [`trial_errors`] scores (movement mask,
/// known reference); `None` for a track without σ. A reported σ of zero with a non-zero error
/// counts as an infinite NEES: it is not skipped.
///
/// # Errors
/// As [`trial_errors`]; [`DataError::Length`] when the track's σ are not one per sample.
pub fn track_nees(track: &AttitudeTrack, log: &ImuLog) -> Result<Option<NeesSums>, DataError> {
    const ORIGIN: &str = "track_nees";
    let (Some(h), Some(t)) = (&track.heading_sigma, &track.tilt_sigma) else {
        return Ok(None);
    };
    check_length(ORIGIN, "heading_sigma", log.len(), h.len())?;
    check_length(ORIGIN, "tilt_sigma", log.len(), t.len())?;
    let mut sums = NeesSums::default();
    for (k, e) in scored(&track.orientations, log, ORIGIN)? {
        sums.heading += normalised_square(e.heading, h[k]);
        sums.tilt += normalised_square(e.inclination, t[k]);
        sums.samples += 1;
    }
    if sums.samples == 0 {
        return Err(nothing_scored(ORIGIN));
    }
    Ok(Some(sums))
}

/// `(e / σ)²`, 0 for `e = 0` whatever σ.
fn normalised_square(e: f64, sigma: f64) -> f64 {
    if e == 0.0 { 0.0 } else { (e / sigma).powi(2) }
}

/// The scored samples of `log` (movement mask, known reference) with their errors.
fn scored<'a>(
    estimates: &'a [UnitQuaternion<f64>],
    log: &'a ImuLog,
    origin: &str,
) -> Result<impl Iterator<Item = (usize, SampleErrors)> + 'a, DataError> {
    let reference = reference_of(estimates, log, origin)?;
    let movement = log.movement();
    Ok(estimates
        .iter()
        .zip(reference)
        .enumerate()
        .filter_map(move |(k, (q, r))| {
            r.as_ref()
                .filter(|_| movement.is_none_or(|m| m[k]))
                .map(|r| (k, sample_errors(q, r)))
        }))
}

fn nothing_scored(origin: &str) -> DataError {
    DataError::NothingToScore {
        origin: origin.to_owned(),
        message: "no movement sample has a reference orientation".to_owned(),
    }
}

fn reference_of<'a>(
    estimates: &[UnitQuaternion<f64>],
    log: &'a ImuLog,
    origin: &str,
) -> Result<&'a [Option<UnitQuaternion<f64>>], DataError> {
    let reference = log.reference().ok_or_else(|| DataError::NothingToScore {
        origin: origin.to_owned(),
        message: "the log has no reference orientation".to_owned(),
    })?;
    check_length(origin, "estimates", log.len(), estimates.len())?;
    Ok(reference)
}
