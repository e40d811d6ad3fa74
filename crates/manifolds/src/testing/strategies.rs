//! proptest strategies for every space of the crate, generic over the scalar.
//!
//! Each strategy mixes uniformly distributed elements with the curated edge cases where Lie-group code
//! breaks: the identity, elements within 1e-8 of it, rotation angles within 1e-12 of π and exactly π,
//! tangents of norm 20 and 30, and (for SU(2)) `w = −1` and `w < 0`. Values are drawn in `f64` and
//! rounded to the scalar type.

use crate::{Left, LieGroup, Manifold, ProductManifold, Real, Rn, S2, So2, So3, Su2, Tangent};
use nalgebra::{Quaternion, SVector, Vector1, Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};
use std::fmt::Debug;

use crate::{Se2, Se3, Se23};
use nalgebra::Vector6;

/// A unit vector of R³, uniform on the sphere (z uniform in [−1, 1], longitude uniform).
fn unit_vector_f64() -> impl Strategy<Value = [f64; 3]> {
    (-1.0..=1.0_f64, 0.0..TAU).prop_map(|(z, phi)| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    })
}

/// Rotation angles / tangent norms: typical values in [0, 2π) and the curated edge cases.
pub fn angle_magnitude() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => 0.0..TAU,
        1 => Just(0.0),
        1 => 1e-10..=1e-8_f64,
        1 => (0.0..=1e-12_f64).prop_map(|d| PI - d),
        1 => Just(PI),
        1 => Just(20.0),
        1 => Just(30.0),
    ]
}

fn to_vector<T: Real>(u: [f64; 3], scale: f64) -> Vector3<T> {
    Vector3::new(
        T::lit(u[0] * scale),
        T::lit(u[1] * scale),
        T::lit(u[2] * scale),
    )
}

/// Rotation vectors (tangents of SO(3) and SU(2)): uniform direction, norm from [`angle_magnitude`].
pub fn rotation_vector<T: Real>() -> impl Strategy<Value = Vector3<T>> {
    (unit_vector_f64(), angle_magnitude()).prop_map(|(u, n)| to_vector(u, n))
}

/// Tangents of SO(2): a signed angle from [`angle_magnitude`].
pub fn so2_tangent<T: Real>() -> impl Strategy<Value = Vector1<T>> {
    (angle_magnitude(), any::<bool>())
        .prop_map(|(a, negative)| Vector1::new(T::lit(if negative { -a } else { a })))
}

/// Tangents of S² (two coordinates in the tangent basis): uniform direction in the plane, norm from
/// [`angle_magnitude`].
pub fn s2_tangent<T: Real>() -> impl Strategy<Value = Vector2<T>> {
    (0.0..TAU, angle_magnitude())
        .prop_map(|(phi, n)| Vector2::new(T::lit(n * phi.cos()), T::lit(n * phi.sin())))
}

/// Tangents of Rⁿ: components in [−1e3, 1e3], and the zero vector.
pub fn rn_tangent<T: Real, const N: usize>() -> impl Strategy<Value = SVector<T, N>> {
    prop_oneof![
        6 => proptest::array::uniform::<_, N>(-1e3..1e3_f64)
            .prop_map(|a| SVector::from_fn(|i, _| T::lit(a[i]))),
        1 => Just(SVector::zeros()),
    ]
}

/// Points of R³ for group actions: components in [−10, 10], and the origin.
pub fn point3<T: Real>() -> impl Strategy<Value = Vector3<T>> {
    rn_tangent::<T, 3>().prop_map(|v| v / T::lit(100.0))
}

/// Points of R² for group actions: components in [−10, 10], and the origin.
pub fn point2<T: Real>() -> impl Strategy<Value = Vector2<T>> {
    rn_tangent::<T, 2>().prop_map(|v| v / T::lit(100.0))
}

/// Uniform unit quaternion (Shoemake's method), scalar first.
fn uniform_quaternion<T: Real>() -> impl Strategy<Value = Quaternion<T>> {
    (0.0..=1.0_f64, 0.0..TAU, 0.0..TAU).prop_map(|(u, a, b)| {
        let (r1, r2) = ((1.0 - u).sqrt(), u.sqrt());
        Quaternion::new(
            T::lit(r2 * b.cos()),
            T::lit(r1 * a.sin()),
            T::lit(r1 * a.cos()),
            T::lit(r2 * b.sin()),
        )
    })
}

/// A quaternion `(w, xyz)` with the given scalar part and a uniformly drawn axis, normalised.
fn quaternion_with_w<T: Real>(w: f64) -> impl Strategy<Value = Quaternion<T>> {
    unit_vector_f64().prop_map(move |u| {
        let s = (1.0 - w * w).max(0.0).sqrt();
        Quaternion::new(
            T::lit(w),
            T::lit(u[0] * s),
            T::lit(u[1] * s),
            T::lit(u[2] * s),
        )
    })
}

