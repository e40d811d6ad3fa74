//! What every attitude filter takes and gives: [`ImuSample`], one sample's gyroscope and
//! accelerometer readings (the process input), and [`AttitudeEstimate`], the orientation with its
//! error covariance where the filter has one; and [`AttitudeScorer`], BROAD's errors and the NEES
//! of an estimate against the true orientation.

use super::data::{MAX_ANGULAR_RATE, MAX_SPECIFIC_FORCE, check_reading};
use super::metric::sample_errors;
use liebayes_experiments::{Metric, Reduction, Scorer};
use liebayes_operators::OperatorError;
use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector2, Vector3};

/// One sample's gyroscope (rad/s) and accelerometer (m/s²) readings: the process input of every
/// attitude filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// Gyroscope (rad/s, IMU frame).
    pub gyro: Vector3<f64>,
    /// Accelerometer (m/s², IMU frame).
    pub acc: Vector3<f64>,
}

impl ImuSample {
    /// `Ok` when both readings are finite and within the sensors' limits ([`MAX_ANGULAR_RATE`],
    /// [`MAX_SPECIFIC_FORCE`]).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] or [`OperatorError::OutOfRange`] naming the reading.
    pub fn check(&self) -> Result<(), OperatorError> {
        check_reading("gyroscope reading", &self.gyro, MAX_ANGULAR_RATE)?;
        check_reading("accelerometer reading", &self.acc, MAX_SPECIFIC_FORCE)
    }
}

/// An attitude filter's estimate: the orientation (IMU frame w.r.t. ENU) and, for a filter that
/// reports its uncertainty, the covariance of its world-frame error `δθ`,
/// `R_true = exp([δθ]ₓ) R̂` (rad²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeEstimate {
    /// The orientation.
    pub orientation: UnitQuaternion<f64>,
    /// The world-frame error covariance (rad²), `None` for a filter without one (Madgwick's).
    pub covariance: Option<Matrix3<f64>>,
}

impl AttitudeEstimate {
    /// `(heading σ, tilt σ)` (rad) of the covariance Σ: `√Σ_zz` and `√(Σ_xx + Σ_yy)` (negative
    /// diagonal entries from rounding read as zero); `None` without a covariance, or for one (a
    /// public field) whose diagonal is not finite.
    pub fn sigmas(&self) -> Option<(f64, f64)> {
        let p = self.covariance?;
        let d = p.diagonal();
        if !d.iter().all(|v| v.is_finite()) {
            return None;
        }
        let d = d.map(|v| v.max(0.0));
        Some((d[2].sqrt(), (d[0] + d[1]).sqrt()))
    }
}

/// Scores an [`AttitudeEstimate`] against the true orientation: BROAD's heading, inclination
/// (`tilt_error`) and total errors (deg, [`sample_errors`], root mean square over runs) beside the
/// reported σ (`heading_sigma` `√P_zz`, `tilt_sigma` `√(P_xx + P_yy)`, deg), and with the
/// world-frame error `δθ = log(R_true R̂ᵀ)` the NEES of its vertical component `δθ_z² / P_zz`
/// (χ²(1)), of its horizontal part `δθ_xyᵀ P_xy⁻¹ δθ_xy` (χ²(2)) and of the whole `δθᵀ P⁻¹ δθ`
/// (χ²(3)). The σ and NEES are NaN for an estimate without a covariance, or where its block is not
/// positive definite. A truth of type `Option` scores `None` (a sample without a reference, or
/// outside the movement mask) as NaN everywhere: it is left out of every statistic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AttitudeScorer;

/// The metrics, in the order [`AttitudeScorer`] writes them.
const METRICS: [Metric; 8] = [
    Metric::new("heading_error", Reduction::RootMeanSquare, "deg").per_run(),
    Metric::new("heading_sigma", Reduction::RootMeanSquare, "deg"),
    Metric::new("tilt_error", Reduction::RootMeanSquare, "deg").per_run(),
    Metric::new("tilt_sigma", Reduction::RootMeanSquare, "deg"),
    Metric::new("total_error", Reduction::RootMeanSquare, "deg").per_run(),
    Metric::new("heading_nees", Reduction::ChiSquare { dof: 1 }, ""),
    Metric::new("tilt_nees", Reduction::ChiSquare { dof: 2 }, ""),
    Metric::new("nees", Reduction::ChiSquare { dof: 3 }, ""),
];

impl AttitudeScorer {
    /// The index of metric `name` in the scorer's output, `None` for a name it does not write.
    pub fn index(name: &str) -> Option<usize> {
        METRICS.iter().position(|m| m.name == name)
    }
}

impl Scorer<UnitQuaternion<f64>, AttitudeEstimate> for AttitudeScorer {
    fn metrics(&self) -> Vec<Metric> {
        METRICS.to_vec()
    }

    fn score(&self, truth: &UnitQuaternion<f64>, estimate: &AttitudeEstimate, values: &mut [f64]) {
        let e = sample_errors(&estimate.orientation, truth);
        values[0] = e.heading.to_degrees();
        values[2] = e.inclination.to_degrees();
        values[4] = e.total.to_degrees();
        let Some(p) = &estimate.covariance else {
            for j in [1, 3, 5, 6, 7] {
                values[j] = f64::NAN;
            }
            return;
        };
        let (heading_sigma, tilt_sigma) = estimate.sigmas().unwrap_or((f64::NAN, f64::NAN));
        values[1] = heading_sigma.to_degrees();
        values[3] = tilt_sigma.to_degrees();
        let d = (truth * estimate.orientation.inverse()).scaled_axis();
        values[5] = if p[(2, 2)] > 0.0 {
            d.z * d.z / p[(2, 2)]
        } else {
            f64::NAN
        };
        let tilt: Matrix2<f64> = p.fixed_view::<2, 2>(0, 0).into_owned();
        values[6] = tilt.cholesky().map_or(f64::NAN, |c| {
            let h = Vector2::new(d.x, d.y);
            h.dot(&c.solve(&h))
        });
        values[7] = p.cholesky().map_or(f64::NAN, |c| d.dot(&c.solve(&d)));
    }
}

impl Scorer<Option<UnitQuaternion<f64>>, AttitudeEstimate> for AttitudeScorer {
    fn metrics(&self) -> Vec<Metric> {
        METRICS.to_vec()
    }

    fn score(
        &self,
        truth: &Option<UnitQuaternion<f64>>,
        estimate: &AttitudeEstimate,
        values: &mut [f64],
    ) {
        match truth {
            Some(q) => Scorer::<UnitQuaternion<f64>, _>::score(self, q, estimate, values),
            None => values.fill(f64::NAN),
        }
    }
}
