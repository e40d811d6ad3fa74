//! Property-testing your own code with liebayes' strategies.
//!
//! Suppose you wrote `midpoint`, the rotation halfway along the geodesic between two attitudes. The
//! strategies of `liebayes::manifolds::testing` draw rotations uniformly and at the places where such
//! code breaks (the identity, angles within 1e-12 of π and exactly π, huge tangents), so one property
//! run checks what a handful of hand-picked unit tests would miss.
//!
//! Run: `cargo run --example property_test_your_code` (needs the `proptest` feature of
//! liebayes-manifolds, which the root package's dev-dependencies enable).

use liebayes::manifolds::testing::strategies;
use liebayes::manifolds::{LieGroup, Manifold, So3};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// Your code: the geodesic midpoint `a · exp(log(a⁻¹ b) / 2)`.
fn midpoint(a: &So3<f64>, b: &So3<f64>) -> So3<f64> {
    a.retract(&(a.local(b) * 0.5))
}

fn main() {
    let config = Config {
        cases: 2000,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner = TestRunner::new(config);
    let result = runner.run(
        &(strategies::so3::<f64>(), strategies::so3::<f64>()),
        |(a, b)| {
            let m = midpoint(&a, &b);
            // Halfway: equal distances to both ends, summing to the whole.
            let (da, db) = (a.distance(&m), m.distance(&b));
            prop_assert!((da - db).abs() < 1e-12, "unequal halves {da} and {db}");
            prop_assert!((da + db - a.distance(&b)).abs() < 1e-12);
            // Left-equivariant: moving both ends moves the midpoint. Only where the midpoint is unique:
            // when b is a half turn from a, two geodesics join them and a rotated pair may pick the
            // other one. (Without this assumption the run fails within a few cases; the strategies draw
            // half turns on purpose.)
            prop_assume!(a.distance(&b) < std::f64::consts::PI - 1e-6);
            let g = So3::exp(&nalgebra::Vector3::new(0.1, 0.2, 0.3));
            prop_assert!(midpoint(&g.compose(&a), &g.compose(&b)).distance(&g.compose(&m)) < 1e-12);
            Ok(())
        },
    );
    match result {
        Ok(()) => println!("midpoint: 2000 cases passed, including rotations at and near pi"),
        Err(e) => {
            eprintln!("midpoint is wrong: {e}");
            std::process::exit(1);
        }
    }
}
