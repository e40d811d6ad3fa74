//! The weighted mean on manifolds against independent computations: the arithmetic mean on Rⁿ, the
//! circular mean on SO(2) (with the bound on their difference), symmetric configurations whose mean
//! is known, bi-invariance on SO(3), and every error.

use liebayes_manifolds::constants::MEAN_ITERATION_LIMIT;
use liebayes_manifolds::testing::strategies as st;
use liebayes_manifolds::{
    Left, LieGroup, Manifold, ManifoldError, MeanSettings, ProductManifold, Rn, So2, So3,
    weighted_mean,
};
use nalgebra::{Vector1, Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// On Rⁿ the mean is Σ wᵢ xᵢ / Σ wᵢ, also with a negative weight (an unscented centre weight).
    #[test]
    fn arithmetic_mean_on_rn(
        points in proptest::array::uniform6(st::rn::<f64, 3>()),
        weights in proptest::array::uniform6(0.1..10.0_f64),
        centre_weight in -20.0..10.0_f64,
        start in st::rn::<f64, 3>(),
    ) {
        let mut weights = weights;
        weights[0] = centre_weight;
        let sum: f64 = weights.iter().sum();
        prop_assume!(sum.abs() > 0.1);
        let expected = points
            .iter()
            .zip(weights)
            .fold(Vector3::zeros(), |acc, (x, w)| acc + x.coords() * w) / sum;
        // The tolerance a reference computation itself has: eps times the sum of |w x| over |Σw|.
        let size: f64 = points.iter().zip(weights).map(|(x, w)| w.abs() * (1.0 + x.coords().amax())).sum();
        let m = weighted_mean(&start, points.iter().zip(weights), MeanSettings::default()).unwrap();
        prop_assert!((m.coords() - expected).amax() <= 64.0 * f64::EPSILON * size / sum.abs());
    }

    /// On SO(2), angles spread by s < π/2 around a centre anywhere (also across ±π): the mean is
    /// within s³ / (6 cos s) of the circular mean atan2(Σ sin, Σ cos) (with the intrinsic mean's
    /// deviations eᵢ, Σ eᵢ = 0, so |Σ sin eᵢ| = |Σ (sin eᵢ − eᵢ)| ≤ Σ |eᵢ|³ / 6 and
    /// Σ cos eᵢ ≥ n cos s).
    #[test]
    fn circular_mean_on_so2(
        centre in -PI..PI,
        offsets in proptest::array::uniform5(-0.7..0.7_f64),
    ) {
        let xs = offsets.map(|d| So2::from_angle(centre + d).unwrap());
        let m = weighted_mean(&xs[0], xs.iter().map(|x| (x, 1.0)), MeanSettings::default()).unwrap();
        let deviations = xs.map(|x| m.local(&x)[0]);
        let spread = deviations.iter().fold(0.0_f64, |a, e| a.max(e.abs()));
        prop_assert!(deviations.iter().sum::<f64>().abs() < 1e-9);
        let (s, c) = xs.iter().fold((0.0, 0.0), |(s, c), x| (s + x.sin(), c + x.cos()));
        let circular = So2::from_angle(s.atan2(c)).unwrap();
        let bound = spread.powi(3) / (6.0 * spread.cos()) + 1e-12;
        prop_assert!(m.distance(&circular) <= bound, "{} > {bound}", m.distance(&circular));
    }

    /// Pairs c·exp(±εᵢ) have the mean c, on SO(3), on SO(3) with world-frame errors (the same metric,
    /// so the same mean), and on SO(3) × R³.
    #[test]
    fn symmetric_samples_average_to_their_centre(
        c in st::so3::<f64>(),
        e in proptest::array::uniform3(proptest::array::uniform3(-0.4..0.4_f64)),
        w in proptest::array::uniform3(0.5..2.0_f64),
    ) {
        let e = e.map(Vector3::from);
        let xs: Vec<So3<f64>> = e.iter().flat_map(|e| [c.retract(e), c.retract(&-e)]).collect();
        let ws: Vec<f64> = w.iter().flat_map(|w| [*w, *w]).collect();
        let m = weighted_mean(&xs[0], xs.iter().zip(ws.iter().copied()), MeanSettings::default()).unwrap();
        prop_assert!(m.distance(&c) < 1e-10, "{}", m.distance(&c));
        let left: Vec<Left<So3<f64>>> = xs.iter().copied().map(Left::new).collect();
        let ml = weighted_mean(&left[0], left.iter().zip(ws.iter().copied()), MeanSettings::default()).unwrap();
        prop_assert!(ml.inner().distance(&m) < 1e-10);
        let bias = Rn::new(Vector3::new(1.0, 2.0, 3.0)).unwrap();
        let product: Vec<ProductManifold<So3<f64>, Rn<f64, 3>, 3, 3, 6>> = xs
            .iter()
            .zip(&ws)
            .map(|(x, w)| ProductManifold::new(*x, Rn::new(bias.coords() * *w).unwrap()))
            .collect();
        let mp = weighted_mean(&product[0], product.iter().zip(ws.iter().copied()), MeanSettings::default()).unwrap();
        prop_assert!(mp.first().distance(&c) < 1e-10);
        let expected_bias = bias.coords() * (ws.iter().map(|w| w * w).sum::<f64>() / ws.iter().sum::<f64>());
        prop_assert!((mp.second().coords() - expected_bias).amax() < 1e-12);
    }

    /// The mean on SO(3) is bi-invariant: mean(g xᵢ) = g mean(xᵢ) and mean(xᵢ g) = mean(xᵢ) g.
    #[test]
    fn so3_mean_is_bi_invariant(
        c in st::so3::<f64>(),
        g in st::so3::<f64>(),
        e in proptest::array::uniform4(proptest::array::uniform3(-0.6..0.6_f64)),
        w in proptest::array::uniform4(0.1..3.0_f64),
    ) {
        let xs = e.map(|e| c.retract(&Vector3::from(e)));
        let m = weighted_mean(&xs[0], xs.iter().zip(w), MeanSettings::default()).unwrap();
        let gx = xs.map(|x| g.compose(&x));
        let xg = xs.map(|x| x.compose(&g));
        let ml = weighted_mean(&gx[0], gx.iter().zip(w), MeanSettings::default()).unwrap();
        let mr = weighted_mean(&xg[0], xg.iter().zip(w), MeanSettings::default()).unwrap();
        prop_assert!(ml.distance(&g.compose(&m)) < 1e-9, "{}", ml.distance(&g.compose(&m)));
        prop_assert!(mr.distance(&m.compose(&g)) < 1e-9, "{}", mr.distance(&m.compose(&g)));
        // The mean does not depend on the start inside the ball.
        let from_centre = weighted_mean(&c, xs.iter().zip(w), MeanSettings::default()).unwrap();
        prop_assert!(from_centre.distance(&m) < 1e-9);
    }
}

