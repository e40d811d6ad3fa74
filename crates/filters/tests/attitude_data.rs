//! The attitude data layer: the BROAD reader on the twelve trials (skipped without the data) and on
//! malformed files, `ImuLog` validation, the BROAD metric (hand cases, a decomposition property,
//! invariances), CSV in and out, the simulator, the measured magnetometer facts the docs report,
//! and bad input through the bad-input harness (no panic, no hang, no silent NaN; a refused step
//! leaves the filter as it was).
//!
//! The twelve trials are read from `$LIEBAYES_BROAD_DIR` when it is set.

use liebayes_experiments::{Recorded, Recording, RecursiveFilter};
use liebayes_filters::attitude::{
    AttitudeEstimate, DataError, Disturbance, FieldOffset, ImuLog, ImuSample, LogRecording,
    LogScenario, LogScore, MAX_SAMPLES, METHOD_NAMES, Method, RATE_TOLERANCE, Sensors,
    SimulationSettings, read_broad, read_estimates_csv, read_imu_csv, run_log, sample_errors,
    simulate, write_estimates_csv,
};
use liebayes_reference::broad::{SHIPPED, shipped_dir, trials};
use liebayes_reference::fuzz;
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};

mod refusing;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("liebayes-attitude-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

// ---------------------------------------------------------------------------------------------
// The BROAD trials: the two shipped with the repository, the twelve with $LIEBAYES_BROAD_DIR.

#[test]
fn reads_the_trials() {
    for (name, path) in trials() {
        let log = read_broad(path).expect("trial reads");
        let n = log.len();
        assert!(n > 10_000, "{name}: {n} samples");
        assert!(
            (log.rate() - 2000.0 / 7.0).abs() < 1e-9,
            "{name}: rate {}",
            log.rate()
        );
        assert_eq!(log.accelerometer().len(), n);
        assert_eq!(log.magnetometer().expect("9D").len(), n);
        let reference = log.reference().expect("opt_quat");
        let movement = log.movement().expect("movement");
        assert_eq!((reference.len(), movement.len()), (n, n));
        let known = reference.iter().flatten().count();
        for q in reference.iter().flatten() {
            assert!((q.quaternion().norm() - 1.0).abs() < 1e-12);
        }
        let moving = movement.iter().filter(|&&m| m).count();
        // Column-major check: at rest at the start the accelerometer reads about g, which a
        // row-major misreading (mixing axes of different samples) would not give on every row.
        let g = log.accelerometer()[..100]
            .iter()
            .map(Vector3::norm)
            .sum::<f64>()
            / 100.0;
        assert!((g - 9.81).abs() < 0.3, "{name}: |acc| {g} at the start");
        println!(
            "{name}: {n} samples ({:.1} s), {} reference rows NaN, {moving} movement samples, \
             |acc| {g:.3} at the start",
            n as f64 / log.rate(),
            n - known
        );
    }
}

/// The magnetometer's sampling, measured: identical consecutive rows (the sensor holds its last
/// value), the run lengths, the effective rate, and the lag of the magnetometer behind the gyro.
/// The lag is the shift L that best explains each magnetometer change between two updates by the
/// gyro's prediction `Δm = −Σ ω_j × m Δt` over the same interval shifted back by L samples.
#[test]
fn magnetometer_sampling_facts() {
    const WINDOW: usize = 20;
    const MAX_LAG: usize = 20;
    let mut all_runs = Vec::new();
    let mut lags = Vec::new();
    for (name, path) in trials() {
        let log = read_broad(path).expect("trial reads");
        let mag = log.magnetometer().expect("9D");
        let gyr = log.gyroscope();
        let dt = log.interval();
        let updates: Vec<usize> = (1..mag.len()).filter(|&k| mag[k] != mag[k - 1]).collect();
        let repeats = mag.len() - 1 - updates.len();
        let runs: Vec<usize> = updates.windows(2).map(|w| w[1] - w[0]).collect();
        let mean_run = runs.iter().sum::<usize>() as f64 / runs.len() as f64;
        let mut histogram = std::collections::BTreeMap::new();
        for &r in &runs {
            *histogram.entry(r).or_insert(0_usize) += 1;
        }
        // Lag: residual of the predicted change over windows of WINDOW updates (about 28
        // samples, so that the change stands out of the noise), for each shift L in 0..=MAX_LAG.
        let residual = |lag: usize| -> f64 {
            let mut sum = 0.0;
            for w in updates.chunks_exact(WINDOW + 1).filter(|w| w[0] > lag) {
                let (a, b) = (w[0], w[WINDOW]);
                let m = mag[a];
                let predicted: Vector3<f64> = (a + 1 - lag..=b - lag)
                    .map(|j| -gyr[j].cross(&m) * dt)
                    .sum();
                sum += (mag[b] - mag[a] - predicted).norm_squared();
            }
            sum
        };
        let scores: Vec<f64> = (0..=MAX_LAG).map(residual).collect();
        let best = (0..scores.len())
            .min_by(|&i, &j| scores[i].total_cmp(&scores[j]))
            .expect("non-empty");
        // Parabola through the minimum and its neighbours: the lag to a fraction of a sample.
        let refined = if best == 0 || best == MAX_LAG {
            best as f64
        } else {
            let (l, c, r) = (scores[best - 1], scores[best], scores[best + 1]);
            best as f64 + 0.5 * (l - r) / (l - 2.0 * c + r)
        };
        println!(
            "{name}: {:.1} % of rows repeat the previous one, mean run {mean_run:.3} samples \
             ({:.1} Hz), runs {histogram:?}, lag {refined:.2} samples (residual at 0: {:.3e}, at \
             best: {:.3e})",
            100.0 * repeats as f64 / (mag.len() - 1) as f64,
            log.rate() / mean_run,
            scores[0],
            scores[best]
        );
        // The facts the docs report: about 29 % repeats, runs of 1 or 3 samples (never 2; rarely
        // 5 to 9), an effective rate near 200 Hz, and a lag of 2 to 5 samples.
        let fraction = repeats as f64 / (mag.len() - 1) as f64;
        assert!((0.28..0.31).contains(&fraction), "{name}: {fraction}");
        assert!(
            histogram.keys().all(|r| r % 2 == 1),
            "{name}: {histogram:?}"
        );
        assert!((1.40..1.43).contains(&mean_run), "{name}: {mean_run}");
        assert!((2.0..5.0).contains(&refined), "{name}: lag {refined}");
        all_runs.push(mean_run);
        lags.push(refined);
    }
    let mean_run = all_runs.iter().sum::<f64>() / all_runs.len() as f64;
    lags.sort_by(f64::total_cmp);
    let n = lags.len();
    let median = 0.5 * (lags[(n - 1) / 2] + lags[n / 2]);
    println!(
        "over the trials: mean run {mean_run:.3} samples, lags {lags:.2?}, median {median:.2}"
    );
}

/// A truncated copy of a real (compressed) trial gives a typed error, not a panic or a partial
/// log.
#[test]
fn truncated_trial_gives_a_typed_error() {
    let bytes = std::fs::read(shipped_dir().join(format!("{}.mat", SHIPPED[0]))).expect("read");
    let temp = temp_dir("truncated");
    // (The file's last element is the text `info`, which the reader does not use: cut before it.)
    for len in [100, 4096, 65_536, bytes.len() / 2] {
        let path = write(&temp, "truncated.mat", &bytes[..len]);
        let result = read_broad(&path).map(|log| log.len());
        println!("truncated to {len} bytes: {result:?}");
        assert!(
            matches!(
                result,
                Err(DataError::NotMatFile { .. } | DataError::MissingVariable { .. })
            ),
            "{len}: {result:?}"
        );
    }
    std::fs::remove_dir_all(temp).ok();
}

// ---------------------------------------------------------------------------------------------
// Malformed files.

/// A minimal MATLAB 5 file writer (uncompressed elements), for crafted malformed inputs.
enum MatData<'a> {
    Double(&'a [f64]),
    UInt8(&'a [u8]),
}

fn padded(bytes: &mut Vec<u8>, data_type: u32, data: &[u8]) {
    bytes.extend_from_slice(&data_type.to_le_bytes());
    bytes.extend_from_slice(&u32::try_from(data.len()).expect("small").to_le_bytes());
    bytes.extend_from_slice(data);
    while bytes.len() % 8 != 0 {
        bytes.push(0);
    }
}

fn mat_file(variables: &[(&str, [usize; 2], MatData<'_>)]) -> Vec<u8> {
    let mut out = vec![b' '; 116];
    out[..10].copy_from_slice(b"MATLAB 5.0");
    out.extend_from_slice(&[0; 8]);
    out.extend_from_slice(&0x0100_u16.to_le_bytes());
    out.extend_from_slice(b"IM");
    for (name, dims, data) in variables {
        let mut body = Vec::new();
        let class: u32 = match data {
            MatData::Double(_) => 6,
            MatData::UInt8(_) => 9,
        };
        let flags: Vec<u8> = [class, 0].iter().flat_map(|v| v.to_le_bytes()).collect();
        padded(&mut body, 6, &flags);
        let d: Vec<u8> = dims
            .iter()
            .flat_map(|&v| i32::try_from(v).expect("small").to_le_bytes())
            .collect();
        padded(&mut body, 5, &d);
        padded(&mut body, 1, name.as_bytes());
        match data {
            MatData::Double(values) => {
                let v: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
                padded(&mut body, 9, &v);
            }
            MatData::UInt8(values) => padded(&mut body, 2, values),
        }
        out.extend_from_slice(&14_u32.to_le_bytes());
        out.extend_from_slice(&u32::try_from(body.len()).expect("small").to_le_bytes());
        out.extend_from_slice(&body);
    }
    out
}

const N: usize = 4;

fn good_variables<'a>(
    gyr: &'a [f64],
    quat: &'a [f64],
    movement: &'a [u8],
) -> Vec<(&'static str, [usize; 2], MatData<'a>)> {
    vec![
        ("imu_gyr", [N, 3], MatData::Double(gyr)),
        ("imu_acc", [N, 3], MatData::Double(&ACC)),
        ("imu_mag", [N, 3], MatData::Double(&MAG)),
        ("opt_quat", [N, 4], MatData::Double(quat)),
        ("movement", [N, 1], MatData::UInt8(movement)),
        ("sampling_rate", [1, 1], MatData::Double(&[100.0])),
    ]
}

// Column-major N x 3: all x, then all y, then all z.
const GYR: [f64; 3 * N] = [
    0.1, 0.2, 0.3, 0.4, 1.0, 2.0, 3.0, 4.0, -1.0, -2.0, -3.0, -4.0,
];
const ACC: [f64; 3 * N] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 9.8, 9.8, 9.8, 9.8];
const MAG: [f64; 3 * N] = [
    0.0, 0.0, 0.0, 0.0, 20.0, 20.0, 20.0, 20.0, -40.0, -40.0, -40.0, -40.0,
];
const NAN: f64 = f64::NAN;
const QUAT: [f64; 4 * N] = [
    1.0, NAN, 0.0, 0.6, 0.0, NAN, 1.0, 0.0, 0.0, NAN, 0.0, 0.0, 0.0, NAN, 0.0, 0.8,
];

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).expect("write");
    path
}

