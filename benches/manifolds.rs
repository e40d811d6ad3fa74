//! Benchmarks of the manifold layer: exp, log, compose, act and the Jacobians of `So3` and `Su2`, each
//! beside nalgebra's `UnitQuaternion` and `Rotation3` equivalent in the same run; the world-frame
//! retraction of `Left<So3>`; the product SO(3) × R³ beside its two factors done by hand; and the
//! weighted mean of unscented sigma points.
//! The poses `Se2` and `Se3` (compose, act, exp, log, right Jacobian and its inverse) run beside
//! nalgebra's `Isometry2` and `Isometry3` (`cargo bench --bench manifolds -- pose`).
//!
//! Every benchmark maps one operation over the same 256 varied inputs (rotation angles spread over
//! [0, π)) and reports the time per element: single calls of a few nanoseconds are dominated by loop
//! overhead and code alignment on a shared machine, batches are steady.
//!
//! Run: `cargo bench --bench manifolds` (figures in docs/benchmarks.md).

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use liebayes::manifolds::{
    GroupAction, Left, LieGroup, Manifold, MeanSettings, ProductManifold, Rn, Se2, Se3, So3, Su2,
    weighted_mean,
};
use nalgebra::{
    Isometry2, Isometry3, Point2, Point3, Rotation3, SVector, UnitQuaternion, Vector3, Vector6,
};
use std::hint::black_box;
use std::time::Duration;

const BATCH: usize = 256;

/// Deterministic, varied inputs: rotation vectors with angles in [0, π) and points in [−2, 2]³.
struct Inputs {
    v: Vec<Vector3<f64>>,
    w: Vec<Vector3<f64>>,
    p: Vec<Vector3<f64>>,
}

impl Inputs {
    fn new() -> Self {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut uniform = move || {
            // xorshift64*: enough to spread inputs, no dependency.
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut vector = |scale: f64| {
            let u = Vector3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5);
            u.normalize() * (scale * uniform())
        };
        let v = (0..BATCH).map(|_| vector(3.1)).collect();
        let w = (0..BATCH).map(|_| vector(3.1)).collect();
        let p = (0..BATCH).map(|_| vector(3.4)).collect();
        Self { v, w, p }
    }
}

/// Times `f` mapped over `inputs`, per element.
fn batch<I, O>(
    g: &mut BenchmarkGroup<'_, WallTime>,
    name: &str,
    inputs: &[I],
    f: impl Fn(&I) -> O,
) {
    g.bench_function(name, |b| {
        b.iter(|| {
            for x in black_box(inputs) {
                black_box(f(x));
            }
        });
    });
}

fn group<'a>(c: &'a mut Criterion, name: &str) -> BenchmarkGroup<'a, WallTime> {
    let mut g = c.benchmark_group(name);
    g.throughput(Throughput::Elements(BATCH as u64));
    g
}

fn exp(c: &mut Criterion) {
    let x = Inputs::new();
    let mut g = group(c, "exp");
    batch(&mut g, "So3", &x.v, So3::exp);
    batch(&mut g, "Su2", &x.v, Su2::exp);
    batch(
        &mut g,
        "nalgebra UnitQuaternion::from_scaled_axis",
        &x.v,
        |v| UnitQuaternion::from_scaled_axis(*v),
    );
    batch(&mut g, "nalgebra Rotation3::from_scaled_axis", &x.v, |v| {
        Rotation3::from_scaled_axis(*v)
    });
    g.finish();
    // One sample's turn of a strapdown integrator, |ω| Δt: the same directions with angles in
    // [0, 0.2), exp's series range.
    let small: Vec<_> = x.v.iter().map(|v| v * (0.2 / 3.1)).collect();
    let mut g = group(c, "exp_small_angle");
    batch(&mut g, "So3", &small, So3::exp);
    batch(
        &mut g,
        "nalgebra UnitQuaternion::from_scaled_axis",
        &small,
        |v| UnitQuaternion::from_scaled_axis(*v),
    );
    g.finish();
}

