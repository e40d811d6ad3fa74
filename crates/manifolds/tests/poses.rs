//! Properties specific to SE(2), SE(3) and SE₂(3) beyond the law suite: exp against the matrix exponential,
//! the logarithm at and near a half turn, agreement with nalgebra's isometries and with the rotation
//! groups, comparisons up to the quaternion sign, and bad input (NaN, infinities, non-orthonormal
//! blocks, wrong bottom rows, tangents near the largest finite value).

use approx::assert_relative_eq;
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{
    GroupAction, LieGroup, Manifold, ManifoldError, Se2, Se3, Se23, So2, So3,
};
use nalgebra::{
    Isometry2, Isometry3, Matrix2, Matrix3, Matrix4, Matrix5, Point2, Point3, Quaternion, SVector,
    Vector2, Vector3, Vector6,
};
use proptest::prelude::*;
use std::f64::consts::PI;

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

/// Finite components of any size: subnormal, normal up to the largest finite value, zero.
fn any_finite() -> impl Strategy<Value = f64> {
    prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO
}

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn no_nan<'a>(values: impl IntoIterator<Item = &'a f64>) -> bool {
    values.into_iter().all(|v| !v.is_nan())
}

/// A valid element: unit rotation (within 1e-12) and a finite translation.
fn valid_se3(x: &Se3<f64>) -> bool {
    let q = x.rotation().to_quaternion_wxyz();
    let norm = Quaternion::new(q[0], q[1], q[2], q[3]).norm();
    finite(&q) && (norm - 1.0).abs() < 1e-12 && finite(x.translation().as_slice())
}

/// A valid extended pose: unit rotation (within 1e-12), finite velocity and position.
fn valid_se23(x: &Se23<f64>) -> bool {
    valid_se3(&x.pose()) && finite(x.velocity().as_slice())
}