#[test]
fn crafted_file_reads_column_major_with_nan_references() {
    let dir = temp_dir("crafted");
    let path = write(
        &dir,
        "good.mat",
        &mat_file(&good_variables(&GYR, &QUAT, &[0, 1, 1, 0])),
    );
    let log = read_broad(&path).expect("reads");
    assert_eq!(log.len(), N);
    assert_eq!(log.rate(), 100.0);
    assert_eq!(log.gyroscope()[1], Vector3::new(0.2, 2.0, -2.0));
    assert_eq!(
        log.magnetometer().expect("9D")[3],
        Vector3::new(0.0, 20.0, -40.0)
    );
    let reference = log.reference().expect("opt_quat");
    assert!(reference[1].is_none());
    let q3 = reference[3].expect("known");
    assert_eq!((q3.w, q3.i, q3.j, q3.k), (0.6, 0.0, 0.0, 0.8));
    assert_eq!(
        log.movement().expect("movement"),
        [false, true, true, false]
    );
    std::fs::remove_dir_all(dir).ok();
}

/// The file with every top-level element compressed (miCOMPRESSED holding the zlib stream of the
/// element), as MATLAB writes them; `edit` changes each element's bytes before compression.
fn compressed(uncompressed: &[u8], edit: impl Fn(&mut Vec<u8>)) -> Vec<u8> {
    use std::io::Write as _;
    let mut out = uncompressed[..128].to_vec();
    let mut at = 128;
    while at < uncompressed.len() {
        let size = u32::from_le_bytes(uncompressed[at + 4..at + 8].try_into().unwrap()) as usize;
        let mut element = uncompressed[at..at + 8 + size].to_vec();
        edit(&mut element);
        let mut encoder = libflate::zlib::Encoder::new(Vec::new()).unwrap();
        encoder.write_all(&element).unwrap();
        let stream = encoder.finish().into_result().unwrap();
        out.extend_from_slice(&15_u32.to_le_bytes());
        out.extend_from_slice(&u32::try_from(stream.len()).unwrap().to_le_bytes());
        out.extend_from_slice(&stream);
        at += 8 + size;
    }
    out
}

