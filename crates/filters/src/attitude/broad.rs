//! [`read_broad`]: a trial of the BROAD dataset (Laidig, Caruso, Cereatti and Seel, "BROAD - A
//! Benchmark for Robust Inertial Orientation Estimation", Data 6(7):72, 2021), a MATLAB 5 file.

use super::data::{DataError, ImuLog, check_count, check_length, reference_from_components};
use matfile::{Array, MatFile, NumericData};
use nalgebra::Vector3;
use std::path::Path;

/// The largest .mat file the reader opens (1 GiB), checked before reading it.
pub const MAX_MAT_FILE_BYTES: u64 = 1 << 30;

/// Reads a BROAD trial: the variables `imu_gyr`, `imu_acc`, `imu_mag` (N × 3, double: rad/s, m/s²,
/// µT), `sampling_rate` (1 × 1, Hz), and when present `opt_quat` (N × 4, w x y z, the IMU frame
/// w.r.t. East-North-Up; NaN rows where the capture lost the markers, kept as `None`) and
/// `movement` (N × 1, uint8: non-zero for the samples that count in the error). MATLAB stores
/// arrays column-major: element (i, j) of an N × k array is at `i + j N`.
///
/// # Errors
/// [`DataError::Io`] if the file cannot be read, [`DataError::TooLarge`] beyond
/// [`MAX_MAT_FILE_BYTES`] or [`MAX_SAMPLES`](super::MAX_SAMPLES), [`DataError::NotMatFile`] if it does not parse,
/// [`DataError::MissingVariable`], [`DataError::Shape`], [`DataError::Type`] for a variable that
/// is absent or not as described, [`DataError::BadValue`] for a non-finite measurement (with its
/// row) or a reference quaternion that is not of unit norm.
pub fn read_broad(path: impl AsRef<Path>) -> Result<ImuLog, DataError> {
    let path = path.as_ref();
    let origin = path.display().to_string();
    let io = |e: std::io::Error| DataError::Io {
        origin: origin.clone(),
        message: e.to_string(),
    };
    let size = std::fs::metadata(path).map_err(io)?.len();
    if size > MAX_MAT_FILE_BYTES {
        return Err(DataError::TooLarge {
            origin,
            what: "the file size in bytes",
            size,
            limit: MAX_MAT_FILE_BYTES,
        });
    }
    let bytes = std::fs::read(path).map_err(io)?;
    let not_mat = |message: String| DataError::NotMatFile {
        origin: origin.clone(),
        message,
    };
    check_elements(&origin, &bytes)?;
    // The parser can panic on some malformed files (an overflowing product of dimensions inside
    // a compressed element): such a file is reported as unreadable, like any other parse failure.
    let parsed = std::panic::catch_unwind(|| MatFile::parse(bytes.as_slice()))
        .map_err(|_| not_mat("the parser failed on malformed contents".to_owned()))?;
    let mat = parsed.map_err(|e| not_mat(e.to_string()))?;
    from_mat(&origin, &mat)
}

/// Checks the file's elements before the parser sees them: every top-level element is a matrix
/// (miMATRIX) or a compressed matrix (miCOMPRESSED), a compressed one a valid zlib stream that
/// inflates to at most [`MAX_MAT_FILE_BYTES`] and holds a matrix, and every matrix has
/// dimensions that are non-negative with a product within `i32` (the format's limit). So the parser
/// never multiplies overflowing dimensions, inflates without a bound, or prints on a corrupt
/// stream. A structure the walk does not reach (a truncated element, a missing header) is left to
/// the parser, which reports it.
fn check_elements(origin: &str, bytes: &[u8]) -> Result<(), DataError> {
    let little = match bytes.get(126..128) {
        Some(b"IM") => true,
        Some(b"MI") => false,
        _ => return Ok(()),
    };
    walk(origin, bytes, 128, little, None)
}

