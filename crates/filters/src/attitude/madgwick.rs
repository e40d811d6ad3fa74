//! [`Madgwick`]: Madgwick's gradient-descent orientation filter (S. O. H. Madgwick, "An efficient
//! orientation filter for inertial and inertial/magnetic sensor arrays", 2010), in the variant of
//! his published code that the BROAD dataset's example evaluation runs, and [`run_madgwick`], that
//! evaluation's run of it on a log.

use super::data::{DataError, ImuLog};
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
/// `β ≥ 0`, a finite positive rate and finite readings.
#[derive(Clone, Debug, PartialEq)]
pub struct Madgwick {
    beta: f64,
    interval: f64,
    q: Vector4<f64>,
}

impl Madgwick {
    /// A filter with gain `beta` (rad/s) at `rate` Hz, starting at the identity (NWU).
    ///
    /// # Errors
    /// [`DataError::BadValue`] unless β is finite and non-negative and the rate finite and
    /// positive.
    pub fn new(beta: f64, rate: f64) -> Result<Self, DataError> {
        let bad = |variable: &str, value: f64, expected| DataError::BadValue {
            origin: "Madgwick::new".to_owned(),
            variable: variable.to_owned(),
            row: 0,
            value: value.to_string(),
            expected,
        };
        if !(beta.is_finite() && beta >= 0.0) {
            return Err(bad("beta", beta, "a finite non-negative gain in rad/s"));
        }
        if !(rate.is_finite() && rate > 0.0) {
            return Err(bad("rate", rate, "a finite positive rate in Hz"));
        }
        Ok(Self {
            beta,
            interval: 1.0 / rate,
            q: Vector4::new(1.0, 0.0, 0.0, 0.0),
        })
    }

    /// Sets the state: the sensor frame w.r.t. NWU.
    pub fn set_state(&mut self, q_nwu: &UnitQuaternion<f64>) {
        let q = q_nwu.quaternion();
        self.q = Vector4::new(q.w, q.i, q.j, q.k);
    }

    /// The state: the sensor frame w.r.t. NWU.
    pub fn state(&self) -> UnitQuaternion<f64> {
        let q = &self.q;
        UnitQuaternion::new_unchecked(Quaternion::new(q[0], q[1], q[2], q[3]))
    }

    /// The estimate: the sensor frame w.r.t. ENU, `enu_from_nwu() ⊗ state`.
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        enu_from_nwu() * self.state()
    }

    /// One step with the gyroscope (rad/s), the accelerometer and, for the 9D filter, the
    /// magnetometer (any units: both are normalised, scaled by their largest component first so
    /// that huge readings do not overflow).
    ///
    /// # Errors
    /// [`DataError::BadValue`] when the step would leave a non-finite state (a non-finite input,
    /// or a rate so large that `q̇ Δt` overflows); the state is then unchanged.
    pub fn update(
        &mut self,
        gyr: &Vector3<f64>,
        acc: &Vector3<f64>,
        mag: Option<&Vector3<f64>>,
    ) -> Result<(), DataError> {
        let q = self.q;
        let omega = Quaternion::new(0.0, gyr.x, gyr.y, gyr.z);
        let qdot = Quaternion::new(q[0], q[1], q[2], q[3]) * omega * 0.5;
        let mut rate = Vector4::new(qdot.w, qdot.i, qdot.j, qdot.k);
        if let Some(a) = direction(acc) {
            let gradient = match mag.and_then(direction) {
                Some(m) => gradient_marg(&q, &a, &m),
                None => gradient_imu(&q, &a),
            };
            let norm = gradient.norm();
            if norm > 0.0 {
                rate -= gradient * (self.beta / norm);
            }
        }
        let next = q + rate * self.interval;
        let next = next / next.amax();
        let next = next / next.norm();
        if !next.iter().all(|c| c.is_finite()) {
            return Err(DataError::BadValue {
                origin: "Madgwick::update".to_owned(),
                variable: "gyroscope, accelerometer, magnetometer".to_owned(),
                row: 0,
                value: format!(
                    "{:?}, {:?}, {:?}",
                    gyr.as_slice(),
                    acc.as_slice(),
                    mag.map(nalgebra::Matrix::as_slice)
                ),
                expected: "finite readings giving a finite step",
            });
        }
        self.q = next;
        Ok(())
    }
}