fn valid_se2(x: &Se2<f64>) -> bool {
    let (c, s) = (x.rotation().cos(), x.rotation().sin());
    finite(&[c, s]) && (c.hypot(s) - 1.0).abs() < 1e-12 && finite(x.translation().as_slice())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// exp agrees with the matrix exponential of hat(v) (nalgebra's Padé approximation, an independent
    /// computation), and log inverts it inside the injectivity radius.
    #[test]
    fn exp_is_the_matrix_exponential(v in st::se3_tangent::<f64>(), w in st::se2_tangent::<f64>()) {
        prop_assume!(v.norm() < 25.0 && w.norm() < 25.0);
        let x = Se3::exp(&v);
        let expected = Se3::hat(&v).exp();
        let scale = 1.0 + v.norm();
        prop_assert!((x.to_homogeneous() - expected).amax() <= 1e-12 * scale * scale,
            "{v}: {} vs {expected}", x.to_homogeneous());
        let y = Se2::exp(&w);
        let expected = Se2::hat(&w).exp();
        let scale = 1.0 + w.norm();
        prop_assert!((y.to_homogeneous() - expected).amax() <= 1e-12 * scale * scale);
    }

    /// The rotation blocks are the rotation groups' own operations, and the translations follow
    /// `p ↦ R p + t`.
    #[test]
    fn rotation_blocks_are_the_rotation_groups(
        a in st::se3::<f64>(), b in st::se3::<f64>(), c in st::se2::<f64>(), d in st::se2::<f64>(),
        p in st::point3::<f64>(), q in st::point2::<f64>(),
    ) {
        let ab = a.compose(&b);
        prop_assert_eq!(ab.rotation(), &a.rotation().compose(b.rotation()));
        prop_assert!((ab.act(&p) - a.act(&b.act(&p))).norm() <= 1e-12 * (1.0 + p.norm() + a.translation().norm() + b.translation().norm()));
        prop_assert!((a.act(&p) - (a.rotation().rotate(&p) + a.translation())).norm() == 0.0);
        let log = a.log();
        prop_assert!((Vector3::new(log[3], log[4], log[5]) - a.rotation().log()).norm() == 0.0);
        let cd = c.compose(&d);
        prop_assert_eq!(cd.rotation(), &c.rotation().compose(d.rotation()));
        prop_assert!((cd.act(&q) - c.act(&d.act(&q))).norm() <= 1e-12 * (1.0 + q.norm() + c.translation().norm() + d.translation().norm()));
        let angle = c.rotation().angle();
        prop_assert_eq!(c.log().z, if angle == -PI { PI } else { angle });
    }

    /// Conversions to and from nalgebra's isometries agree with nalgebra's own operations.
    #[test]
    fn nalgebra_interop(a in st::se3::<f64>(), b in st::se3::<f64>(), c in st::se2::<f64>(), d in st::se2::<f64>(),
                        p in st::point3::<f64>(), q in st::point2::<f64>()) {
        let (ia, ib): (Isometry3<f64>, Isometry3<f64>) = (a.into(), b.into());
        let tol = |x: f64| 1e-12 * (1.0 + x);
        prop_assert!(Se3::from(ia * ib).distance(&a.compose(&b)) <= tol(ia.translation.vector.norm() + ib.translation.vector.norm()));
        prop_assert!((ia.transform_point(&Point3::from(p)).coords - a.act(&p)).norm() <= tol(p.norm() + ia.translation.vector.norm()));
        prop_assert!(Se3::from(ia.inverse()).distance(&a.inverse()) <= tol(ia.translation.vector.norm()));
        prop_assert!((ia.to_homogeneous() - a.to_homogeneous()).amax() <= 1e-15 * (1.0 + a.translation().amax()));
        prop_assert_eq!(Se3::from(ia), a);
        let (ic, id): (Isometry2<f64>, Isometry2<f64>) = (c.into(), d.into());
        prop_assert!(Se2::from(ic * id).distance(&c.compose(&d)) <= tol(ic.translation.vector.norm() + id.translation.vector.norm()));
        prop_assert!((ic.transform_point(&Point2::from(q)).coords - c.act(&q)).norm() <= tol(q.norm() + ic.translation.vector.norm()));
        prop_assert_eq!(Se2::from(ic), c);
        prop_assert!((ic.to_homogeneous() - c.to_homogeneous()).amax() == 0.0);
    }

    /// Matrices round-trip, and a perturbed entry is refused exactly when the matrix stops being a
    /// rigid motion (bottom row, orthonormality, determinant, finiteness), with the matching error.
    #[test]
    fn matrix_constructors(a in st::se3::<f64>(), c in st::se2::<f64>(), i in 0usize..16, j in 0usize..9,
                           bad in raw(), flip in any::<bool>()) {
        let m = a.to_homogeneous();
        prop_assert!(Se3::from_matrix(&m).unwrap().distance(&a) <= 1e-12 * (1.0 + a.translation().amax()));
        prop_assert_eq!(Se3::from_matrix_unchecked(&m), Se3::from_matrix(&m).unwrap());
        let mut m = m;
        m[i] = bad;
        if flip {
            m.set_column(0, &-m.column(0));
        }
        let r = m.fixed_view::<3, 3>(0, 0).into_owned();
        let bottom = (m[(3, 0)].abs()).max(m[(3, 1)].abs()).max(m[(3, 2)].abs()).max((m[(3, 3)] - 1.0).abs());
        let is_finite = m.iter().all(|v| v.is_finite());
        let rotation = (r.transpose() * r - Matrix3::identity()).amax() <= 1e-9 && (r.determinant() - 1.0).abs() <= 1e-9;
        match Se3::from_matrix(&m) {
            Ok(x) => { prop_assert!(is_finite && bottom <= 1e-9 && rotation); prop_assert!(valid_se3(&x)); }
            Err(ManifoldError::NonFinite { .. }) => prop_assert!(!is_finite),
            Err(ManifoldError::NotHomogeneous { deviation, .. }) => { prop_assert!(is_finite && bottom > 1e-9); prop_assert_eq!(deviation, bottom); }
            Err(ManifoldError::NotOrthonormal { .. } | ManifoldError::NotProperRotation { .. }) => prop_assert!(is_finite && bottom <= 1e-9 && !rotation),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
        let t = m.fixed_view::<3, 1>(0, 3).into_owned();
        prop_assert_eq!(Se3::from_parts(&r, &t).is_ok(), is_finite_all(&r, &t) && rotation);

        let mut n = c.to_homogeneous();
        n[j] = bad;
        if flip {
            n.set_column(0, &-n.column(0));
        }
        let r2 = Matrix2::new(n.m11, n.m12, n.m21, n.m22);
        let is_finite = n.iter().all(|v| v.is_finite());
        let bottom = n.m31.abs().max(n.m32.abs()).max((n.m33 - 1.0).abs());
        let rotation = (r2.transpose() * r2 - Matrix2::identity()).amax() <= 1e-9 && (r2.determinant() - 1.0).abs() <= 1e-9;
        match Se2::from_matrix(&n) {
            Ok(x) => { prop_assert!(is_finite && bottom <= 1e-9 && rotation); prop_assert!(valid_se2(&x)); }
            Err(ManifoldError::NonFinite { .. }) => prop_assert!(!is_finite),
            Err(ManifoldError::NotHomogeneous { .. }) => prop_assert!(is_finite && bottom > 1e-9),
            Err(ManifoldError::NotOrthonormal { .. } | ManifoldError::NotProperRotation { .. }) => prop_assert!(is_finite && bottom <= 1e-9 && !rotation),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }

    /// `new` refuses exactly the non-finite inputs; `from_angle_translation` likewise.
    #[test]
    fn part_constructors(x in raw(), y in raw(), z in raw(), angle in raw(), r in st::so3::<f64>()) {
        let t = Vector3::new(x, y, z);
        let ok3 = finite(&[x, y, z]);
        match Se3::new(r, t) {
            Ok(p) => { prop_assert!(ok3); prop_assert!(valid_se3(&p)); }
            Err(e) => { prop_assert!(!ok3); prop_assert!(matches!(e, ManifoldError::NonFinite { .. }), "{}", e); }
        }
        let t2 = Vector2::new(x, y);
        let ok2 = finite(&[x, y, angle]);
        match Se2::from_angle_translation(angle, t2) {
            Ok(p) => { prop_assert!(ok2); prop_assert!(valid_se2(&p)); }
            Err(e) => { prop_assert!(!ok2); prop_assert!(!e.to_string().is_empty()); }
        }
        let broken = So3::from_quaternion_unchecked(Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        prop_assert!(Se3::new(broken, Vector3::zeros()).is_err());
        let broken = So2::from_cos_sin_unchecked(f64::INFINITY, 0.0);
        prop_assert!(Se2::new(broken, Vector2::zeros()).is_err());
    }

    /// Tangents with components anywhere in the finite range: exp gives a valid element (translations
    /// beyond the range saturate at the largest finite value), and nothing returns NaN.
    #[test]
    fn huge_tangents_give_valid_elements(
        a in any_finite(), b in any_finite(), c in any_finite(),
        d in any_finite(), e in any_finite(), f in -1e3..1e3_f64,
        x in st::se3::<f64>(), p in st::point3::<f64>(),
    ) {
        for v in [Vector6::new(a, b, c, d, e, f), Vector6::new(d, e, f, a, b, c)] {
            let y = Se3::exp(&v);
            prop_assert!(valid_se3(&y), "exp({v}) = {y:?}");
            prop_assert!(finite(y.log().as_slice()), "log(exp({v}))");
            prop_assert!(no_nan(Se3::right_jacobian(&v).iter()), "Jr({v})");
            prop_assert!(no_nan(Se3::right_jacobian_inverse(&v).iter()), "Jr^-1({v})");
            prop_assert!(no_nan(x.j_retract_self(&v).iter()));
            prop_assert!(no_nan(y.adjoint().iter()));
            prop_assert!(no_nan(y.act(&p).iter()));
            prop_assert!(no_nan(x.retract(&v).translation().iter()));
        }
        // Points anywhere in the finite range act and differentiate to finite values (saturating).
        for q in [Vector3::new(a, b, c), Vector3::new(d, e, f)] {
            prop_assert!(finite(x.act(&q).as_slice()), "{x:?} . {q}");
            prop_assert!(finite(x.j_act_self(&q).as_slice()), "J {x:?} . {q}");
            let nav = Se23::new(*x.rotation(), q, -q).unwrap();
            prop_assert!(finite(nav.act(&q).as_slice()) && finite(nav.j_act_self(&q).as_slice()));
            let planar = Se2::exp(&Vector3::new(0.0, 0.0, f));
            prop_assert!(finite(planar.act(&q.xy()).as_slice()));
            prop_assert!(finite(planar.j_act_self(&q.xy()).as_slice()));
        }
        for w in [Vector3::new(a, b, f), Vector3::new(f, c, d)] {
            let y = Se2::exp(&w);
            prop_assert!(valid_se2(&y), "exp({w}) = {y:?}");
            prop_assert!(finite(y.log().as_slice()), "log(exp({w}))");
            prop_assert!(no_nan(Se2::right_jacobian(&w).iter()), "Jr({w})");
            prop_assert!(no_nan(Se2::right_jacobian_inverse(&w).iter()), "Jr^-1({w})");
            prop_assert!(no_nan(y.adjoint().iter()));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// The blocks of SE₂(3) are SE(3)'s: the pose `(R, p)` composes, inverts, acts and exponentiates
    /// as [`Se3`] does, and the velocity follows the same formulas as the position.
    #[test]
    fn se23_blocks_are_poses(a in st::se23::<f64>(), b in st::se23::<f64>(), v in st::se23_tangent::<f64>(),
                             p in st::point3::<f64>()) {
        let scale = 1.0 + a.position().amax().max(a.velocity().amax()) + b.position().amax().max(b.velocity().amax());
        let ab = a.compose(&b);
        prop_assert_eq!(ab.pose(), a.pose().compose(&b.pose()));
        let swapped = |x: &Se23<f64>| Se3::new_unchecked(*x.rotation(), *x.velocity());
        prop_assert_eq!(swapped(&ab), swapped(&a).compose(&swapped(&b)));
        prop_assert_eq!(a.inverse().pose(), a.pose().inverse());
        prop_assert!((a.act(&p) - a.pose().act(&p)).norm() == 0.0);
        let x = Se23::exp(&v);
        let pose = Vector6::new(v[0], v[1], v[2], v[3], v[4], v[5]);
        let velocity = Vector6::new(v[6], v[7], v[8], v[3], v[4], v[5]);
        prop_assert_eq!(x.pose(), Se3::exp(&pose));
        prop_assert!((x.velocity() - Se3::exp(&velocity).translation()).amax() <= 1e-15 * scale);
        let log = a.log();
        let pose_log = a.pose().log();
        prop_assert!((log.fixed_rows::<6>(0) - pose_log).amax() == 0.0);
        prop_assert!(valid_se23(&ab) && valid_se23(&a.inverse()) && valid_se23(&x));
    }

    /// exp agrees with the matrix exponential of hat(ξ) (nalgebra's Padé approximation).
    #[test]
    fn se23_exp_is_the_matrix_exponential(v in st::se23_tangent::<f64>()) {
        prop_assume!(v.norm() < 25.0);
        let scale = 1.0 + v.norm();
        let expected = Se23::hat(&v).exp();
        prop_assert!((Se23::exp(&v).to_matrix() - expected).amax() <= 1e-12 * scale * scale);
    }

    /// Matrices round-trip, and a perturbed entry is refused exactly when the matrix stops being an
    /// extended pose (bottom rows, orthonormality, determinant, finiteness), with the matching error.
    #[test]
    fn se23_matrix_constructors(a in st::se23::<f64>(), i in 0usize..25, bad in raw(), flip in any::<bool>()) {
        let m = a.to_matrix();
        prop_assert!(Se23::from_matrix(&m).unwrap().distance(&a) <= 1e-12 * (1.0 + m.amax()));
        prop_assert_eq!(Se23::from_matrix_unchecked(&m), Se23::from_matrix(&m).unwrap());
        let mut m = m;
        m[i] = bad;
        if flip {
            m.set_column(0, &-m.column(0));
        }
        let r = m.fixed_view::<3, 3>(0, 0).into_owned();
        let bottom = (m.fixed_rows::<2>(3) - Matrix5::<f64>::identity().fixed_rows::<2>(3)).amax();
        let is_finite = m.iter().all(|v| v.is_finite());
        let rotation = (r.transpose() * r - Matrix3::identity()).amax() <= 1e-9 && (r.determinant() - 1.0).abs() <= 1e-9;
        match Se23::from_matrix(&m) {
            Ok(x) => { prop_assert!(is_finite && bottom <= 1e-9 && rotation); prop_assert!(valid_se23(&x)); }
            Err(ManifoldError::NonFinite { .. }) => prop_assert!(!is_finite),
            Err(ManifoldError::NotHomogeneous { deviation, .. }) => { prop_assert!(is_finite && bottom > 1e-9); prop_assert_eq!(deviation, bottom); }
            Err(ManifoldError::NotOrthonormal { .. } | ManifoldError::NotProperRotation { .. }) => prop_assert!(is_finite && bottom <= 1e-9 && !rotation),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
        let (v, p) = (m.fixed_view::<3, 1>(0, 3).into_owned(), m.fixed_view::<3, 1>(0, 4).into_owned());
        prop_assert_eq!(Se23::from_parts(&r, &v, &p).is_ok(), is_finite_all(&r, &v) && finite(p.as_slice()) && rotation);
    }

    /// `new` refuses exactly the non-finite inputs.
    #[test]
    fn se23_part_constructors(x in raw(), y in raw(), z in raw(), r in st::so3::<f64>()) {
        let w = Vector3::new(x, y, z);
        let ok = finite(&[x, y, z]);
        for (v, p) in [(w, Vector3::zeros()), (Vector3::zeros(), w)] {
            match Se23::new(r, v, p) {
                Ok(e) => { prop_assert!(ok); prop_assert!(valid_se23(&e)); }
                Err(e) => { prop_assert!(!ok); prop_assert!(matches!(e, ManifoldError::NonFinite { .. }), "{}", e); }
            }
        }
        let broken = So3::from_quaternion_unchecked(Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        prop_assert!(Se23::new(broken, Vector3::zeros(), Vector3::zeros()).is_err());
    }

    /// Tangents with components anywhere in the finite range: exp gives a valid element (velocities
    /// and positions beyond the range saturate at the largest finite value), and nothing returns NaN.
    #[test]
    fn se23_huge_tangents_give_valid_elements(
        c in proptest::array::uniform9(any_finite()), f in -1e3..1e3_f64,
        x in st::se23::<f64>(), p in st::point3::<f64>(),
    ) {
        let mut moderate_rotation = SVector::<f64, 9>::from_column_slice(&c);
        moderate_rotation[4] = f;
        for v in [SVector::<f64, 9>::from_column_slice(&c), moderate_rotation] {
            let y = Se23::exp(&v);
            prop_assert!(valid_se23(&y), "exp({v}) = {y:?}");
            prop_assert!(finite(y.log().as_slice()), "log(exp({v}))");
            prop_assert!(no_nan(Se23::right_jacobian(&v).iter()), "Jr({v})");
            prop_assert!(no_nan(Se23::right_jacobian_inverse(&v).iter()), "Jr^-1({v})");
            prop_assert!(no_nan(x.j_retract_self(&v).iter()));
            prop_assert!(no_nan(y.adjoint().iter()));
            prop_assert!(no_nan(y.act(&p).iter()));
            prop_assert!(valid_se23(&x.retract(&v)));
        }
    }
}

fn is_finite_all(r: &Matrix3<f64>, t: &Vector3<f64>) -> bool {
    r.iter().chain(t.iter()).all(|v| v.is_finite())
}

#[test]
fn log_at_and_near_the_half_turn() {
    let rho = Vector3::new(0.3, -2.0, 1.5);
    let axis = Vector3::new(1.0, 2.0, -2.0) / 3.0;
    for delta in [0.0, 1e-15, 1e-12, 1e-9] {
        let phi = axis * (PI - delta);
        let v = Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z);
        let back = Se3::exp(&v).log();
        assert!(
            (back - v).norm() <= 16.0 * f64::EPSILON * v.norm(),
            "delta {delta}: {back}"
        );
        let w = Vector3::new(rho.x, rho.y, PI - delta);
        let back = Se2::exp(&w).log();
        assert!(
            (back - w).norm() <= 16.0 * f64::EPSILON * w.norm(),
            "delta {delta}: {back}"
        );
    }
    // A half turn stored with sine −0 has the angle +π, inside (−π, π].
    let half = Se2::new(
        So2::from_cos_sin_unchecked(-1.0, -0.0),
        Vector2::new(1.0, 2.0),
    )
    .unwrap();
    assert_eq!(half.log().z, PI);
    assert_relative_eq!(Se2::exp(&half.log()), half, epsilon = 1e-15);
    // At the half turn V⁻¹ is regular: ρ = V(π u)⁻¹ t = (I − (π/2) U + U²) t.
    let r = So3::from_axis_angle(&Vector3::z(), PI).unwrap();
    let x = Se3::new(r, Vector3::new(1.0, 0.0, 2.0)).unwrap();
    let log = x.log();
    let phi = Vector3::new(log[3], log[4], log[5]);
    let u = phi / PI;
    let expected = Vector3::new(0.0, 0.0, 2.0) - u.cross(&Vector3::new(1.0, 0.0, 0.0)) * (PI / 2.0);
    assert!((Vector3::new(log[0], log[1], log[2]) - expected).norm() < 1e-15);
}

#[test]
fn a_right_perturbation_moves_along_the_body_axes() {
    let x = Se3::new(
        So3::from_axis_angle(&Vector3::new(1.0, 1.0, 0.0), 0.7).unwrap(),
        Vector3::new(1.0, 2.0, 3.0),
    )
    .unwrap();
    let step = Vector3::new(0.1, -0.2, 0.3);
    let y = x.retract(&Vector6::new(step.x, step.y, step.z, 0.0, 0.0, 0.0));
    assert_relative_eq!(
        *y.translation(),
        x.translation() + x.rotation().rotate(&step),
        epsilon = 1e-15
    );
    let planar = Se2::from_angle_translation(1.2, Vector2::new(-1.0, 0.5)).unwrap();
    let z = planar.retract(&Vector3::new(0.4, 0.0, 0.0));
    let forward = planar.rotation().as_unit_complex() * Vector2::new(0.4, 0.0);
    assert_relative_eq!(
        *z.translation(),
        planar.translation() + forward,
        epsilon = 1e-15
    );
}

#[test]
fn comparisons_treat_the_quaternion_sign_as_one_rotation() {
    let q = So3::exp(&Vector3::new(0.3, -0.2, 0.1));
    let minus_q = So3::from_quaternion_unchecked(-*q.as_unit_quaternion().quaternion());
    let t = Vector3::new(1.0, 2.0, 3.0);
    let a = Se3::new(q, t).unwrap();
    let b = Se3::new(minus_q, t).unwrap();
    assert_eq!(a, b);
    assert_relative_eq!(a, b, epsilon = 1e-15);
    assert!(a.distance(&b) < 1e-15);
    let c = Se3::new(q, t + Vector3::new(1e-3, 0.0, 0.0)).unwrap();
    assert_ne!(a, c);
    assert!(!approx::relative_eq!(a, c, epsilon = 1e-6));
    let d = Se2::from_angle_translation(0.5, Vector2::new(1.0, 0.0)).unwrap();
    let e = Se2::from_angle_translation(0.5 + 1e-3, Vector2::new(1.0, 0.0)).unwrap();
    assert!(!approx::relative_eq!(d, e, epsilon = 1e-6));
    assert_relative_eq!(d, d.renormalized(), epsilon = 1e-15);
}

#[test]
fn errors_say_what_to_do() {
    let mut m = Matrix4::<f64>::identity();
    m[(3, 0)] = 0.5;
    let e = Se3::from_matrix(&m).unwrap_err();
    assert!(matches!(e, ManifoldError::NotHomogeneous { .. }));
    assert!(e.to_string().contains("from_parts"), "{e}");
    let e = Se3::from_parts(&(Matrix3::identity() * 2.0), &Vector3::zeros()).unwrap_err();
    assert!(matches!(e, ManifoldError::NotOrthonormal { .. }), "{e}");
    let e = Se2::from_parts(&Matrix2::new(1.0, 0.0, 0.0, -1.0), &Vector2::zeros()).unwrap_err();
    assert!(matches!(e, ManifoldError::NotProperRotation { .. }), "{e}");
    let e = Se2::new(So2::identity(), Vector2::new(f64::NAN, 0.0)).unwrap_err();
    assert!(
        matches!(
            e,
            ManifoldError::NonFinite {
                what: "translation",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn se23_right_perturbations_move_along_the_body_axes_and_compare_up_to_sign() {
    let q = So3::from_axis_angle(&Vector3::new(1.0, 1.0, 0.0), 0.7).unwrap();
    let x = Se23::new(q, Vector3::new(-1.0, 0.5, 0.0), Vector3::new(1.0, 2.0, 3.0)).unwrap();
    let step = Vector3::new(0.1, -0.2, 0.3);
    let mut position_step = SVector::<f64, 9>::zeros();
    position_step.fixed_rows_mut::<3>(0).copy_from(&step);
    let y = x.retract(&position_step);
    assert_relative_eq!(
        *y.position(),
        x.position() + q.rotate(&step),
        epsilon = 1e-15
    );
    assert_eq!(y.velocity(), x.velocity());
    let minus_q = So3::from_quaternion_unchecked(-*q.as_unit_quaternion().quaternion());
    let z = Se23::new(minus_q, *x.velocity(), *x.position()).unwrap();
    assert_eq!(x, z);
    assert_relative_eq!(x, z, epsilon = 1e-15);
    assert!(!approx::relative_eq!(x, y, epsilon = 1e-6));
    assert_relative_eq!(x, x.renormalized(), epsilon = 1e-15);
    let e = Se23::from_matrix(&(Matrix5::identity() * 2.0)).unwrap_err();
    assert!(matches!(e, ManifoldError::NotHomogeneous { .. }), "{e}");
    assert!(
        e.to_string().contains("[[R, v, p], [0, 1, 0], [0, 0, 1]]"),
        "{e}"
    );
    let e = Se23::new(q, Vector3::new(f64::NAN, 0.0, 0.0), Vector3::zeros()).unwrap_err();
    assert!(
        matches!(
            e,
            ManifoldError::NonFinite {
                what: "velocity",
                ..
            }
        ),
        "{e}"
    );
}

/// The log at and near a half turn keeps full accuracy in both linear blocks.
#[test]
fn se23_log_at_and_near_the_half_turn() {
    let axis = Vector3::new(1.0, 2.0, -2.0) / 3.0;
    for delta in [0.0, 1e-15, 1e-12, 1e-9] {
        let phi = axis * (PI - delta);
        let v = SVector::<f64, 9>::from_column_slice(&[
            0.3, -2.0, 1.5, phi.x, phi.y, phi.z, 4.0, 0.5, -1.0,
        ]);
        let back = Se23::exp(&v).log();
        assert!(
            (back - v).norm() <= 16.0 * f64::EPSILON * v.norm(),
            "delta {delta}: {back}"
        );
    }
}