#[test]
fn angles_across_pi_average_to_pi() {
    let xs = [3.0, -3.0, 3.1, -3.1].map(|a| So2::from_angle(a).unwrap());
    let m = weighted_mean(&xs[0], xs.iter().map(|x| (x, 1.0)), MeanSettings::default()).unwrap();
    assert!(m.distance(&So2::from_angle(PI).unwrap()) < 1e-15);
}

#[test]
fn invalid_weights_are_errors() {
    let xs = [
        So3::<f64>::identity(),
        So3::exp(&Vector3::new(0.1, 0.0, 0.0)),
    ];
    let mean = |w: [f64; 2]| weighted_mean(&xs[0], xs.iter().zip(w), MeanSettings::default());
    assert!(matches!(
        mean([1.0, -1.0]),
        Err(ManifoldError::DegenerateWeights { sum, .. }) if sum == 0.0
    ));
    assert!(matches!(
        mean([1.0, -1.0 + 1e-17]),
        Err(ManifoldError::DegenerateWeights { .. })
    ));
    assert!(matches!(
        mean([f64::MAX, f64::MAX]),
        Err(ManifoldError::DegenerateWeights { .. })
    ));
    assert!(matches!(
        mean([1.0, f64::NAN]),
        Err(ManifoldError::NonFiniteWeight { index: 1, .. })
    ));
    assert!(matches!(
        mean([f64::NEG_INFINITY, 1.0]),
        Err(ManifoldError::NonFiniteWeight { index: 0, .. })
    ));
    let empty: [(&So3<f64>, f64); 0] = [];
    assert!(matches!(
        weighted_mean(&xs[0], empty, MeanSettings::default()),
        Err(ManifoldError::EmptyInput { .. })
    ));
    // Messages say what to fix.
    let message = mean([1.0, -1.0]).unwrap_err().to_string();
    assert!(
        message.contains("sum") && message.contains("normalised"),
        "{message}"
    );
}