/// The element walk of [`check_elements`] over `bytes` from `start`; `inside` is the byte of the
/// compressed element whose inflated contents these are.
fn walk(
    origin: &str,
    bytes: &[u8],
    start: usize,
    little: bool,
    inside: Option<usize>,
) -> Result<(), DataError> {
    let word = |at: usize| -> Option<u32> {
        let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
        Some(if little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    };
    let refuse = |at: usize, what: &str| {
        let place = match inside {
            Some(outer) => format!("byte {at} of the compressed element at byte {outer}"),
            None => format!("byte {at}"),
        };
        DataError::NotMatFile {
            origin: origin.to_owned(),
            message: format!("the element at {place} {what}"),
        }
    };
    let mut at = start;
    // Each element takes at least 8 bytes: the walk is bounded by the length.
    for _ in 0..bytes.len() / 8 {
        let (Some(data_type), Some(size)) = (word(at), word(at + 4)) else {
            break;
        };
        let body = at + 8;
        match data_type {
            // miMATRIX: array flags (8 + 8 bytes), then the dimensions sub-element (miINT32).
            14 => {
                if let (Some(5), Some(dims_bytes)) = (word(body + 16), word(body + 20)) {
                    let mut product: i64 = 1;
                    for k in 0..(dims_bytes / 4).min(64) {
                        let Some(dim) = word(body + 24 + 4 * k as usize) else {
                            break;
                        };
                        #[allow(clippy::cast_possible_wrap)]
                        let dim = i64::from(dim as i32);
                        product = product.saturating_mul(dim.max(-1));
                        if dim < 0 || product > i64::from(i32::MAX) {
                            return Err(refuse(
                                at,
                                "has dimensions that are negative or multiply beyond 2^31",
                            ));
                        }
                    }
                }
            }
            15 if inside.is_none() => {
                let Some(stream) = bytes.get(body..body.saturating_add(size as usize)) else {
                    break;
                };
                let inflated = inflate(stream).map_err(|why| refuse(at, &why))?;
                walk(origin, &inflated, 0, little, Some(at))?;
            }
            other => {
                return Err(refuse(
                    at,
                    &format!("is of type {other}, not a matrix (14) or a compressed matrix (15)"),
                ));
            }
        }
        // A matrix is padded to 8 bytes; in u64, so that a size near u32::MAX cannot overflow.
        let step = if data_type == 15 {
            u64::from(size)
        } else {
            u64::from(size).next_multiple_of(8)
        };
        let Some(next) = usize::try_from(step)
            .ok()
            .and_then(|step| body.checked_add(step))
        else {
            break;
        };
        at = next;
    }
    Ok(())
}

/// A zlib stream inflated, refused when it is corrupt or inflates beyond [`MAX_MAT_FILE_BYTES`].
fn inflate(stream: &[u8]) -> Result<Vec<u8>, String> {
    use std::io::Read as _;
    let corrupt = |e: std::io::Error| format!("is not a valid zlib stream ({e})");
    let decoder = libflate::zlib::Decoder::new(stream).map_err(corrupt)?;
    let mut inflated = Vec::new();
    decoder
        .take(MAX_MAT_FILE_BYTES + 1)
        .read_to_end(&mut inflated)
        .map_err(corrupt)?;
    if inflated.len() as u64 > MAX_MAT_FILE_BYTES {
        return Err(format!(
            "inflates beyond {MAX_MAT_FILE_BYTES} bytes (the reader's limit)"
        ));
    }
    Ok(inflated)
}

fn from_mat(origin: &str, mat: &MatFile) -> Result<ImuLog, DataError> {
    let gyr = doubles(origin, mat, "imu_gyr")?;
    let n = rows(origin, gyr.0, 3)?;
    let acc = doubles(origin, mat, "imu_acc")?;
    let mag = doubles(origin, mat, "imu_mag")?;
    let rate = doubles(origin, mat, "sampling_rate")?;
    if rate.0.size().as_slice() != [1, 1] || rate.1.len() != 1 {
        return Err(shape(origin, rate.0, "1 x 1"));
    }
    check_length(origin, "imu_acc", n, rows(origin, acc.0, 3)?)?;
    check_length(origin, "imu_mag", n, rows(origin, mag.0, 3)?)?;
    let mut log = ImuLog::new_from(
        origin,
        ["imu_gyr", "imu_acc", "imu_mag"],
        rate.1[0],
        vectors(gyr.1, n),
        vectors(acc.1, n),
        Some(vectors(mag.1, n)),
    )?;
    if let Some(quat) = optional_doubles(origin, mat, "opt_quat")? {
        check_length(origin, "opt_quat", n, rows(origin, quat.0, 4)?)?;
        let q = quat.1;
        let reference = (0..n)
            .map(|i| {
                reference_from_components(origin, i, q[i], q[i + n], q[i + 2 * n], q[i + 3 * n])
            })
            .collect::<Result<Vec<_>, _>>()?;
        log = log.with_reference(reference)?;
    }
    if let Some(movement) = mat.find_by_name("movement") {
        check_length(origin, "movement", n, rows(origin, movement, 1)?)?;
        let NumericData::UInt8 { real, .. } = movement.data() else {
            return Err(DataError::Type {
                origin: origin.to_owned(),
                variable: "movement".to_owned(),
                expected: "uint8",
                found: type_name(movement.data()),
            });
        };
        log = log.with_movement(real.iter().map(|&m| m != 0).collect())?;
    }
    Ok(log)
}

type Doubles<'a> = (&'a Array, &'a [f64]);

fn doubles<'a>(origin: &str, mat: &'a MatFile, name: &str) -> Result<Doubles<'a>, DataError> {
    optional_doubles(origin, mat, name)?.ok_or_else(|| DataError::MissingVariable {
        origin: origin.to_owned(),
        variable: name.to_owned(),
    })
}

