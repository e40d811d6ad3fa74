//! [`ImuLog`]: a recorded (or simulated) IMU log, validated, and [`DataError`], what can go wrong
//! in reading or building one.

use crate::scaled::unit_and_norm;
use liebayes_manifolds::Readable;
use liebayes_operators::OperatorError;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use thiserror::Error;

/// The largest number of samples a log may hold (2^28, about 10 days at 300 Hz): every reader
/// checks it before allocating.
pub const MAX_SAMPLES: usize = 1 << 28;

/// The sampling rates (Hz) a log, a simulation and the attitude filters accept: from one sample in
/// 1000 s to 1 MHz, so that the interval 1/rate and every sample's time are ordinary numbers (a
/// subnormal rate made the interval infinite and the first sample's time NaN).
pub const RATE_RANGE: (f64, f64) = (1e-3, 1e6);

/// A filter's sampling rate checked against [`RATE_RANGE`].
pub(crate) fn check_rate(origin: &'static str, rate: f64) -> Result<(), crate::FilterError> {
    if (RATE_RANGE.0..=RATE_RANGE.1).contains(&rate) {
        return Ok(());
    }
    Err(crate::FilterError::Setting {
        origin,
        setting: "rate",
        value: Readable(rate).to_string(),
        expected: "a rate in [1e-3, 1e6] Hz",
    })
}

/// The largest angular rate a gyroscope reading may have (rad/s): far above any gyroscope's range
/// (MEMS gyroscopes saturate near 35 rad/s), so a reading above it is a corrupt sample. Logs
/// ([`ImuLog::new`]) and the filters' steps refuse it.
pub const MAX_ANGULAR_RATE: f64 = 1e4;

/// The largest specific force an accelerometer reading may have (m/s², about 1000 g).
pub const MAX_SPECIFIC_FORCE: f64 = 1e4;

/// The largest magnetometer reading's norm, in the reading's own unit (the filters use its
/// direction; the earth's field is about 50 µT, 0.5 G, or 5e4 nT).
pub const MAX_FIELD: f64 = 1e9;

/// How far the norm of a reference quaternion may be from 1 (it is then normalised).
pub const REFERENCE_NORM_TOLERANCE: f64 = 1e-3;

/// What can go wrong in reading, writing or building an IMU log, or in scoring estimates against
/// it. Each message names where (`origin`: the file, or the function for data built in memory),
/// what, and what was expected.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DataError {
    /// The file could not be opened, read or written.
    #[error("{origin}: {message}")]
    Io {
        /// The file.
        origin: String,
        /// The system's message.
        message: String,
    },
    /// The file is not a MATLAB 5 file the reader understands (truncated, not a .mat file, ...).
    #[error(
        "{origin}: not a readable MATLAB 5 .mat file ({message}); give an uncorrupted .mat file"
    )]
    NotMatFile {
        /// The file.
        origin: String,
        /// The parser's message.
        message: String,
    },
    /// A variable the reader needs is absent.
    #[error("{origin}: the variable `{variable}` is missing; the file must hold it")]
    MissingVariable {
        /// The file.
        origin: String,
        /// The variable's name.
        variable: String,
    },
    /// A variable has the wrong shape.
    #[error("{origin}: `{variable}` has shape {found:?}, expected {expected}")]
    Shape {
        /// The file (or function).
        origin: String,
        /// The variable's name.
        variable: String,
        /// The expected shape, in words.
        expected: String,
        /// The shape found.
        found: Vec<usize>,
    },
    /// A variable has the wrong element type.
    #[error("{origin}: `{variable}` holds {found} numbers, expected {expected}")]
    Type {
        /// The file.
        origin: String,
        /// The variable's name.
        variable: String,
        /// The expected element type.
        expected: &'static str,
        /// The element type found.
        found: &'static str,
    },
    /// A value is NaN or infinite where a finite value is needed, or outside its range.
    #[error("{origin}: `{variable}` at row {row} is {value}, expected {expected}")]
    BadValue {
        /// The file (or function).
        origin: String,
        /// The variable's name.
        variable: String,
        /// The row (0-based sample index).
        row: usize,
        /// The value, as text.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// Two sequences that must have one entry per sample have different lengths.
    #[error("{origin}: `{variable}` has {found} rows, expected {expected} (one per sample)")]
    Length {
        /// The file (or function).
        origin: String,
        /// The variable's name.
        variable: String,
        /// The expected number of rows.
        expected: usize,
        /// The number found.
        found: usize,
    },
    /// More data than the library accepts, refused before allocating.
    #[error("{origin}: {what} is {size}, more than the limit {limit}")]
    TooLarge {
        /// The file (or function).
        origin: String,
        /// What is too large.
        what: &'static str,
        /// Its size.
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// A text (CSV) file with more rows than the reader accepts: refused at the first line beyond
    /// them, before that row is parsed or kept (a file's length is known only as it is read).
    #[error(
        "{origin}: line {line}: more than {limit} {what}, the most accepted; give a shorter file"
    )]
    TooManyRows {
        /// The file.
        origin: String,
        /// The first line beyond the limit (1-based; the header is line 1).
        line: usize,
        /// What the rows are (`"samples"`, `"estimates"`).
        what: &'static str,
        /// The most rows accepted.
        limit: usize,
    },
    /// A text (CSV) file with a malformed line.
    #[error("{origin}: line {line}, column {column}: {message}")]
    Csv {
        /// The file.
        origin: String,
        /// The line number (1-based; the header is line 1).
        line: usize,
        /// The column number (1-based; 0 for the line as a whole).
        column: usize,
        /// What is wrong and what was expected.
        message: String,
    },
    /// Scoring found no sample to score (no movement sample with a reference).
    #[error("{origin}: no sample to score: {message}")]
    NothingToScore {
        /// The function.
        origin: String,
        /// Why.
        message: String,
    },
}