#[test]
fn non_convergence_is_an_error_with_the_last_step() {
    // Weights 2 and −1 at the angles 0 and 3 extrapolate to −3; from there the wrapped residuals sum
    // to a full turn, 2π, at every step: the iteration never settles.
    let xs = [0.0, 3.0].map(|a| So2::from_angle(a).unwrap());
    match weighted_mean(&xs[0], xs.iter().zip([2.0, -1.0]), MeanSettings::default()) {
        Err(ManifoldError::MeanNotConverged {
            iterations,
            last_step,
            tolerance,
        }) => {
            assert_eq!(iterations, 50);
            assert!((last_step - 2.0 * PI).abs() < 1e-9, "{last_step}");
            assert!(tolerance == 1e-10);
        }
        other => panic!("expected non-convergence, got {other:?}"),
    }
    // Too few iterations for samples spread over a radian.
    let ys = [
        So3::exp(&Vector3::new(1.0, 0.0, 0.0)),
        So3::exp(&Vector3::new(0.0, 1.0, 0.0)),
        So3::exp(&Vector3::new(0.0, 0.0, 1.0)),
    ];
    let one_step = MeanSettings::new(1, 1e-12).unwrap();
    let error = weighted_mean(&ys[0], ys.iter().map(|y| (y, 1.0)), one_step).unwrap_err();
    assert!(
        matches!(error, ManifoldError::MeanNotConverged { iterations: 1, last_step, .. } if last_step > 0.5)
    );
    assert!(error.to_string().contains("did not converge"));
}

#[test]
fn settings_are_checked() {
    for bound in [0, MEAN_ITERATION_LIMIT + 1, usize::MAX] {
        assert!(matches!(
            MeanSettings::new(bound, 1e-10_f64),
            Err(ManifoldError::OutOfRange { .. })
        ));
    }
    assert!(MeanSettings::new(MEAN_ITERATION_LIMIT, 1e-10_f64).is_ok());
    for bad in [0.0, -1e-10, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            MeanSettings::new(10, bad),
            Err(ManifoldError::OutOfRange { .. })
        ));
    }
    let s = MeanSettings::new(7, 1e-6_f32).unwrap();
    assert_eq!((s.max_iterations(), s.tolerance()), (7, 1e-6));
    let d = MeanSettings::<f32>::default();
    assert_eq!((d.max_iterations(), d.tolerance()), (50, 1e-5));
}

/// f32 works with its own default tolerance.
#[test]
fn f32_mean() {
    let xs = [0.3_f32, 0.5, 0.4].map(|a| So2::exp(&Vector1::new(a)));
    let m = weighted_mean(&xs[0], xs.iter().map(|x| (x, 1.0)), MeanSettings::default()).unwrap();
    assert!((m.angle() - 0.4).abs() < 1e-6);
}

/// Points far from the origin of Rⁿ (eps |x| above the tolerance): the step stalls at the rounding
/// of the coordinates, which ends the iteration with the mean as accurate as they allow.
#[test]
fn far_from_the_origin_the_mean_is_as_accurate_as_the_coordinates() {
    let base = Vector3::new(4.2e6, -3.1e6, 1.0e7);
    let xs = [
        Vector3::new(0.5, -0.25, 1.0),
        Vector3::new(-1.0, 0.75, 0.5),
        Vector3::new(0.25, 0.5, -2.0),
    ]
    .map(|d| Rn::new(base + d).unwrap());
    let m = weighted_mean(&xs[0], xs.iter().map(|x| (x, 1.0)), MeanSettings::default()).unwrap();
    let expected = base + Vector3::new(-0.25, 1.0, -0.5) / 3.0;
    assert!((m.coords() - expected).amax() <= 4.0 * f64::EPSILON * 1e7);
    let ys = [10.5_f32, 11.0, 12.5].map(|v| Rn::new(Vector1::new(v * 100.0)).unwrap());
    let m = weighted_mean(&ys[0], ys.iter().map(|y| (y, 1.0)), MeanSettings::default()).unwrap();
    assert!((m.coords()[0] - 1_133.333_3).abs() <= 1e-3);
}

