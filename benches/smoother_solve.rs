//! The iterated smoother's normal equations: a symmetric positive definite block-tridiagonal
//! matrix of K blocks of D × D, factored and solved for one right-hand side (one Gauss-Newton
//! step), four ways in the same run:
//!
//! * `block/nalgebra`: the block recursion on nalgebra's fixed-size blocks;
//! * `block/faer`: the same recursion on faer's dense blocks;
//! * `square root`: the factors from the whitened Jacobian J by block QR with row pivoting (what
//!   the iterated smoother runs, never forming `Λ = JᵀJ`), then the recursion's solve on the
//!   backend for D;
//! * `faer sparse`: faer's sparse Cholesky (supernodal/simplicial, AMD ordering) of the assembled
//!   matrix, lower triangle given as triplets;
//! * `dense/nalgebra`: nalgebra's dense `DMatrix` Cholesky of the assembled matrix (the naive
//!   alternative; only up to K·D = 1500, beyond which it needs more than a few seconds per solve).
//!
//! D ∈ {3, 6, 15, 30, 60}, K ∈ {100, 1000}. Run: `cargo bench --bench smoother_solve` (figures and
//! the crossover in docs/benchmarks.md).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side, linalg::solvers::Solve};
use liebayes::operators::iterated_smoother::{Backend, BlockJacobian, BlockTridiagonal};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Duration;

/// A random whitened Jacobian of K epochs coupling neighbours (as a Gauss-Newton step builds it),
/// its normal matrix `Σ Jᵀ J`, and a right-hand side.
fn problem<const D: usize>(
    blocks: usize,
) -> (BlockJacobian<D>, BlockTridiagonal<D>, Vec<SVector<f64, D>>) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut random = || SMatrix::<f64, D, D>::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let mut jacobian = BlockJacobian::new(blocks).unwrap();
    for k in 0..blocks {
        let identity = DMatrix::<f64>::identity(D, D);
        jacobian.add_rows(k, identity.as_view()).unwrap();
        let a = random();
        let a = DMatrix::from_column_slice(D, D, a.as_slice());
        jacobian.add_rows(k, a.as_view()).unwrap();
        if k + 1 < blocks {
            jacobian.set_transition(k, random(), random()).unwrap();
        }
    }
    let rhs = (0..blocks)
        .map(|k| SVector::from_fn(|i, _| ((k + i) as f64).sin()))
        .collect();
    let normal = jacobian.normal().unwrap();
    (jacobian, normal, rhs)
}

/// The lower triangle of the assembled matrix as faer triplets.
fn triplets<const D: usize>(m: &BlockTridiagonal<D>) -> Vec<Triplet<usize, usize, f64>> {
    let mut entries = Vec::new();
    for (k, a) in m.diagonal().iter().enumerate() {
        for j in 0..D {
            for i in j..D {
                entries.push(Triplet::new(k * D + i, k * D + j, a[(i, j)]));
            }
        }
    }
    for (k, b) in m.lower().iter().enumerate() {
        for j in 0..D {
            for i in 0..D {
                entries.push(Triplet::new((k + 1) * D + i, k * D + j, b[(i, j)]));
            }
        }
    }
    entries
}

fn solve_dimension<const D: usize>(c: &mut Criterion) {
    let mut g = c.benchmark_group(format!("smoother_solve/D={D}"));
    g.sample_size(10);
    for blocks in [100_usize, 1000] {
        let (jacobian, m, rhs) = problem::<D>(blocks);
        for (name, backend) in [
            ("block/nalgebra", Backend::FixedSize),
            ("block/faer", Backend::Faer),
        ] {
            g.bench_function(BenchmarkId::new(name, blocks), |b| {
                b.iter(|| {
                    let factor = black_box(&m).factor_with(backend).unwrap();
                    factor.solve(black_box(&rhs)).unwrap()
                });
            });
        }
        g.bench_function(BenchmarkId::new("square root", blocks), |b| {
            b.iter(|| {
                let factor = black_box(&jacobian).factor().unwrap();
                factor.solve(black_box(&rhs)).unwrap()
            });
        });
        let n = blocks * D;
        let entries = triplets(&m);
        let stacked = Mat::from_fn(n, 1, |i, _| rhs[i / D][i % D]);
        g.bench_function(BenchmarkId::new("faer sparse", blocks), |b| {
            b.iter(|| {
                let sparse =
                    SparseColMat::<usize, f64>::try_new_from_triplets(n, n, black_box(&entries))
                        .unwrap();
                let factor = sparse.sp_cholesky(Side::Lower).unwrap();
                let mut x = stacked.clone();
                factor.solve_in_place(x.as_mut());
                x
            });
        });
        if n <= 1500 {
            let dense = m.to_dense().unwrap();
            let stacked = DVector::from_fn(n, |i, _| rhs[i / D][i % D]);
            g.bench_function(BenchmarkId::new("dense/nalgebra", blocks), |b| {
                b.iter(|| {
                    black_box(&dense)
                        .clone()
                        .cholesky()
                        .unwrap()
                        .solve(&stacked)
                });
            });
        }
    }
    g.finish();
}

fn smoother_solve(c: &mut Criterion) {
    solve_dimension::<3>(c);
    solve_dimension::<6>(c);
    solve_dimension::<15>(c);
    solve_dimension::<30>(c);
    solve_dimension::<60>(c);
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    targets = smoother_solve
}
criterion_main!(benches);
