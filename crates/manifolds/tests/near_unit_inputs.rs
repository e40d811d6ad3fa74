//! Quaternions, unit complex numbers, unit vectors and rotation matrices accepted within the unit-norm
//! tolerance (1e-9) are stored unit to rounding: products of them keep their norm, their own matrices
//! read back, and the sphere's exponential at such a point stays on its side.

use liebayes_manifolds::{GroupAction, LieGroup, Manifold, S2, Se2, Se3, Se23, So2, So3, Su2};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use std::f64::consts::PI;

/// `abs(|q| − 1)` of a stored quaternion.
fn quaternion_deviation(q: [f64; 4]) -> f64 {
    (q.iter().map(|c| c * c).sum::<f64>().sqrt() - 1.0).abs()
}

/// A rotation whose quaternion is 9e-10 off unit norm, accepted by `from_quaternion_wxyz`.
fn near_unit_rotation() -> So3<f64> {
    let (w, x, y, z) = (0.5_f64, 0.5, -0.5, 0.5);
    let k = 1.0 + 9e-10;
    So3::from_quaternion_wxyz(w * k, x * k, y * k, z * k).unwrap()
}

/// 30 squarings of `from_quaternion_wxyz(1 + 9e-10, 0, 0, 0)` gave a quaternion of norm 2.6 (the
/// norm squares at each step) whose matrix was 6.9 I; and 30 products with a near-unit rotation
/// drifted by 2.7e-8. Both now stay unit to 1e-14.
#[test]
fn products_of_near_unit_quaternions_keep_unit_norm() {
    let mut r = So3::from_quaternion_wxyz(1.0 + 9e-10, 0.0, 0.0, 0.0).unwrap();
    let mut q = Su2::from_quaternion_wxyz(1.0 + 9e-10, 0.0, 0.0, 0.0).unwrap();
    for _ in 0..30 {
        r = r.compose(&r);
        q = q.compose(&q);
    }
    assert!(
        quaternion_deviation(r.to_quaternion_wxyz()) < 1e-14,
        "{r:?}"
    );
    assert!(
        quaternion_deviation(q.to_quaternion_wxyz()) < 1e-14,
        "{q:?}"
    );
    let v = Vector3::new(1.0, -2.0, 0.5);
    assert!((r.rotate(&v) - v).norm() < 1e-14);
    assert!((r.to_matrix() - Matrix3::identity()).amax() < 1e-14);

    let step = near_unit_rotation();
    let mut chain = step;
    for _ in 0..30 {
        chain = chain.compose(&step);
    }
    assert!(
        quaternion_deviation(chain.to_quaternion_wxyz()) < 1e-14,
        "{chain:?}"
    );
    assert!((chain.rotate(&v).norm() - v.norm()).abs() < 1e-13);

    // The unit complex numbers of SO(2) the same way.
    let z = So2::<f64>::from_cos_sin(1.0 + 9e-10, 0.0).unwrap();
    let turn = So2::<f64>::from_cos_sin(0.6 * (1.0 + 9e-10), 0.8 * (1.0 + 9e-10)).unwrap();
    let (mut zz, mut turns) = (z, turn);
    for _ in 0..30 {
        zz = zz.compose(&zz);
        turns = turns.compose(&turn);
    }
    for x in [zz, turns] {
        assert!((x.cos().hypot(x.sin()) - 1.0).abs() < 1e-14, "{x:?}");
        let p = Vector2::new(3.0, -4.0);
        assert!((x.act(&p).norm() - 5.0).abs() < 1e-13);
    }
}

