//! CSV in and out: a user's own IMU log ([`read_imu_csv`]) and orientation estimates
//! ([`write_estimates_csv`], [`read_estimates_csv`]).
//!
//! IMU log layout: a header line `t,gx,gy,gz,ax,ay,az` (6D) or `t,gx,gy,gz,ax,ay,az,mx,my,mz` (9D),
//! then one sample per line: t in seconds (increasing at a constant rate), the gyroscope in rad/s,
//! the accelerometer in m/s², the magnetometer in µT, all in the IMU's axes. Estimates layout: a
//! header `t,w,x,y,z`, then the time (s, strictly increasing) and the unit quaternion (scalar
//! first) of the IMU frame w.r.t. ENU. Fields are separated by commas, surrounding spaces are
//! ignored, empty lines are not allowed.
//!
//! The readers keep at most [`MAX_SAMPLES`] rows (or a caller's lower limit,
//! [`read_imu_csv_at_most`]), counted as the lines are read: a longer file is refused at its first
//! line beyond the limit, and its columns never hold more than the limit's rows.

use super::data::{DataError, ImuLog, MAX_SAMPLES, RATE_RANGE};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::io::{BufRead, Write};

/// The longest line read (bytes), checked before it is kept.
pub(crate) const MAX_LINE_BYTES: usize = 4096;

/// How far each time step may be from the mean step `(t_last − t_first) / (n − 1)`, relative to
/// it (1 %): the rate is `1 / mean step`.
pub const RATE_TOLERANCE: f64 = 0.01;

/// How far the norm of a read quaternion may be from 1.
const UNIT_TOLERANCE: f64 = 1e-6;

/// How far the norm of a read quaternion may be from 1 and be kept as written (unit to the
/// manifolds' tolerance); between this and [`UNIT_TOLERANCE`] it is normalised.
const KEPT_TOLERANCE: f64 = 1e-12;

const IMU_6D: [&str; 7] = ["t", "gx", "gy", "gz", "ax", "ay", "az"];
const IMU_9D: [&str; 10] = ["t", "gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz"];
const ESTIMATES: [&str; 5] = ["t", "w", "x", "y", "z"];

/// Orientation estimates with their times: `times[k]` (s) and `orientations[k]` (IMU w.r.t. ENU).
#[derive(Clone, Debug, PartialEq)]
pub struct Estimates {
    /// The times (s).
    pub times: Vec<f64>,
    /// The orientations.
    pub orientations: Vec<UnitQuaternion<f64>>,
}

/// Reads an IMU log in the layout of this module's doc from `reader`, naming `origin` (the file)
/// in errors: [`read_imu_csv_at_most`] with the library's limit, [`MAX_SAMPLES`] samples.
///
/// # Errors
/// As [`read_imu_csv_at_most`].
pub fn read_imu_csv<R: BufRead>(reader: R, origin: &str) -> Result<ImuLog, DataError> {
    read_imu_csv_at_most(reader, origin, MAX_SAMPLES)
}

