//! Samples per second on one core of the attitude filters on one simulated minute at BROAD's rate
//! (285.7 Hz): the production EKF in 9D and 6D, the talk's Bingham / heat-kernel filter, and
//! Madgwick's filter, in one run. Each filter is built from its `Method` and stepped through
//! `RecursiveFilter` over the log's steps by `record` (predict with each sample's gyroscope and
//! accelerometer, update with its magnetometer reading, the estimate kept for every sample), as
//! `liebayes attitude` runs it: VQF's C++ batch API, timed beside that command by
//! `tools/attitude_peers.py` (same invocation ratios), likewise returns an orientation per sample.
//! `cargo bench --bench attitude`; figures in docs/benchmarks.md.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use liebayes::experiments::record;
use liebayes::filters::attitude::{LogScenario, Method, SimulationSettings, simulate};
use std::hint::black_box;
use std::time::Duration;

/// A simulated log of `samples` samples as a scenario.
fn scenario(samples: usize) -> LogScenario {
    let settings = SimulationSettings {
        samples,
        ..SimulationSettings::default()
    };
    let log = simulate(&settings, 1).expect("a simulated log");
    LogScenario::new(log).expect("a non-empty log")
}

fn attitude(c: &mut Criterion) {
    let minute = scenario(SimulationSettings::default().samples);
    let short = scenario(2000);
    let mut group = c.benchmark_group("attitude");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    for (id, name, scenario) in [
        ("ekf_9d", "ekf-9d", &minute),
        ("ekf_6d", "ekf-6d", &minute),
        ("ekf_offline_9d", "ekf-offline-9d", &minute),
        ("madgwick_9d", "madgwick-9d", &minute),
        ("talk_filter_9d", "talk-9d", &short),
    ] {
        let method = Method::from_name(name).expect("a method name");
        let rate = scenario.log().rate();
        group.throughput(Throughput::Elements(scenario.log().len() as u64));
        group.bench_function(id, |b| {
            b.iter(|| {
                let mut filter = method.build(rate).expect("valid settings");
                record(&mut filter, black_box(scenario).steps()).expect("the filter runs")
            });
        });
    }
    group.finish();
}

criterion_group!(benches, attitude);
criterion_main!(benches);
