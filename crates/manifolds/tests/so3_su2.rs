//! Properties specific to SO(3) and SU(2): the double cover, equality up to sign, and conversions to and
//! from nalgebra.

use approx::assert_relative_eq;
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, So2, So3, Su2};
use nalgebra::{Matrix3, Rotation2, Rotation3, UnitComplex, UnitQuaternion, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// The covering map is a homomorphism and forgets the sign.
    #[test]
    fn covering_map(a in st::su2::<f64>(), b in st::su2::<f64>(), p in st::point3::<f64>()) {
        let ab = a.compose(&b).to_so3();
        prop_assert!(ab.distance(&a.to_so3().compose(&b.to_so3())) < 1e-13);
        prop_assert_eq!(a.to_so3(), a.antipode().to_so3());
        prop_assert!(a.to_so3().distance(&a.antipode().to_so3()) < 1e-15);
        prop_assert!((a.act(&p) - a.to_so3().act(&p)).norm() < 1e-12 * (1.0 + p.norm()));
        // On SU(2), q and -q are 2π apart in the tangent norm: |log(q^-1 (-q))| = 2π.
        prop_assert!((a.distance(&a.antipode()) - 2.0 * PI).abs() < 1e-12);
        prop_assert!(a != a.antipode());
        let lift = a.to_so3().to_su2();
        prop_assert!(lift == a || lift == a.antipode());
        prop_assert!(lift.to_quaternion_wxyz()[0] >= 0.0);
    }

    /// SO(3)'s angle lies in [0, π] and equals |log|; matrices round-trip, also near π.
    #[test]
    fn so3_angle_and_matrix(r in st::so3::<f64>()) {
        let angle = r.angle();
        prop_assert!((0.0..=PI).contains(&angle));
        prop_assert!((angle - r.log().norm()).abs() < 1e-14);
        let back = So3::from_matrix(&r.to_matrix()).unwrap();
        prop_assert!(back.distance(&r) < 1e-14, "{:?} vs {:?}", back, r);
        prop_assert!(relative_eq_rot(&back, &r));
    }

    /// Conversions to and from nalgebra agree with nalgebra's own operations.
    #[test]
    fn nalgebra_interop(r in st::so3::<f64>(), s in st::so3::<f64>(), p in st::point3::<f64>(), z in st::so2::<f64>()) {
        let q: UnitQuaternion<f64> = r.into();
        let qs: UnitQuaternion<f64> = s.into();
        prop_assert!(So3::from(q * qs).distance(&r.compose(&s)) < 1e-14);
        prop_assert!((q * p - r.act(&p)).norm() < 1e-12 * (1.0 + p.norm()));
        let m: Rotation3<f64> = r.into();
        prop_assert!(So3::from(m).distance(&r) < 1e-14);
        prop_assert!((m * p - r.act(&p)).norm() < 1e-12 * (1.0 + p.norm()));
        let c: UnitComplex<f64> = z.into();
        prop_assert_eq!(So2::from(c), z);
        let m2: Rotation2<f64> = z.into();
        prop_assert!(So2::from(m2).distance(&z) < 1e-15);
        // nalgebra's exp agrees away from the small-angle regime where it truncates.
        let v = r.log();
        if v.norm() > 1e-6 {
            prop_assert!(So3::from(UnitQuaternion::from_scaled_axis(v)).distance(&r) < 1e-14);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// On well-conditioned matrices (a rotation times a symmetric positive definite stretch, so the
    /// nearest rotation is known exactly), the Jacobi polar factor equals the rotation and agrees with
    /// nalgebra's SVD-based polar decomposition.
    #[test]
    fn orthonormalized_is_the_polar_factor(
        r in st::so3::<f64>(),
        s in st::so3::<f64>(),
        stretch in proptest::array::uniform3(0.2..5.0_f64),
        scale in prop_oneof![Just(1.0), Just(1e-200), Just(1e200)],
    ) {
        // m = R P with P = S diag(stretch) Sᵀ symmetric positive definite: polar(m) = R.
        let p = s.to_matrix() * Matrix3::from_diagonal(&nalgebra::Vector3::from(stretch)) * s.to_matrix().transpose();
        let m = r.to_matrix() * p * scale;
        let q = So3::from_matrix_orthonormalized(&m).unwrap();
        prop_assert!(q.distance(&r) < 1e-13, "{:e}", q.distance(&r));
        let (_, u) = (m / scale).polar();
        prop_assert!((q.to_matrix() - u).amax() < 1e-13);
    }
}

fn relative_eq_rot(a: &So3<f64>, b: &So3<f64>) -> bool {
    approx::relative_eq!(*a, *b, epsilon = 1e-14)
}

#[test]
fn so3_equality_ignores_the_sign_and_su2_equality_does_not() {
    let q = Su2::exp(&Vector3::new(0.3, -0.2, 0.1));
    assert_eq!(q.to_so3(), q.antipode().to_so3());
    assert_relative_eq!(q.to_so3(), q.antipode().to_so3(), epsilon = 1e-15);
    assert_ne!(q, q.antipode());
    assert!(!approx::relative_eq!(q, q.antipode(), epsilon = 1e-3));
}

#[test]
fn log_at_and_near_pi() {
    for delta in [0.0, 1e-15, 1e-12, 1e-9] {
        let axis = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        let v = axis * (PI - delta);
        let r = So3::exp(&v);
        assert!(
            (r.log() - v).norm() <= 4.0 * f64::EPSILON,
            "delta {delta}: {:?}",
            r.log()
        );
        // Past π the SO(3) log flips the axis; SU(2) keeps it, up to 2π.
        let w = axis * (PI + 0.5);
        assert!((So3::exp(&w).log() + axis * (PI - 0.5)).norm() < 1e-14);
        assert!((Su2::exp(&w).log() - w).norm() < 1e-14);
    }
    // SU(2) at w = −1 exactly: every axis is a logarithm; the x axis is returned.
    let minus_one = Su2::from_quaternion_wxyz(-1.0, 0.0, 0.0, 0.0).unwrap();
    assert_eq!(minus_one.log(), Vector3::new(2.0 * PI, 0.0, 0.0));
    assert_eq!(So3::from(minus_one).log(), Vector3::zeros());
}

#[test]
fn exp_near_identity_keeps_first_order_accuracy() {
    // nalgebra's from_scaled_axis returns the identity below its epsilon; ours keeps v/2.
    for scale in [1e-8, 1e-12, 1e-20, 1e-300] {
        let v = Vector3::new(1.0, -2.0, 0.5) * scale;
        let q = So3::exp(&v).to_quaternion_wxyz();
        assert_relative_eq!(q[1], v.x / 2.0, max_relative = 1e-15);
        assert_relative_eq!(So3::exp(&v).log(), v, max_relative = 1e-15);
    }
}

#[test]
fn so2_half_turn_with_negative_zero_sine_has_angle_pi() {
    use liebayes_manifolds::{LieGroup, So2};
    let r = So2::<f64>::from_cos_sin_unchecked(-1.0, -0.0);
    assert_eq!(r.angle(), std::f64::consts::PI);
    assert_eq!(r.log().x, std::f64::consts::PI);
}