/// The unit vector along `v`, computed as `(v / max|v_i|) / |v / max|v_i||`; `None` for a zero
/// (or non-finite) vector.
fn direction(v: &Vector3<f64>) -> Option<Vector3<f64>> {
    let scale = v.amax();
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    Some((v / scale).normalize())
}

/// `J_gᵀ f_g`: the gradient of ½|R(q)ᵀ ẑ − â|² in the polynomial forms of [`Madgwick`].
pub fn gradient_imu(q: &Vector4<f64>, acc: &Vector3<f64>) -> Vector4<f64> {
    let (f, j) = gravity_objective(q, acc);
    j.transpose() * f
}

/// `Jᵀ f` of the stacked gravity and field objective of [`Madgwick`] (b held constant).
pub fn gradient_marg(q: &Vector4<f64>, acc: &Vector3<f64>, mag: &Vector3<f64>) -> Vector4<f64> {
    let (fg, jg) = gravity_objective(q, acc);
    let (fb, jb) = field_objective(q, mag);
    jg.transpose() * fg + jb.transpose() * fb
}

/// The field reference `b = (½ √(h_x² + h_y²), ½ h_z)` (horizontal, vertical) of the normalised
/// measurement `mag`, `h = q ⊗ m ⊗ q*`, as [`Madgwick`] computes it.
pub fn field_reference(q: &Vector4<f64>, mag: &Vector3<f64>) -> (f64, f64) {
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

/// The BROAD example's initial state from the first accelerometer and magnetometer samples: the
/// rotation whose matrix has the columns `x = normalise((a × −m) × a)`, `y = normalise(a × x)`,
/// `z = normalise(a)`, set directly as the filter's (NWU) state. Without a magnetometer, `m` is
/// taken as `−e_x` (the sensor's x axis in place of the field). `None` when `a` or `m` is zero or
/// not finite, or `a` is parallel to `m`.
pub fn broad_initial_state(
    acc: &Vector3<f64>,
    mag: Option<&Vector3<f64>>,
) -> Option<UnitQuaternion<f64>> {
    // Scaled to unit length first (the construction is scale-free): no overflow.
    let m = match mag {
        Some(m) => direction(m)?,
        None => -Vector3::x(),
    };
    let z = direction(acc)?;
    let x = direction(&z.cross(&-m).cross(&z))?;
    let y = direction(&z.cross(&x))?;
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Some(UnitQuaternion::from_rotation_matrix(&r))
}

/// Madgwick's filter run on `log` as the BROAD example evaluation runs it: gain β at the log's
/// rate, the state initialised by [`broad_initial_state`] from the first sample, updated causally
/// from the first sample on (9D when the log has a magnetometer, else 6D), each estimate the
/// orientation w.r.t. ENU after that sample's update.
///
/// # Errors
/// As [`Madgwick::new`]; [`DataError::BadValue`] when the first accelerometer sample is zero or
/// parallel to the magnetometer (no initial state), or a step fails (as [`Madgwick::update`],
/// with the sample's row); [`DataError::NothingToScore`] for an empty log.
pub fn run_madgwick(log: &ImuLog, beta: f64) -> Result<Vec<UnitQuaternion<f64>>, DataError> {
    let mut filter = Madgwick::new(beta, log.rate())?;
    let (Some(acc0), gyr) = (log.accelerometer().first(), log.gyroscope()) else {
        return Err(DataError::NothingToScore {
            origin: "run_madgwick".to_owned(),
            message: "the log is empty".to_owned(),
        });
    };
    let mag = log.magnetometer();
    let q0 = broad_initial_state(acc0, mag.map(|m| &m[0])).ok_or_else(|| DataError::BadValue {
        origin: "run_madgwick".to_owned(),
        variable: "accelerometer".to_owned(),
        row: 0,
        value: format!("{:?}", acc0.as_slice()),
        expected: "a non-zero reading not parallel to the magnetometer",
    })?;
    filter.set_state(&q0);
    let acc = log.accelerometer();
    (0..log.len())
        .map(|k| {
            filter
                .update(&gyr[k], &acc[k], mag.map(|m| &m[k]))
                .map_err(|e| match e {
                    DataError::BadValue {
                        variable,
                        value,
                        expected,
                        ..
                    } => DataError::BadValue {
                        origin: "run_madgwick".to_owned(),
                        variable,
                        row: k,
                        value,
                        expected,
                    },
                    other => other,
                })?;
            Ok(filter.orientation())
        })
        .collect()
}
