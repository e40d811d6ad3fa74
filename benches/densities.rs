//! Benchmarks of the densities: von Mises moments (the Bessel ratios), von Mises-Fisher log-pdf, the
//! heat-kernel density in both of its forms, and sampling throughput of each family.
//!
//! Run: `cargo bench --bench densities` (figures in docs/benchmarks.md).

use criterion::{Criterion, criterion_group, criterion_main};
use liebayes::densities::{
    Bingham, Density, Gaussian, GenVonMises2, HeatKernelSo3, VonMises, VonMisesFisher, special,
};
use liebayes::manifolds::{LieGroup, S2, So2, So3};
use nalgebra::{Matrix3, Matrix4, Vector2, Vector3, Vector4};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;

const CONCENTRATIONS: [f64; 4] = [0.5, 10.0, 1e3, 1e6];

fn von_mises_moments(c: &mut Criterion) {
    let mut g = c.benchmark_group("von Mises moments");
    for kappa in CONCENTRATIONS {
        g.bench_function(format!("A1 = I1/I0, kappa {kappa:e}"), |b| {
            b.iter(|| special::a1(black_box(kappa)));
        });
        g.bench_function(format!("A2 = I2/I0, kappa {kappa:e}"), |b| {
            b.iter(|| special::a2(black_box(kappa)));
        });
        g.bench_function(format!("log I0, kappa {kappa:e}"), |b| {
            b.iter(|| special::log_i0(black_box(kappa)));
        });
        g.bench_function(format!("scaled (I0, I1) pair, kappa {kappa:e}"), |b| {
            b.iter(|| special::scaled_i0_i1(black_box(kappa)));
        });
        g.bench_function(
            format!("scaled pair the obvious way (exp(log I0 - k), A1), kappa {kappa:e}"),
            |b| {
                b.iter(|| {
                    let k = black_box(kappa);
                    (
                        (special::log_i0(k).unwrap() - k).exp(),
                        special::a1(k).unwrap(),
                    )
                });
            },
        );
    }
    for kappa in [1.0, 1e4, f64::MAX] {
        g.bench_function(
            format!("I_n/I0 at the highest order n = 100000, kappa {kappa:e}"),
            |b| b.iter(|| special::bessel_ratio(black_box(special::MAX_ORDER), black_box(kappa))),
        );
    }
    g.bench_function("A^-1(0.9)", |b| {
        b.iter(|| special::a1_inverse(black_box(0.9)));
    });
    g.finish();
}

fn von_mises_fisher_log_pdf(c: &mut Criterion) {
    let mut g = c.benchmark_group("von Mises-Fisher log-pdf");
    let x = S2::new(Vector3::new(0.6, 0.0, 0.8)).unwrap();
    for kappa in [0.5, 100.0, 1e6] {
        let p = VonMisesFisher::new(S2::new(Vector3::z()).unwrap(), kappa).unwrap();
        g.bench_function(format!("log_pdf, kappa {kappa:e}"), |b| {
            b.iter(|| black_box(&p).log_pdf(black_box(&x)));
        });
    }
    // The obvious alternative: the textbook normaliser, which overflows past kappa ≈ 710.
    g.bench_function("naive ln(k / (4 pi sinh k)) + k mu.x, kappa 100", |b| {
        b.iter(|| {
            let k = black_box(100.0_f64);
            (k / (4.0 * PI * k.sinh())).ln() + k * 0.8
        });
    });
    g.finish();
}

fn heat_kernel(c: &mut Criterion) {
    let mut g = c.benchmark_group("heat kernel on SO(3)");
    for s in [1e-4, 0.1, 1.0, 3.0] {
        let h = HeatKernelSo3::new(So3::identity(), s).unwrap();
        g.bench_function(format!("log density at angle 1, s {s:e}"), |b| {
            b.iter(|| black_box(&h).log_density_of_angle(black_box(1.0)).unwrap());
        });
    }
    let r = So3::exp(&Vector3::new(0.3, -0.5, 0.2));
    let h = HeatKernelSo3::new(So3::identity(), 0.1).unwrap();
    g.bench_function("log_pdf of a rotation, s 0.1", |b| {
        b.iter(|| black_box(&h).log_pdf(black_box(&r)));
    });
    g.bench_function("angle CDF at 1, s 0.1", |b| {
        b.iter(|| black_box(&h).angle_cdf(black_box(1.0)).unwrap());
    });
    g.finish();
}

