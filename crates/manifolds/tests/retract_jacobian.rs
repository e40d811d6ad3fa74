//! `Manifold::j_retract_tangent`: the default central difference against the closed forms of the
//! groups, and the closed forms of products and `Left` against the factors'.

use liebayes_manifolds::{Left, LieGroup, Manifold, Rn, S2, Se23, So3, Tangent};
use nalgebra::{SVector, Vector2, Vector3};

/// SO(3) without its closed form: the trait's default applies.
#[derive(Clone, Debug)]
struct Plain(So3<f64>);

impl Manifold<3> for Plain {
    type Scalar = f64;

    fn retract(&self, v: &Tangent<f64, 3>) -> Self {
        Self(self.0.retract(v))
    }

    fn local(&self, other: &Self) -> Tangent<f64, 3> {
        self.0.local(&other.0)
    }

    fn is_finite(&self) -> bool {
        self.0.is_finite()
    }
}

#[test]
fn the_default_matches_the_closed_form_of_so3() {
    let x = So3::exp(&Vector3::new(0.3, -1.1, 2.0));
    for v in [
        Vector3::zeros(),
        Vector3::new(0.1, 0.2, -0.3),
        Vector3::new(1.5, -1.0, 1.2),
    ] {
        let numeric = Plain(x).j_retract_tangent(&v);
        let closed = x.j_retract_tangent(&v);
        assert!((numeric - closed).amax() < 1e-9, "{numeric} vs {closed}");
        assert!((closed - So3::<f64>::right_jacobian(&v)).amax() == 0.0);
    }
}

#[test]
fn left_rn_and_products_give_their_closed_forms() {
    let v = Vector3::new(0.4, 0.1, -0.7);
    let x = So3::exp(&Vector3::new(-0.2, 0.5, 1.0));
    assert_eq!(
        Left::new(x).j_retract_tangent(&v),
        So3::<f64>::left_jacobian(&v)
    );
    let r = Rn::new(Vector2::new(3.0, 4.0)).unwrap();
    assert_eq!(
        r.j_retract_tangent(&Vector2::new(1.0, 2.0)),
        nalgebra::Matrix2::identity()
    );
    let pose = Se23::new(x, Vector3::new(1.0, 2.0, 3.0), Vector3::new(-4.0, 5.0, 6.0)).unwrap();
    let xi = SVector::<f64, 9>::from_fn(|i, _| 0.1 * (i as f64 - 4.0));
    assert_eq!(
        pose.j_retract_tangent(&xi),
        Se23::<f64>::right_jacobian(&xi)
    );
    assert_eq!(
        Left::new(pose).j_retract_tangent(&xi),
        Se23::<f64>::left_jacobian(&xi)
    );
}

#[test]
fn the_sphere_default_carries_steps_to_the_point_reached() {
    let x = S2::from_vector_normalizing(&Vector3::new(1.0, 2.0, -0.5)).unwrap();
    let v = Vector2::new(0.4, -0.9);
    let j = x.j_retract_tangent(&v);
    assert!(
        (x.j_retract_tangent(&Vector2::zeros()) - nalgebra::Matrix2::identity()).amax() < 1e-10
    );
    let reached = x.retract(&v);
    // A central difference with another step (1e-4): agrees to its truncation error, ~1e-8 relative.
    for e in [
        Vector2::new(1e-4, 0.0),
        Vector2::new(0.0, -1e-4),
        Vector2::new(6e-5, 8e-5),
    ] {
        let moved =
            (reached.local(&x.retract(&(v + e))) - reached.local(&x.retract(&(v - e)))) / 2.0;
        assert!(
            (moved - j * e).norm() < 1e-7 * e.norm(),
            "{moved} vs {}",
            j * e
        );
    }
}
