//! Bad input never panics and never yields NaN. Every public constructor and operation of the crate is
//! fed NaN, ±∞, ±MAX, ±MIN_POSITIVE, subnormals, ±0, ±1e±300 and ordinary numbers: a constructor must
//! return an error exactly when its input is invalid and a valid element (unit norm, orthonormal)
//! otherwise; an operation on valid elements with finite tangents must return finite numbers and
//! valid elements. The fixed cases at the end are the regressions of reported failures.

use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{
    GroupAction, Left, LieGroup, Manifold, ManifoldError, MeanSettings, ProductManifold, Real, Rn,
    S2, Se2, Se3, So2, So3, Su2, weighted_mean,
};
use liebayes_reference::fuzz;
use nalgebra::{Matrix2, Matrix3, Quaternion, SVector, Vector1, Vector2, Vector3, Vector6};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use std::f64::consts::PI;

/// Raw numbers a user might pass, good and bad: the shared bad-input harness's generator (NaN, ±∞,
/// ±MAX, ±MIN_POSITIVE, subnormals, ±0, ±1e±300, ordinary and log-uniform magnitudes).
fn raw() -> impl Strategy<Value = f64> {
    fuzz::value()
}

/// The finite values of [`raw`].
fn finite() -> impl Strategy<Value = f64> {
    raw().prop_filter("finite", |x| x.is_finite())
}

/// The same classes in f32 (MAX, MIN_POSITIVE and subnormals of f32, 1e±30 for 1e±300).
fn finite_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -2.0..2.0_f32,
        1 => Just(f32::MAX),
        1 => Just(-f32::MAX),
        1 => Just(f32::MIN_POSITIVE),
        1 => prop::num::f32::SUBNORMAL,
        2 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(1e30),
        1 => Just(-1e-30),
    ]
}

fn all_finite<T: Real>(values: impl IntoIterator<Item = T>) -> bool {
    values.into_iter().all(|v| v.is_finite())
}

/// The Euclidean norm without overflow or underflow (the reference for the checks, computed
/// independently of the crate's own scaling).
fn safe_norm(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |acc: f64, v| acc.hypot(*v))
}

/// A quaternion `[w, x, y, z]` is finite and unit within `tolerance`.
fn unit_wxyz<T: Real>(q: [T; 4], tolerance: T) -> bool {
    all_finite(q) && (Quaternion::new(q[0], q[1], q[2], q[3]).norm() - T::one()).abs() <= tolerance
}

/// A matrix is a rotation: finite, orthonormal and with determinant +1, within `tolerance`.
fn is_rotation(m: &Matrix3<f64>, tolerance: f64) -> bool {
    all_finite(m.iter().copied())
        && (m.transpose() * m - Matrix3::identity()).amax() <= tolerance
        && (m.determinant() - 1.0).abs() <= tolerance
}

/// `So3::from_matrix_orthonormalized(m)` is an error exactly for non-finite matrices and those with
/// det m <= 0 (decided by the cofactor determinant of `m / max |m_ij|` where that is clearly away
/// from zero), and otherwise a unit quaternion whose matrix Q is a rotation and the nearest one:
/// `Qᵀ m` is symmetric (the first-order optimality condition of max tr(Qᵀ m) over rotations).
fn check_orthonormalized(m: &Matrix3<f64>) -> Result<(), TestCaseError> {
    let finite = all_finite(m.iter().copied());
    let scaled = if finite && m.amax() > 0.0 {
        m / m.amax()
    } else {
        *m
    };
    let det = scaled.determinant();
    match So3::from_matrix_orthonormalized(m) {
        Ok(s) => {
            prop_assert!(finite && det > -1e-12, "accepted with det {det:e}");
            prop_assert!(unit_wxyz(s.to_quaternion_wxyz(), 4.0 * f64::EPSILON));
            let q = s.to_matrix();
            prop_assert!(is_rotation(&q, 1e-14));
            let h = q.transpose() * scaled;
            prop_assert!((h - h.transpose()).amax() <= 1e-14, "Q^T M = {h:e}");
        }
        Err(ManifoldError::NonFinite { .. }) => prop_assert!(!finite),
        Err(ManifoldError::NotProperRotation { det: reported }) => {
            prop_assert!(
                finite && reported <= 0.0 && det < 1e-12,
                "refused with det {det:e}"
            );
        }
        Err(e) => prop_assert!(false, "unexpected error {e}"),
    }
    Ok(())
}

