//! [`read_broad`]: a trial of the BROAD dataset (Laidig, Caruso, Cereatti and Seel, "BROAD - A
//! Benchmark for Robust Inertial Orientation Estimation", Data 6(7):72, 2021), a MATLAB 5 file.

use super::data::{DataError, ImuLog, check_count, check_length, reference_from_components};
use matfile::{Array, MatFile, NumericData};
use nalgebra::Vector3;
use std::io::Read as _;
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
/// [`DataError::Io`] if the file cannot be read or is not a regular file, [`DataError::TooLarge`] beyond
/// [`MAX_MAT_FILE_BYTES`], [`MAX_MAT_DECLARED_BYTES`] or [`MAX_SAMPLES`](super::MAX_SAMPLES),
/// [`DataError::NotMatFile`] if its structure is malformed (an element declaring more bytes than
/// it holds, dimensions beyond the format's, matrices nested deeper than [`MAX_MAT_NESTING`]) or
/// it does not parse,
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
    let metadata = std::fs::metadata(path).map_err(io)?;
    // A FIFO would block the read and a device might never end it: regular files only.
    if !metadata.is_file() {
        return Err(DataError::Io {
            origin,
            message: "not a regular file (a FIFO, a folder or a device)".to_owned(),
        });
    }
    let too_large = |size: u64| DataError::TooLarge {
        origin: origin.clone(),
        what: "the file size in bytes",
        size,
        limit: MAX_MAT_FILE_BYTES,
    };
    if metadata.len() > MAX_MAT_FILE_BYTES {
        return Err(too_large(metadata.len()));
    }
    // At most one byte past the limit: a file that grows after the check is refused too.
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(io)?
        .take(MAX_MAT_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_MAT_FILE_BYTES {
        return Err(too_large(bytes.len() as u64));
    }
    let not_mat = |message: String| DataError::NotMatFile {
        origin: origin.clone(),
        message,
    };
    check_elements(&origin, &bytes)?;
    // The walk above refuses every malformed structure the parser is known to panic on; should
    // another reach it, the file is reported as unreadable, like any other parse failure.
    let parsed = std::panic::catch_unwind(|| MatFile::parse(bytes.as_slice()))
        .map_err(|_| not_mat("the parser failed on malformed contents".to_owned()))?;
    let mat = parsed.map_err(|e| not_mat(e.to_string()))?;
    from_mat(&origin, &mat)
}

/// The most the values of a file's matrices may take in all, counted as doubles (1 GiB), and the
/// most its compressed elements may inflate to in all: the parser holds every matrix's data and its
/// conversion to the class's type, so their sum is bounded before it runs.
pub const MAX_MAT_DECLARED_BYTES: u64 = MAX_MAT_FILE_BYTES;

/// The deepest a `.mat` file's matrices may nest (cells and structures within each other): far
/// beyond any recording's few levels, and a bound on the structure check's recursion.
pub const MAX_MAT_NESTING: usize = 32;

/// Checks the file's structure before the parser sees them, so that the parser never meets a size
/// it would overflow, inflate without a bound or allocate beyond memory for:
///
/// * every top-level element is a matrix (miMATRIX, 14) or a compressed matrix (miCOMPRESSED,
///   15), and declares no more bytes than follow it;
/// * a compressed element is a valid zlib stream holding matrices, and all of them inflate to at
///   most [`MAX_MAT_DECLARED_BYTES`] together;
/// * inside a matrix, every sub-element (flags, dimensions, name, data, nested matrices of cells
///   and structures) declares no more bytes than the matrix holds, and the dimensions are
///   non-negative with a product within `i32` (the format's limit);
/// * matrices nest at most [`MAX_MAT_NESTING`] deep;
/// * the products of all dimensions, as doubles, take at most [`MAX_MAT_DECLARED_BYTES`].
///
/// A file without the MATLAB 5 header is left to the parser, which refuses it.
fn check_elements(origin: &str, bytes: &[u8]) -> Result<(), DataError> {
    let little = match bytes.get(126..128) {
        Some(b"IM") => true,
        Some(b"MI") => false,
        _ => return Ok(()),
    };
    let mut walk = Walk {
        origin,
        little,
        declared: 0,
        inflated: 0,
    };
    walk.elements(bytes, 128, None)
}