/// Compressed elements are checked before the parser sees them: a corrupt zlib stream (the parser
/// printed a stray line on it), dimensions that overflow inside a compressed element (the parser
/// panicked), and an element of another type (the parser printed it) are refused with the byte of
/// the element; a well-formed compressed file reads as its uncompressed original.
#[test]
fn compressed_elements_are_checked_before_parsing() {
    let dir = temp_dir("compressed");
    let good = mat_file(&good_variables(&GYR, &QUAT, &[0, 1, 1, 0]));
    let path = write(&dir, "compressed.mat", &compressed(&good, |_| ()));
    let log = read_broad(&path).expect("reads");
    assert_eq!(log.len(), N);
    assert_eq!(log.gyroscope()[1], Vector3::new(0.2, 2.0, -2.0));
    let mut corrupt = compressed(&good, |_| ());
    for b in &mut corrupt[140..150] {
        *b ^= 0x5a;
    }
    // Dimensions 2^20 x 2^20 in every element (the dimensions sub-element starts at byte 32).
    let huge = compressed(&good, |e| {
        e[32..36].copy_from_slice(&(1_i32 << 20).to_le_bytes());
        e[36..40].copy_from_slice(&(1_i32 << 20).to_le_bytes());
    });
    let other = compressed(&good, |e| e[..4].copy_from_slice(&9_u32.to_le_bytes()));
    let mut plain_other = good.clone();
    plain_other[128..132].copy_from_slice(&9_u32.to_le_bytes());
    for (name, bytes, needle) in [
        ("corrupt.mat", corrupt, "zlib"),
        ("huge.mat", huge, "dimensions"),
        ("other.mat", other, "type 9"),
        ("plain-other.mat", plain_other, "type 9"),
    ] {
        let path = write(&dir, name, &bytes);
        match read_broad(&path) {
            Err(DataError::NotMatFile { message, .. }) => {
                assert!(message.contains(needle), "{name}: {message}");
                assert!(message.contains("byte 128"), "{name}: {message}");
            }
            other => panic!("{name}: {other:?}"),
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn malformed_files_give_typed_errors() {
    let dir = temp_dir("malformed");
    let movement = [0, 1, 1, 0];
    let good = mat_file(&good_variables(&GYR, &QUAT, &movement));
    // Truncated, garbage, empty.
    for (name, bytes) in [
        ("truncated.mat", &good[..good.len() / 2]),
        (
            "garbage.mat",
            &b"this is not a MATLAB file at all, but it is long enough"[..],
        ),
        ("empty.mat", &[][..]),
    ] {
        let path = write(&dir, name, bytes);
        let result = read_broad(&path);
        println!("{name}: {result:?}");
        match result {
            Err(
                DataError::NotMatFile { origin, .. } | DataError::MissingVariable { origin, .. },
            ) => {
                assert!(origin.ends_with(name));
            }
            other => panic!("{name}: {other:?}"),
        }
    }
    // Missing imu_gyr.
    let mut vars = good_variables(&GYR, &QUAT, &movement);
    vars.remove(0);
    let path = write(&dir, "no_gyr.mat", &mat_file(&vars));
    let err = read_broad(&path).expect_err("no imu_gyr");
    assert!(
        matches!(&err, DataError::MissingVariable { variable, .. } if variable == "imu_gyr"),
        "{err:?}"
    );
    println!("{err}");
    // imu_acc of the wrong shape (N x 2 taken from its first 8 values).
    let mut vars = good_variables(&GYR, &QUAT, &movement);
    vars[1] = ("imu_acc", [N, 2], MatData::Double(&ACC[..2 * N]));
    let err = read_broad(write(&dir, "shape.mat", &mat_file(&vars))).expect_err("shape");
    assert!(
        matches!(&err, DataError::Shape { variable, .. } if variable == "imu_acc"),
        "{err:?}"
    );
    // imu_gyr as uint8.
    let bytes = [0_u8; 3 * N];
    let mut vars = good_variables(&GYR, &QUAT, &movement);
    vars[0] = ("imu_gyr", [N, 3], MatData::UInt8(&bytes));
    let err = read_broad(write(&dir, "type.mat", &mat_file(&vars))).expect_err("type");
    assert!(
        matches!(&err, DataError::Type { variable, .. } if variable == "imu_gyr"),
        "{err:?}"
    );
    // A NaN gyroscope value at row 2.
    let mut gyr = GYR;
    gyr[N + 2] = f64::NAN;
    let vars = good_variables(&gyr, &QUAT, &movement);
    let err = read_broad(write(&dir, "nan.mat", &mat_file(&vars))).expect_err("nan");
    assert!(
        matches!(&err, DataError::BadValue { row: 2, variable, .. } if variable == "imu_gyr"),
        "{err:?}"
    );
    println!("{err}");
    // A reference quaternion of norm 2.
    let mut quat = QUAT;
    quat[0] = 2.0;
    let vars = good_variables(&GYR, &quat, &movement);
    let err = read_broad(write(&dir, "norm.mat", &mat_file(&vars))).expect_err("norm");
    assert!(
        matches!(&err, DataError::BadValue { row: 0, .. }),
        "{err:?}"
    );
    // A movement mask of the wrong length.
    let vars = good_variables(&GYR, &QUAT, &movement[..3]);
    let mut vars = vars;
    vars[4] = ("movement", [3, 1], MatData::UInt8(&movement[..3]));
    let err = read_broad(write(&dir, "movement.mat", &mat_file(&vars))).expect_err("length");
    assert!(
        matches!(&err, DataError::Length { found: 3, .. }),
        "{err:?}"
    );
    // A missing file.
    let err = read_broad(dir.join("absent.mat")).expect_err("absent");
    assert!(matches!(err, DataError::Io { .. }), "{err:?}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn imu_log_validates_its_input() {
    let v = vec![Vector3::new(0.0, 0.0, 1.0); 3];
    assert!(ImuLog::new(100.0, v.clone(), v.clone(), Some(v.clone())).is_ok());
    for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            ImuLog::new(rate, v.clone(), v.clone(), None),
            Err(DataError::BadValue { .. })
        ));
    }
    assert!(matches!(
        ImuLog::new(100.0, v.clone(), v[..2].to_vec(), None),
        Err(DataError::Length {
            expected: 3,
            found: 2,
            ..
        })
    ));
    let mut bad = v.clone();
    bad[1].y = f64::INFINITY;
    assert!(matches!(
        ImuLog::new(100.0, v.clone(), v.clone(), Some(bad)),
        Err(DataError::BadValue { row: 1, .. })
    ));
    // A gyroscope row beyond MAX_ANGULAR_RATE (1e4 rad/s) is refused, naming its row; the limit
    // itself is accepted.
    let mut fast = v.clone();
    fast[2] = Vector3::new(1e5, 0.0, 0.0);
    let err = ImuLog::new(100.0, fast.clone(), v.clone(), None).unwrap_err();
    assert!(
        matches!(&err, DataError::BadValue { variable, row: 2, .. } if variable == "gyroscope"),
        "{err:?}"
    );
    assert!(err.to_string().contains("row 2"), "{err}");
    fast[2] = Vector3::new(1e4, 0.0, 0.0);
    assert!(ImuLog::new(100.0, fast, v.clone(), None).is_ok());
    let log = ImuLog::new(100.0, v.clone(), v.clone(), None).expect("valid");
    assert!(log.clone().with_reference(vec![None; 2]).is_err());
    assert!(log.clone().with_movement(vec![true; 4]).is_err());
}

// ---------------------------------------------------------------------------------------------
// The metric.

fn yaw(deg: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), deg.to_radians())
}

fn about(axis: Vector3<f64>, deg: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), deg.to_radians())
}

#[test]
fn metric_hand_cases() {
    let reference = UnitQuaternion::from_euler_angles(0.3, -0.5, 2.0);
    // A pure heading error of 10°.
    let e = sample_errors(&(yaw(10.0) * reference), &reference);
    assert!((e.heading.to_degrees() - 10.0).abs() < 1e-9, "{e:?}");
    assert!((e.total.to_degrees() - 10.0).abs() < 1e-9);
    assert!(e.inclination.to_degrees().abs() < 1e-6);
    // A pure tilt of 7° about a horizontal axis.
    let e = sample_errors(
        &(about(Vector3::new(1.0, 2.0, 0.0), 7.0) * reference),
        &reference,
    );
    assert!((e.inclination.to_degrees() - 7.0).abs() < 1e-9, "{e:?}");
    assert!(e.heading.abs() < 1e-12);
    // Exactly 180° about a horizontal axis: e_w = e_z = 0, heading 0 (not NaN).
    let flip = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(0.0, 0.6, 0.8, 0.0));
    let e = sample_errors(&flip, &UnitQuaternion::identity());
    assert_eq!(e.heading, 0.0);
    assert!((e.total.to_degrees() - 180.0).abs() < 1e-12, "{e:?}");
    assert!((e.inclination.to_degrees() - 180.0).abs() < 1e-12, "{e:?}");
    // A tiny error is resolved (acos would not resolve it).
    let e = sample_errors(
        &about(Vector3::new(0.0, 1.0, 0.0), 1e-9),
        &UnitQuaternion::identity(),
    );
    assert!(
        (e.inclination.to_degrees() / 1e-9 - 1.0).abs() < 1e-9,
        "{e:?}"
    );
    assert!((e.total.to_degrees() / 1e-9 - 1.0).abs() < 1e-9, "{e:?}");
    // 180° about the vertical: e_w = 0 gives heading 180°.
    let e = sample_errors(&(yaw(180.0) * reference), &reference);
    assert!((e.heading.to_degrees() - 180.0).abs() < 1e-6, "{e:?}");
    assert!(e.inclination.to_degrees().abs() < 1e-6);
    // No error.
    let e = sample_errors(&reference, &reference);
    assert_eq!((e.total, e.heading, e.inclination), (0.0, 0.0, 0.0));
}

/// Four samples at rest with an identity reference: scored are the first two (the third has no
/// reference, the fourth is outside the movement mask).
fn four_samples_two_scored() -> ImuLog {
    let v = vec![Vector3::new(0.0, 0.0, 9.8); 4];
    let truth = UnitQuaternion::identity();
    ImuLog::new(100.0, v.clone(), v, None)
        .and_then(|l| l.with_reference(vec![Some(truth), Some(truth), None, Some(truth)]))
        .and_then(|l| l.with_movement(vec![true, true, true, false]))
        .expect("valid")
}

/// A recording of `log` with the given estimates, one per sample, the truths as its scenario
/// gives them.
fn recording(log: &ImuLog, estimates: &[AttitudeEstimate]) -> LogRecording {
    let scenario = LogScenario::new(log.clone()).expect("a non-empty log");
    assert_eq!(estimates.len(), log.len());
    Recording {
        steps: scenario
            .steps()
            .zip(estimates)
            .map(|(step, estimate)| Recorded {
                time: step.time,
                truth: step.truth,
                estimate: *estimate,
                update: None,
            })
            .collect(),
        smoothed: Vec::new(),
        seconds: 1.0,
    }
}

fn without_covariance(orientation: UnitQuaternion<f64>) -> AttitudeEstimate {
    AttitudeEstimate {
        orientation,
        covariance: None,
    }
}