/// Reads an IMU log in the layout of this module's doc from `reader`, naming `origin` (the file)
/// in errors, keeping at most `max_samples` samples (at most [`MAX_SAMPLES`] whatever the
/// argument): a caller whose own limit is lower, such as a run that records every sample (at most
/// [`MAX_EPOCHS`](liebayes_experiments::MAX_EPOCHS) steps), refuses a longer log while reading it,
/// before holding more than its limit. The rate is inferred from the times: every step within
/// [`RATE_TOLERANCE`] of the mean step. Nothing is returned on error.
///
/// # Errors
/// [`DataError::Csv`] naming the line and column of a wrong header, a missing, extra or
/// unparsable field, a non-finite value, a time step off the constant rate, fewer than two
/// samples or a line longer than 4096 bytes; [`DataError::TooManyRows`] naming the first line
/// beyond `max_samples` samples (or [`MAX_SAMPLES`]); [`DataError::TooLarge`] when the system
/// refuses the memory of the samples read; [`DataError::BadValue`] for a reading beyond its
/// sensor's limit (as [`ImuLog::new`]); [`DataError::Io`] when reading fails.
pub fn read_imu_csv_at_most<R: BufRead>(
    reader: R,
    origin: &str,
    max_samples: usize,
) -> Result<ImuLog, DataError> {
    let mut lines = Lines::new(reader, origin);
    let header = lines
        .next_line()?
        .ok_or_else(|| csv(origin, 1, 0, "empty file, expected the header"))?;
    let header = without_byte_order_mark(&header);
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    let nine = if columns == IMU_9D {
        true
    } else if columns == IMU_6D {
        false
    } else {
        return Err(csv(
            origin,
            1,
            0,
            &format!(
                "header {header:?}, expected {:?} or {:?}",
                IMU_6D.join(","),
                IMU_9D.join(",")
            ),
        ));
    };
    let width = columns.len();
    let rows = RowLimit {
        origin,
        what: "samples",
        limit: max_samples.min(MAX_SAMPLES),
    };
    let (mut t, mut gyr, mut acc, mut mag) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut fields = vec![0.0; width];
    while let Some(line) = lines.next_line()? {
        rows.check(t.len(), lines.number)?;
        parse_fields(&line, lines.number, origin, &mut fields)?;
        rows.make_room(&mut t)?;
        rows.make_room(&mut gyr)?;
        rows.make_room(&mut acc)?;
        t.push(fields[0]);
        gyr.push(Vector3::new(fields[1], fields[2], fields[3]));
        acc.push(Vector3::new(fields[4], fields[5], fields[6]));
        if nine {
            rows.make_room(&mut mag)?;
            mag.push(Vector3::new(fields[7], fields[8], fields[9]));
        }
    }
    let rate = infer_rate(&t, origin)?;
    ImuLog::new_from(
        origin,
        ["gx,gy,gz", "ax,ay,az", "mx,my,mz"],
        rate,
        gyr,
        acc,
        nine.then_some(mag),
    )
}

/// Writes `estimates` (one per time) as `t,w,x,y,z` lines under that header; numbers in Rust's
/// shortest form that reads back to the same `f64`.
///
/// # Errors
/// [`DataError::Length`] unless there is one time per estimate; [`DataError::Io`] when writing
/// fails.
pub fn write_estimates_csv<W: Write>(
    mut writer: W,
    times: &[f64],
    orientations: &[UnitQuaternion<f64>],
    origin: &str,
) -> Result<(), DataError> {
    super::data::check_length(origin, "orientations", times.len(), orientations.len())?;
    let io = |e: std::io::Error| DataError::Io {
        origin: origin.to_owned(),
        message: e.to_string(),
    };
    writeln!(writer, "{}", ESTIMATES.join(",")).map_err(io)?;
    for (t, q) in times.iter().zip(orientations) {
        let q = q.quaternion();
        writeln!(writer, "{t:?},{:?},{:?},{:?},{:?}", q.w, q.i, q.j, q.k).map_err(io)?;
    }
    writer.flush().map_err(io)
}

/// Reads estimates written by [`write_estimates_csv`] (header `t,w,x,y,z`). The times must
/// increase strictly, as the estimates of a run's successive samples do (an IMU log's times are
/// held to the same order by its rate). Each quaternion's norm must be within 1e-6 of 1 (a file
/// written with fewer digits); it is kept as written when within 1e-12 of 1 (so a round trip
/// through [`write_estimates_csv`] is exact) and normalised otherwise, so that every orientation
/// read is a unit quaternion.
///
/// # Errors
/// [`DataError::Csv`] naming the line and column of a malformed line, a time not after the one
/// before it or a quaternion not of unit norm; [`DataError::TooManyRows`] naming the first line
/// beyond [`MAX_SAMPLES`] estimates; [`DataError::TooLarge`] when the system refuses the memory
/// of the estimates read; [`DataError::Io`] when reading fails.
pub fn read_estimates_csv<R: BufRead>(reader: R, origin: &str) -> Result<Estimates, DataError> {
    let mut lines = Lines::new(reader, origin);
    let header = lines
        .next_line()?
        .ok_or_else(|| csv(origin, 1, 0, "empty file, expected the header"))?;
    let header = without_byte_order_mark(&header);
    if header.split(',').map(str::trim).ne(ESTIMATES) {
        return Err(csv(
            origin,
            1,
            0,
            &format!("header {header:?}, expected \"t,w,x,y,z\""),
        ));
    }
    let rows = RowLimit {
        origin,
        what: "estimates",
        limit: MAX_SAMPLES,
    };
    let (mut times, mut orientations) = (Vec::new(), Vec::new());
    let mut fields = [0.0; 5];
    while let Some(line) = lines.next_line()? {
        rows.check(times.len(), lines.number)?;
        parse_fields(&line, lines.number, origin, &mut fields)?;
        if let Some(&previous) = times.last().filter(|&&previous| fields[0] <= previous) {
            return Err(csv(
                origin,
                lines.number,
                1,
                &format!(
                    "time {} s, expected a time after the previous line's {previous} s (times \
                     increase strictly)",
                    fields[0]
                ),
            ));
        }
        let q = Quaternion::new(fields[1], fields[2], fields[3], fields[4]);
        if (q.norm() - 1.0).abs() > UNIT_TOLERANCE {
            return Err(csv(
                origin,
                lines.number,
                2,
                &format!(
                    "quaternion of norm {}, expected a unit quaternion",
                    q.norm()
                ),
            ));
        }
        rows.make_room(&mut times)?;
        rows.make_room(&mut orientations)?;
        times.push(fields[0]);
        orientations.push(if (q.norm() - 1.0).abs() > KEPT_TOLERANCE {
            UnitQuaternion::new_normalize(q)
        } else {
            UnitQuaternion::new_unchecked(q)
        });
    }
    Ok(Estimates {
        times,
        orientations,
    })
}