/// An IMU log at a constant sampling rate: per sample, the gyroscope (rad/s), the accelerometer
/// (m/s², the specific force: at rest it reads +g along the sensor's up direction), optionally the
/// magnetometer (µT; absent in a 6D log), and optionally the reference orientation (the IMU frame
/// with respect to East-North-Up, `None` where the capture lost it) and the movement mask (the
/// samples that count in the error). All in the IMU's own axes.
///
/// Built validated ([`ImuLog::new`], [`ImuLog::with_reference`], [`ImuLog::with_movement`]):
/// the rate is finite and positive, every row is finite and within its sensor's limit
/// ([`MAX_ANGULAR_RATE`], [`MAX_SPECIFIC_FORCE`], [`MAX_FIELD`]), every sequence has one entry per sample,
/// at most [`MAX_SAMPLES`] samples.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuLog {
    rate: f64,
    gyroscope: Vec<Vector3<f64>>,
    accelerometer: Vec<Vector3<f64>>,
    magnetometer: Option<Vec<Vector3<f64>>>,
    reference: Option<Vec<Option<UnitQuaternion<f64>>>>,
    movement: Option<Vec<bool>>,
}

const NEW: &str = "ImuLog::new";

/// The names of the gyroscope, accelerometer and magnetometer in errors about data in memory.
const MEMORY_NAMES: [&str; 3] = ["gyroscope", "accelerometer", "magnetometer"];

impl ImuLog {
    /// A log of `gyroscope` (rad/s) and `accelerometer` (m/s²) samples at `rate` Hz, with the
    /// `magnetometer` (µT) for a 9D log.
    ///
    /// # Errors
    /// [`DataError::BadValue`] for a rate outside [`RATE_RANGE`] or a row that is not finite or
    /// beyond its sensor's limit,
    /// [`DataError::Length`] when the sequences differ in length, [`DataError::TooLarge`] beyond
    /// [`MAX_SAMPLES`].
    pub fn new(
        rate: f64,
        gyroscope: Vec<Vector3<f64>>,
        accelerometer: Vec<Vector3<f64>>,
        magnetometer: Option<Vec<Vector3<f64>>>,
    ) -> Result<Self, DataError> {
        Self::new_from(
            NEW,
            MEMORY_NAMES,
            rate,
            gyroscope,
            accelerometer,
            magnetometer,
        )
    }

