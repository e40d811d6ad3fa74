//! The generic law suite (crate `testing` module) run on every space, in f64 and in f32, with uniform
//! and curated edge elements (identity, 1e-8 from it, within 1e-12 of π, exactly π, w = −1, tangents of
//! norm 20 and 30; for the poses also translations of 1e3): the groups, the groups with world-frame
//! errors (`Left`), and products.

use liebayes_manifolds::testing::laws::{
    check_action, check_bad_input, check_group, check_jacobians, check_manifold,
    check_manifold_bad_input,
};
use liebayes_manifolds::testing::{Tolerance, strategies as st};

use proptest::prelude::*;

/// Cases per property: enough to hit every curated class many times (each has weight >= 1/30).
const CASES: u32 = 2048;

/// The manifold, group and Jacobian laws of a group, and its action laws when points are given.
macro_rules! group_laws {
    ($name:ident, $t:ty, $elem:expr, $tangent:expr $(, $point:expr)?) => {
        mod $name {
            use super::*;

            proptest! {
                #![proptest_config(ProptestConfig::with_cases(CASES))]

                #[test]
                fn manifold(x in $elem, y in $elem, v in $tangent) {
                    check_manifold(&x, &y, &v, &Tolerance::<$t>::for_scalar())?;
                }

                #[test]
                fn group(a in $elem, b in $elem, c in $elem, v in $tangent) {
                    check_group(&a, &b, &c, &v, &Tolerance::<$t>::for_scalar())?;
                }

                #[test]
                fn jacobians(a in $elem, b in $elem, v in $tangent) {
                    check_jacobians(&a, &b, &v, &Tolerance::<$t>::for_scalar())?;
                }

                #[test]
                fn bad_input(
                    x in $elem,
                    v in prop_oneof![
                        st::extreme_tangent::<$t, _>(),
                        st::extreme_raw_tangent::<$t, _>(),
                        $tangent,
                    ],
                ) {
                    check_bad_input(&x, &v)?;
                }

                $(
                #[test]
                fn action(a in $elem, b in $elem, p in $point) {
                    check_action(&a, &b, &p, &Tolerance::<$t>::for_scalar())?;
                }
                )?
            }
        }
    };
}

group_laws!(
    so2_f64,
    f64,
    st::so2::<f64>(),
    st::so2_tangent::<f64>(),
    st::point2::<f64>()
);
group_laws!(
    so2_f32,
    f32,
    st::so2::<f32>(),
    st::so2_tangent::<f32>(),
    st::point2::<f32>()
);
group_laws!(
    se2_f64,
    f64,
    st::se2::<f64>(),
    st::se2_tangent::<f64>(),
    st::point2::<f64>()
);
group_laws!(
    se2_f32,
    f32,
    st::se2::<f32>(),
    st::se2_tangent::<f32>(),
    st::point2::<f32>()
);
group_laws!(
    so3_f64,
    f64,
    st::so3::<f64>(),
    st::rotation_vector::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    so3_f32,
    f32,
    st::so3::<f32>(),
    st::rotation_vector::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    su2_f64,
    f64,
    st::su2::<f64>(),
    st::rotation_vector::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    su2_f32,
    f32,
    st::su2::<f32>(),
    st::rotation_vector::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    se3_f64,
    f64,
    st::se3::<f64>(),
    st::se3_tangent::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    se3_f32,
    f32,
    st::se3::<f32>(),
    st::se3_tangent::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    se23_f64,
    f64,
    st::se23::<f64>(),
    st::se23_tangent::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    se23_f32,
    f32,
    st::se23::<f32>(),
    st::se23_tangent::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    r3_f64,
    f64,
    st::rn::<f64, 3>(),
    st::rn_tangent::<f64, 3>(),
    st::point3::<f64>()
);
group_laws!(
    r3_f32,
    f32,
    st::rn::<f32, 3>(),
    st::rn_tangent::<f32, 3>(),
    st::point3::<f32>()
);

mod s2_laws {
    use super::*;
    use liebayes_manifolds::{Manifold, S2};
    use nalgebra::Vector3;

