//! [`Madgwick`]: Madgwick's gradient-descent orientation filter (S. O. H. Madgwick, "An efficient
//! orientation filter for inertial and inertial/magnetic sensor arrays", 2010), in the variant of
//! his published code that the BROAD dataset's example evaluation runs.

use super::data::check_rate;
use super::data::{MAX_FIELD, check_reading, scaled_unit};
use super::ekf::Sensors;
use super::estimate::{AttitudeEstimate, ImuSample};
use crate::error::{FilterError, positive_setting};
use liebayes_experiments::{RecursiveFilter, Update};
use liebayes_operators::OperatorError;
use nalgebra::{
    Matrix3, Quaternion, Rotation3, SMatrix, SVector, UnitQuaternion, Vector3, Vector4,
};

/// β of the BROAD example's evaluation (rad/s): the gain of the gradient step.
pub const BROAD_BETA: f64 = 0.12;

/// The rotation from the filter's earth frame (x magnetic North, y West, z Up: NWU) to
/// East-North-Up, a quarter turn about the vertical: `q_ENU = Q ⊗ q_NWU` with
/// `Q = (1/√2, 0, 0, 1/√2)`.
pub fn enu_from_nwu() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2)
}

/// Madgwick's filter. Its state q is the sensor frame with respect to the NWU earth frame (scalar
/// first, `v_earth = q ⊗ v_sensor ⊗ q*`). One step, with gyroscope ω, normalised accelerometer â
/// and magnetometer m̂, and the sampling interval Δt:
///
/// * `q̇_ω = ½ q ⊗ (0, ω)`;
/// * the objective `f(q)` (stacked): gravity `f_g = R(q)ᵀ ẑ − â` and, with a magnetometer, the
///   field `f_b = R(q)ᵀ b − m̂`, where `h = q ⊗ m̂ ⊗ q*` is the measured field in the earth frame
///   and `b = (½ √(h_x² + h_y²), 0, ½ h_z)`, the reference direction exactly as the published code
///   computes it (its variable named 2b_x holds √(h_x² + h_y²), so the reference has half the
///   measured field's length; kept to reproduce the published numbers);
/// * the gradient `∇ = J(q)ᵀ f(q)` with J the Jacobian of the polynomial forms
///   `R(q)ᵀ ẑ = (2(q₁q₃ − q₀q₂), 2(q₀q₁ + q₂q₃), 1 − 2q₁² − 2q₂²)` and
///   `R(q)ᵀ b = b_x (1 − 2q₂² − 2q₃², 2(q₁q₂ − q₀q₃), 2(q₀q₂ + q₁q₃))
///   + b_z (2(q₁q₃ − q₀q₂), 2(q₀q₁ + q₂q₃), 1 − 2q₁² − 2q₂²)`, with `b` held constant;
/// * `q ← normalise(q + Δt (q̇_ω − β ∇ / |∇|))`.
///
/// The feedback is skipped when the accelerometer reads exactly zero or the gradient vanishes; a
/// magnetometer reading of exactly zero falls back to the 6D step (gravity only). Valid for
/// `β ≥ 0`, a finite positive rate and readings within the sensors' limits.
///
/// On the experiment layer, as the BROAD example evaluation runs it: the first sample sets the
/// state ([`broad_initial_state`]) and every sample makes one step, the 9D step where `update`
/// gives the sample's magnetometer reading (the first sample's start is then taken with the
/// magnetometer too), else the 6D step with the sample's gyroscope and accelerometer alone. So
/// that a sample costs one step, in 9D `predict` only keeps the sample and the state before it,
/// and the step is made by the call that first needs it: `update` (the 9D step), the next
/// `predict` (the 6D step of a sample without a reading) or `estimate` (which computes that 6D
/// step without keeping it: read after every sample without a reading, such a sample costs two
/// steps). A step made later is the same step, bit for bit. In 6D a reading changes nothing and
/// `predict` makes the step at once. Every step is all or nothing, and a step that fails is
/// reported by the call that makes it: `predict` makes the 9D filter's 6D step at once, to refuse
/// the sample, when `(|ω|_∞ + β) Δt` exceeds ¼ (at or below it the step cannot fail, see
/// `DEFERRED_BOUND`), so a `predict` that returns `Ok` never leaves a step that fails later. The
/// estimate has no covariance.
///
/// # Example
/// ```
/// use liebayes_experiments::RecursiveFilter;
/// use liebayes_filters::attitude::{BROAD_BETA, ImuSample, Madgwick, Sensors};
/// use nalgebra::Vector3;
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let mut filter = Madgwick::new(BROAD_BETA, Sensors::NineD, 100.0)?;
/// let still = ImuSample { gyro: Vector3::zeros(), acc: Vector3::new(0.0, 0.0, 9.81) };
/// filter.predict(&still)?;
/// filter.update(&Vector3::new(0.0, 20.0, -40.0))?; // µT: North and down
/// let estimate = filter.estimate()?;
/// assert!(estimate.orientation.angle() < 1e-9); // level, facing North
/// assert!(estimate.covariance.is_none());
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Madgwick {
    beta: f64,
    sensors: Sensors,
    interval: f64,
    /// The last sample, `None` before the first.
    last: Option<Last>,
}