#[test]
fn trial_rmse_over_movement_samples_with_a_reference() {
    let log = four_samples_two_scored();
    // The truth counts where the sample has a reference and is inside the movement mask.
    let scenario = LogScenario::new(log.clone()).expect("a non-empty log");
    let truths: Vec<bool> = scenario.steps().map(|s| s.truth.is_some()).collect();
    assert_eq!(truths, [true, true, false, false]);
    // Errors 3° and 4° on the two scored samples; huge errors on the unscored ones.
    let estimates = [yaw(3.0), yaw(4.0), yaw(90.0), yaw(90.0)].map(without_covariance);
    let score = LogScore::of(&recording(&log, &estimates));
    let e = score.errors().expect("scored");
    assert_eq!(e.samples, 2);
    let expected = (12.5_f64).sqrt(); // √((9 + 16) / 2)
    assert!(
        (e.heading - expected).abs() < 1e-9 && (e.total - expected).abs() < 1e-9,
        "{e:?}"
    );
    assert!(e.inclination.abs() < 1e-6);
    assert_eq!(score.samples, 4);
    assert_eq!(score.nees(), None, "no covariance, no NEES");
    let none = log.clone().with_movement(vec![false; 4]).expect("valid");
    assert_eq!(LogScore::of(&recording(&none, &estimates)).errors(), None);
}

/// The NEES means over the scored samples, by hand. The truth is the identity, so the world-frame
/// error is `δθ = log(R_true R̂ᵀ) = −r` for an estimate of rotation vector r: `r = (0, 0, 3°)` on
/// the first scored sample and `(1°, 0, 4°)` on the second. With the covariance of heading σ 2°
/// (independent) and tilt block `s² [[1, ρ], [ρ, 1]]`, s = 0.5°, ρ = 0.5 (whose inverse is
/// `[[1, −ρ], [−ρ, 1]] / (s² (1 − ρ²))`), the heading NEES (χ²(1)) are 9/4 and 16/4, the tilt
/// NEES (χ²(2)) 0 and `(1/0.5)² / (1 − ρ²)` = 16/3, and the whole (χ²(3)) their sums; the
/// unscored samples (no reference, outside the mask) do not count.
#[test]
fn nees_means_over_the_scored_samples() {
    let log = four_samples_two_scored();
    let (s, rho, h) = (0.5f64.to_radians(), 0.5, 2f64.to_radians());
    let covariance = nalgebra::Matrix3::new(
        s * s,
        rho * s * s,
        0.0,
        rho * s * s,
        s * s,
        0.0,
        0.0,
        0.0,
        h * h,
    );
    let with = |r: Vector3<f64>| AttitudeEstimate {
        orientation: UnitQuaternion::from_scaled_axis(r.map(f64::to_radians)),
        covariance: Some(covariance),
    };
    let estimates = [
        with(Vector3::new(0.0, 0.0, 3.0)),
        with(Vector3::new(1.0, 0.0, 4.0)),
        with(Vector3::new(0.0, 0.0, 90.0)),
        with(Vector3::new(0.0, 0.0, 90.0)),
    ];
    let score = LogScore::of(&recording(&log, &estimates));
    let [heading, tilt, whole] = score.nees().expect("a covariance");
    // Per scored sample: (heading, tilt) NEES; the whole is their sum (independent blocks).
    let samples = [(9.0 / 4.0, 0.0), (16.0 / 4.0, 16.0 / 3.0)];
    let mean = |f: fn(&(f64, f64)) -> f64| samples.iter().map(f).sum::<f64>() / 2.0;
    let expected = [mean(|s| s.0), mean(|s| s.1), mean(|s| s.0 + s.1)];
    for (ours, hand) in [heading, tilt, whole].iter().zip(expected) {
        assert!((ours - hand).abs() < 1e-9, "{ours} vs {hand}");
    }
    assert_eq!(score.stats("nees").expect("a metric").count(), 2);
    // Pooling a log with itself keeps the means and doubles the count.
    let mut pooled = score.clone();
    pooled.merge(&score).unwrap();
    assert_eq!(pooled.stats("nees").expect("a metric").count(), 4);
    let again = pooled.nees().expect("a covariance");
    assert!((again[0] - heading).abs() < 1e-12);
}

fn rotation() -> impl Strategy<Value = UnitQuaternion<f64>> {
    (-3.0..3.0_f64, -1.5..1.5_f64, -3.0..3.0_f64)
        .prop_map(|(r, p, y)| UnitQuaternion::from_euler_angles(r, p, y))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// An error built as a heading rotation ψ about the vertical after a tilt θ about a horizontal
    /// axis is measured as heading ψ and inclination θ, whatever the reference.
    #[test]
    fn metric_recovers_heading_and_tilt(
        psi in 0.0..179.0_f64, theta in 0.0..179.0_f64, phi in -180.0..180.0_f64,
        reference in rotation(),
    ) {
        let axis = Vector3::new(phi.to_radians().cos(), phi.to_radians().sin(), 0.0);
        let error = yaw(psi) * about(axis, theta);
        let e = sample_errors(&(error * reference), &reference);
        prop_assert!((e.heading.to_degrees() - psi).abs() < 1e-6, "{e:?}");
        prop_assert!((e.inclination.to_degrees() - theta).abs() < 1e-6, "{e:?}");
        prop_assert!((e.total - error.angle()).abs() < 1e-6);
    }

    /// The errors do not change with the sign of either quaternion, a common change of the
    /// sensor frame (right product), or swapping estimate and reference; heading and inclination
    /// never exceed the total.
    #[test]
    fn metric_invariances(a in rotation(), b in rotation(), c in rotation()) {
        let e = sample_errors(&a, &b);
        let close = |x: f64, y: f64| (x - y).abs() < 1e-9;
        for other in [
            sample_errors(&UnitQuaternion::new_unchecked(-a.into_inner()), &b),
            sample_errors(&(a * c), &(b * c)),
            sample_errors(&b, &a),
        ] {
            prop_assert!(close(e.total, other.total) && close(e.heading, other.heading)
                && close(e.inclination, other.inclination), "{e:?} vs {other:?}");
        }
        prop_assert!(e.heading <= e.total + 1e-12 && e.inclination <= e.total + 1e-12);
    }
}

// ---------------------------------------------------------------------------------------------
// CSV.

const IMU_CSV: &str = "t,gx,gy,gz,ax,ay,az,mx,my,mz
0.00,0.1,0.2,0.3,0,0,9.8,0,20,-40
0.01,0.1,0.2,0.3,0,0,9.8,0,20,-40
0.02, 0.1 ,0.2,0.3,0,0,9.8,0,20,-40
0.0301,-1e-3,0.2,0.3,0,0,9.8,1,20,-40
";

#[test]
fn reads_an_imu_csv_log() {
    let log = read_imu_csv(IMU_CSV.as_bytes(), "imu.csv").expect("reads");
    assert_eq!(log.len(), 4);
    assert!((log.rate() - 3.0 / 0.0301).abs() < 1e-9);
    assert_eq!(log.gyroscope()[3], Vector3::new(-1e-3, 0.2, 0.3));
    assert_eq!(
        log.magnetometer().expect("9D")[3],
        Vector3::new(1.0, 20.0, -40.0)
    );
    let six = "t,gx,gy,gz,ax,ay,az\r\n0,0,0,0,0,0,9.8\r\n0.5,0,0,0,0,0,9.8\r\n";
    let log = read_imu_csv(six.as_bytes(), "six.csv").expect("reads 6D");
    assert!(log.magnetometer().is_none() && log.rate() == 2.0);
}

