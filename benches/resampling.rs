//! Resampling cost against the particle count: every scheme is linear in N (each particle's draws
//! counted from its cumulative weight, the multinomial points sorted by exponential spacings drawn
//! a block at a time), 1e6 and 1e8 particles; `resample_indices` allocates its result (the first
//! touch of fresh pages is part of its cost), a `Resampler` reuses its buffers from call to call.
//!
//! Run: `cargo bench --bench resampling` (figures in docs/benchmarks.md; the 1e8 case holds 1.6 GB,
//! the weights and the indices, 2.4 GB with a resampler's buffers beside them).

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::operators::particle::{Resampler, Resampling, resample_indices};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Duration;

fn resampling(c: &mut Criterion) {
    let mut g = c.benchmark_group("resample_indices");
    g.sample_size(10);
    for n in [1_000_000_usize, 100_000_000] {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let weights: Vec<f64> = (0..n).map(|_| rng.random::<f64>()).collect();
        for scheme in [
            Resampling::Multinomial,
            Resampling::Stratified,
            Resampling::Systematic,
            Resampling::Residual,
        ] {
            g.bench_function(format!("{scheme:?}, {n:e} particles"), |b| {
                b.iter(|| resample_indices(black_box(&weights), n, scheme, &mut rng).unwrap());
            });
            let mut resampler = Resampler::with_capacity(n).expect("room for the draws");
            g.bench_function(
                format!("{scheme:?} reusing buffers, {n:e} particles"),
                |b| {
                    b.iter(|| {
                        resampler
                            .draw(black_box(&weights), n, scheme, &mut rng)
                            .map(|indices| indices[n / 2])
                            .unwrap()
                    });
                },
            );
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    targets = resampling
}
criterion_main!(benches);