proptest! {
    // Each case is a few cheap calls: 32 times the harness's case count (2048 in CI), which
    // `LIEBAYES_FUZZ_CASES` scales for the long run.
    // The finite-only inputs filter out about one draw in eight; the reject budget grows with the
    // case count (proptest's default, 65 536, would end a long run).
    // The generator is seeded by `LIEBAYES_FUZZ_SEED` like the other suites, so a failure reproduces.
    #![proptest_config(ProptestConfig {
        cases: 32 * fuzz::cases(),
        max_local_rejects: 32 * fuzz::cases(),
        rng_seed: proptest::test_runner::RngSeed::Fixed(fuzz::seed()),
        ..ProptestConfig::default()
    })]

    #[test]
    fn quaternion_constructors(w in raw(), x in raw(), y in raw(), z in raw()) {
        let q = Quaternion::new(w, x, y, z);
        let finite = all_finite([w, x, y, z]);
        let norm = safe_norm(&[w, x, y, z]);
        let unit = finite && (norm - 1.0).abs() <= 1e-9;
        match Su2::from_quaternion(q) {
            Ok(e) => {
                prop_assert!(unit);
                prop_assert!(unit_wxyz(e.to_quaternion_wxyz(), 1e-9));
            }
            Err(err) => { prop_assert!(!unit); prop_assert!(!err.to_string().is_empty()); }
        }
        prop_assert_eq!(Su2::from_quaternion_wxyz(w, x, y, z).is_ok(), unit);
        prop_assert_eq!(So3::from_quaternion(q).is_ok(), unit);
        prop_assert_eq!(So3::from_quaternion_wxyz(w, x, y, z).is_ok(), unit);
        let long_enough = finite && norm >= 1e-150;
        match So3::from_quaternion_normalizing(q) {
            Ok(r) => {
                prop_assert!(long_enough);
                prop_assert!(unit_wxyz(r.to_quaternion_wxyz(), 1e-15));
            }
            Err(ManifoldError::NonFinite { .. }) => prop_assert!(!finite),
            Err(ManifoldError::ZeroVector { .. }) => prop_assert!(finite && norm < 1e-150),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
        match Su2::from_quaternion_normalizing(q) {
            Ok(r) => {
                prop_assert!(long_enough);
                let c = r.to_quaternion_wxyz();
                prop_assert!(unit_wxyz(c, 1e-15));
                // The same direction as q: q / |q| componentwise (q scaled by its largest entry first).
                let scale = q.coords.amax();
                let scaled = safe_norm(&[w / scale, x / scale, y / scale, z / scale]);
                for (got, raw) in c.iter().zip([w, x, y, z]) {
                    prop_assert!((got - raw / scale / scaled).abs() <= 1e-15);
                }
            }
            Err(_) => prop_assert!(!long_enough),
        }
    }

    #[test]
    fn vector_constructors(x in raw(), y in raw(), z in raw(), angle in raw()) {
        let v = Vector3::new(x, y, z);
        let finite = all_finite([x, y, z]);
        let norm = safe_norm(&[x, y, z]);
        let unit = finite && (norm - 1.0).abs() <= 1e-9;
        prop_assert_eq!(S2::new(v).is_ok(), unit);
        match S2::from_vector_normalizing(&v) {
            Ok(s) => {
                prop_assert!(finite && norm >= 1e-150);
                let u = s.as_vector();
                prop_assert!(all_finite(u.iter().copied()) && (u.norm() - 1.0).abs() < 1e-15);
                // Parallel to v and pointing the same way.
                let scaled = v / v.amax();
                prop_assert!(u.cross(&scaled).norm() <= 1e-15 * scaled.norm() && u.dot(&scaled) > 0.0);
            }
            Err(_) => prop_assert!(!finite || norm < 1e-150),
        }
        for r in [So3::from_rotation_vector(&v), Su2::from_rotation_vector(&v).map(So3::from)] {
            match r {
                Ok(r) => {
                    prop_assert!(finite);
                    prop_assert!(unit_wxyz(r.to_quaternion_wxyz(), 1e-12), "exp({v:?}) = {r:?}");
                    // A rotation about v: v is fixed (v scaled to order one first).
                    let axis = if norm > 0.0 { v / v.amax() } else { v };
                    prop_assert!((r.rotate(&axis) - axis).norm() <= 1e-12);
                }
                Err(_) => prop_assert!(!finite),
            }
        }
        match So3::from_axis_angle(&v, angle) {
            Ok(r) => {
                prop_assert!(finite && angle.is_finite() && norm >= 1e-150);
                prop_assert!(unit_wxyz(r.to_quaternion_wxyz(), 1e-12));
                let axis = v / v.amax();
                prop_assert!((r.rotate(&axis) - axis).norm() <= 1e-12);
            }
            Err(_) => prop_assert!(!finite || !angle.is_finite() || norm < 1e-150),
        }
        prop_assert_eq!(Rn::new(v).is_ok(), finite);
        prop_assert_eq!(Rn::<f64, 3>::from_slice(&[x, y, z]).is_ok(), finite);
        let wrong_length = matches!(
            Rn::<f64, 3>::from_slice(&[x, y]),
            Err(ManifoldError::WrongLength { expected: 3, got: 2, .. })
        );
        prop_assert!(wrong_length);
        match So2::from_angle(angle) {
            Ok(r) => {
                prop_assert!(angle.is_finite());
                prop_assert!((r.cos().hypot(r.sin()) - 1.0).abs() <= 1e-15);
            }
            Err(_) => prop_assert!(!angle.is_finite()),
        }
        let p = Vector2::new(x, y);
        let norm2 = safe_norm(&[x, y]);
        let finite2 = all_finite([x, y]);
        prop_assert_eq!(So2::from_cos_sin(x, y).is_ok(), finite2 && (norm2 - 1.0).abs() <= 1e-9);
        match So2::from_vector_normalizing(&p) {
            Ok(r) => {
                prop_assert!(finite2 && norm2 >= 1e-150);
                // The angle of the direction, on the principal branch (−π, π].
                let expected = y.atan2(x);
                let expected = if expected == -PI { PI } else { expected };
                prop_assert!((r.angle() - expected).abs() <= 1e-15);
            }
            Err(_) => prop_assert!(!finite2 || norm2 < 1e-150),
        }
    }

    /// A rotation with one entry replaced, or scaled, or with a flipped column.
    #[test]
    fn matrix_constructors(
        r in st::so3::<f64>(),
        i in 0usize..9,
        bad in raw(),
        scale in finite(),
        replace in any::<bool>(),
        flip in any::<bool>(),
    ) {
        for mut m in [r.to_matrix(), r.to_matrix() * scale] {
            if replace {
                m[i] = bad;
            }
            if flip {
                m.set_column(0, &-m.column(0));
            }
            let finite = all_finite(m.iter().copied());
            let rotation = finite
                && (m.transpose() * m - Matrix3::identity()).amax() <= 1e-9
                && (m.determinant() - 1.0).abs() <= 1e-9;
            match So3::from_matrix(&m) {
                Ok(s) => {
                    prop_assert!(rotation);
                    prop_assert!(unit_wxyz(s.to_quaternion_wxyz(), 1e-12));
                    prop_assert!((s.to_matrix() - m).amax() <= 1e-8);
                }
                Err(e) => prop_assert!(!rotation, "{}", e),
            }
            check_orthonormalized(&m)?;
            let m2 = Matrix2::new(m.m11, m.m12, m.m21, m.m22);
            let rotation2 = all_finite(m2.iter().copied())
                && (m2.transpose() * m2 - Matrix2::identity()).amax() <= 1e-9
                && (m2.determinant() - 1.0).abs() <= 1e-9;
            match So2::from_matrix(&m2) {
                Ok(s) => { prop_assert!(rotation2); prop_assert!((s.to_matrix() - m2).amax() <= 1e-8); }
                Err(_) => prop_assert!(!rotation2),
            }
        }
    }

    /// Matrices of entries of every size and sign (many of them reflections or degenerate): the
    /// nearest rotation is a unit quaternion and satisfies the optimality condition, or an error.
    #[test]
    fn orthonormalizing_arbitrary_matrices(entries in proptest::array::uniform9(raw())) {
        check_orthonormalized(&Matrix3::from_column_slice(&entries))?;
    }

    /// Every operation of the rotation groups on finite tangents and points of any size gives finite
    /// numbers and valid elements.
    #[test]
    fn rotation_operations_stay_finite(
        x in finite(), y in finite(), z in finite(),
        px in finite(), py in finite(), pz in finite(),
        a in st::so3::<f64>(),
    ) {
        let v = Vector3::new(x, y, z);
        // Points anywhere in the finite range: a rotated point or a Jacobian entry beyond it
        // saturates at the largest finite value.
        let p = Vector3::new(px, py, pz);
        let finite3 = |m: &Matrix3<f64>| all_finite(m.iter().copied());
        for r in [So3::exp(&v), a.retract(&v), Left::new(a).retract(&v).into_inner()] {
            prop_assert!(unit_wxyz(r.to_quaternion_wxyz(), 1e-12), "{r:?}");
            prop_assert!(r.log().norm() <= std::f64::consts::PI * (1.0 + 1e-15));
            prop_assert!(all_finite(r.act(&p).iter().copied()), "{r:?} . {p:?}");
            prop_assert!(all_finite(a.local(&r).iter().copied()));
        }
        let q = Su2::exp(&v);
        prop_assert!(unit_wxyz(q.to_quaternion_wxyz(), 1e-12));
        prop_assert!(q.log().norm() <= 2.0 * std::f64::consts::PI * (1.0 + 1e-15));
        for j in [
            So3::right_jacobian(&v),
            So3::right_jacobian_inverse(&v),
            So3::left_jacobian(&v),
            So3::left_jacobian_inverse(&v),
            a.j_retract_self(&v),
            a.j_retract_tangent(&v),
            a.j_act_self(&p),
            Left::new(a).j_retract_self(&v),
            Left::new(a).j_act_self(&p),
        ] {
            prop_assert!(finite3(&j), "{j:e}");
        }
        let so2 = So2::exp(&Vector1::new(x));
        prop_assert!((so2.cos().hypot(so2.sin()) - 1.0).abs() <= 1e-15);
        prop_assert!(so2.angle().is_finite() && all_finite(so2.act(&p.xy()).iter().copied()));
    }

    /// The same in f32, whose range ends at 3.4e38.
    #[test]
    fn rotation_operations_stay_finite_f32(x in finite_f32(), y in finite_f32(), z in finite_f32()) {
        let v = Vector3::new(x, y, z);
        let r = So3::exp(&v);
        prop_assert!(unit_wxyz(r.to_quaternion_wxyz(), 1e-5), "exp({v:?}) = {r:?}");
        prop_assert!(all_finite(r.log().iter().copied()));
        prop_assert!(unit_wxyz(Su2::exp(&v).to_quaternion_wxyz(), 1e-5));
        prop_assert!(all_finite(So3::right_jacobian(&v).iter().copied()));
        prop_assert!(all_finite(So3::right_jacobian_inverse(&v).iter().copied()));
        let s = S2::new(Vector3::new(0.0_f32, 0.6, 0.8)).unwrap();
        let t = s.retract(&v.xy());
        prop_assert!((t.as_vector().norm() - 1.0).abs() <= 1e-6, "{t:?}");
        prop_assert!(all_finite(s.local(&t).iter().copied()));
    }

    /// The sphere's exp and log on finite tangents of any size, and between any two points.
    #[test]
    fn sphere_operations_stay_finite(
        x in finite(), y in finite(), z in finite(),
        s in st::s2::<f64>(),
        t in st::s2::<f64>(),
    ) {
        let on_sphere = |p: &S2<f64>| (p.as_vector().norm() - 1.0).abs() <= 1e-15;
        let u = Vector2::new(x, y);
        let moved = s.retract(&u);
        prop_assert!(on_sphere(&moved), "retract({u:?}) = {moved:?}");
        let w = Vector3::new(x, y, z);
        prop_assert!(on_sphere(&s.exp_at(&w)), "exp_at({w:?})");
        for (a, b) in [(s, t), (s, moved), (s, s)] {
            let l = a.log_at(&b);
            // |log| = θ |d| with θ ≤ π and a unit direction d: the rounding of d's normalisation and
            // of the norm itself allow π (1 + 4ε) (the long run met π + 3 ulp near the antipode).
            let bound = std::f64::consts::PI * (1.0 + 4.0 * f64::EPSILON);
            prop_assert!(all_finite(l.iter().copied()) && l.norm() <= bound, "|log| = {:e}", l.norm());
            prop_assert!(all_finite(a.local(&b).iter().copied()));
            prop_assert!(a.distance(&b).is_finite());
        }
        // Moderate tangents keep local(x, retract(x, u)) = u (inside the injectivity radius).
        if u.norm() < 3.0 {
            prop_assert!((s.local(&moved) - u).norm() <= 1e-12 * (1.0 + u.norm()));
        }
    }

    /// Rⁿ and products on inputs of any finite size: sums and differences beyond the range
    /// saturate at the largest finite value (`Rn([MAX]) ∘ Rn([MAX])` was ∞).
    #[test]
    fn vector_space_and_product_operations_stay_finite(
        x in finite(), y in finite(), z in finite(),
        a in st::so3::<f64>(),
    ) {
        let v = Vector3::new(x, y, z);
        let p = Rn::new(v).unwrap();
        let q = Rn::new(-v).unwrap();
        for r in [p.retract(&v), p.compose(&p), p.compose(&q), p.inverse(), Rn::exp(&v)] {
            prop_assert!(all_finite(r.coords().iter().copied()));
        }
        prop_assert!(all_finite(p.local(&q).iter().copied()));
        // The distance 2|v| is +∞ only where it overflows (a coordinate beyond MAX / 4 at least).
        let d = p.distance(&q);
        prop_assert!(d >= 0.0 && (d.is_finite() || v.amax() > f64::MAX / 4.0), "{}", d);
        prop_assert!(all_finite(p.act(&Vector3::new(z, x, y)).iter().copied()));
        let xb = ProductManifold::<_, _, 3, 3, 6>::new(a, p);
        let d = SVector::<f64, 6>::from_fn(|i, _| v[i % 3]);
        let moved = xb.retract(&d);
        prop_assert!(unit_wxyz(moved.first().to_quaternion_wxyz(), 1e-12));
        prop_assert!(all_finite(xb.local(&moved).iter().copied()));
        prop_assert!(all_finite(xb.j_retract_tangent(&d).iter().copied()));
    }

    /// The weighted mean with weights of every kind: an error exactly when a weight is not finite or
    /// the sum is zero up to rounding or overflows, and a valid rotation otherwise.
    #[test]
    fn mean_weights(w1 in raw(), w2 in raw(), w3 in raw(), a in st::so3::<f64>()) {
        let xs = [
            a,
            a.retract(&Vector3::new(0.1, 0.0, 0.0)),
            a.retract(&Vector3::new(0.0, -0.1, 0.05)),
        ];
        let weights = [w1, w2, w3];
        let result = weighted_mean(&a, xs.iter().zip(weights), MeanSettings::default());
        let sum: f64 = weights.iter().sum();
        let absolute: f64 = weights.iter().map(|w| w.abs()).sum();
        let valid = all_finite(weights)
            && sum.is_finite()
            && absolute.is_finite()
            && sum.abs() > 3.0 * f64::EPSILON * absolute;
        match result {
            Ok(m) => {
                prop_assert!(valid);
                prop_assert!(unit_wxyz(m.to_quaternion_wxyz(), 1e-12));
            }
            Err(ManifoldError::NonFiniteWeight { index, value }) => {
                prop_assert!(!weights[index].is_finite());
                prop_assert!(value.is_nan() == weights[index].is_nan());
            }
            Err(ManifoldError::DegenerateWeights { .. }) => prop_assert!(!valid),
            // Valid weights can extrapolate far (a sum near zero makes the normalised weights huge):
            // the iteration may then not converge.
            Err(ManifoldError::MeanNotConverged { .. }) => {
                prop_assert!(valid);
                let largest = weights.iter().map(|w| (w / sum).abs()).fold(0.0, f64::max);
                prop_assert!(largest > 2.0, "weights {weights:?} did not converge");
            }
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }
}

/// `So3::from_rotation_vector` with components near the largest finite value once gave a NaN
/// rotation: |v| overflowed. The half angle |v/2| does not.
#[test]
fn rotation_vector_near_max_is_a_rotation() {
    for v in [
        Vector3::new(f64::MAX, f64::MAX, 0.0),
        Vector3::new(f64::MAX, f64::MAX, f64::MAX),
        Vector3::new(-f64::MAX, 0.0, f64::MAX),
    ] {
        let r = So3::from_rotation_vector(&v).unwrap();
        assert!(unit_wxyz(r.to_quaternion_wxyz(), 1e-15), "{r:?}");
        let axis = v / f64::MAX;
        assert!((r.rotate(&axis) - axis).norm() < 1e-15);
        assert!(all_finite(So3::right_jacobian_inverse(&v).iter().copied()));
        assert!(all_finite(So3::right_jacobian(&v).iter().copied()));
    }
}

/// `So3::from_matrix_orthonormalized` of a matrix with entries from 1e-271 to 1e105 once returned a
/// quaternion of norm 0.707: the SVD's U Vᵀ was a reflection (the sign of the smallest singular value
/// was noise) although det m > 0.
#[test]
fn orthonormalized_mixed_scales_is_a_rotation() {
    let m = Matrix3::new(
        1.652_582_859_788_945e105,
        8.421_494_974_489_744e-166,
        -2.073_439_323_802_459_3e25,
        3.022_673_643_029_488e25,
        -3.801_107_542_442_793_6e17,
        1.754_641_897_787_742e-61,
        3.388_117_856_695_569e-115,
        -8.995_655_003_933_006e55,
        5.096_182_860_333_663e-35,
    );
    let s = So3::from_matrix_orthonormalized(&m).unwrap();
    assert!(unit_wxyz(s.to_quaternion_wxyz(), 4.0 * f64::EPSILON));
    assert!(is_rotation(&s.to_matrix(), 1e-15));
}

/// A rotation scaled into the subnormal range (6.7e-313) with one entry replaced by −f64::MAX and
/// its first column flipped, found by the long bad-input run: the second singular direction comes
/// from subnormal entries with about 36 significant bits, and was orthogonal to the first only to
/// 3e-11, so the quaternion read from Q missed the dominant column's direction by as much. It is
/// now projected off the first direction, and the nearest-rotation condition holds to 1e-14.
#[test]
fn orthonormalized_subnormal_rotation_with_a_huge_entry() {
    let r = So3::from_quaternion_wxyz(
        1.0,
        -2.951_928_330_351_989e-11,
        -4.035_606_414_464_289_5e-11,
        0.0,
    )
    .unwrap();
    let mut m = r.to_matrix() * 6.715_935_259_06e-313;
    m[0] = -f64::MAX;
    m.set_column(0, &-m.column(0));
    check_orthonormalized(&m).unwrap();
}

/// A rotation scaled to f64::MIN_POSITIVE with its middle entry f64::MAX, found by the long run: the
/// two subnormal columns, nearly orthogonal and of nearly equal norms, were rotated by an angle
/// computed from a subnormal product of a few bits, which missed by more than it corrected, and the
/// Jacobi sweeps reached their bound. Now it converges to the nearest rotation.
#[test]
fn orthonormalized_subnormal_columns_beside_a_huge_entry_converge() {
    let r = So3::from_quaternion_wxyz(
        -0.999_584_562_276_204_2,
        0.002_743_944_715_748_482_5,
        -0.028_244_642_830_538_715,
        0.005_041_207_976_419_799,
    )
    .unwrap();
    let mut m = r.to_matrix() * f64::MIN_POSITIVE;
    m[4] = f64::MAX;
    check_orthonormalized(&m).unwrap();
}

/// Uniformly scaled rotations of any finite scale, and rotations with columns or rows of different
/// scales (`R D` and `D R` have the nearest rotation R), orthonormalise to R.
#[test]
fn orthonormalized_scaled_rotations_recover_the_rotation() {
    let r = So3::exp(&Vector3::new(0.3, -0.4, 1.0));
    let m = r.to_matrix();
    for scale in [1e-300, 1e-200, 1e-20, 1.0, 1e20, 1e200, 1e300, f64::MAX] {
        let s = So3::from_matrix_orthonormalized(&(m * scale)).unwrap();
        assert!(s.distance(&r) < 4.0 * f64::EPSILON, "scale {scale}");
        assert!(unit_wxyz(s.to_quaternion_wxyz(), 4.0 * f64::EPSILON));
    }
    for d in [
        Vector3::new(1e300, 1.0, 1e-300),
        Vector3::new(1.0, 1e-300, 1e-300),
        Vector3::new(1e-150, 1e150, 3.0),
        Vector3::new(f64::MAX, 1.0, 1e-300),
        Vector3::new(1.0, 1e-310, 1e-310),
    ] {
        // Subnormal entries carry fewer digits: relative precision eps · MIN_POSITIVE / |entry|.
        let precision = 1.0 + f64::MIN_POSITIVE / d.min();
        let d = Matrix3::from_diagonal(&d);
        for graded in [m * d, d * m] {
            let s = So3::from_matrix_orthonormalized(&graded).unwrap();
            let error = s.distance(&r);
            assert!(
                error < 16.0 * f64::EPSILON * precision,
                "{graded:e}: {error:e}"
            );
        }
    }
}

/// Matrices at the ends of the range that stalled or broke earlier versions of the Jacobi polar
/// factor: a rotation scaled to MIN_POSITIVE (subnormal entries) with one entry 1 or MAX (ratios
/// beyond the exponent range), a negative scale with one entry MIN_POSITIVE, and the zero matrix.
#[test]
fn orthonormalized_at_the_ends_of_the_range() {
    let r = So3::exp(&Vector3::new(0.4, -1.3, 0.2)).to_matrix();
    for (scale, entry, value) in [
        (f64::MIN_POSITIVE, 4, 1.0),
        (f64::MIN_POSITIVE, 8, f64::MAX),
        (-f64::MIN_POSITIVE, 1, f64::MIN_POSITIVE),
        (2e-308, 0, 1e-300),
        (5e-324, 3, 1.0),
    ] {
        let mut m = r * scale;
        m[entry] = value;
        check_orthonormalized(&m).unwrap();
    }
    assert!(matches!(
        So3::from_matrix_orthonormalized(&Matrix3::<f64>::zeros()),
        Err(ManifoldError::NotProperRotation { det }) if det == 0.0
    ));
}

/// `S2::log_at` next to the antipode with a subnormal component once gave [inf, NaN]: the direction's
/// norm was subnormal and θ / norm overflowed.
#[test]
fn sphere_log_next_to_the_antipode_with_subnormal_components() {
    let x = S2::new(Vector3::new(0.0, 0.0, 1.0)).unwrap();
    for tiny in [5e-324_f64, 1e-310, -2.2e-308, 1e-200] {
        let y = S2::new(Vector3::new(tiny, 0.0, -1.0)).unwrap();
        let l = x.log_at(&y);
        assert!(all_finite(l.iter().copied()), "{l:?}");
        assert!((l.norm() - std::f64::consts::PI).abs() < 1e-15);
        assert!((l.normalize() - Vector3::x() * tiny.signum()).norm() < 1e-15);
        let z = S2::new(Vector3::new(tiny, 0.0, 1.0)).unwrap();
        assert!(all_finite(x.log_at(&z).iter().copied()));
        assert!(x.log_at(&z).norm() <= 1e-15);
    }
}

/// `is_finite` tells points built unchecked from NaN apart from valid ones, on every space.
#[test]
fn is_finite_flags_non_finite_coordinates() {
    use liebayes_manifolds::{Se2, Se3, Se23};
    let nan = f64::NAN;
    assert!(So2::<f64>::from_angle_unchecked(0.3).is_finite());
    assert!(!So2::<f64>::from_cos_sin_unchecked(nan, 0.0).is_finite());
    assert!(
        !So3::<f64>::from_quaternion_unchecked(Quaternion::new(nan, 0.0, 0.0, 0.0)).is_finite()
    );
    assert!(
        !Su2::<f64>::from_quaternion_unchecked(Quaternion::new(1.0, f64::INFINITY, 0.0, 0.0))
            .is_finite()
    );
    assert!(!S2::<f64>::new_unchecked(Vector3::new(nan, 0.0, 1.0)).is_finite());
    assert!(!Rn::<f64, 2>::new_unchecked(Vector2::new(1.0, nan)).is_finite());
    let rotation = So2::<f64>::from_angle_unchecked(1.0);
    assert!(Se2::new_unchecked(rotation, Vector2::new(1.0, 2.0)).is_finite());
    assert!(!Se2::new_unchecked(rotation, Vector2::new(nan, 2.0)).is_finite());
    assert!(!Se3::new_unchecked(So3::<f64>::identity(), Vector3::new(0.0, nan, 0.0)).is_finite());
    let (e, zero) = (So3::<f64>::identity(), Vector3::zeros());
    assert!(Se23::new_unchecked(e, zero, zero).is_finite());
    assert!(!Se23::new_unchecked(e, Vector3::new(nan, 0.0, 0.0), zero).is_finite());
    assert!(!Se23::new_unchecked(e, zero, Vector3::new(0.0, 0.0, nan)).is_finite());
    assert!(!Left::new(So2::<f64>::from_cos_sin_unchecked(nan, 0.0)).is_finite());
    let product = |r: So2<f64>, t: f64| {
        ProductManifold::<_, _, 1, 1, 2>::new(r, Rn::<f64, 1>::new_unchecked(Vector1::new(t)))
    };
    assert!(product(rotation, 1.0).is_finite());
    assert!(!product(rotation, nan).is_finite());
}

/// `Su2::log` at q = (−1, −1.7e-308, −0, 0), a unit quaternion a subnormal away from −1, was
/// (−∞, NaN, NaN): the factor 2π/|xyz| overflowed. It is the turn of 2π about −x.
#[test]
fn su2_log_next_to_minus_one_is_finite() {
    let q = Su2::from_quaternion_wxyz(-1.0, -1.7e-308, -0.0, 0.0).unwrap();
    let v = q.log();
    assert!(all_finite(v.iter().copied()), "{v:?}");
    assert!((v.x + 2.0 * std::f64::consts::PI).abs() <= 1e-15, "{v:?}");
    assert_eq!((v.y, v.z), (0.0, 0.0));
}

/// Se3 near the largest finite value: `local` between translations whose difference overflows,
/// `conjugate_algebra` with products that overflow, and the Jacobians of a rotation vector whose
/// norm overflows all returned NaN. Each now saturates: finite, never NaN.
#[test]
fn se3_near_the_largest_value_is_finite() {
    let turn = So3::from_rotation_vector(&Vector3::new(0.3, -1.0, 2.0)).unwrap();
    let max = f64::MAX;
    for (a, b) in [(1.0, max), (1e200, -max), (1e308, max), (-1e308, -max)] {
        let x = Se3::new(turn, Vector3::new(a, b, 1.0)).unwrap();
        let y = Se3::new(turn, Vector3::new(-b, a, -a)).unwrap();
        let local = x.local(&y);
        assert!(
            all_finite(local.iter().copied()),
            "local {a:e} {b:e}: {local:?}"
        );
        assert!(x.inverse().compose(&y).is_finite());
        let algebra = Se3::<f64>::hat(&Vector6::new(a, b, 1.0, 0.5, -0.2, 0.1));
        let conjugated = x.conjugate_algebra(&algebra);
        assert!(
            all_finite(conjugated.iter().copied()),
            "conjugate {a:e} {b:e}"
        );
        let v = Vector6::new(1.0, 0.5, 2.0, a.abs(), b, 0.1);
        let jacobians = [Se3::right_jacobian(&v), Se3::right_jacobian_inverse(&v)];
        for j in jacobians {
            assert!(all_finite(j.iter().copied()), "Jacobian at {v:?}");
        }
    }
}

/// Found by the groups' bad-input law: `Se2::compose` and `inverse` rotated a translation of
/// (MAX, MAX) into ±∞, and `Se3::adjoint` multiplied hat(t) R into ±∞ or NaN, for translations
/// near the largest finite value. Each now saturates like `exp`.
#[test]
fn poses_with_the_largest_translations_compose_and_adjoin_finitely() {
    let max = f64::MAX;
    let half_turn = So2::from_angle(3.0).unwrap();
    let x = Se2::new(half_turn, Vector2::new(max, max)).unwrap();
    for y in [x.compose(&x), x.inverse(), x.inverse().compose(&x)] {
        assert!(y.is_finite(), "{y:?}");
    }
    let turn = So3::from_rotation_vector(&Vector3::new(0.3, -1.0, 2.0)).unwrap();
    let x = Se3::new(turn, Vector3::new(max, -max, max)).unwrap();
    for y in [x.compose(&x), x.inverse(), x.inverse().compose(&x)] {
        assert!(y.is_finite(), "{y:?}");
    }
    assert!(all_finite(x.adjoint().iter().copied()));
}

/// `vee` of algebra elements with entries near f64::MAX is the exact, finite vector: the difference
/// of two entries overflowed before it was halved (found by the Python package's fuzzer).
#[test]
fn vee_of_entries_near_the_largest_value_is_finite() {
    let m = f64::MAX * 0.6;
    let a = Matrix3::new(0.0, m, -m, -m, 0.0, m, m, -m, 0.0);
    assert_eq!(So3::vee(&a), Vector3::new(-m, -m, -m));
    let mut h = nalgebra::Matrix4::zeros();
    h.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
    assert_eq!(Se3::vee(&h), Vector6::new(0.0, 0.0, 0.0, -m, -m, -m));
    assert_eq!(Se2::vee(&a), Vector3::new(-m, m, -m));
    assert_eq!(So2::vee(&Matrix2::new(0.0, m, -m, 0.0)), Vector1::new(-m));
}

/// The conjugation of algebra elements near f64::MAX (a reading found it): SO(2) and SO(3) summed
/// products of the largest values into ±∞ (SO(2) is abelian: the exact result is `a`), and SE(2)
/// with a translation of MAX gave NaN from ∞ − ∞. Each is now computed at unit scale and
/// saturates; at an ordinary scale it is the plain product.
#[test]
fn conjugations_near_the_largest_value_are_finite() {
    let max = f64::MAX;
    let r = So2::from_cos_sin(-0.106_030_374_571_057_84, -0.994_362_891_337_122_1).unwrap();
    let a = So2::hat(&Vector1::new(max));
    let c = r.conjugate_algebra(&a);
    assert!(all_finite(c.iter().copied()));
    assert!((c - a).amax() <= 4.0 * f64::EPSILON * max, "{c}");
    let q = So3::exp(&Vector3::new(1.0, 1.0, 0.0));
    let v = Vector3::new(0.5 * max, max, 0.0);
    let c = q.conjugate_algebra(&So3::hat(&v));
    assert!(all_finite(c.iter().copied()));
    let expected = So3::hat(&(q.to_matrix() * (v / max))) * max;
    assert!(
        (c - expected).amax() <= 1e-14 * max,
        "{c} against {expected}"
    );
    let x = Se2::from_angle_translation(std::f64::consts::FRAC_PI_4, Vector2::new(max, 0.0));
    let c = x
        .unwrap()
        .conjugate_algebra(&Se2::hat(&Vector3::new(0.0, 0.0, 4.0)));
    assert!(all_finite(c.iter().copied()), "{c}");
    let small = So3::exp(&Vector3::new(0.3, 0.1, -0.2));
    let a = So3::hat(&Vector3::new(1.0, 2.0, 3.0));
    let r = small.to_matrix();
    assert_eq!(small.conjugate_algebra(&a), r * a * r.transpose());
    // SU(2): two quaternion products of (0, MAX, MAX, 0) overflowed and then met ∞ · 0. A quarter
    // turn about z maps (x, y) to (−y, x).
    let quarter = Su2::exp(&Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
    let c = quarter.conjugate_algebra(&Quaternion::new(0.0, max, max, 0.0));
    assert!(all_finite(c.coords.iter().copied()), "{c}");
    assert!(
        (c.imag() - Vector3::new(-max, max, 0.0)).amax() <= 1e-15 * max,
        "{c}"
    );
    assert_eq!(c.w, 0.0);
    let a = Quaternion::new(0.0, 0.5, -1.0, 2.0);
    let q = Su2::exp(&Vector3::new(0.3, 0.1, -0.2));
    let [w, x, y, z] = q.to_quaternion_wxyz();
    let plain = Quaternion::new(w, x, y, z) * a * Quaternion::new(w, -x, -y, -z);
    assert!((q.conjugate_algebra(&a).coords - plain.coords).amax() <= 1e-15);
    // A pose with a translation of 1e200 or 1e300: the products were taken at one common scale,
    // so the rotation block (entries of 1) fell to 0 against the translation. Each entry now keeps
    // its own precision: the exact conjugation, block by block.
    for t in [1e200, 1e300] {
        let x = Se2::new(So2::identity(), Vector2::new(t, 0.0)).unwrap();
        let c = x.conjugate_algebra(&Se2::hat(&Vector3::new(1.0, 0.0, 1.0)));
        let expected = Matrix3::new(0.0, -1.0, 1.0, 1.0, 0.0, -t, 0.0, 0.0, 0.0);
        assert!((c - expected).amax() <= 1e-15 * t, "{c}");
        assert_eq!((c[(0, 1)], c[(1, 0)], c[(0, 2)]), (-1.0, 1.0, 1.0), "{c}");
        let y = Se3::new(So3::identity(), Vector3::new(t, 0.0, 0.0)).unwrap();
        let v = Vector6::new(t, 0.0, 0.0, 0.0, 0.0, 1.0);
        let c = y.conjugate_algebra(&Se3::hat(&v));
        assert_eq!(Se3::vee(&c), Vector6::new(t, -t, 0.0, 0.0, 0.0, 1.0), "{c}");
        assert_eq!(Se3::vee(&c), y.adjoint() * v);
        // World-frame errors of the same pose: J = [I | −hat(R p + t)], the identity kept.
        let j = Left::new(y).j_act_self(&Vector3::new(t, 0.0, 0.0));
        assert_eq!(j.fixed_view::<3, 3>(0, 0), Matrix3::identity(), "{j}");
        assert_eq!(j[(1, 5)], 2.0 * t, "{j}");
    }
    // vee doubles the vector part: it saturates beyond half the largest value.
    assert_eq!(
        Su2::vee(&Quaternion::new(0.0, max, -max, 1.0)),
        Vector3::new(max, -max, 2.0)
    );
}

/// NaN never reads as a number: `stable_norm((NaN, 0))` was 0 (nalgebra's `amax` skips a NaN that
/// is not last), so a NaN sample gave `weighted_mean` a zero step and it returned `Ok((NaN, 0))`;
/// the quaternion (NaN, NaN, NaN, NaN) had the logarithm (2π, 0, 0) and (1, NaN, 0, 0) the
/// identity's, so a NaN estimate had a finite error; and the sphere retracted a NaN tangent to
/// the point itself. Each NaN now shows in the result.
#[test]
fn nan_components_are_never_read_as_numbers() {
    let nan_point = Rn::<f64, 2>::new_unchecked(Vector2::new(f64::NAN, 0.0));
    let one = Rn::new(Vector2::new(1.0, 0.0)).unwrap();
    let mean = weighted_mean(
        &one,
        [(&nan_point, 1.0), (&one, 1.0)],
        MeanSettings::default(),
    );
    assert!(mean.is_err(), "{mean:?}");
    for q in [
        Quaternion::new(f64::NAN, f64::NAN, f64::NAN, f64::NAN),
        Quaternion::new(1.0, f64::NAN, 0.0, 0.0),
        Quaternion::new(f64::NAN, 0.0, 0.0, 0.0),
    ] {
        let log = So3::from_quaternion_unchecked(q).log();
        assert!(log.iter().all(|v| v.is_nan()), "{q:?}: {log:?}");
        let identity = So3::<f64>::identity();
        assert!(!all_finite(
            identity
                .local(&So3::from_quaternion_unchecked(q))
                .iter()
                .copied()
        ));
    }
    let x = S2::<f64>::new(Vector3::new(0.0, 0.0, 1.0)).unwrap();
    for w in [
        Vector3::new(f64::NAN, 0.0, 0.0),
        Vector3::new(0.0, f64::NAN, 0.0),
    ] {
        assert!(!x.exp_at(&w).is_finite(), "{w:?}");
    }
    assert!(!x.retract(&Vector2::new(f64::NAN, 0.0)).is_finite());
}

/// The SE(3) Jacobians at a rotation vector with an infinite or NaN component halved it and
/// called themselves again with the same value, without end (a stack overflow, which aborts the
/// process). They now return NaN entries at once.
#[test]
fn pose_jacobians_of_non_finite_tangents_return() {
    for phi in [
        Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, f64::INFINITY),
        Vector6::new(0.0, 0.0, 0.0, f64::NEG_INFINITY, 1.0, 0.0),
        Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, f64::NAN),
    ] {
        for jacobian in [
            Se3::<f64>::right_jacobian(&phi),
            Se3::<f64>::right_jacobian_inverse(&phi),
            Se3::<f64>::left_jacobian(&phi),
            Se3::<f64>::left_jacobian_inverse(&phi),
        ] {
            assert!(jacobian.iter().any(|v| v.is_nan()), "{phi:?}");
        }
    }
}