/// Points 1e9 from the origin of Rⁿ spread by 1e-3 (a UKF's sigma points of a position far from
/// its origin): the rounding of the coordinates, 1.2e-7, is above √eps times the residuals, so the
/// step never passes the stall test; it is below what the coordinates resolve, which ends the
/// iteration (it used to fail with `MeanNotConverged`).
#[test]
fn a_step_the_coordinates_cannot_resolve_ends_the_mean() {
    let base = Vector3::new(1.1e9, -0.7e9, 0.3e9);
    let offsets = [
        Vector3::new(1e-3, 0.0, -2e-3),
        Vector3::new(-1e-3, 3e-3, 0.0),
        Vector3::new(0.0, -1e-3, 1e-3),
    ];
    let xs = offsets.map(|d| Rn::new(base + d).unwrap());
    let weights = [0.5, 0.3, 0.2];
    let m = weighted_mean(&xs[0], xs.iter().zip(weights), MeanSettings::default()).unwrap();
    let expected = base + offsets[0] * 0.5 + offsets[1] * 0.3 + offsets[2] * 0.2;
    assert!((m.coords() - expected).amax() <= 4.0 * f64::EPSILON * 1.1e9);
}

/// Sigma points of a diffuse prior on R²: two 1e16 from the origin along x (weights 0.45), two
/// near it (weights 0.05). The far points' residuals round the mean's x away (their ulp is 2),
/// so each Gauss-Newton step moves x by a tenth of its distance to the fixed point: a contraction
/// of 0.9 a step, from a start 0.3 off, still 1.5e-3 off after 50 steps, and the mean failed with
/// `MeanNotConverged`. Such a step is far below the rounding of the sum that computes it
/// (`n ε Σ |w̃ᵢ| |rᵢ|`, here 8), and it now ends the iteration: the mean is as accurate as that
/// rounding.
#[test]
fn a_step_below_the_rounding_of_its_sum_ends_the_mean() {
    let points = [
        Vector2::new(1e16, 0.0),
        Vector2::new(-1e16, 0.0),
        Vector2::new(0.0, 1.0),
        Vector2::new(0.0, -1.0),
    ]
    .map(|x| Rn::new(x).unwrap());
    let weights = [0.45, 0.45, 0.05, 0.05];
    let start = Rn::new(Vector2::new(0.3, 0.3)).unwrap();
    let m = weighted_mean(&start, points.iter().zip(weights), MeanSettings::default()).unwrap();
    // The exact mean is the origin; the sum's rounding is 4 ε · 0.9e16 = 8.
    assert!(m.coords().amax() <= 8.0, "{}", m.coords());
}

/// Points 1e200 apart on Rⁿ: the step's length is taken without squaring its entries (squares of
/// 1e200 overflow), so the iteration converges instead of stopping with `MeanNotConverged`.
#[test]
fn points_far_apart_have_a_mean() {
    let (origin, far) = (
        Rn::new(Vector1::new(0.0)).unwrap(),
        Rn::new(Vector1::new(1e200)).unwrap(),
    );
    let m = weighted_mean(&origin, [(&far, 1.0)], MeanSettings::default()).unwrap();
    assert_eq!(m.coords()[0], 1e200);
    let m = weighted_mean(
        &origin,
        [(&origin, 1.0), (&far, 1.0)],
        MeanSettings::default(),
    )
    .unwrap();
    assert_eq!(m.coords()[0], 5e199);
}

/// The unscented transform's weights with α = 1e-3 (centre weight about −1e6, the others about
/// 1.7e5): the sigma points of a symmetric spread average back to their centre, to the rounding of
/// the points amplified by the normalised weights, eps Σ |wᵢ| (about 4e-10 here).
#[test]
fn unscented_weights_with_a_large_negative_centre_weight() {
    let (d, alpha) = (3.0_f64, 1e-3_f64);
    let lambda = alpha * alpha * d - d;
    let (w0, wi) = (lambda / (d + lambda), 0.5 / (d + lambda));
    let gamma = (d + lambda).sqrt();
    let c = So3::exp(&Vector3::new(2.0, -1.0, 0.5));
    let columns = [
        Vector3::new(0.3, 0.0, 0.0),
        Vector3::new(0.1, 0.2, 0.0),
        Vector3::new(-0.05, 0.1, 0.4),
    ];
    let plus = columns.map(|l| c.retract(&(l * gamma)));
    let minus = columns.map(|l| c.retract(&(l * -gamma)));
    let samples = std::iter::once((&c, w0))
        .chain(plus.iter().map(|x| (x, wi)))
        .chain(minus.iter().map(|x| (x, wi)));
    let m = weighted_mean(&c, samples, MeanSettings::default()).unwrap();
    let amplified = f64::EPSILON * (w0.abs() + 6.0 * wi);
    assert!(
        m.distance(&c) < 4.0 * amplified,
        "{} vs {amplified:e}",
        m.distance(&c)
    );
}