fn log(c: &mut Criterion) {
    let x = Inputs::new();
    let r: Vec<_> = x.v.iter().map(So3::exp).collect();
    let q: Vec<_> = x.v.iter().map(Su2::exp).collect();
    let u: Vec<_> =
        x.v.iter()
            .map(|v| UnitQuaternion::from_scaled_axis(*v))
            .collect();
    let m: Vec<_> =
        x.v.iter()
            .map(|v| Rotation3::from_scaled_axis(*v))
            .collect();
    let mut g = group(c, "log");
    batch(&mut g, "So3", &r, So3::log);
    batch(&mut g, "Su2", &q, Su2::log);
    batch(
        &mut g,
        "nalgebra UnitQuaternion::scaled_axis",
        &u,
        UnitQuaternion::scaled_axis,
    );
    batch(
        &mut g,
        "nalgebra Rotation3::scaled_axis",
        &m,
        Rotation3::scaled_axis,
    );
    g.finish();
}

fn compose(c: &mut Criterion) {
    let x = Inputs::new();
    let pairs =
        |f: &dyn Fn(&Vector3<f64>) -> _| -> Vec<(UnitQuaternion<f64>, UnitQuaternion<f64>)> {
            x.v.iter().zip(&x.w).map(|(v, w)| (f(v), f(w))).collect()
        };
    let uq = pairs(&|v| UnitQuaternion::from_scaled_axis(*v));
    let r: Vec<_> = uq
        .iter()
        .map(|(a, b)| (So3::from(*a), So3::from(*b)))
        .collect();
    let q: Vec<_> = uq
        .iter()
        .map(|(a, b)| (Su2::from(*a), Su2::from(*b)))
        .collect();
    let m: Vec<_> = uq
        .iter()
        .map(|(a, b)| (a.to_rotation_matrix(), b.to_rotation_matrix()))
        .collect();
    let mut g = group(c, "compose");
    batch(&mut g, "So3", &r, |(a, b)| a.compose(b));
    batch(&mut g, "Su2", &q, |(a, b)| a.compose(b));
    batch(&mut g, "nalgebra UnitQuaternion *", &uq, |(a, b)| a * b);
    batch(&mut g, "nalgebra Rotation3 *", &m, |(a, b)| a * b);
    g.finish();
}

fn act(c: &mut Criterion) {
    let x = Inputs::new();
    let uq: Vec<_> =
        x.v.iter()
            .zip(&x.p)
            .map(|(v, p)| (UnitQuaternion::from_scaled_axis(*v), *p))
            .collect();
    let r: Vec<_> = uq.iter().map(|(a, p)| (So3::from(*a), *p)).collect();
    let q: Vec<_> = uq.iter().map(|(a, p)| (Su2::from(*a), *p)).collect();
    let m: Vec<_> = uq
        .iter()
        .map(|(a, p)| (a.to_rotation_matrix(), *p))
        .collect();
    let mut g = group(c, "act");
    batch(&mut g, "So3", &r, |(a, p)| a.act(p));
    batch(&mut g, "Su2", &q, |(a, p)| a.act(p));
    batch(
        &mut g,
        "nalgebra UnitQuaternion * Vector3",
        &uq,
        |(a, p)| a * p,
    );
    batch(&mut g, "nalgebra Rotation3 * Vector3", &m, |(a, p)| a * p);
    g.finish();
}

fn jacobians(c: &mut Criterion) {
    let x = Inputs::new();
    let r: Vec<_> =
        x.v.iter()
            .zip(&x.w)
            .zip(&x.p)
            .map(|((v, w), p)| (So3::exp(v), So3::exp(w), *p))
            .collect();
    let q: Vec<_> =
        x.v.iter()
            .zip(&x.w)
            .zip(&x.p)
            .map(|((v, w), p)| (Su2::exp(v), Su2::exp(w), *p))
            .collect();
    let mut g = group(c, "jacobians");
    batch(&mut g, "So3 right_jacobian", &x.v, So3::right_jacobian);
    batch(
        &mut g,
        "So3 right_jacobian_inverse",
        &x.v,
        So3::right_jacobian_inverse,
    );
    batch(&mut g, "So3 j_act_self", &r, |(a, _, p)| a.j_act_self(p));
    batch(&mut g, "So3 j_compose_self", &r, |(a, b, _)| {
        a.j_compose_self(b)
    });
    batch(&mut g, "So3 local", &r, |(a, b, _)| a.local(b));
    batch(&mut g, "So3 j_local_other", &r, |(a, b, _)| {
        a.j_local_other(b)
    });
    batch(&mut g, "Su2 right_jacobian", &x.v, Su2::right_jacobian);
    batch(&mut g, "Su2 j_act_self", &q, |(a, _, p)| a.j_act_self(p));
    batch(&mut g, "Su2 j_local_other", &q, |(a, b, _)| {
        a.j_local_other(b)
    });
    g.finish();
}