#[test]
fn malformed_csv_names_line_and_column() {
    let cases: [(&str, usize, usize); 8] = [
        ("t,gx,gy,gz,ax,ay\n0,0,0,0,0,0\n", 1, 0),
        (
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n0.1,0,0,0,x,0,1\n",
            3,
            5,
        ),
        ("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n0.1,0,0,0,0,0\n", 3, 7),
        (
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n0.1,0,0,0,0,0,1,2\n",
            3,
            8,
        ),
        (
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n0.1,0,0,inf,0,0,1\n",
            3,
            4,
        ),
        (
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n\n0.2,0,0,0,0,0,1\n",
            3,
            0,
        ),
        // Steps 0.1 then 0.2: the mean step is 0.15, each 33 % off.
        (
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n0.1,0,0,0,0,0,1\n0.3,0,0,0,0,0,1\n",
            3,
            1,
        ),
        ("t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n", 2, 0),
    ];
    for (text, line, column) in cases {
        match read_imu_csv(text.as_bytes(), "bad.csv") {
            Err(DataError::Csv {
                line: l,
                column: c,
                ref message,
                ..
            }) => {
                assert_eq!((l, c), (line, column), "{text:?}: {message}");
            }
            other => panic!("{text:?}: {other:?}"),
        }
    }
    // A step just inside the tolerance is accepted, just outside refused.
    let step = |s: f64| {
        format!(
            "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,1\n1,0,0,0,0,0,1\n{},0,0,0,0,0,1\n",
            2.0 + s
        )
    };
    assert!(read_imu_csv(step(RATE_TOLERANCE).as_bytes(), "ok.csv").is_ok());
    assert!(read_imu_csv(step(3.0 * RATE_TOLERANCE).as_bytes(), "off.csv").is_err());
    let long = format!("t,gx,gy,gz,ax,ay,az\n{}\n", "0".repeat(10_000));
    assert!(matches!(
        read_imu_csv(long.as_bytes(), "long.csv"),
        Err(DataError::Csv { line: 2, .. })
    ));
}