    fn basis_laws<T: liebayes_manifolds::Real>(
        x: &S2<T>,
        v: &nalgebra::Vector2<T>,
    ) -> Result<(), TestCaseError> {
        let tol = Tolerance::<T>::for_scalar().identity;
        let b = x.tangent_basis();
        let n = x.as_vector();
        let gram = b.transpose() * b - nalgebra::Matrix2::identity();
        prop_assert!(
            gram.amax() <= tol,
            "tangent basis not orthonormal: {gram:?}"
        );
        prop_assert!(
            (b.transpose() * n).amax() <= tol,
            "tangent basis not orthogonal to x"
        );
        let handed: Vector3<T> = b.column(0).cross(&b.column(1)) - n;
        prop_assert!(handed.amax() <= tol, "b1 x b2 != x");
        let y = x.retract(v);
        prop_assert!(
            (y.as_vector().norm() - T::one()).abs() <= tol,
            "retract left the sphere"
        );
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(CASES))]

        #[test]
        fn manifold_f64(x in st::s2::<f64>(), y in st::s2::<f64>(), v in st::s2_tangent::<f64>()) {
            check_manifold(&x, &y, &v, &Tolerance::<f64>::for_scalar())?;
            basis_laws(&x, &v)?;
        }

        #[test]
        fn bad_input_f64(x in st::s2::<f64>(), v in prop_oneof![st::extreme_tangent::<f64, 2>(), st::extreme_raw_tangent::<f64, 2>()]) {
            check_manifold_bad_input(&x, &v)?;
        }

        #[test]
        fn bad_input_f32(x in st::s2::<f32>(), v in prop_oneof![st::extreme_tangent::<f32, 2>(), st::extreme_raw_tangent::<f32, 2>()]) {
            check_manifold_bad_input(&x, &v)?;
        }

        #[test]
        fn manifold_f32(x in st::s2::<f32>(), y in st::s2::<f32>(), v in st::s2_tangent::<f32>()) {
            check_manifold(&x, &y, &v, &Tolerance::<f32>::for_scalar())?;
            basis_laws(&x, &v)?;
        }
    }
}

// World-frame (left) errors: the finite differences go through Left's retract and local, so these
// check the left-convention Jacobians.
group_laws!(
    left_so2_f64,
    f64,
    st::left(st::so2::<f64>()),
    st::so2_tangent::<f64>(),
    st::point2::<f64>()
);
group_laws!(
    left_so2_f32,
    f32,
    st::left(st::so2::<f32>()),
    st::so2_tangent::<f32>(),
    st::point2::<f32>()
);
group_laws!(
    left_so3_f64,
    f64,
    st::left(st::so3::<f64>()),
    st::rotation_vector::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    left_so3_f32,
    f32,
    st::left(st::so3::<f32>()),
    st::rotation_vector::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    left_su2_f64,
    f64,
    st::left(st::su2::<f64>()),
    st::rotation_vector::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    left_su2_f32,
    f32,
    st::left(st::su2::<f32>()),
    st::rotation_vector::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    left_r3_f64,
    f64,
    st::left(st::rn::<f64, 3>()),
    st::rn_tangent::<f64, 3>(),
    st::point3::<f64>()
);
group_laws!(
    left_r3_f32,
    f32,
    st::left(st::rn::<f32, 3>()),
    st::rn_tangent::<f32, 3>(),
    st::point3::<f32>()
);
group_laws!(
    left_se2_f64,
    f64,
    st::left(st::se2::<f64>()),
    st::se2_tangent::<f64>(),
    st::point2::<f64>()
);
group_laws!(
    left_se2_f32,
    f32,
    st::left(st::se2::<f32>()),
    st::se2_tangent::<f32>(),
    st::point2::<f32>()
);
group_laws!(
    left_se3_f64,
    f64,
    st::left(st::se3::<f64>()),
    st::se3_tangent::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    left_se3_f32,
    f32,
    st::left(st::se3::<f32>()),
    st::se3_tangent::<f32>(),
    st::point3::<f32>()
);
group_laws!(
    left_se23_f64,
    f64,
    st::left(st::se23::<f64>()),
    st::se23_tangent::<f64>(),
    st::point3::<f64>()
);
group_laws!(
    left_se23_f32,
    f32,
    st::left(st::se23::<f32>()),
    st::se23_tangent::<f32>(),
    st::point3::<f32>()
);

/// Products: SO(3) × R³, SO(2) × R², Left<SO(3)> × R³ and (SO(3) × R³) × R², in both scalars.
mod products {
    use super::*;
    use liebayes_manifolds::{Left, ProductManifold, Rn, So2, So3};

    type So3R3<T> = ProductManifold<So3<T>, Rn<T, 3>, 3, 3, 6>;

