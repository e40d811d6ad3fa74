//! Samples per second on one core of the attitude filters on one simulated minute at BROAD's rate
//! (285.7 Hz): the production EKF in 9D and 6D, the talk's Bingham / heat-kernel filter, and
//! Madgwick's filter, in one run. VQF's C++ is timed beside liebayes by `tools/attitude_peers.py`
//! (same invocation ratios). `cargo bench --bench attitude`; figures in docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use liebayes::filters::attitude::{
    AttitudeParams, BROAD_BETA, Sensors, SimulationSettings, TalkParams, run_attitude_ekf,
    run_madgwick, run_talk_filter, simulate,
};
use std::hint::black_box;
use std::time::Duration;

fn attitude(c: &mut Criterion) {
    let log = simulate(&SimulationSettings::default(), 1).expect("a simulated log");
    let short = simulate(
        &SimulationSettings {
            samples: 2000,
            ..SimulationSettings::default()
        },
        1,
    )
    .expect("a simulated log");
    let params = AttitudeParams::default();
    let mut group = c.benchmark_group("attitude");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    group.throughput(Throughput::Elements(log.len() as u64));
    group.bench_function("ekf_9d", |b| {
        b.iter(|| run_attitude_ekf(black_box(&log), &params, Sensors::NineD).unwrap());
    });
    group.bench_function("ekf_6d", |b| {
        b.iter(|| run_attitude_ekf(black_box(&log), &params, Sensors::SixD).unwrap());
    });
    group.bench_function("madgwick_9d", |b| {
        b.iter(|| run_madgwick(black_box(&log), BROAD_BETA).unwrap());
    });
    group.throughput(Throughput::Elements(short.len() as u64));
    group.bench_function("talk_filter_9d", |b| {
        b.iter(|| run_talk_filter(black_box(&short), &TalkParams::default()).unwrap());
    });
    group.finish();
}

criterion_group!(benches, attitude);
criterion_main!(benches);
