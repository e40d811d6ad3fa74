//! serde round trips of every space (feature `serde`), and refusal of invalid points on reading.
#![cfg(feature = "serde")]

use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{
    Left, MeanSettings, ProductManifold, Rn, S2, Se2, Se3, Se23, So2, So3, Su2,
};
use proptest::prelude::*;
use serde::{Serialize, de::DeserializeOwned};
use std::fmt::Debug;

/// JSON and back gives the same value, exactly.
fn round_trip<X: Serialize + DeserializeOwned + PartialEq + Debug>(
    x: &X,
) -> Result<(), TestCaseError> {
    let text = serde_json::to_string(x).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let back: X =
        serde_json::from_str(&text).map_err(|e| TestCaseError::fail(format!("{e}: {text}")))?;
    prop_assert_eq!(&back, x, "{}", text);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn rotations(a in st::so2::<f64>(), b in st::so3::<f64>(), c in st::su2::<f64>(), d in st::so3::<f32>()) {
        round_trip(&a)?;
        round_trip(&b)?;
        round_trip(&c)?;
        round_trip(&d)?;
        round_trip(&Left::new(b))?;
    }

    #[test]
    fn sphere_vectors_and_poses(
        a in st::s2::<f64>(),
        b in st::rn::<f64, 3>(),
        c in st::se2::<f64>(),
        d in st::se3::<f64>(),
        e in st::se3::<f32>(),
    ) {
        round_trip(&a)?;
        round_trip(&b)?;
        round_trip(&c)?;
        round_trip(&d)?;
        round_trip(&e)?;
    }

    #[test]
    fn extended_poses(a in st::se23::<f64>(), b in st::se23::<f32>()) {
        round_trip(&a)?;
        round_trip(&b)?;
        round_trip(&Left::new(a))?;
    }

    #[test]
    fn products(r in st::so3::<f64>(), b in st::rn::<f64, 3>(), t in st::rn::<f64, 2>()) {
        let inner = ProductManifold::<_, _, 3, 3, 6>::new(r, b);
        round_trip(&inner)?;
        round_trip(&ProductManifold::<_, _, 6, 2, 8>::new(inner, t))?;
    }
}

#[test]
fn the_written_forms_are_the_documented_ones() {
    let r = <So3<f64> as liebayes_manifolds::LieGroup<3>>::identity();
    assert_eq!(serde_json::to_string(&r).unwrap(), "[1.0,0.0,0.0,0.0]");
    let x = Se2::new(
        So2::<f64>::from_cos_sin(0.0, 1.0).unwrap(),
        nalgebra::Vector2::new(1.0, 2.0),
    )
    .unwrap();
    assert_eq!(
        serde_json::to_string(&x).unwrap(),
        r#"{"rotation":[0.0,1.0],"translation":[1.0,2.0]}"#
    );
    let e = Se23::new(
        r,
        nalgebra::Vector3::new(1.0, 2.0, 3.0),
        nalgebra::Vector3::new(4.0, 5.0, 6.0),
    )
    .unwrap();
    assert_eq!(
        serde_json::to_string(&e).unwrap(),
        r#"{"rotation":[1.0,0.0,0.0,0.0],"velocity":[1.0,2.0,3.0],"position":[4.0,5.0,6.0]}"#
    );
    let settings = MeanSettings::<f64>::new(20, 1e-9).unwrap();
    assert_eq!(
        serde_json::to_string(&settings).unwrap(),
        r#"{"max_iterations":20,"tolerance":1e-9}"#
    );
}

#[test]
fn invalid_points_are_refused_with_the_constructors_message() {
    let not_unit = serde_json::from_str::<So3<f64>>("[2.0,0.0,0.0,0.0]").unwrap_err();
    assert!(not_unit.to_string().contains("unit norm"), "{not_unit}");
    assert!(serde_json::from_str::<Su2<f64>>("[0.5,0.5,0.5]").is_err());
    assert!(serde_json::from_str::<So2<f64>>("[0.0,0.0]").is_err());
    assert!(serde_json::from_str::<S2<f64>>("[0.0,0.0,0.0]").is_err());
    assert!(serde_json::from_str::<Rn<f64, 2>>("[1.0]").is_err());
    assert!(serde_json::from_str::<Se3<f64>>(r#"{"rotation":[1.0,0.0,0.0,0.0]}"#).is_err());
    assert!(
        serde_json::from_str::<Se2<f64>>(
            r#"{"rotation":[1.0,0.0],"translation":[0.0,0.0],"scale":2.0}"#
        )
        .is_err()
    );
    let half =
        r#"{"rotation":[0.5,0.0,0.0,0.0],"velocity":[0.0,0.0,0.0],"position":[0.0,0.0,0.0]}"#;
    let not_unit = serde_json::from_str::<Se23<f64>>(half).unwrap_err();
    assert!(not_unit.to_string().contains("unit norm"), "{not_unit}");
    assert!(
        serde_json::from_str::<Se23<f64>>(
            r#"{"rotation":[1.0,0.0,0.0,0.0],"velocity":[0.0,0.0,0.0]}"#
        )
        .is_err()
    );
    assert!(
        serde_json::from_str::<MeanSettings<f64>>(r#"{"max_iterations":0,"tolerance":1e-9}"#)
            .is_err()
    );
}

/// The composition of two rotations accepted 9e-10 off unit norm had norm 1 + 1.8e-9, which the
/// reader refused (`NotUnit`); every value is now stored unit to rounding, and compositions of
/// stored values, their poses and their matrices' rotations read back bit for bit.
#[test]
fn compositions_of_near_unit_values_round_trip_exactly() {
    use liebayes_manifolds::LieGroup;
    use nalgebra::{Vector2, Vector3};
    let k = 1.0 + 9e-10;
    let r = So3::from_quaternion_wxyz(0.5 * k, 0.5 * k, -0.5 * k, 0.5 * k).unwrap();
    let identity = So3::from_quaternion_wxyz(k, 0.0, 0.0, 0.0).unwrap();
    let q = Su2::from_quaternion_wxyz(0.6 * k, 0.0, 0.8 * k, 0.0).unwrap();
    let z = So2::from_cos_sin(0.6 * k, -0.8 * k).unwrap();
    let mut chain = r;
    for _ in 0..4 {
        chain = chain.compose(&r);
        round_trip(&chain).unwrap();
    }
    round_trip(&identity.compose(&identity)).unwrap();
    round_trip(&q.compose(&q)).unwrap();
    round_trip(&z.compose(&z)).unwrap();
    let t = Vector3::new(1.0, -2.0, 3.0);
    let pose = Se3::from_parts(&(r.to_matrix() * (1.0 + 3e-10)), &t).unwrap();
    round_trip(&pose.compose(&pose)).unwrap();
    let planar =
        Se2::from_parts(&(z.to_matrix() * (1.0 + 3e-10)), &Vector2::new(1.0, 2.0)).unwrap();
    round_trip(&planar.compose(&planar)).unwrap();
    let extended = Se23::new(r, t, -t).unwrap();
    round_trip(&extended.compose(&extended)).unwrap();
    let direction = S2::new(Vector3::new(0.0, 0.6, 0.8) * k).unwrap();
    round_trip(&direction).unwrap();
}