fn bingham(c: &mut Criterion) {
    let mut g = c.benchmark_group("Bingham normaliser + gradient");
    for z in [
        [0.0, -0.5, -1.0, -2.0],
        [0.0, -20.0, -300.0, -1000.0],
        [0.0, -2000.0, -5000.0, -1e4],
        [0.0, -3.7e8, -6.1e8, -1e9],
        [0.0, -3.7e11, -6.1e11, -1e12],
    ] {
        g.bench_function(format!("normaliser + gradient alone, z {z:?}"), |b| {
            b.iter(|| special::bingham_log_normalizer_and_moments(black_box(&z)));
        });
        let m = Matrix4::from_diagonal(&Vector4::from(z));
        g.bench_function(
            format!("construct (eigen + normaliser + moments), z {z:?}"),
            |b| {
                b.iter(|| Bingham::from_natural(black_box(m)));
            },
        );
    }
    g.finish();
}

fn sampling(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampling");
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for kappa in [0.5, 100.0, 1e6] {
        let vm = VonMises::new(So2::from_angle_unchecked(1.0), kappa).unwrap();
        g.bench_function(format!("von Mises, kappa {kappa:e}"), |b| {
            b.iter(|| vm.sample(&mut rng));
        });
        let vmf = VonMisesFisher::new(S2::new(Vector3::z()).unwrap(), kappa).unwrap();
        g.bench_function(format!("von Mises-Fisher, kappa {kappa:e}"), |b| {
            b.iter(|| vmf.sample(&mut rng));
        });
    }
    for s in [1e-3, 0.1, 2.0] {
        let h = HeatKernelSo3::new(So3::identity(), s).unwrap();
        g.bench_function(format!("heat kernel, s {s:e}"), |b| {
            b.iter(|| h.sample(&mut rng));
        });
    }
    for z in [[0.0, -1.0, -2.0, -3.0], [0.0, -100.0, -100.0, -1e4]] {
        let bingham = Bingham::from_natural(Matrix4::from_diagonal(&Vector4::from(z))).unwrap();
        g.bench_function(format!("Bingham (ACG rejection), z {z:?}"), |b| {
            b.iter(|| bingham.sample(&mut rng));
        });
    }
    let gaussian = Gaussian::new(
        Vector3::new(1.0, -2.0, 0.5),
        Matrix3::new(2.0, 0.3, 0.0, 0.3, 1.0, 0.1, 0.0, 0.1, 0.5),
    )
    .unwrap();
    g.bench_function("Gaussian<3> (mu + L z)", |b| {
        b.iter(|| gaussian.sample(&mut rng));
    });
    for (name, eta2) in [
        ("aligned", Vector2::new(3.0, 0.0)),
        ("opposed (grid envelope)", Vector2::new(-60.0, 0.0)),
    ] {
        let p = GenVonMises2::from_natural(Vector2::new(40.0, 0.0), eta2).unwrap();
        g.bench_function(
            format!("GenVonMises2, kappa1 40, second harmonic {name}, one-off"),
            |b| b.iter(|| p.sample(&mut rng)),
        );
        let sampler = p.sampler();
        g.bench_function(
            format!("GenVonMises2, kappa1 40, second harmonic {name}, kept sampler"),
            |b| b.iter(|| rand::distr::Distribution::sample(&sampler, &mut rng)),
        );
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    targets = von_mises_moments, von_mises_fisher_log_pdf, heat_kernel, bingham, sampling
}
criterion_main!(benches);
