//! IMU attitude: data, metric, baselines, the talk's filter and the production filter.
//!
//! * [`ImuLog`]: a validated IMU log (gyroscope, accelerometer, optional magnetometer, optional
//!   reference orientation and movement mask), read from a BROAD trial ([`read_broad`]) or a CSV
//!   file ([`read_imu_csv`]);
//! * the BROAD error metric ([`trial_errors`], [`per_sample_errors`], [`sample_errors`]) and the
//!   NEES of a filter's reported σ ([`track_nees`]);
//! * [`Madgwick`]'s filter as the BROAD example evaluation runs it ([`run_madgwick`]);
//! * an IMU simulator with its truth ([`simulate`]);
//! * the talk's Bingham / heat-kernel filter ([`TalkFilter`], [`run_talk_filter`]);
//! * the production filter ([`AttitudeEkf`], [`run_attitude_ekf`]);
//! * the experiment layer's view of them ([`ImuScenario`], [`AttitudeScorer`], and
//!   `RecursiveFilter` on [`AttitudeEkf`]): studies of many simulated runs.
//!
//! Orientations are unit quaternions (scalar first) of the IMU frame with respect to
//! East-North-Up. The math and the facts measured on the data are in `docs/filters/attitude.md`.

mod broad;
mod csv;
mod data;
mod ekf;
mod madgwick;
mod metric;
mod simulate;
mod study;
mod talk;
mod track;

pub use broad::{MAX_MAT_FILE_BYTES, read_broad};
pub use csv::{
    Estimates, MAX_LINE_BYTES, RATE_TOLERANCE, read_estimates_csv, read_imu_csv,
    write_estimates_csv,
};
pub use data::{
    DataError, ImuLog, MAX_SAMPLES, REFERENCE_NORM_TOLERANCE, reference_from_components,
};
pub use ekf::{
    AttitudeEkf, AttitudeParams, AttitudeState, Block, BlockProcess, DisturbanceParams,
    FieldOffset, Heading, MagnetometerParams, Propagation, RestParams, STATE_DIM, Sensors,
    StateSlice, run_attitude_ekf,
};
pub use madgwick::{
    BROAD_BETA, Madgwick, broad_initial_state, enu_from_nwu, field_reference, gradient_imu,
    gradient_marg, run_madgwick,
};
pub use metric::{
    NeesSums, SampleErrors, TrialErrors, per_sample_errors, sample_errors, track_nees, trial_errors,
};
pub use simulate::{Disturbance, SimulationSettings, simulate};
pub use study::{AttitudeEstimate, AttitudeScorer, ImuSample, ImuScenario, ImuSteps};
pub use talk::{TalkFilter, TalkParams, TalkRun, field_reference_from, run_talk_filter};
pub use track::AttitudeTrack;