    /// [`ImuLog::new`], naming `origin` (a file) and `names` (its variables for the gyroscope,
    /// accelerometer and magnetometer) in its errors.
    pub(crate) fn new_from(
        origin: &str,
        names: [&str; 3],
        rate: f64,
        gyroscope: Vec<Vector3<f64>>,
        accelerometer: Vec<Vector3<f64>>,
        magnetometer: Option<Vec<Vector3<f64>>>,
    ) -> Result<Self, DataError> {
        if !(RATE_RANGE.0..=RATE_RANGE.1).contains(&rate) {
            return Err(DataError::BadValue {
                origin: origin.to_owned(),
                variable: "sampling_rate".to_owned(),
                row: 0,
                value: Readable(rate).to_string(),
                expected: "a rate in [1e-3, 1e6] Hz",
            });
        }
        let n = gyroscope.len();
        check_count(origin, n)?;
        check_length(origin, names[1], n, accelerometer.len())?;
        check_rows(origin, names[0], &gyroscope, LIMITS[0])?;
        check_rows(origin, names[1], &accelerometer, LIMITS[1])?;
        if let Some(mag) = &magnetometer {
            check_length(origin, names[2], n, mag.len())?;
            check_rows(origin, names[2], mag, LIMITS[2])?;
        }
        Ok(Self {
            rate,
            gyroscope,
            accelerometer,
            magnetometer,
            reference: None,
            movement: None,
        })
    }

    /// The log with its reference orientations (IMU frame w.r.t. ENU; `None` where unknown).
    /// Each given orientation must be finite with `|‖q‖ − 1| ≤` [`REFERENCE_NORM_TOLERANCE`], the
    /// tolerance of the readers (`reference_from_components`); it is kept normalised, as the
    /// readers keep theirs (a `UnitQuaternion` made unchecked may be off the unit sphere).
    ///
    /// # Errors
    /// [`DataError::Length`] unless there is one per sample; [`DataError::BadValue`] naming the
    /// first sample whose orientation is not finite or not unit within the tolerance.
    pub fn with_reference(
        mut self,
        reference: Vec<Option<UnitQuaternion<f64>>>,
    ) -> Result<Self, DataError> {
        check_length(
            "ImuLog::with_reference",
            "reference",
            self.len(),
            reference.len(),
        )?;
        let mut reference = reference;
        for (row, q) in reference.iter_mut().enumerate() {
            let Some(q) = q else { continue };
            // NaN and ±∞ components give a NaN or infinite norm.
            let norm = q.coords.norm();
            if !norm.is_finite() || (norm - 1.0).abs() > REFERENCE_NORM_TOLERANCE {
                return Err(DataError::BadValue {
                    origin: "ImuLog::with_reference".to_owned(),
                    variable: "reference".to_owned(),
                    row,
                    value: format!("{:?} of norm {norm}", q.coords.as_slice()),
                    expected: "a finite unit quaternion (norm within 1e-3 of 1; normalise it), or \
                               None where unknown",
                });
            }
            *q = UnitQuaternion::new_normalize(q.into_inner());
        }
        self.reference = Some(reference);
        Ok(self)
    }

    /// The log with its movement mask (`true` for the samples that count in the error).
    ///
    /// # Errors
    /// [`DataError::Length`] unless there is one per sample.
    pub fn with_movement(mut self, movement: Vec<bool>) -> Result<Self, DataError> {
        check_length(
            "ImuLog::with_movement",
            "movement",
            self.len(),
            movement.len(),
        )?;
        self.movement = Some(movement);
        Ok(self)
    }

    /// The sampling rate (Hz).
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// The sampling interval 1 / rate (s).
    pub fn interval(&self) -> f64 {
        1.0 / self.rate
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        self.gyroscope.len()
    }

    /// Whether the log has no sample.
    pub fn is_empty(&self) -> bool {
        self.gyroscope.is_empty()
    }

    /// The gyroscope samples (rad/s).
    pub fn gyroscope(&self) -> &[Vector3<f64>] {
        &self.gyroscope
    }

    /// The accelerometer samples (m/s²).
    pub fn accelerometer(&self) -> &[Vector3<f64>] {
        &self.accelerometer
    }

    /// The magnetometer samples (µT), for a 9D log.
    pub fn magnetometer(&self) -> Option<&[Vector3<f64>]> {
        self.magnetometer.as_deref()
    }

    /// The reference orientations, when the log has them.
    pub fn reference(&self) -> Option<&[Option<UnitQuaternion<f64>>]> {
        self.reference.as_deref()
    }

    /// The movement mask, when the log has one.
    pub fn movement(&self) -> Option<&[bool]> {
        self.movement.as_deref()
    }