/// Pose tangents from the same inputs: SE(3) `[ρ; φ] = [p; v]`, SE(2) `[p_x, p_y, θ]` with
/// θ = ±|v| in (−π, π).
fn pose_tangents(x: &Inputs) -> (Vec<Vector6<f64>>, Vec<Vector3<f64>>) {
    let se3 =
        x.p.iter()
            .zip(&x.v)
            .map(|(p, v)| Vector6::new(p.x, p.y, p.z, v.x, v.y, v.z));
    let se2 =
        x.p.iter()
            .zip(&x.v)
            .map(|(p, v)| Vector3::new(p.x, p.y, v.norm().copysign(v.x)));
    (se3.collect(), se2.collect())
}

fn poses(c: &mut Criterion) {
    let x = Inputs::new();
    let (v3, v2) = pose_tangents(&x);
    let (w3, w2) = {
        let swapped = Inputs {
            v: x.w.clone(),
            w: x.v.clone(),
            p: x.p.iter().rev().copied().collect(),
        };
        pose_tangents(&swapped)
    };
    let pairs3: Vec<_> = v3
        .iter()
        .zip(&w3)
        .map(|(a, b)| (Se3::exp(a), Se3::exp(b)))
        .collect();
    let pairs2: Vec<_> = v2
        .iter()
        .zip(&w2)
        .map(|(a, b)| (Se2::exp(a), Se2::exp(b)))
        .collect();
    let iso3: Vec<(Isometry3<f64>, Isometry3<f64>)> = pairs3
        .iter()
        .map(|(a, b)| ((*a).into(), (*b).into()))
        .collect();
    let iso2: Vec<(Isometry2<f64>, Isometry2<f64>)> = pairs2
        .iter()
        .map(|(a, b)| ((*a).into(), (*b).into()))
        .collect();

    let mut g = group(c, "pose compose");
    batch(&mut g, "Se2", &pairs2, |(a, b)| a.compose(b));
    batch(&mut g, "nalgebra Isometry2 *", &iso2, |(a, b)| a * b);
    batch(&mut g, "Se3", &pairs3, |(a, b)| a.compose(b));
    batch(&mut g, "nalgebra Isometry3 *", &iso3, |(a, b)| a * b);
    g.finish();

    let points3: Vec<_> = pairs3
        .iter()
        .zip(&x.p)
        .map(|((a, _), p)| (*a, *p))
        .collect();
    let iso_points3: Vec<_> = iso3
        .iter()
        .zip(&x.p)
        .map(|((a, _), p)| (*a, Point3::from(*p)))
        .collect();
    let points2: Vec<_> = pairs2
        .iter()
        .zip(&x.p)
        .map(|((a, _), p)| (*a, p.xy()))
        .collect();
    let iso_points2: Vec<_> = iso2
        .iter()
        .zip(&x.p)
        .map(|((a, _), p)| (*a, Point2::from(p.xy())))
        .collect();
    let mut g = group(c, "pose act");
    batch(&mut g, "Se2", &points2, |(a, p)| a.act(p));
    batch(
        &mut g,
        "nalgebra Isometry2 * Point2",
        &iso_points2,
        |(a, p)| a * p,
    );
    batch(&mut g, "Se3", &points3, |(a, p)| a.act(p));
    batch(
        &mut g,
        "nalgebra Isometry3 * Point3",
        &iso_points3,
        |(a, p)| a * p,
    );
    g.finish();

    let mut g = group(c, "pose exp");
    batch(&mut g, "Se2", &v2, Se2::exp);
    batch(&mut g, "Se3", &v3, Se3::exp);
    g.finish();

    let elements2: Vec<_> = pairs2.iter().map(|(a, _)| *a).collect();
    let elements3: Vec<_> = pairs3.iter().map(|(a, _)| *a).collect();
    let mut g = group(c, "pose log");
    batch(&mut g, "Se2", &elements2, Se2::log);
    batch(&mut g, "Se3", &elements3, Se3::log);
    g.finish();

    let mut g = group(c, "pose jacobians");
    batch(&mut g, "Se2 right_jacobian", &v2, Se2::right_jacobian);
    batch(
        &mut g,
        "Se2 right_jacobian_inverse",
        &v2,
        Se2::right_jacobian_inverse,
    );
    batch(&mut g, "Se3 right_jacobian", &v3, Se3::right_jacobian);
    batch(
        &mut g,
        "Se3 right_jacobian_inverse",
        &v3,
        Se3::right_jacobian_inverse,
    );
    batch(&mut g, "Se3 adjoint", &elements3, Se3::adjoint);
    g.finish();
}