/// The rows a reader keeps at most, checked as each line is read.
struct RowLimit<'a> {
    /// The file, named in errors.
    origin: &'a str,
    /// What a row is (`"samples"`), named in errors.
    what: &'static str,
    /// The most rows kept (at most [`MAX_SAMPLES`]).
    limit: usize,
}

impl RowLimit<'_> {
    /// The rows reserved first; the columns then double, up to the limit.
    const FIRST_ROWS: usize = 1024;

    /// Refuses the row on `line` when the limit's `kept` rows are kept already, before the row is
    /// parsed.
    fn check(&self, kept: usize, line: usize) -> Result<(), DataError> {
        if kept < self.limit {
            return Ok(());
        }
        Err(DataError::TooManyRows {
            origin: self.origin.to_owned(),
            line,
            what: self.what,
            limit: self.limit,
        })
    }

    /// Room for one more row in `column`, which holds fewer than the limit (after
    /// [`check`](Self::check)): when it is full, its capacity doubles (from
    /// [`FIRST_ROWS`](Self::FIRST_ROWS)) but never past the limit, reserved with
    /// `try_reserve_exact` so that memory the system refuses is an error, not an abort.
    fn make_room<T>(&self, column: &mut Vec<T>) -> Result<(), DataError> {
        let kept = column.len();
        if kept < column.capacity() {
            return Ok(());
        }
        let more = kept.max(Self::FIRST_ROWS).min(self.limit - kept);
        column
            .try_reserve_exact(more)
            .map_err(|_| DataError::TooLarge {
                origin: self.origin.to_owned(),
                what: "the number of rows (their memory cannot be allocated)",
                size: (kept + more) as u64,
                limit: self.limit as u64,
            })
    }
}

fn csv(origin: &str, line: usize, column: usize, message: &str) -> DataError {
    DataError::Csv {
        origin: origin.to_owned(),
        line,
        column,
        message: message.to_owned(),
    }
}

/// Parses exactly `out.len()` finite numbers from a line.
fn parse_fields(line: &str, number: usize, origin: &str, out: &mut [f64]) -> Result<(), DataError> {
    let mut parts = line.split(',');
    for (column, slot) in out.iter_mut().enumerate() {
        let Some(text) = parts.next() else {
            return Err(csv(
                origin,
                number,
                column + 1,
                &format!("missing field, expected {} fields", out.len()),
            ));
        };
        let value: f64 = text.trim().parse().map_err(|_| {
            csv(
                origin,
                number,
                column + 1,
                &format!("{:?} is not a number", text.trim()),
            )
        })?;
        if !value.is_finite() {
            return Err(csv(
                origin,
                number,
                column + 1,
                &format!("{value} is not finite"),
            ));
        }
        *slot = value;
    }
    if parts.next().is_some() {
        return Err(csv(
            origin,
            number,
            out.len() + 1,
            &format!("extra field, expected {} fields", out.len()),
        ));
    }
    Ok(())
}

/// A header line without the byte-order mark (U+FEFF) that spreadsheet programs put before a
/// UTF-8 file's first line.
fn without_byte_order_mark(header: &str) -> &str {
    header.strip_prefix('\u{feff}').unwrap_or(header)
}