/// Elements of SU(2): uniform, exp of [`rotation_vector`], exactly π (`w = 0`), `w = −1`, and the
/// identity.
pub fn su2<T: Real>() -> impl Strategy<Value = Su2<T>> {
    // The drawn quaternions are unit in f64; renormalise after rounding to T.
    let normalized = |q: Quaternion<T>| Su2::from_quaternion_unchecked(q.normalize());
    prop_oneof![
        4 => uniform_quaternion::<T>().prop_map(normalized),
        4 => rotation_vector::<T>().prop_map(|v| Su2::exp(&v)),
        1 => quaternion_with_w::<T>(0.0).prop_map(normalized),
        1 => quaternion_with_w::<T>(-1.0).prop_map(normalized),
        1 => Just(Su2::identity()),
    ]
}

/// Elements of SO(3): the images of [`su2`] (uniform, near the identity, near and exactly at π, large
/// tangents).
pub fn so3<T: Real>() -> impl Strategy<Value = So3<T>> {
    su2::<T>().prop_map(|q| q.to_so3())
}

/// Elements of SO(2): exp of [`so2_tangent`] (including ±π exactly), uniform angles, and the identity.
pub fn so2<T: Real>() -> impl Strategy<Value = So2<T>> {
    prop_oneof![
        4 => so2_tangent::<T>().prop_map(|v| So2::exp(&v)),
        2 => (-PI..PI).prop_map(|a| So2::from_angle_unchecked(T::lit(a))),
        1 => Just(So2::from_cos_sin_unchecked(-T::one(), T::zero())),
        1 => Just(So2::identity()),
    ]
}

/// Points of S²: uniform, the poles exactly, and points within 1e-12 of the equator (where the tangent
/// basis switches charts).
pub fn s2<T: Real>() -> impl Strategy<Value = S2<T>> {
    // The drawn vectors are unit in f64; renormalise after rounding to T.
    let from = |u: [f64; 3]| S2::new_unchecked(to_vector::<T>(u, 1.0).normalize());
    prop_oneof![
        6 => unit_vector_f64().prop_map(from),
        1 => Just(from([0.0, 0.0, 1.0])),
        1 => Just(from([0.0, 0.0, -1.0])),
        1 => (0.0..TAU, -1e-12..=1e-12_f64)
            .prop_map(move |(phi, z)| from([phi.cos(), phi.sin(), z])),
    ]
}

/// Points of Rⁿ: components in [−1e3, 1e3], and the origin.
pub fn rn<T: Real, const N: usize>() -> impl Strategy<Value = Rn<T, N>> {
    rn_tangent::<T, N>().prop_map(Rn::new_unchecked)
}

/// Sizes of translation blocks of pose tangents: typical values in [0, 10), zero, within 1e-8 of
/// zero, 20 and 30.
pub fn translation_magnitude() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => 0.0..10.0_f64,
        1 => Just(0.0),
        1 => 1e-10..=1e-8_f64,
        1 => Just(20.0),
        1 => Just(30.0),
    ]
}

/// Sizes of pose translations: [`translation_magnitude`] and large ones (1e3, the scale of the [`rn`]
/// strategies).
fn pose_translation_magnitude() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => translation_magnitude(),
        1 => Just(1e3),
    ]
}

fn planar<T: Real>(phi: f64, n: f64) -> Vector2<T> {
    Vector2::new(T::lit(n * phi.cos()), T::lit(n * phi.sin()))
}

/// Translations of R² for poses: uniform direction, norm from [`translation_magnitude`] or 1e3.
pub fn translation2<T: Real>() -> impl Strategy<Value = Vector2<T>> {
    (0.0..TAU, pose_translation_magnitude()).prop_map(|(phi, n)| planar(phi, n))
}

/// Translations of R³ for poses: uniform direction, norm from [`translation_magnitude`] or 1e3.
pub fn translation3<T: Real>() -> impl Strategy<Value = Vector3<T>> {
    (unit_vector_f64(), pose_translation_magnitude()).prop_map(|(u, n)| to_vector(u, n))
}