/// `So3::from_matrix(&r.to_matrix())` refused the matrix of a rotation accepted 9e-10 off unit
/// norm (RᵀR − I = 3.6e-9); a matrix accepted within the orthonormality tolerance left that
/// deviation in the stored quaternion. Every rotation's matrix now reads back, and a matrix
/// accepted 6e-10 off orthonormal gives a unit quaternion, in every type built on them.
#[test]
fn rotation_matrices_read_back_and_give_unit_rotations() {
    for r in [
        near_unit_rotation(),
        So3::from_quaternion_wxyz(1.0 + 9e-10, 0.0, 0.0, 0.0).unwrap(),
    ] {
        let back = So3::from_matrix(&r.to_matrix()).unwrap();
        assert!(back.distance(&r) < 1e-15);
        let pose = Se3::from_parts(&r.to_matrix(), &Vector3::new(1.0, 2.0, 3.0)).unwrap();
        assert!(Se3::from_matrix(&pose.to_homogeneous()).is_ok());
    }
    let z = So2::from_cos_sin(1.0 + 9e-10, 0.0).unwrap();
    assert!(So2::from_matrix(&z.to_matrix()).is_ok());

    // Matrices 3e-10 too long (RᵀR − I = 6e-10 and det − 1 = 9e-10, accepted).
    let k = 1.0 + 3e-10;
    let rotation = near_unit_rotation().renormalized().to_matrix() * k;
    let r = So3::from_matrix(&rotation).unwrap();
    assert!(
        quaternion_deviation(r.to_quaternion_wxyz()) < 1e-15,
        "{r:?}"
    );
    let t = Vector3::new(1.0, 2.0, 3.0);
    for rotation in [
        *Se3::from_parts(&rotation, &t).unwrap().rotation(),
        *Se23::from_parts(&rotation, &t, &t).unwrap().rotation(),
    ] {
        assert!(quaternion_deviation(rotation.to_quaternion_wxyz()) < 1e-15);
    }
    let (s, c) = 0.7_f64.sin_cos();
    let planar = Matrix2::new(c, -s, s, c) * k;
    for x in [
        So2::from_matrix(&planar).unwrap(),
        *Se2::from_parts(&planar, &Vector2::new(1.0, 2.0))
            .unwrap()
            .rotation(),
    ] {
        assert!((x.cos().hypot(x.sin()) - 1.0).abs() < 1e-15, "{x:?}");
    }
}

/// Accepted unit vectors are stored unit: the von Mises-Fisher mode of a mean 9e-10 off the
/// sphere was that far off it.
#[test]
fn near_unit_directions_are_stored_unit() {
    let x = S2::<f64>::new(Vector3::new(0.0, 0.0, 1.0 + 9e-10)).unwrap();
    assert!((x.as_vector().norm() - 1.0).abs() < 1e-15);
    let y = S2::<f64>::new(Vector3::new(0.6, 0.8, 0.0) * (1.0 - 9e-10)).unwrap();
    assert!((y.as_vector().norm() - 1.0).abs() < 1e-15);
    // A point unit to rounding is kept bit for bit, so normalising is idempotent.
    assert_eq!(S2::new(*y.as_vector()).unwrap(), y);
    let q = near_unit_rotation().to_quaternion_wxyz();
    assert_eq!(
        So3::from_quaternion_wxyz(q[0], q[1], q[2], q[3])
            .unwrap()
            .to_quaternion_wxyz(),
        q
    );
}

/// At `x = (0, 0, 1 + 2⁻³⁰)` (accepted by `S2::new`), `exp_at(w)` for a `w` along x (whose exact
/// exponential is x itself) projected w to a tangent of the wrong sign and returned the antipode
/// (0, 0, −1). It returns x, also for a point made off the sphere with `new_unchecked`.
#[test]
fn the_exponential_along_the_point_stays_at_the_point() {
    let off = Vector3::new(0.0, 0.0, 1.0 + 2f64.powi(-30));
    let w = Vector3::new(0.0, 0.0, PI * 2f64.powi(29));
    for x in [S2::new(off).unwrap(), S2::new_unchecked(off)] {
        let y = x.exp_at(&w);
        assert!(y.as_vector().z > 0.0, "{y:?}");
        assert!(y.angle_to(&S2::new(Vector3::z()).unwrap()) < 1e-6, "{y:?}");
        assert!((y.as_vector().norm() - 1.0).abs() < 1e-15);
    }
}

/// `exp_at(K x)` for tangents along the point at scales up to 1e300, where the projection
/// `w − x (x · w)` cancels to rounding: always a unit vector (the sum could cancel to 0 and
/// normalise to NaN).
#[test]
fn the_exponential_of_tangents_along_the_point_is_a_unit_vector() {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..2000 {
        let v = Vector3::new(uniform(), uniform(), uniform());
        let Ok(x) = S2::from_vector_normalizing(&v) else {
            continue;
        };
        for exponent in [0, 9, 16, 100, 200, 300] {
            let k = 10f64.powi(exponent) * (1.0 + uniform());
            let y = x.exp_at(&(x.as_vector() * k));
            assert!(
                (y.as_vector().norm() - 1.0).abs() < 1e-15,
                "{x:?} times {k:e}: {y:?}"
            );
            // The component along x is ignored: only its rounding, ε k, moves the point.
            if exponent <= 9 {
                assert!(x.angle_to(&y) < 1e-15 * k.max(1.0), "{x:?}, {k:e}: {y:?}");
            }
        }
    }
}
