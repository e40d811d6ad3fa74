//! The experiment layer's statistics: exact summation against a plain f64 sum and Neumaier's
//! compensated sum (the usual cheap improvement, which is not exact and does not merge exactly).

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::experiments::{ExactSum, RunningStats};
use std::hint::black_box;

/// 10 000 values of mixed sign over nine decades, the shape of per-run errors and NEES values.
fn values() -> Vec<f64> {
    (0..10_000_u32)
        .map(|i| {
            let t = f64::from(i);
            (t * 0.618_033_988_749_895).sin() * 10f64.powf((t * 0.001).sin() * 4.5)
        })
        .collect()
}

fn neumaier(values: &[f64]) -> f64 {
    let (mut sum, mut compensation) = (0.0_f64, 0.0_f64);
    for &x in values {
        let t = sum + x;
        compensation += if sum.abs() >= x.abs() {
            (sum - t) + x
        } else {
            (x - t) + sum
        };
        sum = t;
    }
    sum + compensation
}

fn summation(c: &mut Criterion) {
    let values = values();
    let mut group = c.benchmark_group("sum of 10 000 values");
    group.bench_function("f64 sum", |b| {
        b.iter(|| black_box(&values).iter().sum::<f64>());
    });
    group.bench_function("Neumaier compensated", |b| {
        b.iter(|| neumaier(black_box(&values)));
    });
    group.bench_function("ExactSum", |b| {
        b.iter(|| {
            black_box(&values)
                .iter()
                .copied()
                .collect::<ExactSum>()
                .value()
        });
    });
    group.bench_function("RunningStats", |b| {
        b.iter(|| {
            let mut s = RunningStats::new();
            for &x in black_box(&values) {
                s.add(x);
            }
            s.variance()
        });
    });
    group.finish();
    let (a, b) = (
        values.iter().copied().collect::<ExactSum>(),
        ExactSum::new(),
    );
    c.bench_function("ExactSum merge and value", |bench| {
        bench.iter(|| {
            let mut m = black_box(&b).clone();
            m.merge(black_box(&a)).map(|()| m.value())
        });
    });
}

criterion_group!(benches, summation);
criterion_main!(benches);