    /// The log without its magnetometer (a 6D log).
    #[must_use]
    pub fn without_magnetometer(mut self) -> Self {
        self.magnetometer = None;
        self
    }
}

/// A reference quaternion from its components `(w, x, y, z)` at sample `row` of `origin` (named in
/// the error): `None` when any is NaN (the capture lost it), else the normalised quaternion.
///
/// # Errors
/// [`DataError::BadValue`] for an infinite component or a norm further than
/// [`REFERENCE_NORM_TOLERANCE`] from 1.
pub fn reference_from_components(
    origin: &str,
    row: usize,
    w: f64,
    x: f64,
    y: f64,
    z: f64,
) -> Result<Option<UnitQuaternion<f64>>, DataError> {
    if [w, x, y, z].iter().any(|c| c.is_nan()) {
        return Ok(None);
    }
    let q = Quaternion::new(w, x, y, z);
    let norm = q.norm();
    if !norm.is_finite() || (norm - 1.0).abs() > REFERENCE_NORM_TOLERANCE {
        return Err(DataError::BadValue {
            origin: origin.to_owned(),
            variable: "opt_quat".to_owned(),
            row,
            value: format!("({w}, {x}, {y}, {z}) of norm {norm}"),
            expected: "a unit quaternion (w, x, y, z), or NaN where unknown",
        });
    }
    Ok(Some(UnitQuaternion::from_quaternion(q)))
}

pub(crate) fn check_count(origin: &str, n: usize) -> Result<(), DataError> {
    if n > MAX_SAMPLES {
        return Err(DataError::TooLarge {
            origin: origin.to_owned(),
            what: "the number of samples",
            size: n as u64,
            limit: MAX_SAMPLES as u64,
        });
    }
    Ok(())
}

pub(crate) fn check_length(
    origin: &str,
    variable: &str,
    expected: usize,
    found: usize,
) -> Result<(), DataError> {
    if expected == found {
        Ok(())
    } else {
        Err(DataError::Length {
            origin: origin.to_owned(),
            variable: variable.to_owned(),
            expected,
            found,
        })
    }
}

/// Every row finite with a norm of at most `limit`.
fn check_rows(
    origin: &str,
    variable: &str,
    rows: &[Vector3<f64>],
    (limit, expected): (f64, &'static str),
) -> Result<(), DataError> {
    match rows
        .iter()
        .position(|v| !(v.iter().all(|c| c.is_finite()) && v.norm() <= limit))
    {
        None => Ok(()),
        Some(row) => Err(DataError::BadValue {
            origin: origin.to_owned(),
            variable: variable.to_owned(),
            row,
            value: format!("{:?}", rows[row].as_slice()),
            expected,
        }),
    }
}

/// The gyroscope's, accelerometer's and magnetometer's limits, with what a log's error says.
const LIMITS: [(f64, &str); 3] = [
    (
        MAX_ANGULAR_RATE,
        "finite values of norm at most 1e4 rad/s (MAX_ANGULAR_RATE)",
    ),
    (
        MAX_SPECIFIC_FORCE,
        "finite values of norm at most 1e4 m/s^2 (MAX_SPECIFIC_FORCE)",
    ),
    (MAX_FIELD, "finite values of norm at most 1e9 (MAX_FIELD)"),
];

/// `Ok` for a finite reading of norm at most `limit`, else the step's error naming `what`.
pub(crate) fn check_reading(
    what: &'static str,
    v: &Vector3<f64>,
    limit: f64,
) -> Result<(), OperatorError> {
    if let Some(&value) = v.iter().find(|c| !c.is_finite()) {
        return Err(OperatorError::NonFinite { what, value });
    }
    let norm = v.norm();
    if norm > limit {
        return Err(OperatorError::OutOfRange {
            what,
            value: norm,
            range: "a norm within the sensor limit (MAX_ANGULAR_RATE, MAX_SPECIFIC_FORCE, MAX_FIELD)",
        });
    }
    Ok(())
}

/// `v / |v|` computed from `v` scaled by its largest entry (no overflow); `None` for a zero or
/// non-finite vector.
pub(crate) fn scaled_unit(v: &Vector3<f64>) -> Option<Vector3<f64>> {
    unit_and_norm(v).map(|(unit, _)| unit)
}