    macro_rules! product_laws {
        ($t:ident) => {
            mod $t {
                use super::*;

                group_laws!(
                    so3_r3,
                    $t,
                    st::product::<_, _, 3, 3, 6>(st::so3::<$t>(), st::rn::<$t, 3>()),
                    st::product_tangent::<So3<$t>, Rn<$t, 3>, 3, 3, 6>(
                        st::rotation_vector(),
                        st::rn_tangent()
                    )
                );
                group_laws!(
                    so2_r2,
                    $t,
                    st::product::<_, _, 1, 2, 3>(st::so2::<$t>(), st::rn::<$t, 2>()),
                    st::product_tangent::<So2<$t>, Rn<$t, 2>, 1, 2, 3>(
                        st::so2_tangent(),
                        st::rn_tangent()
                    )
                );
                group_laws!(
                    left_so3_r3,
                    $t,
                    st::product::<_, _, 3, 3, 6>(st::left(st::so3::<$t>()), st::rn::<$t, 3>()),
                    st::product_tangent::<Left<So3<$t>>, Rn<$t, 3>, 3, 3, 6>(
                        st::rotation_vector(),
                        st::rn_tangent()
                    )
                );
                group_laws!(
                    so3_r3_r2,
                    $t,
                    st::product::<_, _, 6, 2, 8>(
                        st::product::<_, _, 3, 3, 6>(st::so3::<$t>(), st::rn::<$t, 3>()),
                        st::rn::<$t, 2>()
                    ),
                    st::product_tangent::<So3R3<$t>, Rn<$t, 2>, 6, 2, 8>(
                        st::product_tangent::<So3<$t>, Rn<$t, 3>, 3, 3, 6>(
                            st::rotation_vector(),
                            st::rn_tangent()
                        ),
                        st::rn_tangent()
                    )
                );

                proptest! {
                    #![proptest_config(ProptestConfig::with_cases(CASES))]

                    /// S² × R³: a product of a manifold that is not a group.
                    #[test]
                    fn s2_r3_manifold(
                        x in st::product::<_, _, 2, 3, 5>(st::s2::<$t>(), st::rn::<$t, 3>()),
                        y in st::product::<_, _, 2, 3, 5>(st::s2::<$t>(), st::rn::<$t, 3>()),
                        v in st::product_tangent::<liebayes_manifolds::S2<$t>, Rn<$t, 3>, 2, 3, 5>(
                            st::s2_tangent(),
                            st::rn_tangent()
                        ),
                    ) {
                        check_manifold(&x, &y, &v, &Tolerance::<$t>::for_scalar())?;
                    }
                }
            }
        };
    }

    product_laws!(f64);
    product_laws!(f32);
}

/// Named products of four factors (`product_manifold!`): SO(3) × R³ × R³ × R⁶, with body-frame and
/// with world-frame (`Left`) attitude errors, in both scalars.
mod named_products {
    use super::*;
    use liebayes_manifolds::{Left, Rn, So3, product_manifold};

    macro_rules! nav_state_laws {
        ($module:ident, $t:ident, $attitude:ty, $attitude_strategy:expr) => {
            mod $module {
                use super::*;

                product_manifold! {
                    /// Attitude, velocity, position and six biases.
                    struct NavState<$t> {
                        attitude: $attitude,
                        velocity: Rn<$t, 3>,
                        position: Rn<$t, 3>,
                        bias: Rn<$t, 6>,
                    }
                }

                fn states() -> impl Strategy<Value = NavState> {
                    (
                        $attitude_strategy,
                        st::rn::<$t, 3>(),
                        st::rn::<$t, 3>(),
                        st::rn::<$t, 6>(),
                    )
                        .prop_map(NavState::from)
                }

                fn tangents() -> impl Strategy<Value = nalgebra::SVector<$t, 15>> {
                    (
                        st::rotation_vector::<$t>(),
                        st::rn_tangent::<$t, 3>(),
                        st::rn_tangent::<$t, 3>(),
                        st::rn_tangent::<$t, 6>(),
                    )
                        .prop_map(|(a, v, p, b)| NavState::join_tangent(&a, &v, &p, &b))
                }

                group_laws!(laws, $t, states(), tangents());
            }
        };
    }

    nav_state_laws!(so3_f64, f64, So3<f64>, st::so3::<f64>());
    nav_state_laws!(so3_f32, f32, So3<f32>, st::so3::<f32>());
    nav_state_laws!(
        left_so3_f64,
        f64,
        Left<So3<f64>>,
        st::left(st::so3::<f64>())
    );
    nav_state_laws!(
        left_so3_f32,
        f32,
        Left<So3<f32>>,
        st::left(st::so3::<f32>())
    );
}

/// The law functions check their tolerances: a finite-difference step of 0 divided 0 by 0 and an
/// infinite tolerance passed anything; both now fail naming the field.
#[test]
fn law_tolerances_must_be_finite_and_positive() {
    use liebayes_manifolds::{LieGroup, So3};
    let a = So3::exp(&nalgebra::Vector3::new(0.1, 0.2, 0.3));
    let v = nalgebra::Vector3::new(0.3, -0.1, 0.2);
    assert!(check_jacobians(&a, &a, &v, &Tolerance::for_scalar()).is_ok());
    for (bad, field) in [
        (
            Tolerance {
                fd_step: 0.0,
                ..Tolerance::for_scalar()
            },
            "fd_step",
        ),
        (
            Tolerance {
                identity: f64::INFINITY,
                ..Tolerance::for_scalar()
            },
            "identity",
        ),
        (
            Tolerance {
                fd: f64::NAN,
                ..Tolerance::for_scalar()
            },
            "fd",
        ),
    ] {
        let error = check_jacobians(&a, &a, &v, &bad).unwrap_err();
        assert!(error.to_string().contains(field), "{error}");
    }
}