/// The bound on `(|ω|_∞ + β) Δt` at or below which [`Madgwick`]'s `predict` leaves the 6D step to
/// the call that needs it, because the step cannot fail there. Each component of
/// `Δt (q̇_ω − β ∇/|∇|)` is at most `1.25 (|ω|_∞ + β) Δt ≤ 0.3125`: a component of
/// `q̇_ω = ½ q ⊗ (0, ω)` is at most `½ √3 |ω|_∞` for a unit q, and one of `∇/|∇|` at most
/// `√1.5 < 1.25` (1 up to rounding, `√1.5` when `|∇|²` is subnormal and rounded down). So the
/// step's `q + Δt (…)` is finite (`Δt ≥ 10⁻⁶ s`, so `β ≤ 2.5·10⁵`) and keeps the largest
/// component of the unit q, at least ½, away from zero: its normalisation is finite.
const DEFERRED_BOUND: f64 = 0.25;

/// [`Madgwick`]'s last sample with the state before it and, once made, its step.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Last {
    sample: ImuSample,
    /// The state before the sample (NWU), `None` for the first sample (its start depends on its
    /// magnetometer reading).
    before: Option<Vector4<f64>>,
    /// The state after the sample once its step is made, `None` while the step waits.
    after: Option<Vector4<f64>>,
}

impl Madgwick {
    /// A filter with gain `beta` (rad/s) at `rate` Hz using `sensors`, initialised by its first
    /// sample.
    ///
    /// β is 0 (the gyroscope alone) or a gain in [1.5e-154, 1e150] rad/s, the shared range of a
    /// positive setting (`positive_setting`: its square a normal number up to 1e300); the rate is
    /// in [`RATE_RANGE`](super::RATE_RANGE).
    ///
    /// # Errors
    /// [`FilterError::Setting`] naming `beta` or `rate` outside those ranges (NaN included).
    pub fn new(beta: f64, sensors: Sensors, rate: f64) -> Result<Self, FilterError> {
        if beta != 0.0 {
            positive_setting("Madgwick::new", "beta", beta)?;
        }
        check_rate("Madgwick::new", rate)?;
        Ok(Self {
            beta,
            sensors,
            interval: 1.0 / rate,
            last: None,
        })
    }

    /// The state: the sensor frame w.r.t. NWU, `None` before the first sample (a waiting step is
    /// made for this, and cannot fail: see `DEFERRED_BOUND`).
    pub fn state(&self) -> Option<UnitQuaternion<f64>> {
        self.current().ok().flatten().map(|q| unit(&q))
    }

    /// The state after the last sample, its 6D step made now if it waits; `None` before the
    /// first sample.
    fn current(&self) -> Result<Option<Vector4<f64>>, OperatorError> {
        self.last
            .as_ref()
            .map(|last| match last.after {
                Some(q) => Ok(q),
                None => self.step_from(last.before, &last.sample, None),
            })
            .transpose()
    }

    /// The step of `sample` from the state `before`, or from the sample's start for the first
    /// sample; the 9D step with `mag`.
    fn step_from(
        &self,
        before: Option<Vector4<f64>>,
        sample: &ImuSample,
        mag: Option<&Vector3<f64>>,
    ) -> Result<Vector4<f64>, OperatorError> {
        let q = match before {
            Some(q) => q,
            None => Self::start(sample, mag)?,
        };
        self.checked_step(&q, sample, mag)
    }

