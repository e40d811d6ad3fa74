//! The chi-square quantile and distribution function against independent values: closed forms
//! (k = 2: `x = −2 ln(1 − p)`; k = 1: `x = z²` of the normal quantile of `(1 + p)/2`), published
//! table values, and the Wilson-Hilferty cube where it is accurate (large k).

use liebayes_densities::special::normal_cdf;
use liebayes_operators::evaluation::{chi_square_cdf, chi_square_quantile};

/// Normal quantiles and their probabilities (`Φ(z)`), from the standard tables.
const Z: [(f64, f64); 4] = [
    (1.959_963_984_540_054, 0.975),
    (-1.959_963_984_540_054, 0.025),
    (3.290_526_731_491_926, 0.9995),
    (-3.290_526_731_491_926, 0.0005),
];

#[test]
fn two_degrees_of_freedom_match_the_closed_form() {
    for (z, p) in Z {
        let exact = -2.0 * (1.0 - p).ln();
        let ours = chi_square_quantile(z, 2.0).unwrap();
        assert!(
            (ours / exact - 1.0).abs() < 1e-9,
            "z {z}: {ours} vs {exact}"
        );
    }
}

#[test]
fn one_degree_of_freedom_matches_the_normal() {
    // P(χ²(1) ≤ x) = 2 Φ(√x) − 1: the quantile at p = 0.95 is 1.959964² = 3.841459.
    let z95 = 1.644_853_626_951_472; // Φ(z95) = 0.95
    let x = chi_square_quantile(z95, 1.0).unwrap();
    assert!(
        (x / 1.959_963_984_540_054f64.powi(2) - 1.0).abs() < 1e-9,
        "{x}"
    );
    for x in [1e-6, 0.01, 0.5, 1.0, 3.0, 10.0, 40.0] {
        let (p, q) = chi_square_cdf(x, 1.0).unwrap();
        let exact = 2.0 * normal_cdf(-x.sqrt());
        assert!((q / exact - 1.0).abs() < 1e-12, "x {x}: {q} vs {exact}");
        assert!((p + q - 1.0).abs() < 1e-15);
    }
}

#[test]
fn table_values() {
    // (k, z, quantile) from published χ² tables, to their 6 significant digits.
    for (k, z, x) in [
        (1.0, 1.959_963_984_540_054, 5.023_89),
        (1.0, -1.959_963_984_540_054, 0.000_982_069),
        (10.0, -1.959_963_984_540_054, 3.246_97),
        (10.0, 1.959_963_984_540_054, 20.483_2),
        (100.0, 1.959_963_984_540_054, 129.561),
    ] {
        let ours = chi_square_quantile(z, k).unwrap();
        assert!((ours / x - 1.0).abs() < 5e-6, "k {k}, z {z}: {ours} vs {x}");
    }
}

#[test]
fn large_dof_agree_with_wilson_hilferty_and_small_do_not() {
    let cube = |z: f64, k: f64| {
        let h = 2.0 / (9.0 * k);
        k * (1.0 - h + z * h.sqrt()).powi(3)
    };
    let z = 1.959_963_984_540_054;
    let k = 2000.0;
    assert!((chi_square_quantile(z, k).unwrap() / cube(z, k) - 1.0).abs() < 1e-4);
    // At k = 1 the cube's lower quantile is off by over 10 %: the exact form is what a band of
    // few runs needs.
    let exact = chi_square_quantile(-z, 1.0).unwrap();
    assert!((cube(-z, 1.0) / exact - 1.0).abs() > 0.1);
}

#[test]
fn quantile_and_distribution_function_are_inverse() {
    for k in [1.0, 2.0, 3.0, 7.0, 24.0, 300.0] {
        for (z, p) in Z {
            let x = chi_square_quantile(z, k).unwrap();
            let (lower, upper) = chi_square_cdf(x, k).unwrap();
            let (got, want) = if p > 0.5 {
                (upper, 1.0 - p)
            } else {
                (lower, p)
            };
            assert!(
                (got / want - 1.0).abs() < 1e-9,
                "k {k}, z {z}: {got} vs {want}"
            );
        }
    }
}

/// The distribution function at the largest accepted k against 50-digit values (mpmath), to 1e-14
/// relative: the prefactor `a ln y − y − ln Γ(a)` cancelled from 4e4 to a few units (5e-12 lost),
/// and the series, which needs about 625 terms there, stopped at 500.
#[test]
fn the_distribution_function_holds_at_the_largest_k() {
    for (x, k, lower) in [
        (9999.0, 1e4, 0.499_059_615_587_306_44),
        (9000.0, 1e4, 1.269_773_170_520_442e-13),
        (4990.0, 5e3, 0.462_793_331_412_898_8),
    ] {
        let (p, _) = chi_square_cdf(x, k).unwrap();
        assert!(
            (p / lower - 1.0).abs() < 5e-14,
            "x {x}, k {k}: {p} vs {lower}"
        );
    }
}

#[test]
fn bad_arguments_are_refused() {
    assert!(chi_square_quantile(f64::NAN, 2.0).is_err());
    assert!(chi_square_quantile(1.0, 0.5).is_err());
    assert!(chi_square_quantile(40.0, 2.0).is_err());
    assert_eq!(chi_square_cdf(-1.0, 3.0), Ok((0.0, 1.0)));
    assert_eq!(chi_square_cdf(f64::INFINITY, 3.0), Ok((1.0, 0.0)));
    assert!(chi_square_cdf(f64::NAN, 3.0).is_err());
    assert!(chi_square_cdf(1.0, 2e4).is_err());
    // Beyond 1e4 degrees of freedom the quantile is the cube, still finite.
    assert!(chi_square_quantile(3.0, 1e300).unwrap().is_finite());
}
