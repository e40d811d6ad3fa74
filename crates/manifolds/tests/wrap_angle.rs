//! `wrap_angle`: into [−π, π), by a whole number of turns, idempotent, and the identity inside.

use liebayes_manifolds::wrap_angle;
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn wraps_by_whole_turns_into_the_half_open_interval(angle in -1e6..1e6_f64) {
        let wrapped = wrap_angle(angle);
        prop_assert!((-PI..PI).contains(&wrapped), "{angle} -> {wrapped}");
        let turns = (angle - wrapped) / TAU;
        // The remainder is exact to the rounding of |angle| (ulp(1e6) is 1.2e-10).
        prop_assert!((turns - turns.round()).abs() <= 1e-15 * (1.0 + angle.abs()), "{turns}");
        prop_assert_eq!(wrap_angle(wrapped), wrapped);
    }

    #[test]
    fn is_the_identity_inside(angle in -PI..PI) {
        prop_assert_eq!(wrap_angle(angle), angle);
    }
}

#[test]
fn ends_and_non_finite_values() {
    assert_eq!(wrap_angle(PI), -PI);
    assert_eq!(wrap_angle(-PI), -PI);
    assert_eq!(wrap_angle(3.0 * PI), -PI);
    assert!(wrap_angle(-1e-300) < 0.0);
    // A tiny negative angle far beyond the fast path still lands inside.
    assert!((-PI..PI).contains(&wrap_angle(-TAU * 1e6 - 1e-12)));
    assert!(wrap_angle(f64::NAN).is_nan());
    assert!(wrap_angle(f64::INFINITY).is_nan());
}