fn optional_doubles<'a>(
    origin: &str,
    mat: &'a MatFile,
    name: &str,
) -> Result<Option<Doubles<'a>>, DataError> {
    let Some(array) = mat.find_by_name(name) else {
        return Ok(None);
    };
    match array.data() {
        NumericData::Double { real, imag: None } => Ok(Some((array, real.as_slice()))),
        other => Err(DataError::Type {
            origin: origin.to_owned(),
            variable: name.to_owned(),
            expected: "real double",
            found: type_name(other),
        }),
    }
}

/// The number of rows of an N × `columns` array, checking its shape and its element count.
fn rows(origin: &str, array: &Array, columns: usize) -> Result<usize, DataError> {
    let expected = format!("N x {columns}");
    let &[n, k] = array.size().as_slice() else {
        return Err(shape(origin, array, &expected));
    };
    if k != columns {
        return Err(shape(origin, array, &expected));
    }
    check_count(origin, n)?;
    if element_count(array.data()) != n * k {
        return Err(shape(
            origin,
            array,
            "as many elements as its dimensions say",
        ));
    }
    Ok(n)
}

fn shape(origin: &str, array: &Array, expected: &str) -> DataError {
    DataError::Shape {
        origin: origin.to_owned(),
        variable: array.name().to_owned(),
        expected: expected.to_owned(),
        found: array.size().clone(),
    }
}

/// The rows of a column-major N × 3 array (its length checked).
fn vectors(data: &[f64], n: usize) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|i| Vector3::new(data[i], data[i + n], data[i + 2 * n]))
        .collect()
}

fn element_count(data: &NumericData) -> usize {
    match data {
        NumericData::Int8 { real, .. } => real.len(),
        NumericData::UInt8 { real, .. } => real.len(),
        NumericData::Int16 { real, .. } => real.len(),
        NumericData::UInt16 { real, .. } => real.len(),
        NumericData::Int32 { real, .. } => real.len(),
        NumericData::UInt32 { real, .. } => real.len(),
        NumericData::Int64 { real, .. } => real.len(),
        NumericData::UInt64 { real, .. } => real.len(),
        NumericData::Single { real, .. } => real.len(),
        NumericData::Double { real, .. } => real.len(),
    }
}

fn type_name(data: &NumericData) -> &'static str {
    match data {
        NumericData::Int8 { .. } => "int8",
        NumericData::UInt8 { .. } => "uint8",
        NumericData::Int16 { .. } => "int16",
        NumericData::UInt16 { .. } => "uint16",
        NumericData::Int32 { .. } => "int32",
        NumericData::UInt32 { .. } => "uint32",
        NumericData::Int64 { .. } => "int64",
        NumericData::UInt64 { .. } => "uint64",
        NumericData::Single { .. } => "single",
        NumericData::Double { imag: Some(_), .. } => "complex double",
        NumericData::Double { imag: None, .. } => "double",
    }
}
