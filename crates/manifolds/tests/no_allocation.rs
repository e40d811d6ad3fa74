//! Every operation of the manifold layer runs without touching the heap: a counting global allocator
//! sees zero allocations on the calling thread across exp, log, compose, inverse, act, retract,
//! local and every Jacobian, for the groups, the groups with world-frame errors, products (also those
//! of `product_manifold!`), and the weighted mean.
#![allow(unsafe_code)] // implementing GlobalAlloc is unsafe by definition; this wrapper only counts.

use liebayes_manifolds::{
    GroupAction, Left, LieGroup, Manifold, MeanSettings, ProductManifold, Rn, S2, Se23, So2, So3,
    Su2, product_manifold, weighted_mean,
};
use nalgebra::{Vector1, Vector2, Vector3};
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

product_manifold! {
    /// A state of four factors, built by the macro.
    struct NavState<f64> {
        attitude: Left<So3<f64>>,
        velocity: Rn<f64, 3>,
        position: Rn<f64, 3>,
        bias: Rn<f64, 6>,
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn group_ops<G: GroupAction<D, P, Scalar = f64>, const D: usize, const P: usize>(
    a: &G,
    b: &G,
    v: &nalgebra::SVector<G::Scalar, D>,
    p: &nalgebra::SVector<G::Scalar, P>,
) {
    lie_ops(a, b, v);
    black_box(a.act(p));
    black_box(a.j_act_self(p));
    black_box(a.j_act_point(p));
}

fn lie_ops<G: LieGroup<D, Scalar = f64>, const D: usize>(
    a: &G,
    b: &G,
    v: &nalgebra::SVector<G::Scalar, D>,
) {
    black_box(G::exp(v));
    black_box(a.log());
    black_box(a.compose(b));
    black_box(a.inverse());
    black_box(a.retract(v));
    black_box(a.local(b));
    black_box(a.adjoint());
    black_box(G::right_jacobian(v));
    black_box(G::right_jacobian_inverse(v));
    black_box(G::left_jacobian(v));
    black_box(G::left_jacobian_inverse(v));
    black_box(a.j_compose_self(b));
    black_box(a.j_compose_other(b));
    black_box(a.j_inverse_self());
    black_box(a.j_log_self());
    black_box(a.j_retract_self(v));
    black_box(a.j_retract_tangent(v));
    black_box(a.j_local_self(b));
    black_box(a.j_local_other(b));
    // Close samples converge (a mean far from them could fail, which is not what this measures).
    let near = a.retract(&(v * 1e-3));
    black_box(weighted_mean(a, [(a, 0.5), (&near, 0.5)], MeanSettings::default()).ok());
}

#[test]
fn no_heap_allocation_in_any_operation() {
    let v = Vector3::new(0.3, -1.1, 0.7);
    let w = Vector3::new(-0.4, 0.2, 2.1);
    let p = Vector3::new(1.0, -2.0, 0.5);
    let s2 = S2::new(Vector3::z()).unwrap();
    let before = allocated();
    group_ops(&So3::exp(&v), &So3::exp(&w), &v, &p);
    group_ops(&Su2::exp(&v), &Su2::exp(&w), &v, &p);
    group_ops(
        &So2::exp(&Vector1::new(0.3)),
        &So2::exp(&Vector1::new(-2.0)),
        &Vector1::new(1.0),
        &Vector2::new(1.0, 2.0),
    );
    let (v6, w6) = (
        nalgebra::Vector6::new(1.0, -2.0, 0.5, v.x, v.y, v.z),
        nalgebra::Vector6::new(-0.3, 0.7, 2.0, w.x, w.y, w.z),
    );
    group_ops(
        &liebayes_manifolds::Se3::exp(&v6),
        &liebayes_manifolds::Se3::exp(&w6),
        &v6,
        &p,
    );
    group_ops(
        &liebayes_manifolds::Se2::exp(&v),
        &liebayes_manifolds::Se2::exp(&w),
        &v,
        &Vector2::new(1.0, 2.0),
    );
    group_ops(&Rn::new_unchecked(v), &Rn::new_unchecked(w), &v, &p);
    group_ops(&Left::new(So3::exp(&v)), &Left::new(So3::exp(&w)), &v, &p);
    let attitude_bias = |v: &Vector3<f64>| {
        ProductManifold::<_, _, 3, 3, 6>::new(So3::exp(v), Rn::new_unchecked(*v))
    };
    let v6 = nalgebra::SVector::<f64, 6>::from_fn(|i, _| 0.1 * i as f64);
    lie_ops(&attitude_bias(&v), &attitude_bias(&w), &v6);
    let (v9, w9) = (
        nalgebra::SVector::<f64, 9>::from_fn(|i, _| 0.3 - 0.1 * i as f64),
        nalgebra::SVector::<f64, 9>::from_fn(|i, _| 0.05 * (i * i) as f64 - 0.4),
    );
    group_ops(&Se23::exp(&v9), &Se23::exp(&w9), &v9, &p);
    let v15 = nalgebra::SVector::<f64, 15>::from_fn(|i, _| 0.1 - 0.02 * i as f64);
    let (a, b) = (NavState::exp(&v15), NavState::exp(&-v15));
    lie_ops(&a, &b, &v15);
    black_box(NavState::split_tangent(&v15));
    let t = black_box(s2.retract(&Vector2::new(0.3, 0.2)));
    black_box(s2.local(&t));
    black_box(s2.tangent_basis());
    let after = allocated();
    assert_eq!(
        after - before,
        0,
        "the manifold layer allocated on the heap"
    );
}