    /// One step from the state `q` with the gyroscope, the accelerometer and, for the 9D step, the
    /// magnetometer (both normalised, scaled by their largest component first so that huge
    /// readings do not overflow); `None` when the result is not finite.
    fn step(
        &self,
        q: &Vector4<f64>,
        sample: &ImuSample,
        mag: Option<&Vector3<f64>>,
    ) -> Option<Vector4<f64>> {
        let gyr = &sample.gyro;
        let omega = Quaternion::new(0.0, gyr.x, gyr.y, gyr.z);
        let qdot = Quaternion::new(q[0], q[1], q[2], q[3]) * omega * 0.5;
        let mut rate = Vector4::new(qdot.w, qdot.i, qdot.j, qdot.k);
        if let Some(a) = scaled_unit(&sample.acc) {
            let gradient = match mag.and_then(scaled_unit) {
                Some(m) => gradient_marg(q, &a, &m),
                None => gradient_imu(q, &a),
            };
            let norm = gradient.norm();
            if norm > 0.0 {
                // Normalised first: `∇/|∇|` has components of at most `√1.5`, so the feedback is
                // finite for every finite β (`β / |∇|` overflows when `|∇| < β / f64::MAX`).
                rate -= (gradient / norm) * self.beta;
            }
        }
        let next = q + rate * self.interval;
        let next = next / next.amax();
        let next = next / next.norm();
        next.iter().all(|c| c.is_finite()).then_some(next)
    }

    /// The state a first sample starts from (NWU): from its magnetometer reading when that gives
    /// a heading, else (a zero reading, or one parallel to gravity) as without one.
    fn start(
        sample: &ImuSample,
        mag: Option<&Vector3<f64>>,
    ) -> Result<Vector4<f64>, OperatorError> {
        let q = broad_initial_state(&sample.acc, mag)
            .or_else(|| broad_initial_state(&sample.acc, None))
            .ok_or(OperatorError::OutOfRange {
                what: "Madgwick's first accelerometer reading (its norm)",
                value: sample.acc.norm(),
                range: "> 0, and not along the sensor's x axis when the magnetometer gives no heading",
            })?;
        let q = q.quaternion();
        Ok(Vector4::new(q.w, q.i, q.j, q.k))
    }

    /// `step`, or the error naming the sample that left a non-finite state.
    fn checked_step(
        &self,
        q: &Vector4<f64>,
        sample: &ImuSample,
        mag: Option<&Vector3<f64>>,
    ) -> Result<Vector4<f64>, OperatorError> {
        self.step(q, sample, mag).ok_or(OperatorError::NonFinite {
            what: "Madgwick's state after the step (the rate times the interval overflows, or the \
                   step cancels the state: lower β or raise the rate)",
            value: f64::INFINITY,
        })
    }
}

impl RecursiveFilter for Madgwick {
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Estimate = AttitudeEstimate;

    fn predict(&mut self, input: &ImuSample) -> Result<(), OperatorError> {
        input.check()?;
        let before = self.current()?;
        let q = match before {
            Some(q) => q,
            None => Self::start(input, None)?,
        };
        let now = self.sensors == Sensors::SixD
            || (input.gyro.amax() + self.beta) * self.interval > DEFERRED_BOUND;
        let after = if now {
            Some(self.checked_step(&q, input, None)?)
        } else {
            None
        };
        self.last = Some(Last {
            sample: *input,
            before,
            after,
        });
        Ok(())
    }

    fn update(&mut self, z: &Vector3<f64>) -> Result<Update, OperatorError> {
        check_reading("magnetometer reading", z, MAX_FIELD)?;
        let Some(last) = self.last else {
            return Err(OperatorError::NotReady {
                what: "Madgwick's filter",
                needs: "the sample (predict) the magnetometer reading belongs to",
            });
        };
        if self.sensors == Sensors::NineD {
            let after = self.step_from(last.before, &last.sample, Some(z))?;
            self.last = Some(Last {
                after: Some(after),
                ..last
            });
        }
        Ok(Update {
            log_evidence: 0.0,
            nis: None,
        })
    }

    fn estimate(&self) -> Result<AttitudeEstimate, OperatorError> {
        let q = self.current()?.ok_or(OperatorError::NotReady {
            what: "Madgwick's filter",
            needs: "a first sample (predict)",
        })?;
        Ok(AttitudeEstimate {
            orientation: enu_from_nwu() * unit(&q),
            covariance: None,
        })
    }
}