/// The docs of `S2::from_vector_normalizing`, `So2::from_vector_normalizing` and
/// `So3::from_axis_angle` said "any non-zero length", but `normalized` refuses a vector shorter than
/// `MIN_DIRECTION_NORM` = 1e-150. The docs now state that floor; this checks it as written: just
/// above it the direction is kept, below it (and at zero) each refuses with `ZeroVector`.
#[test]
fn the_normalising_constructors_keep_their_documented_floor() {
    use liebayes_manifolds::constants::Thresholds;
    let floor = <f64 as Thresholds>::MIN_DIRECTION_NORM;
    assert_eq!(floor, 1e-150);
    for scale in [1e-150, 1e-100, 1e300] {
        let s2 = S2::from_vector_normalizing(&(Vector3::new(3.0, 0.0, 4.0) * scale)).unwrap();
        assert!((s2.as_vector() - Vector3::new(0.6, 0.0, 0.8)).norm() < 1e-15);
        let so2 = So2::from_vector_normalizing(&(Vector2::new(0.0, 2.0) * scale)).unwrap();
        assert!((so2.angle() - PI / 2.0).abs() < 1e-15);
        let so3 = So3::from_axis_angle(&(Vector3::z() * scale), 0.5).unwrap();
        assert!((so3.log() - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-15);
    }
    for scale in [0.9e-150, 1e-200, 5e-324, 0.0] {
        let zero = |e: ManifoldError| matches!(e, ManifoldError::ZeroVector { .. });
        assert!(zero(
            S2::from_vector_normalizing(&(Vector3::x() * scale)).unwrap_err()
        ));
        assert!(zero(
            So2::from_vector_normalizing(&(Vector2::x() * scale)).unwrap_err()
        ));
        assert!(zero(
            So3::from_axis_angle(&(Vector3::x() * scale), 0.5).unwrap_err()
        ));
    }
}