/// Attitude and gyroscope bias.
type AttitudeBias = ProductManifold<So3<f64>, Rn<f64, 3>, 3, 3, 6>;

fn product(c: &mut Criterion) {
    let x = Inputs::new();
    let states: Vec<(AttitudeBias, AttitudeBias, SVector<f64, 6>)> = x
        .v
        .iter()
        .zip(&x.w)
        .zip(&x.p)
        .map(|((v, w), p)| {
            let state = |r: &Vector3<f64>| AttitudeBias::new(So3::exp(r), Rn::new_unchecked(*p));
            (
                state(v),
                state(w),
                AttitudeBias::join_tangent(&(w * 0.1), p),
            )
        })
        .collect();
    let mut g = group(c, "product");
    batch(&mut g, "So3 x R3 retract", &states, |(a, _, d)| {
        a.retract(d)
    });
    batch(
        &mut g,
        "So3 retract + R3 add (by hand)",
        &states,
        |(a, _, d)| {
            let (dr, db) = AttitudeBias::split_tangent(d);
            (a.first().retract(&dr), a.second().coords() + db)
        },
    );
    batch(&mut g, "So3 x R3 local", &states, |(a, b, _)| a.local(b));
    batch(&mut g, "So3 x R3 compose", &states, |(a, b, _)| {
        a.compose(b)
    });
    batch(&mut g, "So3 x R3 j_retract_self", &states, |(a, _, d)| {
        a.j_retract_self(d)
    });
    batch(&mut g, "So3 x R3 j_local_other", &states, |(a, b, _)| {
        a.j_local_other(b)
    });
    let left: Vec<_> =
        x.v.iter()
            .zip(&x.w)
            .map(|(v, w)| (Left::new(So3::exp(v)), Left::new(So3::exp(w)), w * 0.1))
            .collect();
    batch(&mut g, "Left<So3> retract", &left, |(a, _, d)| a.retract(d));
    batch(&mut g, "Left<So3> local", &left, |(a, b, _)| a.local(b));
    g.finish();
}

/// The 2D + 1 sigma points of the scaled unscented transform (α = 1, κ = 0) around `centre` with
/// offsets `columns`, and their weights.
fn sigma_points<X: Manifold<D, Scalar = f64>, const D: usize>(
    centre: &X,
    columns: &[SVector<f64, D>; D],
) -> (Vec<X>, Vec<f64>) {
    let spread = (D as f64).sqrt();
    let points = std::iter::once(centre.clone())
        .chain(columns.iter().map(|l| centre.retract(&(l * spread))))
        .chain(columns.iter().map(|l| centre.retract(&(l * -spread))))
        .collect();
    let weights = std::iter::once(0.0)
        .chain(std::iter::repeat_n(0.5 / D as f64, 2 * D))
        .collect();
    (points, weights)
}

fn mean(c: &mut Criterion) {
    let x = Inputs::new();
    let columns3: [Vector3<f64>; 3] = std::array::from_fn(|i| x.w[i] * 0.1);
    let columns6: [SVector<f64, 6>; 6] =
        std::array::from_fn(|i| AttitudeBias::join_tangent(&(x.w[i] * 0.1), &x.p[i]));
    let so3: Vec<_> =
        x.v.iter()
            .map(|v| sigma_points(&So3::exp(v), &columns3))
            .collect();
    let product: Vec<_> =
        x.v.iter()
            .zip(&x.p)
            .map(|(v, p)| {
                sigma_points(
                    &AttitudeBias::new(So3::exp(v), Rn::new_unchecked(*p)),
                    &columns6,
                )
            })
            .collect();
    let mut g = group(c, "weighted_mean");
    batch(&mut g, "So3, 7 sigma points", &so3, |(xs, ws)| {
        weighted_mean(
            &xs[0],
            xs.iter().zip(ws.iter().copied()),
            MeanSettings::default(),
        )
    });
    batch(&mut g, "So3 x R3, 13 sigma points", &product, |(xs, ws)| {
        weighted_mean(
            &xs[0],
            xs.iter().zip(ws.iter().copied()),
            MeanSettings::default(),
        )
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = exp, log, compose, act, jacobians, poses, product, mean
}
criterion_main!(benches);