/// Tangents of SE(2), `[ρ; θ]`: the angle from [`so2_tangent`] (0, 1e-8, within 1e-12 of ±π, exactly
/// ±π, 20, 30), the translation block of uniform direction with norm from
/// [`translation_magnitude`], and whole tangents within 1e-8 of zero.
pub fn se2_tangent<T: Real>() -> impl Strategy<Value = Vector3<T>> {
    let small = (unit_vector_f64(), 1e-10..=1e-8_f64).prop_map(|(u, n)| to_vector::<T>(u, n));
    prop_oneof![
        8 => (0.0..TAU, translation_magnitude(), so2_tangent::<T>()).prop_map(|(phi, n, theta)| {
            let rho = planar::<T>(phi, n);
            Vector3::new(rho.x, rho.y, theta.x)
        }),
        1 => small,
    ]
}

/// Tangents of SE(3), `[ρ; φ]`: the rotation block from [`rotation_vector`] (0, 1e-8, within 1e-12 of
/// π, exactly π, 20, 30), the translation block of uniform direction with norm from
/// [`translation_magnitude`], and whole tangents within 1e-8 of zero.
pub fn se3_tangent<T: Real>() -> impl Strategy<Value = Vector6<T>> {
    let small = (
        unit_vector_f64(),
        unit_vector_f64(),
        0.0..=1.0_f64,
        1e-10..=1e-8_f64,
    )
        .prop_map(|(a, b, share, n)| {
            let rho = to_vector::<T>(a, n * share.sqrt());
            let phi = to_vector::<T>(b, n * (1.0 - share).sqrt());
            Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
        });
    prop_oneof![
        8 => (unit_vector_f64(), translation_magnitude(), rotation_vector::<T>()).prop_map(
            |(u, n, phi)| {
                let rho = to_vector::<T>(u, n);
                Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
            }
        ),
        1 => small,
    ]
}

/// Elements of SE(2): a rotation from [`so2`] (uniform, exactly π, identity, near ±π) with a
/// translation from [`translation2`] (including 1e3), exp of [`se2_tangent`] (within 1e-8 of the
/// identity, angles within 1e-12 of π, tangents of norm 20 and 30), and the identity.
pub fn se2<T: Real>() -> impl Strategy<Value = Se2<T>> {
    prop_oneof![
        4 => (so2::<T>(), translation2::<T>()).prop_map(|(r, t)| Se2::new_unchecked(r, t)),
        4 => se2_tangent::<T>().prop_map(|v| Se2::exp(&v)),
        1 => Just(Se2::identity()),
    ]
}

/// Elements of SE(3): a rotation from [`so3`] (uniform, near the identity, within 1e-12 of π,
/// exactly π) with a translation from [`translation3`] (including 1e3), exp of [`se3_tangent`]
/// (within 1e-8 of the identity, tangents of norm 20 and 30), and the identity.
pub fn se3<T: Real>() -> impl Strategy<Value = Se3<T>> {
    prop_oneof![
        4 => (so3::<T>(), translation3::<T>()).prop_map(|(r, t)| Se3::new_unchecked(r, t)),
        4 => se3_tangent::<T>().prop_map(|v| Se3::exp(&v)),
        1 => Just(Se3::identity()),
    ]
}

/// Tangents of SE₂(3), `[ρ; φ; ν]`: the rotation block from [`rotation_vector`] (0, 1e-8, within
/// 1e-12 of π, exactly π, 20, 30), the position and velocity blocks of uniform directions with norms
/// from [`translation_magnitude`] (0, 1e-8, 20, 30), and whole tangents within 1e-8 of zero.
pub fn se23_tangent<T: Real>() -> impl Strategy<Value = SVector<T, 9>> {
    let linear =
        || (unit_vector_f64(), translation_magnitude()).prop_map(|(u, n)| to_vector::<T>(u, n));
    let stack = |rho: Vector3<T>, phi: Vector3<T>, nu: Vector3<T>| {
        SVector::<T, 9>::from_fn(|i, _| [rho, phi, nu][i / 3][i % 3])
    };
    let small = (
        unit_vector_f64(),
        unit_vector_f64(),
        unit_vector_f64(),
        1e-10..=1e-8_f64,
    )
        .prop_map(move |(a, b, c, n)| {
            let third = n / 3.0_f64.sqrt();
            stack(
                to_vector(a, third),
                to_vector(b, third),
                to_vector(c, third),
            )
        });
    prop_oneof![
        8 => (linear(), rotation_vector::<T>(), linear())
            .prop_map(move |(rho, phi, nu)| stack(rho, phi, nu)),
        1 => small,
    ]
}

/// Elements of SE₂(3): a rotation from [`so3`] (uniform, near the identity, within 1e-12 of π,
/// exactly π) with a velocity and a position from [`translation3`] (0, 1e-8, 20, 30, 1e3), exp of
/// [`se23_tangent`] (within 1e-8 of the identity, tangents of norm 20 and 30), and the identity.
pub fn se23<T: Real>() -> impl Strategy<Value = Se23<T>> {
    prop_oneof![
        4 => (so3::<T>(), translation3::<T>(), translation3::<T>())
            .prop_map(|(r, v, p)| Se23::new_unchecked(r, v, p)),
        4 => se23_tangent::<T>().prop_map(|v| Se23::exp(&v)),
        1 => Just(Se23::identity()),
    ]
}