/// The state of [`check_elements`]'s walk: the byte order and the totals so far.
struct Walk<'a> {
    origin: &'a str,
    little: bool,
    /// Bytes the matrices' values take as doubles.
    declared: u64,
    /// Bytes the compressed elements inflated to.
    inflated: u64,
}

/// A data element's tag at some offset: its type, the bytes of its data, and where the next
/// element starts (past the padding to 8 bytes, or past a small element's 4 bytes of data).
struct Tag {
    data_type: u32,
    start: usize,
    size: usize,
    next: usize,
}

impl Walk<'_> {
    /// The top-level elements of `bytes` from `start` (the file, or a compressed element's
    /// inflated contents: `inside` is then the compressed element's offset in the file).
    fn elements(
        &mut self,
        bytes: &[u8],
        start: usize,
        inside: Option<usize>,
    ) -> Result<(), DataError> {
        let mut at = start;
        // Each element takes at least 8 bytes: the walk is bounded by the length.
        while at < bytes.len() {
            // Compressed streams are not padded: their element ends where its size says.
            let tag = self.tag(bytes, at, bytes.len(), inside)?;
            match tag.data_type {
                14 => self.matrix(bytes, &tag, inside, 1)?,
                15 if inside.is_none() => {
                    let stream = &bytes[tag.start..tag.start + tag.size];
                    let inflated = self
                        .inflate(stream)
                        .map_err(|why| self.refuse(at, inside, &why))?;
                    self.elements(&inflated, 0, Some(at))?;
                }
                other => {
                    return Err(self.refuse(
                        at,
                        inside,
                        &format!(
                            "is of type {other}, not a matrix (14) or a compressed matrix (15)"
                        ),
                    ));
                }
            }
            at = if tag.data_type == 15 {
                tag.start + tag.size
            } else {
                tag.next
            };
        }
        Ok(())
    }

    /// The tag at `at`, whose element must end by `end`.
    fn tag(
        &self,
        bytes: &[u8],
        at: usize,
        end: usize,
        inside: Option<usize>,
    ) -> Result<Tag, DataError> {
        let (Some(first), Some(second)) = (self.word(bytes, at), self.word(bytes, at + 4)) else {
            return Err(self.refuse(
                at,
                inside,
                "is cut short: fewer than 8 bytes of its tag remain",
            ));
        };
        // A small element packs its size (at most 4) into the upper half of the first word.
        let (data_type, size, start, padded) = if first >> 16 == 0 {
            let size = second as usize;
            (first, size, at + 8, size.next_multiple_of(8))
        } else {
            (first & 0xffff, (first >> 16) as usize, at + 4, 4)
        };
        let room = end.saturating_sub(start);
        if size > room || (first >> 16 != 0 && size > 4) {
            return Err(self.refuse(
                at,
                inside,
                &format!("declares {size} bytes, but only {room} remain where it lies"),
            ));
        }
        Ok(Tag {
            data_type,
            start,
            size,
            // The last element may end without its padding.
            next: start + padded.min(room),
        })
    }

    /// A matrix's sub-elements: flags, dimensions (checked and counted), then name, data and
    /// nested matrices, each within the matrix. `depth` counts the matrices it lies in, itself
    /// included: at most [`MAX_MAT_NESTING`] (each level is a call, and a crafted file of 8-byte
    /// matrices each holding the next overflowed the stack, an abort no error can report).
    fn matrix(
        &mut self,
        bytes: &[u8],
        matrix: &Tag,
        inside: Option<usize>,
        depth: usize,
    ) -> Result<(), DataError> {
        if depth > MAX_MAT_NESTING {
            return Err(self.refuse(
                matrix.start.saturating_sub(8),
                inside,
                &format!("is a matrix nested more than {MAX_MAT_NESTING} deep"),
            ));
        }
        let end = matrix.start + matrix.size;
        let mut at = matrix.start;
        let mut index = 0;
        while at < end {
            let tag = self.tag(bytes, at, end, inside)?;
            if tag.data_type == 14 {
                self.matrix(bytes, &tag, inside, depth + 1)?;
            } else if index == 1 {
                self.dimensions(bytes, &tag, at, inside)?;
            }
            at = tag.next;
            index += 1;
        }
        Ok(())
    }

    /// A matrix's dimensions (miINT32): non-negative, their product within `i32`, and the values
    /// counted against [`MAX_MAT_DECLARED_BYTES`].
    fn dimensions(
        &mut self,
        bytes: &[u8],
        tag: &Tag,
        at: usize,
        inside: Option<usize>,
    ) -> Result<(), DataError> {
        if tag.data_type != 5 {
            return Err(self.refuse(
                at,
                inside,
                &format!(
                    "holds matrix dimensions of type {}, not int32 (5)",
                    tag.data_type
                ),
            ));
        }
        let mut product: i64 = 1;
        for k in 0..tag.size / 4 {
            // Within the tag's bytes, checked by `tag`.
            let dim = self.word(bytes, tag.start + 4 * k).unwrap_or_default();
            #[allow(clippy::cast_possible_wrap)]
            let dim = i64::from(dim as i32);
            product = product.saturating_mul(dim.max(-1));
            if dim < 0 || product > i64::from(i32::MAX) {
                return Err(self.refuse(
                    at,
                    inside,
                    "has dimensions that are negative or multiply beyond 2^31",
                ));
            }
        }
        // At most 2^31 · 8 per matrix: the sum cannot overflow before it is refused.
        self.declared += product.unsigned_abs() * 8;
        if self.declared > MAX_MAT_DECLARED_BYTES {
            return Err(DataError::TooLarge {
                origin: self.origin.to_owned(),
                what: "the bytes the file's matrices declare, as doubles",
                size: self.declared,
                limit: MAX_MAT_DECLARED_BYTES,
            });
        }
        Ok(())
    }

    /// A zlib stream inflated, refused when it is corrupt or the file's compressed elements
    /// inflate beyond [`MAX_MAT_DECLARED_BYTES`] together.
    fn inflate(&mut self, stream: &[u8]) -> Result<Vec<u8>, String> {
        let corrupt = |e: std::io::Error| format!("is not a valid zlib stream ({e})");
        let room = MAX_MAT_DECLARED_BYTES - self.inflated;
        let decoder = libflate::zlib::Decoder::new(stream).map_err(corrupt)?;
        let mut inflated = Vec::new();
        decoder
            .take(room + 1)
            .read_to_end(&mut inflated)
            .map_err(corrupt)?;
        if inflated.len() as u64 > room {
            return Err(format!(
                "inflates the file's compressed elements beyond {MAX_MAT_DECLARED_BYTES} bytes \
                 (the reader's limit)"
            ));
        }
        self.inflated += inflated.len() as u64;
        Ok(inflated)
    }

    /// The 32-bit word at `at` in the file's byte order.
    fn word(&self, bytes: &[u8], at: usize) -> Option<u32> {
        let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
        Some(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    /// The error for the element at `at` (in the file, or inside the compressed element at
    /// `inside`).
    fn refuse(&self, at: usize, inside: Option<usize>, what: &str) -> DataError {
        let place = match inside {
            Some(outer) => format!("byte {at} of the compressed element at byte {outer}"),
            None => format!("byte {at}"),
        };
        DataError::NotMatFile {
            origin: self.origin.to_owned(),
            message: format!("the element at {place} {what}"),
        }
    }
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
