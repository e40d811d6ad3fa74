//! The in-place steps of the weighted containers run without touching the heap: a counting global
//! allocator sees zero allocations on the calling thread across propagations (with and without resampling) and
//! reweightings of a particle set, the marginalized particle filter's step, and the grid's payload
//! steps, reweighting and diffusion (after the first diffusion, which allocates its workspace), and
//! the fixed-lag smoother's steps and backward pass once its window is full.
#![allow(unsafe_code)] // implementing GlobalAlloc is unsafe by definition; this wrapper only counts.

use liebayes_densities::Gaussian;
use liebayes_manifolds::So2;
use liebayes_operators::grid::{CircularGrid, Diffusion};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{
    Given, LikelihoodFn, ParticleSet, Resampler, Resampling, Reweight, SampleFn, Sampled,
};
use liebayes_operators::{Condition, OperatorError, Propagate};
use nalgebra::{Matrix2, Vector2};
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::hint::black_box;

struct Counting;

thread_local! {
    /// Allocations made by this thread: other threads (the test harness's, a thread pool's idle
    /// workers) allocate when they like, and must not be counted against the steps measured here,
    /// which run on the calling thread.
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// This thread's allocations so far.
fn allocated() -> usize {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // `try_with`: nothing is counted while the thread's locals are being torn down.
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The number of allocations `f` makes.
fn allocations(f: impl FnOnce()) -> usize {
    let before = allocated();
    f();
    allocated() - before
}

fn rotation(y: &So2<f64>) -> Matrix2<f64> {
    let (s, c) = y.angle().sin_cos();
    Matrix2::new(c, -s, s, c)
}

/// The steps run on this thread, and only its allocations are counted.
#[test]
fn in_place_steps_do_not_allocate() {
    let walk = SampleFn::new(|x: &f64, u: &f64, rng: &mut dyn RngCore| {
        Ok(x + u + rng.random::<f64>() - 0.5)
    });
    let likelihood = Reweight(LikelihoodFn::new(|x: &f64, z: &f64| -(x - z) * (x - z)));
    let mut set = ParticleSet::from_samples((0..500).map(f64::from).collect()).unwrap();
    for scheme in [
        Resampling::Multinomial,
        Resampling::Stratified,
        Resampling::Systematic,
        Resampling::Residual,
    ] {
        // Fraction 1: every propagation after a reweighting resamples.
        let sampled =
            Sampled::with_resampling(&walk, ChaCha8Rng::seed_from_u64(1), 1.0, scheme).unwrap();
        let count = allocations(|| {
            for z in [10.0, 200.0, 300.0] {
                black_box(set.condition_in_place(&likelihood, &z).unwrap());
                set.propagate_in_place(&sampled, &0.1).unwrap();
            }
        });
        assert_eq!(count, 0, "{scheme:?}");
        // The last propagation resampled: the weights are uniform again.
        assert!(set.log_weights().iter().all(|l| *l == -(500.0_f64).ln()));
    }
    // The harness counts: the by-value step clones the set's buffers.
    assert!(allocations(|| drop(black_box(set.condition(&likelihood, &1.0).unwrap()))) > 0);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    assert_eq!(
        allocations(|| set.resample(Resampling::Residual, &mut rng)),
        0
    );
    // A resampler with room for 1000 draws allocates for none of its calls up to 1000 (every scheme,
    // and a smaller draw after a larger one), and grows once for more.
    let weights: Vec<f64> = (0..700).map(|i| f64::from(i % 13)).collect();
    let mut resampler = Resampler::with_capacity(1000).unwrap();
    for scheme in [
        Resampling::Multinomial,
        Resampling::Stratified,
        Resampling::Systematic,
        Resampling::Residual,
    ] {
        for n in [1000, 10, 999] {
            let count = allocations(|| {
                black_box(resampler.draw(&weights, n, scheme, &mut rng).unwrap());
            });
            assert_eq!(count, 0, "{scheme:?}, {n} draws");
        }
    }
    assert!(
        allocations(|| drop(resampler.draw(&weights, 1001, Resampling::Residual, &mut rng))) > 0
    );

    let prior = Gaussian::new(Vector2::new(1.0, 0.0), Matrix2::identity()).unwrap();
    let measurement =
        Given(|y: &So2<f64>| LinearMeasurement::new(rotation(y), Matrix2::identity()));
    let process = Given(|y: &So2<f64>| {
        LinearProcess::new(Matrix2::identity() * y.angle().cos(), Matrix2::identity())
    });
    let z = Vector2::new(0.5, 1.0);
    let mut marginalized = ParticleSet::from_samples(
        (0..64)
            .map(|j| (So2::from_angle_unchecked(f64::from(j) * 0.1), prior.clone()))
            .collect(),
    )
    .unwrap();
    let mut grid = CircularGrid::uniform(64, prior).unwrap();
    let count = allocations(|| {
        for _ in 0..3 {
            black_box(marginalized.condition_in_place(&measurement, &z).unwrap());
            grid.propagate_in_place(&process, &Vector2::zeros())
                .unwrap();
            black_box(grid.condition_in_place(&measurement, &z).unwrap());
        }
    });
    assert_eq!(count, 0);

    let mut angle = CircularGrid::uniform(128, ()).unwrap();
    let bearing = Reweight(LikelihoodFn::new(|t: &So2<f64>, z: &f64| {
        2.0 * (t.angle() - z).cos()
    }));
    let diffusion = Diffusion(|w: &So2<f64>| (3.0 * w.angle().cos()).exp());
    angle.propagate_in_place(&diffusion, &()).unwrap();
    let count = allocations(|| {
        for z in [0.5, 1.0, -2.0] {
            black_box(angle.condition_in_place(&bearing, &z).unwrap());
            angle.propagate_in_place(&diffusion, &()).unwrap();
        }
    });
    assert_eq!(count, 0);

    // A failed step does not allocate either.
    let failing = Given(
        |_: &So2<f64>| -> Result<LinearMeasurement<2, 2>, OperatorError> {
            Err(OperatorError::NonFinitePoint { what: "test" })
        },
    );
    assert_eq!(
        allocations(|| assert!(grid.condition_in_place(&failing, &z).is_err())),
        0
    );
}

/// Once its window is full, the fixed-lag smoother's steps and backward pass reuse its ring
/// buffers: no allocation per epoch.
#[test]
fn fixed_lag_steps_do_not_allocate_once_the_window_is_full() {
    use liebayes_densities::ManifoldGaussian;
    use liebayes_manifolds::Manifold;
    use liebayes_operators::fixed_lag::FixedLagSmoother;
    use liebayes_operators::{Ekf, MeasurementFn, ProcessFn};
    use nalgebra::{Matrix1, Vector1};

    let gyro = ProcessFn::new(
        |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
        |_, _| Matrix1::new(1e-3),
    );
    let compass = MeasurementFn::new(
        |x: &So2<f64>| Vector1::new(x.angle()),
        |_| Matrix1::new(0.01),
    );
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(1.0)).unwrap();
    let mut smoother = FixedLagSmoother::new(prior, 8).unwrap();
    let mut step = |k: u32| {
        smoother.propagate(&Ekf(&gyro), &0.01).unwrap();
        let reading = Vector1::new(0.01 * f64::from(k));
        smoother.condition(&Ekf(&compass), &reading).unwrap();
        black_box(
            smoother
                .smooth()
                .unwrap()
                .lagged()
                .map(|s| s.covariance()[0]),
        );
    };
    for k in 0..8 {
        step(k);
    }
    assert_eq!(allocations(|| (8..200).for_each(&mut step)), 0);
}
