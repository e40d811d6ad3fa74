//! IMU attitude: data, metric, the production filter, the talk's filter and Madgwick's, on the
//! experiment layer.
//!
//! * [`ImuLog`]: a validated IMU log (gyroscope, accelerometer, optional magnetometer, optional
//!   reference orientation and movement mask), read from a BROAD trial ([`read_broad`]) or a CSV
//!   file ([`read_imu_csv`]), or simulated with its truth ([`simulate`]);
//! * the filters, each a `RecursiveFilter` with the input [`ImuSample`], the measurement a
//!   magnetometer reading and the estimate [`AttitudeEstimate`]: the production filter
//!   ([`AttitudeEkf`]), the talk's Bingham / heat-kernel filter ([`TalkFilter`]) and Madgwick's
//!   ([`Madgwick`]), by name and settings through [`Method`], built as one [`AttitudeFilter`];
//! * scenarios: simulated runs ([`ImuScenario`]) and a recorded log ([`LogScenario`]);
//! * scoring: BROAD's error metric ([`sample_errors`]) and the NEES ([`AttitudeScorer`]); the
//!   BROAD evaluation of every method on every log, per log and pooled ([`evaluate`]).
//!
//! Orientations are unit quaternions (scalar first) of the IMU frame with respect to
//! East-North-Up. The math and the facts measured on the data are in the project's
//! `docs/filters/attitude.md`.

mod broad;
mod csv;
mod data;
mod ekf;
mod estimate;
mod evaluation;
mod madgwick;
mod method;
mod metric;
mod scenario;
mod simulate;
mod talk;

pub use broad::{MAX_MAT_DECLARED_BYTES, MAX_MAT_FILE_BYTES, MAX_MAT_NESTING, read_broad};
pub use csv::{
    Estimates, RATE_TOLERANCE, read_estimates_csv, read_imu_csv, read_imu_csv_at_most,
    write_estimates_csv,
};
pub use data::{
    DataError, ImuLog, MAX_ANGULAR_RATE, MAX_FIELD, MAX_SAMPLES, MAX_SPECIFIC_FORCE, RATE_RANGE,
    REFERENCE_NORM_TOLERANCE, reference_from_components,
};
pub use ekf::{
    ATTITUDE, AttitudeEkf, AttitudeParams, AttitudeState, BIAS, Block, BlockProcess,
    DisturbanceParams, FieldOffset, Heading, MAX_OFFLINE_EPOCHS, MAX_OFFLINE_SAMPLES,
    MEASURED_FIELD_OFFSET, MagnetometerParams, OFFSET, POSITION, Propagation, RestParams,
    STATE_DIM, Sensors, UNIFORM_ROTATION_VARIANCE, VELOCITY,
};
pub use estimate::{AttitudeEstimate, AttitudeScorer, ImuSample};
pub use evaluation::{
    CrossValidation, Evaluation, LogRecording, LogScore, estimates, evaluate, run_log,
};
pub use madgwick::{BROAD_BETA, Madgwick, broad_initial_state, enu_from_nwu};
pub use method::{AtRate, AttitudeFilter, METHOD_NAMES, Method};
pub use metric::{SampleErrors, TrialErrors, sample_errors};
pub use scenario::{ImuScenario, ImuSteps, LogScenario, LogSteps};
pub use simulate::{Disturbance, SimulationSettings, simulate};
pub use talk::{TalkFilter, TalkParams, field_reference_from};

/// The rotation `exp([v]ₓ)` of a rotation vector (rad) as a unit quaternion, through
/// [`So3`](liebayes_manifolds::So3)'s exp: the small turns of one sample take its Taylor series,
/// without a square root or `sin_cos`.
pub(crate) fn rotation(v: &nalgebra::Vector3<f64>) -> nalgebra::UnitQuaternion<f64> {
    use liebayes_manifolds::LieGroup;
    *liebayes_manifolds::So3::exp(v).as_unit_quaternion()
}
