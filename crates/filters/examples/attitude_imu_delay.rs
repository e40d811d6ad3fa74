//! The IMU's delay against a recording's reference, measured: for each BROAD trial the lag at
//! which the gyroscope (linearly interpolated between samples) best matches the reference's
//! rotation rate, `log(q_kᵀ q_{k+1}) / Δt` over `(t_k, t_{k+1}]`, in the least-squares sense over
//! every pair of reference samples (rates above 20 rad/s, the reference's glitches, left out).
//! The lag is searched from 0.5 to 1.5 samples after the interval's middle in steps of 0.01;
//! `AttitudeParams::imu_delay` is the mean lag less half a sample (the filter takes a sample as
//! the interval ending at its time stamp), in seconds.
//!
//! ```text
//! cargo run --release -p liebayes-filters --example attitude_imu_delay [DIR]
//! ```
//! DIR defaults to `$LIEBAYES_BROAD_DIR`.

use liebayes_filters::attitude::{ImuLog, read_broad};
use nalgebra::Vector3;

fn main() {
    let files = liebayes_reference::broad::folder_trials(std::env::args().nth(1)).unwrap_or_else(
        |message| {
            eprintln!("{message}");
            std::process::exit(2);
        },
    );
    let mut delays = Vec::new();
    println!("| trial | lag (samples) | RMS rate difference (rad/s) |");
    println!("|---|---|---|");
    for path in &files {
        let log = read_broad(path).expect("a BROAD trial");
        let (lag, rms) = (50..=150)
            .map(|hundredths| {
                (
                    f64::from(hundredths) / 100.0,
                    rate_difference(&log, hundredths),
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a lag");
        let name = path.file_stem().expect("a file").to_string_lossy();
        println!("| {name} | {lag:.2} | {rms:.3} |");
        delays.push((lag - 0.5) / log.rate());
    }
    let mean = delays.iter().sum::<f64>() / delays.len() as f64;
    println!("imu_delay: {:.2} ms", mean * 1e3);
}

/// The RMS difference between the gyroscope `lag` hundredths of a sample after each reference
/// interval's middle and the reference's mean rate over it.
fn rate_difference(log: &ImuLog, lag: u32) -> f64 {
    let gyro = log.gyroscope();
    let reference = log.reference().expect("a reference");
    // The gyroscope linearly interpolated at k + 0.5 + lag / 100 (clamped to the last sample).
    let shift = 50 + lag;
    let whole = usize::try_from(shift / 100).expect("a small lag");
    let f = f64::from(shift % 100) / 100.0;
    let at = |k: usize| -> Vector3<f64> {
        match (gyro.get(k + whole), gyro.get(k + whole + 1)) {
            (Some(a), Some(b)) => a * (1.0 - f) + b * f,
            _ => gyro[gyro.len() - 1],
        }
    };
    let (mut sum, mut count) = (0.0, 0.0);
    for (k, pair) in reference.windows(2).enumerate() {
        if let [Some(a), Some(b)] = pair {
            let rate = (a.inverse() * b).scaled_axis() * log.rate();
            if rate.norm() <= 20.0 {
                sum += (at(k) - rate).norm_squared();
                count += 1.0;
            }
        }
    }
    (sum / count).sqrt()
}