/// Elements of [`Left<G>`](Left) for any group: the elements of `elements` (for instance [`so3`]),
/// wrapped. Tangents and points are those of `G`.
pub fn left<G: Clone + Debug>(
    elements: impl Strategy<Value = G>,
) -> impl Strategy<Value = Left<G>> {
    elements.prop_map(Left::new)
}

/// Points of a [`ProductManifold`]: the two factors drawn independently. The dimensions are usually
/// named, `product::<_, _, 3, 3, 6>(so3(), rn())`.
pub fn product<A, B, const DA: usize, const DB: usize, const D: usize>(
    first: impl Strategy<Value = A>,
    second: impl Strategy<Value = B>,
) -> impl Strategy<Value = ProductManifold<A, B, DA, DB, D>>
where
    A: Clone + Debug,
    B: Clone + Debug,
{
    (first, second).prop_map(|(a, b)| ProductManifold::new(a, b))
}

/// Tangents of `ProductManifold<A, B, DA, DB, D>`: the blocks drawn independently
/// (for instance [`rotation_vector`] and [`rn_tangent`]) and stacked.
pub fn product_tangent<A, B, const DA: usize, const DB: usize, const D: usize>(
    first: impl Strategy<Value = Tangent<A::Scalar, DA>>,
    second: impl Strategy<Value = Tangent<A::Scalar, DB>>,
) -> impl Strategy<Value = Tangent<A::Scalar, D>>
where
    A: Manifold<DA>,
    B: Manifold<DB, Scalar = A::Scalar>,
{
    (first, second).prop_map(|(a, b)| ProductManifold::<A, B, DA, DB, D>::join_tangent(&a, &b))
}

/// Extreme scalars, the bad-input law's raw numbers: NaN, ±∞, ±MAX, MIN_POSITIVE, subnormals
/// (5e-324 and −1e-310 in f64), ±0, 1e300, −1e-300, ordinary values in [−10, 10], and log-uniform
/// magnitudes from 1e-320 to 1e308 of either sign (which give the other signs of those
/// magnitudes too). Drawn in `f64` and rounded to the scalar type,
/// where a finite value beyond the type's range saturates at its largest finite value (so the
/// finite classes stay finite in f32).
pub fn extreme<T: Real>() -> impl Strategy<Value = T> + Clone {
    prop_oneof![
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        3 => extreme_finite_f64(),
    ]
    .prop_map(to_scalar::<T>)
}

/// The finite values of [`extreme`].
pub fn extreme_finite<T: Real>() -> impl Strategy<Value = T> + Clone {
    extreme_finite_f64().prop_map(to_scalar::<T>)
}

/// Tangent vectors whose components are each drawn from [`extreme_finite`]: every magnitude a
/// finite tangent can have.
pub fn extreme_tangent<T: Real, const D: usize>() -> impl Strategy<Value = SVector<T, D>> {
    proptest::collection::vec(extreme_finite::<T>(), D).prop_map(|c| SVector::from_iterator(c))
}

/// Tangent vectors whose components are each drawn from [`extreme`]: the finite magnitudes, NaN
/// and ±∞, as raw numbers from a corrupt input would give them.
pub fn extreme_raw_tangent<T: Real, const D: usize>() -> impl Strategy<Value = SVector<T, D>> {
    proptest::collection::vec(extreme::<T>(), D).prop_map(|c| SVector::from_iterator(c))
}

/// The finite classes of [`extreme`], in f64.
fn extreme_finite_f64() -> impl Strategy<Value = f64> + Clone {
    prop_oneof![
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
        1 => Just(f64::MIN_POSITIVE),
        1 => Just(5e-324),
        1 => Just(-1e-310),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(1e300),
        1 => Just(-1e-300),
        3 => -10.0..10.0_f64,
        4 => (-320.0..308.0_f64, any::<bool>())
            .prop_map(|(e, negative)| if negative { -(10f64.powf(e)) } else { 10f64.powf(e) }),
    ]
}

/// `x` in the scalar type, a finite value beyond its range saturated at its largest finite value.
fn to_scalar<T: Real>(x: f64) -> T {
    let t = T::lit(x);
    if x.is_finite() && !t.is_finite() {
        if x > 0.0 {
            T::max_finite()
        } else {
            -T::max_finite()
        }
    } else {
        t
    }
}