/// The state `q` (scalar first, unit) as a unit quaternion.
fn unit(q: &Vector4<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// `J_gᵀ f_g`: the gradient of ½|R(q)ᵀ ẑ − â|² in the polynomial forms of [`Madgwick`].
pub(crate) fn gradient_imu(q: &Vector4<f64>, acc: &Vector3<f64>) -> Vector4<f64> {
    let (f, j) = gravity_objective(q, acc);
    j.transpose() * f
}

/// `Jᵀ f` of the stacked gravity and field objective of [`Madgwick`] (b held constant).
pub(crate) fn gradient_marg(
    q: &Vector4<f64>,
    acc: &Vector3<f64>,
    mag: &Vector3<f64>,
) -> Vector4<f64> {
    let (fg, jg) = gravity_objective(q, acc);
    let (fb, jb) = field_objective(q, mag);
    jg.transpose() * fg + jb.transpose() * fb
}

/// The field reference `b = (½ √(h_x² + h_y²), ½ h_z)` (horizontal, vertical) of the normalised
/// measurement `mag`, `h = q ⊗ m ⊗ q*`, as [`Madgwick`] computes it.
pub(crate) fn field_reference(q: &Vector4<f64>, mag: &Vector3<f64>) -> (f64, f64) {
    let (q0, q1, q2, q3) = (q[0], q[1], q[2], q[3]);
    let r = Matrix3::new(
        q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3,
        2.0 * (q1 * q2 - q0 * q3),
        2.0 * (q0 * q2 + q1 * q3),
        2.0 * (q0 * q3 + q1 * q2),
        q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3,
        2.0 * (q2 * q3 - q0 * q1),
        2.0 * (q1 * q3 - q0 * q2),
        2.0 * (q0 * q1 + q2 * q3),
        q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3,
    );
    let h = r * mag;
    (0.5 * h.x.hypot(h.y), 0.5 * h.z)
}

type Objective = (SVector<f64, 3>, SMatrix<f64, 3, 4>);

fn gravity_objective(q: &Vector4<f64>, acc: &Vector3<f64>) -> Objective {
    let (q0, q1, q2, q3) = (q[0], q[1], q[2], q[3]);
    let up = Vector3::new(
        2.0 * (q1 * q3 - q0 * q2),
        2.0 * (q0 * q1 + q2 * q3),
        1.0 - 2.0 * q1 * q1 - 2.0 * q2 * q2,
    );
    let j = SMatrix::<f64, 3, 4>::new(
        -2.0 * q2,
        2.0 * q3,
        -2.0 * q0,
        2.0 * q1,
        2.0 * q1,
        2.0 * q0,
        2.0 * q3,
        2.0 * q2,
        0.0,
        -4.0 * q1,
        -4.0 * q2,
        0.0,
    );
    (up - acc, j)
}

fn field_objective(q: &Vector4<f64>, mag: &Vector3<f64>) -> Objective {
    let (q0, q1, q2, q3) = (q[0], q[1], q[2], q[3]);
    let (bx, bz) = field_reference(q, mag);
    let predicted = Vector3::new(
        bx * (1.0 - 2.0 * q2 * q2 - 2.0 * q3 * q3) + bz * 2.0 * (q1 * q3 - q0 * q2),
        bx * 2.0 * (q1 * q2 - q0 * q3) + bz * 2.0 * (q0 * q1 + q2 * q3),
        bx * 2.0 * (q0 * q2 + q1 * q3) + bz * (1.0 - 2.0 * q1 * q1 - 2.0 * q2 * q2),
    );
    let (x, z) = (2.0 * bx, 2.0 * bz);
    let j = SMatrix::<f64, 3, 4>::new(
        -z * q2,
        z * q3,
        -2.0 * x * q2 - z * q0,
        -2.0 * x * q3 + z * q1,
        -x * q3 + z * q1,
        x * q2 + z * q0,
        x * q1 + z * q3,
        -x * q0 + z * q2,
        x * q2,
        x * q3 - 2.0 * z * q1,
        x * q0 - 2.0 * z * q2,
        x * q1,
    );
    (predicted - mag, j)
}

/// The smallest angle (rad) between the accelerometer and the field from which
/// [`broad_initial_state`] takes a heading: below it the heading's rounding error, about
/// ε / sin(angle), exceeds 2e-6 rad.
const PARALLEL: f64 = 1e-10;

/// The BROAD example's initial state from the first accelerometer and magnetometer samples: the
/// rotation whose matrix has the columns `x = normalise((a × −m) × a)`, `y = normalise(a × x)`,
/// `z = normalise(a)`, set directly as the filter's (NWU) state. Without a magnetometer, `m` is
/// taken as `−e_x` (the sensor's x axis in place of the field). `None` when `a` or `m` is zero or
/// not finite, or `a` is parallel to `m` or within 1e-10 rad of it (where the rounding of their
/// cross product, not the data, would pick the heading).
pub fn broad_initial_state(
    acc: &Vector3<f64>,
    mag: Option<&Vector3<f64>>,
) -> Option<UnitQuaternion<f64>> {
    // Scaled to unit length first (the construction is scale-free): no overflow.
    let m = match mag {
        Some(m) => scaled_unit(m)?,
        None => -Vector3::x(),
    };
    let z = scaled_unit(acc)?;
    let across = z.cross(&-m);
    if across.norm() < PARALLEL {
        return None;
    }
    let x = scaled_unit(&across.cross(&z))?;
    let y = scaled_unit(&z.cross(&x))?;
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Some(UnitQuaternion::from_rotation_matrix(&r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// ½|f|² of the objectives in the polynomial forms, for finite differences.
    fn half_squared_imu(q: &Vector4<f64>, a: &Vector3<f64>) -> f64 {
        let (q0, q1, q2, q3) = (q[0], q[1], q[2], q[3]);
        let f = Vector3::new(
            2.0 * (q1 * q3 - q0 * q2) - a.x,
            2.0 * (q0 * q1 + q2 * q3) - a.y,
            1.0 - 2.0 * q1 * q1 - 2.0 * q2 * q2 - a.z,
        );
        0.5 * f.norm_squared()
    }

    fn half_squared_field(q: &Vector4<f64>, m: &Vector3<f64>, bx: f64, bz: f64) -> f64 {
        let (q0, q1, q2, q3) = (q[0], q[1], q[2], q[3]);
        let f = Vector3::new(
            bx * (1.0 - 2.0 * q2 * q2 - 2.0 * q3 * q3) + bz * 2.0 * (q1 * q3 - q0 * q2) - m.x,
            bx * 2.0 * (q1 * q2 - q0 * q3) + bz * 2.0 * (q0 * q1 + q2 * q3) - m.y,
            bx * 2.0 * (q0 * q2 + q1 * q3) + bz * (1.0 - 2.0 * q1 * q1 - 2.0 * q2 * q2) - m.z,
        );
        0.5 * f.norm_squared()
    }

    fn central_difference(f: impl Fn(&Vector4<f64>) -> f64, q: &Vector4<f64>) -> Vector4<f64> {
        let h = 1e-6;
        Vector4::from_fn(|i, _| {
            let mut plus = *q;
            let mut minus = *q;
            plus[i] += h;
            minus[i] -= h;
            (f(&plus) - f(&minus)) / (2.0 * h)
        })
    }

    fn unit_vector() -> impl Strategy<Value = Vector3<f64>> {
        (-1.0..1.0_f64, -1.0..1.0_f64, -1.0..1.0_f64)
            .prop_filter("not too short", |(x, y, z)| x * x + y * y + z * z > 0.01)
            .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
    }

    fn unit_quaternion() -> impl Strategy<Value = Vector4<f64>> {
        (-1.0..1.0_f64, -1.0..1.0_f64, -1.0..1.0_f64, -1.0..1.0_f64)
            .prop_filter("not too short", |(w, x, y, z)| {
                w * w + x * x + y * y + z * z > 0.01
            })
            .prop_map(|(w, x, y, z)| Vector4::new(w, x, y, z).normalize())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The 6D gradient is the gradient of ½|f_g|² (central differences).
        #[test]
        fn imu_gradient_matches_finite_differences(q in unit_quaternion(), a in unit_vector()) {
            let ours = gradient_imu(&q, &a);
            let numeric = central_difference(|p| half_squared_imu(p, &a), &q);
            prop_assert!((ours - numeric).norm() < 1e-7, "{ours} vs {numeric}");
        }

        /// The 9D gradient is the gradient of ½|f_g|² + ½|f_b|² with the field reference b held
        /// at its value at q (central differences).
        #[test]
        fn marg_gradient_matches_finite_differences(
            q in unit_quaternion(), a in unit_vector(), m in unit_vector()
        ) {
            let ours = gradient_marg(&q, &a, &m);
            let (bx, bz) = field_reference(&q, &m);
            let numeric = central_difference(
                |p| half_squared_imu(p, &a) + half_squared_field(p, &m, bx, bz),
                &q,
            );
            prop_assert!((ours - numeric).norm() < 1e-7, "{ours} vs {numeric}");
        }
    }
}
