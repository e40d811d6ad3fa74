//! Bad input never panics and never yields NaN: every constructor is fed NaN, infinities, zeros, huge and
//! tiny numbers; it must return an error exactly when the input is invalid, and a valid element
//! otherwise. And every operation on valid elements with finite tangents returns finite numbers.

use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, ManifoldError, Rn, S2, So2, So3, Su2};
use nalgebra::{Matrix2, Matrix3, Quaternion, Vector2, Vector3};
use proptest::prelude::*;

/// Raw numbers a user might pass, good and bad.
fn raw() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -2.0..2.0_f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        2 => Just(0.0),
        1 => Just(1.0),
        1 => Just(1e300),
        1 => Just(-1e-300),
    ]
}

fn all_finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn finite_slice(values: &[f64]) -> bool {
    values.iter().all(|v| !v.is_nan() && v.is_finite())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    #[test]
    fn quaternion_constructors(w in raw(), x in raw(), y in raw(), z in raw()) {
        let q = Quaternion::new(w, x, y, z);
        let finite = all_finite(&[w, x, y, z]);
        let norm = q.norm();
        let unit = finite && (norm - 1.0).abs() <= 1e-9;
        match Su2::from_quaternion(q) {
            Ok(e) => { prop_assert!(unit); prop_assert!(finite_slice(&e.to_quaternion_wxyz())); }
            Err(err) => { prop_assert!(!unit); prop_assert!(!err.to_string().is_empty()); }
        }
        prop_assert_eq!(Su2::from_quaternion_wxyz(w, x, y, z).is_ok(), unit);
        prop_assert_eq!(So3::from_quaternion(q).is_ok(), unit);
        prop_assert_eq!(So3::from_quaternion_wxyz(w, x, y, z).is_ok(), unit);
        match So3::from_quaternion_normalizing(q) {
            Ok(r) => {
                prop_assert!(finite);
                let c = r.to_quaternion_wxyz();
                prop_assert!(finite_slice(&c));
                prop_assert!((Quaternion::new(c[0], c[1], c[2], c[3]).norm() - 1.0).abs() < 1e-15);
            }
            Err(ManifoldError::NonFinite { .. }) => prop_assert!(!finite),
            Err(ManifoldError::ZeroVector { .. }) => prop_assert!(finite && norm < 1e-150),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
        prop_assert_eq!(Su2::from_quaternion_normalizing(q).is_ok(), finite && norm >= 1e-150);
    }

    #[test]
    fn vector_constructors(x in raw(), y in raw(), z in raw(), angle in raw()) {
        let v = Vector3::new(x, y, z);
        let finite = all_finite(&[x, y, z]);
        let unit = finite && (v.norm() - 1.0).abs() <= 1e-9;
        prop_assert_eq!(S2::new(v).is_ok(), unit);
        match S2::from_vector_normalizing(&v) {
            Ok(s) => prop_assert!((s.as_vector().norm() - 1.0).abs() < 1e-15 && finite),
            Err(_) => prop_assert!(!finite || v.amax() < 1e-150),
        }
        match So3::from_rotation_vector(&v) {
            Ok(r) => { prop_assert!(finite); prop_assert!(finite_slice(&r.to_quaternion_wxyz())); }
            Err(_) => prop_assert!(!finite),
        }
        prop_assert_eq!(Su2::from_rotation_vector(&v).is_ok(), finite);
        match So3::from_axis_angle(&v, angle) {
            Ok(r) => prop_assert!(finite_slice(&r.to_quaternion_wxyz())),
            Err(_) => prop_assert!(!finite || !angle.is_finite() || v.amax() < 1e-150),
        }
        prop_assert_eq!(Rn::new(v).is_ok(), finite);
        prop_assert_eq!(Rn::<f64, 3>::from_slice(&[x, y, z]).is_ok(), finite);
        prop_assert!(Rn::<f64, 3>::from_slice(&[x, y]).is_err());
        prop_assert_eq!(So2::from_angle(angle).is_ok(), angle.is_finite());
        let p = Vector2::new(x, y);
        let unit2 = all_finite(&[x, y]) && (p.norm() - 1.0).abs() <= 1e-9;
        prop_assert_eq!(So2::from_cos_sin(x, y).is_ok(), unit2);
        match So2::from_vector_normalizing(&p) {
            Ok(r) => prop_assert!(r.angle().is_finite()),
            Err(_) => prop_assert!(!all_finite(&[x, y]) || p.amax() < 1e-150),
        }
    }

    #[test]
    fn matrix_constructors(r in st::so3::<f64>(), i in 0usize..9, bad in raw(), flip in any::<bool>()) {
        let mut m = r.to_matrix();
        m[i] = bad;
        if flip {
            m.set_column(0, &-m.column(0));
        }
        let finite = m.iter().all(|v| v.is_finite());
        let rotation = finite
            && (m.transpose() * m - Matrix3::identity()).amax() <= 1e-9
            && (m.determinant() - 1.0).abs() <= 1e-9;
        match So3::from_matrix(&m) {
            Ok(s) => { prop_assert!(rotation); prop_assert!(finite_slice(&s.to_quaternion_wxyz())); }
            Err(e) => { prop_assert!(!rotation, "{}", e); }
        }
        match So3::from_matrix_orthonormalized(&m) {
            Ok(s) => {
                prop_assert!(finite && (m / m.amax()).determinant() > 0.0);
                let q = s.to_quaternion_wxyz();
                prop_assert!(finite_slice(&q));
                prop_assert!((s.to_matrix().transpose() * s.to_matrix() - Matrix3::identity()).amax() < 1e-12);
            }
            Err(_) => prop_assert!(!finite || (m / m.amax()).determinant() <= 0.0),
        }
        let m2 = Matrix2::new(m.m11, m.m12, m.m21, m.m22);
        let rotation2 = m2.iter().all(|v| v.is_finite())
            && (m2.transpose() * m2 - Matrix2::identity()).amax() <= 1e-9
            && (m2.determinant() - 1.0).abs() <= 1e-9;
        prop_assert_eq!(So2::from_matrix(&m2).is_ok(), rotation2);
    }

    /// Finite tangents of any size, including subnormal and 1e300, give finite results everywhere.
    #[test]
    fn no_nan_for_finite_input(
        x in prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO,
        y in prop::num::f64::NORMAL | prop::num::f64::ZERO,
        z in -1e3..1e3_f64,
        a in st::so3::<f64>(),
        s in st::s2::<f64>(),
    ) {
        let v = Vector3::new(x, y, z);
        let finite3 = |m: &Matrix3<f64>| m.iter().all(|e| !e.is_nan());
        let r = So3::exp(&v);
        prop_assert!(finite_slice(&r.to_quaternion_wxyz()), "exp({v:?}) = {r:?}");
        prop_assert!(r.log().iter().all(|e| e.is_finite()));
        prop_assert!(finite3(&So3::right_jacobian(&v)), "Jr({v:?})");
        prop_assert!(finite3(&So3::right_jacobian_inverse(&v)), "Jr^-1({v:?})");
        prop_assert!(finite3(&a.j_retract_self(&v)));
        prop_assert!(a.act(&v).iter().all(|e| !e.is_nan()));
        prop_assert!(finite_slice(&Su2::exp(&v).to_quaternion_wxyz()));
        prop_assert!(So2::exp(&nalgebra::Vector1::new(x)).angle().is_finite());
        let u = Vector2::new(x, y);
        let t = s.retract(&u);
        prop_assert!(t.as_vector().iter().all(|e| e.is_finite()), "S2 retract({u:?})");
        prop_assert!(s.local(&t).iter().all(|e| e.is_finite()));
    }
}