#[test]
fn estimates_round_trip_through_csv() {
    let times: Vec<f64> = (0..50).map(|k| f64::from(k) * 0.0035).collect();
    let orientations: Vec<UnitQuaternion<f64>> = (0..50)
        .map(|k| {
            let k = f64::from(k);
            UnitQuaternion::from_euler_angles(0.1 * k, -0.03 * k, 1.0 / (k + 1.0))
        })
        .collect();
    let mut buffer = Vec::new();
    write_estimates_csv(&mut buffer, &times, &orientations, "memory").expect("writes");
    let text = String::from_utf8(buffer.clone()).expect("utf-8");
    assert!(text.starts_with("t,w,x,y,z\n"));
    let back = read_estimates_csv(buffer.as_slice(), "memory").expect("reads");
    assert_eq!(back.times, times);
    assert_eq!(back.orientations, orientations);
    // A quaternion not of unit norm, a bad header, a mismatched write.
    let bad = "t,w,x,y,z\n0,1,0,0,0\n1,1,1,0,0\n";
    assert!(matches!(
        read_estimates_csv(bad.as_bytes(), "bad.csv"),
        Err(DataError::Csv {
            line: 3,
            column: 2,
            ..
        })
    ));
    assert!(matches!(
        read_estimates_csv("t,x,y,z,w\n".as_bytes(), "bad.csv"),
        Err(DataError::Csv { line: 1, .. })
    ));
    assert!(matches!(
        write_estimates_csv(Vec::new(), &times[..3], &orientations, "memory"),
        Err(DataError::Length { .. })
    ));
    // A quaternion of norm 1.0000005 (written with few digits) was kept as it was, off the unit
    // sphere; it is normalised now.
    let short = "t,w,x,y,z\n0,1.0000005,0,0,0\n1,0.6,0.8000004,0,0\n";
    let read = read_estimates_csv(short.as_bytes(), "short.csv").expect("reads");
    for q in &read.orientations {
        assert!(
            (q.quaternion().norm() - 1.0).abs() <= 2.0 * f64::EPSILON,
            "{q:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// The simulator.

fn quiet() -> SimulationSettings {
    SimulationSettings {
        gyro_noise: 0.0,
        acc_noise: 0.0,
        mag_noise: 0.0,
        gyro_bias_walk: 0.0,
        initial_gyro_bias: Vector3::zeros(),
        initial_orientation: UnitQuaternion::from_euler_angles(0.2, -0.4, 1.3),
        ..SimulationSettings::default()
    }
}

/// Without noise or bias, integrating the gyroscope from the first true orientation gives the
/// truth back at every sample.
#[test]
fn simulated_gyro_integrates_to_the_truth() {
    let log = simulate(&quiet(), 7).expect("valid");
    let truth = log.reference().expect("truth");
    let dt = log.interval();
    let mut q = truth[0].expect("known");
    let mut worst = 0.0_f64;
    for (k, w) in log.gyroscope().iter().enumerate() {
        worst = worst.max(q.angle_to(&truth[k].expect("known")));
        // An independent integration: the closed form of exp for a constant rate.
        let angle = w.norm() * dt;
        let step = if angle > 0.0 {
            let axis = w / w.norm();
            nalgebra::Quaternion::from_parts((0.5 * angle).cos(), axis * (0.5 * angle).sin())
        } else {
            nalgebra::Quaternion::identity()
        };
        q = UnitQuaternion::from_quaternion(q.into_inner() * step);
    }
    println!("largest angle between integrated gyro and truth: {worst:.3e} rad");
    assert!(worst < 1e-9, "{worst}");
    // The motion is not trivial: the rates have about the RMS asked for.
    let rms = (log
        .gyroscope()
        .iter()
        .map(Vector3::norm_squared)
        .sum::<f64>()
        / (3 * log.len()) as f64)
        .sqrt();
    assert!((0.6..1.4).contains(&rms), "rate RMS {rms}");
}

/// At rest the accelerometer reads gravity and the magnetometer the earth field, both rotated
/// into the sensor frame (checked with the rotation matrix); a disturbance adds its offset in its
/// interval only; the linear acceleration stays within its bound.
#[test]
fn simulated_accelerometer_and_magnetometer() {
    let offset = Vector3::new(5.0, -3.0, 2.0);
    let settings = SimulationSettings {
        rotation_rate: 0.0,
        acceleration_bound: 0.0,
        disturbances: vec![Disturbance {
            start: 1.0,
            end: 2.0,
            offset,
        }],
        ..quiet()
    };
    let log = simulate(&settings, 1).expect("valid");
    let r = settings
        .initial_orientation
        .to_rotation_matrix()
        .into_inner();
    let gravity = r.transpose() * Vector3::new(0.0, 0.0, 9.81);
    let field = r.transpose() * settings.earth_field;
    let disturbed = r.transpose() * (settings.earth_field + offset);
    for (k, (a, m)) in log
        .accelerometer()
        .iter()
        .zip(log.magnetometer().expect("9D"))
        .enumerate()
    {
        let t = k as f64 * log.interval();
        assert!((a - gravity).norm() < 1e-12, "{k}: {a}");
        let expected = if (1.0..2.0).contains(&t) {
            disturbed
        } else {
            field
        };
        assert!((m - expected).norm() < 1e-12, "{k}: {m}");
    }
    // Hand-held motion: the ENU linear acceleration is bounded componentwise. Each sample is
    // taken at its interval's middle, halfway from one true orientation to the next (the rate is
    // held over the interval, so the halfway rotation is the slerp's).
    let moving = SimulationSettings {
        acceleration_bound: 2.5,
        ..quiet()
    };
    let log = simulate(&moving, 3).expect("valid");
    let mut largest = 0.0_f64;
    for (a, q) in log
        .accelerometer()
        .iter()
        .zip(log.reference().expect("truth").windows(2))
    {
        let halfway = q[0].expect("known").slerp(&q[1].expect("known"), 0.5);
        let linear = halfway * a - Vector3::new(0.0, 0.0, 9.81);
        largest = largest.max(linear.amax());
    }
    assert!(
        largest <= 2.5 + 1e-9 && largest > 0.5,
        "largest component {largest}"
    );
}

/// The noises have the standard deviations asked for (Monte Carlo, 17 143 samples: the
/// standard error of a standard deviation is 0.5 %), the bias walks, and the seed decides.
#[test]
fn simulated_noise_levels() {
    let settings = SimulationSettings {
        rotation_rate: 0.0,
        acceleration_bound: 0.0,
        gyro_noise: 0.01,
        acc_noise: 0.1,
        mag_noise: 0.7,
        ..quiet()
    };
    let log = simulate(&settings, 11).expect("valid");
    let r = settings
        .initial_orientation
        .to_rotation_matrix()
        .into_inner();
    let std =
        |values: Vec<f64>| (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt();
    let gyro = std(log
        .gyroscope()
        .iter()
        .flat_map(|g| g.iter().copied().collect::<Vec<_>>())
        .collect());
    let gravity = r.transpose() * Vector3::new(0.0, 0.0, 9.81);
    let acc = std(log
        .accelerometer()
        .iter()
        .flat_map(|a| (a - gravity).iter().copied().collect::<Vec<_>>())
        .collect());
    let field = r.transpose() * settings.earth_field;
    let mag = std(log
        .magnetometer()
        .expect("9D")
        .iter()
        .flat_map(|m| (m - field).iter().copied().collect::<Vec<_>>())
        .collect());
    println!("noise std: gyro {gyro:.5}, acc {acc:.5}, mag {mag:.5}");
    assert!((gyro / 0.01 - 1.0).abs() < 0.03);
    assert!((acc / 0.1 - 1.0).abs() < 0.03);
    assert!((mag / 0.7 - 1.0).abs() < 0.03);
    // A bias walk of 0.01 rad/s/√s over 60 s: the final bias has a std of 0.077 rad/s per axis.
    let walking = SimulationSettings {
        gyro_bias_walk: 0.01,
        ..settings.clone()
    };
    let mut spread = Vec::new();
    for seed in 0..40 {
        let log = simulate(
            &SimulationSettings {
                gyro_noise: 0.0,
                ..walking.clone()
            },
            seed,
        )
        .expect("valid");
        spread.extend(log.gyroscope().last().expect("samples").iter().copied());
    }
    let walk = std(spread);
    let expected = 0.01 * (settings.samples as f64 / settings.rate).sqrt();
    println!("bias walk std {walk:.4}, expected {expected:.4}");
    assert!((walk / expected - 1.0).abs() < 0.25, "{walk} vs {expected}");
    assert_eq!(simulate(&settings, 5), simulate(&settings, 5));
    assert_ne!(simulate(&settings, 5), simulate(&settings, 6));
    for bad in [
        SimulationSettings {
            rate: 0.0,
            ..settings.clone()
        },
        SimulationSettings {
            samples: 0,
            ..settings.clone()
        },
        SimulationSettings {
            gyro_noise: -1.0,
            ..settings.clone()
        },
        SimulationSettings {
            earth_field: Vector3::zeros(),
            ..settings.clone()
        },
        SimulationSettings {
            disturbances: vec![Disturbance {
                start: 2.0,
                end: 1.0,
                offset: Vector3::x(),
            }],
            ..settings.clone()
        },
        SimulationSettings {
            field_offset: Some(FieldOffset {
                sigma: 0.0,
                correlation_time: 10.0,
            }),
            ..settings.clone()
        },
    ] {
        assert!(
            matches!(simulate(&bad, 0), Err(DataError::BadValue { .. })),
            "{bad:?}"
        );
    }
}

/// The field's heading offset: with no magnetometer noise the field rotated into ENU by the truth
/// points `c` east of north, c drawn from its stationary N(0, σ_c²) (400 runs: the spread within
/// 12 % of σ_c, 3.4 standard errors), and a correlation time of 10 s makes c(1 s) correlate with
/// c(0) by exp(−0.1) = 0.905 (within 0.05).
#[test]
fn simulated_field_offset() {
    let sigma = 4f64.to_radians();
    let settings = SimulationSettings {
        samples: 287,
        mag_noise: 0.0,
        field_offset: Some(FieldOffset {
            sigma,
            correlation_time: 10.0,
        }),
        ..SimulationSettings::default()
    };
    let heading = |log: &ImuLog, k: usize| {
        let world = log.reference().unwrap()[k].unwrap() * log.magnetometer().unwrap()[k];
        world.x.atan2(world.y)
    };
    let (mut first, mut last) = (Vec::new(), Vec::new());
    for seed in 0..400 {
        let log = simulate(&settings, seed).expect("valid");
        first.push(heading(&log, 0));
        last.push(heading(&log, 286));
    }
    let n = first.len() as f64;
    let (mean_a, mean_b) = (first.iter().sum::<f64>() / n, last.iter().sum::<f64>() / n);
    let moment = |x: &[f64], mx: f64, y: &[f64], my: f64| {
        x.iter()
            .zip(y)
            .map(|(a, b)| (a - mx) * (b - my))
            .sum::<f64>()
            / (n - 1.0)
    };
    let spread = moment(&first, mean_a, &first, mean_a).sqrt();
    assert!((spread / sigma - 1.0).abs() < 0.12, "{spread} vs {sigma}");
    let correlation = moment(&first, mean_a, &last, mean_b)
        / (spread * moment(&last, mean_b, &last, mean_b).sqrt());
    println!(
        "offset spread {spread:.4} rad (σ_c {sigma:.4}), correlation over 1 s {correlation:.3}"
    );
    assert!(
        (correlation - (-0.1f64).exp()).abs() < 0.05,
        "{correlation}"
    );
}

// ---------------------------------------------------------------------------------------------
// Bad input: NaN, ±∞, ±MAX, subnormals, zeros and huge sizes, and mutated files, each call on its
// own thread under a time limit (the bad-input harness): an error or a finite result, no panic.

fn fuzz_vector() -> impl Strategy<Value = Vector3<f64>> {
    (fuzz::value(), fuzz::value(), fuzz::value()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn finite(estimate: &AttitudeEstimate) -> bool {
    estimate.orientation.coords.iter().all(|c| c.is_finite())
        && estimate
            .covariance
            .is_none_or(|p| p.iter().all(|c| c.is_finite()))
}

#[test]
fn bad_input_logs_and_madgwick() {
    let strategy = (
        proptest::collection::vec((fuzz_vector(), fuzz_vector(), fuzz_vector()), 0..4),
        fuzz::value(),
        fuzz::value(),
    );
    fuzz::run(
        "ImuLog::new, Madgwick's run_log",
        strategy,
        |(rows, rate, beta)| {
            fuzz::call("Madgwick's run_log", move || {
                let gyr = rows.iter().map(|r| r.0).collect();
                let acc = rows.iter().map(|r| r.1).collect();
                let mag = rows.iter().map(|r| r.2).collect();
                let Some(log) = fuzz::counted(ImuLog::new(rate, gyr, acc, Some(mag))) else {
                    return;
                };
                for (log, sensors) in [
                    (log.clone(), Sensors::NineD),
                    (log.without_magnetometer(), Sensors::SixD),
                ] {
                    let Some(scenario) = fuzz::counted(LogScenario::new(log)) else {
                        continue;
                    };
                    let method = Method::Madgwick { beta, sensors };
                    if let Some(recording) = fuzz::counted(run_log("fuzz", &scenario, &method)) {
                        assert!(
                            recording.steps.iter().all(|s| finite(&s.estimate)),
                            "non-finite estimate"
                        );
                    }
                }
            });
        },
    );
}

/// Every attitude filter (the six methods), after a few good samples: a NaN or out-of-range
/// gyroscope or accelerometer reading (beyond `MAX_ANGULAR_RATE`, `MAX_SPECIFIC_FORCE`) and a NaN
/// or out-of-range magnetometer reading (beyond `MAX_FIELD`) are refused, naming the reading, and
/// the filter is left exactly as it was: its debug form (which writes every field's value, −0
/// apart from 0) and its estimate bit for bit.
#[test]
fn a_refused_step_leaves_every_filter_unchanged() {
    let good = ImuSample {
        gyro: Vector3::new(0.1, -0.2, 0.3),
        acc: Vector3::new(0.3, -0.2, 9.8),
    };
    let field = Vector3::new(0.0, 20.0, -40.0);
    let bad_samples = [
        (Vector3::new(f64::NAN, 0.0, 0.0), good.acc, "gyroscope"),
        (Vector3::new(1e200, 0.0, 0.0), good.acc, "gyroscope"),
        (
            good.gyro,
            Vector3::new(0.0, f64::INFINITY, 0.0),
            "accelerometer",
        ),
        (good.gyro, Vector3::new(0.0, 0.0, 1e5), "accelerometer"),
    ];
    let bad_fields = [
        Vector3::new(0.0, f64::NAN, 0.0),
        Vector3::new(1e10, 0.0, 0.0),
    ];
    let bits = |e: AttitudeEstimate| -> Vec<u64> {
        let covariance = e.covariance.map(|p| p.iter().copied().collect::<Vec<_>>());
        e.orientation
            .coords
            .iter()
            .chain(covariance.iter().flatten())
            .map(|v| v.to_bits())
            .collect()
    };
    for name in METHOD_NAMES {
        let mut filter = Method::from_name(name)
            .and_then(|m| m.build(100.0))
            .expect("a filter");
        for _ in 0..20 {
            filter.predict(&good).expect("a step");
            filter.update(&field).expect("a step");
        }
        let before = format!("{filter:?}");
        let estimate = bits(filter.estimate().expect("an estimate"));
        for (gyro, acc, reading) in bad_samples {
            let err = filter.predict(&ImuSample { gyro, acc }).unwrap_err();
            assert!(err.to_string().contains(reading), "{name}: {err}");
            assert_eq!(format!("{filter:?}"), before, "{name}: {err}");
        }
        for z in bad_fields {
            let err = filter.update(&z).unwrap_err();
            assert!(err.to_string().contains("magnetometer"), "{name}: {err}");
            assert_eq!(format!("{filter:?}"), before, "{name}: {err}");
        }
        assert_eq!(
            bits(filter.estimate().expect("an estimate")),
            estimate,
            "{name}"
        );
    }
}

/// Every attitude filter, fresh and after a good sample, given a step of arbitrary readings:
/// a refused `predict` or `update` leaves it exactly as it was (its debug form, which writes
/// every field's value), an accepted one leaves a finite estimate.
#[test]
fn bad_input_filter_steps_are_all_or_nothing() {
    let strategy = (fuzz_vector(), fuzz_vector(), fuzz_vector(), fuzz::value());
    fuzz::run(
        "attitude filters' steps",
        strategy,
        |(gyro, acc, mag, rate)| {
            fuzz::call("attitude filters' steps", move || {
                let good = ImuSample {
                    gyro: Vector3::new(0.1, -0.2, 0.3),
                    acc: Vector3::new(0.3, -0.2, 9.8),
                };
                let field = Vector3::new(0.0, 20.0, -40.0);
                for name in METHOD_NAMES {
                    let method = Method::from_name(name).expect("a method name");
                    let Some(fresh) = fuzz::counted(method.build(rate)) else {
                        continue;
                    };
                    let mut warm = fresh.clone();
                    if warm.predict(&good).is_err() || warm.update(&field).is_err() {
                        warm = fresh.clone();
                    }
                    for mut filter in [fresh, warm] {
                        let before = format!("{filter:?}");
                        if fuzz::counted(filter.predict(&ImuSample { gyro, acc })).is_none() {
                            assert_eq!(format!("{filter:?}"), before, "{name}: predict");
                        } else if let Ok(e) = filter.estimate() {
                            assert!(finite(&e), "{name}: non-finite estimate");
                        }
                        let before = format!("{filter:?}");
                        if fuzz::counted(filter.update(&mag)).is_none() {
                            assert_eq!(format!("{filter:?}"), before, "{name}: update");
                        } else if let Ok(e) = filter.estimate() {
                            assert!(finite(&e), "{name}: non-finite estimate");
                        }
                    }
                }
            });
        },
    );
}

#[test]
fn bad_input_csv() {
    let field = prop_oneof![
        fuzz::value().prop_map(|v| v.to_string()),
        Just(String::new()),
        Just("x".to_owned()),
        Just("1e999".to_owned()),
    ];
    let line = proptest::collection::vec(field, 0..12).prop_map(|f| f.join(","));
    let text = proptest::collection::vec(line, 0..6)
        .prop_map(|lines| format!("t,gx,gy,gz,ax,ay,az,mx,my,mz\n{}", lines.join("\n")));
    let bytes = proptest::collection::vec(any::<u8>(), 0..300);
    fuzz::run("read_imu_csv", (text, bytes), |(text, bytes)| {
        fuzz::call("read_imu_csv", move || {
            for input in [text.as_bytes(), bytes.as_slice()] {
                if let Some(log) = fuzz::counted(read_imu_csv(input, "fuzz.csv")) {
                    assert!(log.rate().is_finite() && log.rate() > 0.0);
                }
                let _ = fuzz::counted(read_estimates_csv(input, "fuzz.csv"));
            }
        });
    });
}

#[test]
fn bad_input_mat_files() {
    let dir = temp_dir("fuzz-mat");
    let good = mat_file(&good_variables(&GYR, &QUAT, &[0, 1, 1, 0]));
    let len = good.len();
    let mutations = proptest::collection::vec((0..len, any::<u8>()), 1..6);
    let counter = std::sync::atomic::AtomicUsize::new(0);
    fuzz::run(
        "read_broad (crafted)",
        (mutations, 0..=len),
        |(mutations, cut)| {
            let mut bytes = good.clone();
            for (at, byte) in mutations {
                bytes[at] = byte;
            }
            bytes.truncate(cut);
            let k = counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let path = write(&dir, &format!("mutated-{k}.mat"), &bytes);
            fuzz::call("read_broad", move || {
                let _ = fuzz::counted(read_broad(&path));
                std::fs::remove_file(&path).ok();
            });
        },
    );
    std::fs::remove_dir_all(dir).ok();
}

/// A matrix element whose declared size is within 7 of u32::MAX: padding it to 8 bytes overflowed
/// (a panic with overflow checks). It is refused like any truncated file.
#[test]
fn a_mat_element_sized_near_u32_max_is_refused() {
    let dir = temp_dir("huge-element");
    let mut bytes = vec![b' '; 128];
    bytes[124..126].copy_from_slice(&0x0100_u16.to_le_bytes());
    bytes[126..128].copy_from_slice(b"IM");
    bytes.extend_from_slice(&14_u32.to_le_bytes());
    bytes.extend_from_slice(&0xFFFF_FFF9_u32.to_le_bytes());
    let path = write(&dir, "huge-element.mat", &bytes);
    // Refused by the reader's own walk, not by the parser's caught panic.
    let error = read_broad(&path).unwrap_err().to_string();
    assert!(error.contains("declares 4294967289 bytes"), "{error}");
    std::fs::remove_dir_all(dir).ok();
}

/// A MAT header followed by `depth` matrices, each holding only the next: 8 bytes a level, each
/// within its parent, so that only the depth is wrong (at 20 000 levels, 160 KB, the structure
/// check recursed until the stack overflowed and the process aborted).
fn nested(depth: usize) -> Vec<u8> {
    let mut bytes = mat_file(&[("x", [1, 1], MatData::UInt8(&[0; 16]))])[..128].to_vec();
    for level in 0..depth {
        let size = u32::try_from(8 * (depth - 1 - level)).expect("a test size");
        bytes.extend_from_slice(&14_u32.to_le_bytes());
        bytes.extend_from_slice(&size.to_le_bytes());
    }
    bytes
}

/// Crafted files the parser would overflow on or allocate beyond memory for, refused by the
/// reader's walk before the parser runs (each message names what it refused, so none is the
/// parser's caught panic): a sub-element declaring 4 GiB inside a matrix; an element declaring
/// more bytes than the file holds; matrices whose values would take 2 GiB as doubles (the parser
/// would allocate them, plus 8 bytes for every byte of data stored as uint8) in one matrix, in
/// two compressed ones, and in matrices nested in a cell; matrices nested 100 000 deep; and a
/// well-formed small matrix, which passes the walk (and then lacks the trial's variables).
#[test]
fn crafted_mat_files_are_refused_before_the_parser_allocates() {
    let dir = temp_dir("crafted-mat");
    let matrix = |dims: [usize; 2]| mat_file(&[("x", dims, MatData::UInt8(&[0; 16]))]);
    let mut huge_name = matrix([1, 1]);
    // The name's size: after the header (128), the matrix tag (8), the flags (16), the
    // dimensions (16) and the name's type (4).
    huge_name[172..176].copy_from_slice(&0xFFFF_FFF9_u32.to_le_bytes());
    let mut short = matrix([1, 1]);
    short[132..136].copy_from_slice(&4096_u32.to_le_bytes());
    let half = || ("x", [1 << 26, 1], MatData::UInt8(&[0; 16]));
    let cell = {
        let mut body = Vec::new();
        padded(&mut body, 6, &[1, 0, 0, 0, 0, 0, 0, 0]);
        padded(&mut body, 5, &[1, 0, 0, 0, 3, 0, 0, 0]);
        padded(&mut body, 1, b"c");
        for _ in 0..3 {
            body.extend_from_slice(&matrix([1 << 26, 1])[128..]);
        }
        let mut file = matrix([1, 1])[..128].to_vec();
        padded(&mut file, 14, &body);
        file
    };
    let declared = "the bytes the file's matrices declare";
    let cases: [(&str, Vec<u8>, &str); 7] = [
        ("huge-name", huge_name, "declares 4294967289 bytes"),
        ("short", short, "but only"),
        ("large", matrix([1 << 28, 1]), declared),
        (
            "compressed",
            compressed(&mat_file(&[half(), half(), half()]), |_| {}),
            declared,
        ),
        ("cell", cell, declared),
        ("small", matrix([4, 4]), "imu_gyr"),
        ("nested", nested(100_000), "nested more than"),
    ];
    for (name, bytes, expected) in cases {
        let path = write(&dir, &format!("{name}.mat"), &bytes);
        let error = read_broad(&path).unwrap_err().to_string();
        assert!(error.contains(expected), "{name}: {error}");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// Bytes changed inside the compressed elements of a real trial (16 mutated copies).
#[test]
fn bad_input_mutated_trial() {
    let bytes = std::fs::read(shipped_dir().join(format!("{}.mat", SHIPPED[1]))).expect("read");
    let dir = temp_dir("fuzz-trial");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(fuzz::seed());
    for k in 0..16 {
        let mut copy = bytes.clone();
        for _ in 0..4 {
            let at = rng.random_range(128..copy.len());
            copy[at] = rng.random();
        }
        let path = write(&dir, &format!("mutated-{k}.mat"), &copy);
        let result = fuzz::quick("read_broad (mutated trial)", || {
            read_broad(&path).map(|l| l.len())
        });
        println!("mutated copy {k}: {result:?}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_input_simulate() {
    let strategy = (
        proptest::collection::vec(fuzz::value(), 12),
        fuzz::size(MAX_SAMPLES),
        fuzz_vector(),
    );
    fuzz::run("simulate", strategy, |(v, samples, vector)| {
        fuzz::call("simulate", move || {
            let settings = SimulationSettings {
                rate: v[0],
                samples: samples.min(MAX_SAMPLES + 1),
                rotation_rate: v[1],
                rotation_time: v[2],
                acceleration_bound: v[3],
                gyro_noise: v[4],
                acc_noise: v[5],
                mag_noise: v[6],
                gyro_bias_walk: v[7],
                gravity: v[8],
                initial_gyro_bias: vector,
                earth_field: vector,
                disturbances: vec![Disturbance {
                    start: v[9],
                    end: v[9].abs(),
                    offset: vector,
                }],
                field_offset: Some(FieldOffset {
                    sigma: v[10],
                    correlation_time: v[11],
                }),
                ..SimulationSettings::default()
            };
            if let Some(log) = fuzz::counted(simulate(&settings, 0)) {
                assert_eq!(log.len(), settings.samples);
            }
        });
    });
}

/// A simulation's initial orientation must be a unit quaternion: the norm-√2 quaternion of the
/// audit (F6) read gravity as about 21.9 m/s² in the first sample, and zero, NaN and a norm
/// 1 + 2e-6 are refused alike, naming the setting. A norm within 1e-6 of 1 (here 1 + 5e-7) and a
/// rotation built by nalgebra are accepted.
#[test]
fn simulate_refuses_a_non_unit_initial_orientation() {
    let settings = SimulationSettings {
        samples: 10,
        ..SimulationSettings::default()
    };
    let raw =
        |w: f64, x: f64| UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, x, 0.0, 0.0));
    for q in [
        raw(1.0, 1.0),
        raw(0.0, 0.0),
        raw(f64::NAN, 0.0),
        raw(f64::INFINITY, 0.0),
        raw(1.0 + 2e-6, 0.0),
    ] {
        let bad = SimulationSettings {
            initial_orientation: q,
            ..settings.clone()
        };
        let err = simulate(&bad, 0).unwrap_err();
        assert!(
            matches!(&err, DataError::BadValue { variable, .. } if variable == "initial_orientation"),
            "{err:?}"
        );
        assert!(err.to_string().contains("normalise"), "{err}");
    }
    for q in [
        raw(1.0 + 5e-7, 0.0),
        UnitQuaternion::from_euler_angles(0.2, -0.4, 1.3),
    ] {
        let good = SimulationSettings {
            initial_orientation: q,
            ..settings.clone()
        };
        assert_eq!(simulate(&good, 0).expect("a unit orientation").len(), 10);
    }
}

/// `ImuLog::with_reference` refuses a reference orientation that is not finite or whose norm is
/// further than `REFERENCE_NORM_TOLERANCE` (1e-3, the readers' tolerance) from 1, naming its
/// sample; `None` and a norm within the tolerance (1 + 5e-4) are accepted, and kept normalised
/// (a reference 5e-4 off the unit sphere was kept as given).
#[test]
fn with_reference_refuses_non_unit_orientations() {
    let v = vec![Vector3::new(0.0, 0.0, 9.81); 3];
    let log = ImuLog::new(100.0, v.clone(), v, None).expect("valid");
    let raw = |w: f64| UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, 0.0, 0.0, 0.0));
    for bad in [
        raw(f64::NAN),
        raw(f64::INFINITY),
        raw(0.0),
        raw(std::f64::consts::SQRT_2),
        raw(1.0 + 2e-3),
    ] {
        let err = log
            .clone()
            .with_reference(vec![None, Some(UnitQuaternion::identity()), Some(bad)])
            .unwrap_err();
        assert!(
            matches!(&err, DataError::BadValue { variable, row: 2, .. } if variable == "reference"),
            "{err:?}"
        );
        assert!(err.to_string().contains("row 2"), "{err}");
    }
    let accepted = log
        .with_reference(vec![
            None,
            Some(raw(1.0 + 5e-4)),
            Some(UnitQuaternion::identity()),
        ])
        .expect("unit within the tolerance");
    assert_eq!(accepted.len(), 3);
    let kept = accepted.reference().expect("a reference")[1].expect("known");
    assert!((kept.coords.norm() - 1.0).abs() <= f64::EPSILON, "{kept:?}");
}

/// The simulated log's movement mask is allocated fallibly (audit F8), like its other buffers:
/// with the allocation of its `samples` flags refused (on this thread only, by `refusing`), the
/// simulation is `DataError::TooLarge`, where an infallible allocation aborted.
#[test]
fn simulate_reports_a_refused_movement_mask() {
    let settings = SimulationSettings {
        samples: 1237,
        ..SimulationSettings::default()
    };
    let result = refusing::refusing::<bool, _>(1237, || simulate(&settings, 0));
    assert!(
        matches!(&result, Err(DataError::TooLarge { size: 1237, .. })),
        "{result:?}"
    );
    assert_eq!(
        simulate(&settings, 0).expect("the memory given").len(),
        1237
    );
}

/// The number of disturbances is bounded (audit F9: every sample scans them all, so 10⁶ of them
/// over 2²⁸ samples took days): 10 001 are refused as `TooLarge` before anything is drawn, naming
/// the limit; 10 000 are accepted, and the log is the same as with the active one alone (the
/// others lie after the run).
#[test]
fn simulate_bounds_the_disturbances() {
    let active = Disturbance {
        start: 0.0,
        end: 1.0,
        offset: Vector3::new(5.0, 0.0, 0.0),
    };
    let later = Disturbance {
        start: 100.0,
        end: 101.0,
        offset: Vector3::x(),
    };
    let with = |count: usize| SimulationSettings {
        samples: 20,
        disturbances: std::iter::once(active)
            .chain(std::iter::repeat_n(later, count - 1))
            .collect(),
        ..SimulationSettings::default()
    };
    let err = simulate(&with(10_001), 0).unwrap_err();
    assert!(
        matches!(
            &err,
            DataError::TooLarge {
                size: 10_001,
                limit: 10_000,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("disturbances"), "{err}");
    let most = simulate(&with(10_000), 0).expect("at the limit");
    assert_eq!(most, simulate(&with(1), 0).expect("one disturbance"));
}