/// `1 / mean step`, each step within [`RATE_TOLERANCE`] of the mean, the rate within
/// [`RATE_RANGE`].
fn infer_rate(t: &[f64], origin: &str) -> Result<f64, DataError> {
    let (Some(first), Some(last)) = (t.first(), t.last()) else {
        return Err(csv(origin, 2, 0, "no sample, expected at least two"));
    };
    if t.len() < 2 {
        return Err(csv(
            origin,
            2,
            0,
            "one sample, expected at least two to infer the rate",
        ));
    }
    // Infinite when the span of two finite times overflows: a rate of 0, refused below.
    let mean = (last - first) / (t.len() - 1) as f64;
    if mean.is_nan() || mean <= 0.0 {
        return Err(csv(
            origin,
            2,
            1,
            "times do not increase, expected increasing times (s)",
        ));
    }
    let rate = 1.0 / mean;
    if !(RATE_RANGE.0..=RATE_RANGE.1).contains(&rate) {
        return Err(csv(
            origin,
            2,
            1,
            &format!(
                "times of a rate of {rate:e} Hz (a mean step of {mean:e} s), expected a rate \
                 in [{:e}, {:e}] Hz",
                RATE_RANGE.0, RATE_RANGE.1
            ),
        ));
    }
    for (k, pair) in t.windows(2).enumerate() {
        let step = pair[1] - pair[0];
        if (step - mean).abs() > RATE_TOLERANCE * mean {
            // Sample k + 1 is on line k + 3 (the header is line 1).
            return Err(csv(
                origin,
                k + 3,
                1,
                &format!(
                    "time step {step} s, expected the constant step {mean} s within {} %",
                    RATE_TOLERANCE * 100.0
                ),
            ));
        }
    }
    Ok(rate)
}

/// Lines read with a bounded length, counted from 1.
struct Lines<'a, R> {
    reader: R,
    origin: &'a str,
    number: usize,
    buffer: Vec<u8>,
}

impl<'a, R: BufRead> Lines<'a, R> {
    fn new(reader: R, origin: &'a str) -> Self {
        Self {
            reader,
            origin,
            number: 0,
            buffer: Vec::new(),
        }
    }

    /// The next line without its end (`\n` or `\r\n`); `None` at the end of the input; an
    /// error for an empty line.
    fn next_line(&mut self) -> Result<Option<String>, DataError> {
        self.buffer.clear();
        let limit = (MAX_LINE_BYTES + 2) as u64;
        let read = <&mut R as std::io::Read>::take(&mut self.reader, limit)
            .read_until(b'\n', &mut self.buffer)
            .map_err(|e| DataError::Io {
                origin: self.origin.to_owned(),
                message: e.to_string(),
            })?;
        if read == 0 {
            return Ok(None);
        }
        self.number += 1;
        if self.buffer.last() == Some(&b'\n') {
            self.buffer.pop();
            if self.buffer.last() == Some(&b'\r') {
                self.buffer.pop();
            }
        } else if read as u64 == limit {
            return Err(csv(
                self.origin,
                self.number,
                0,
                &format!("line longer than {MAX_LINE_BYTES} bytes"),
            ));
        }
        let text = std::str::from_utf8(&self.buffer)
            .map_err(|_| csv(self.origin, self.number, 0, "not UTF-8 text"))?;
        if text.trim().is_empty() {
            return Err(csv(
                self.origin,
                self.number,
                0,
                "empty line, expected a sample",
            ));
        }
        Ok(Some(text.to_owned()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The columns double from the first block but never past the limit: a file at the limit holds
    /// no more than its rows, and the row after them is refused.
    #[test]
    fn columns_never_grow_past_the_limit() {
        let rows = RowLimit {
            origin: "memory",
            what: "samples",
            limit: 3000,
        };
        let mut column: Vec<f64> = Vec::new();
        let mut capacities = Vec::new();
        for k in 0..rows.limit {
            rows.check(column.len(), k + 2).expect("within the limit");
            rows.make_room(&mut column).expect("memory");
            column.push(0.0);
            if capacities.last() != Some(&column.capacity()) {
                capacities.push(column.capacity());
            }
        }
        assert_eq!(capacities, [1024, 2048, 3000]);
        assert!(matches!(
            rows.check(column.len(), 3002),
            Err(DataError::TooManyRows {
                line: 3002,
                limit: 3000,
                ..
            })
        ));
    }
}
