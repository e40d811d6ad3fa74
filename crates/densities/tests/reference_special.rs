//! The special functions against the reference vectors `specfun_vectors.json` (mpmath, 50 digits):
//! relative error ≤ 1e-13 for every value, κ from 0 to 1e6.

mod common;

use liebayes_densities::special;

const TOLERANCE: f64 = 1e-13;

/// A special function of κ, as the table of columns holds them.
type SpecialFunction = fn(f64) -> Result<f64, liebayes_densities::DensityError>;

#[test]
fn bessel_and_von_mises_fisher_functions_match_the_reference() {
    let reference = common::reference("specfun_vectors.json");
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for row in reference["values"].as_array().expect("values") {
        let kappa = row["kappa"].as_f64().expect("kappa");
        let columns: [(&str, SpecialFunction); 7] = [
            ("log_i0", special::log_i0),
            ("log_i1", special::log_i1),
            ("a1", special::a1),
            ("a2", special::a2),
            ("a3", |k| special::bessel_ratio(3, k)),
            ("vmf_mean_resultant", special::vmf_mean_resultant),
            ("vmf_log_normalizer", special::vmf_log_normalizer),
        ];
        for (name, f) in columns {
            let got = f(kappa).expect("kappa in [0, f64::MAX]");
            match row[name].as_f64() {
                Some(expected) => {
                    let error = common::relative_error(got, expected);
                    assert!(
                        error <= TOLERANCE,
                        "{name}({kappa:e}) = {got:e}, reference {expected:e}, relative error {error:e}"
                    );
                    worst = worst.max(error);
                    checked += 1;
                }
                // The reference has no value where the function is −∞ (log I1(0)).
                None => assert_eq!(got, f64::NEG_INFINITY, "{name}({kappa})"),
            }
        }
    }
    assert!(checked > 150);
    eprintln!("{checked} special-function values, worst relative error {worst:.1e}");
}

#[test]
fn inverse_of_a1_matches_the_reference() {
    let reference = common::reference("specfun_vectors.json");
    for row in reference["inverse_a1"].as_array().expect("inverse_a1") {
        let r = row["r"].as_f64().expect("r");
        let expected = row["kappa"].as_f64().expect("kappa");
        let got = special::a1_inverse(r).expect("r in [0, 1)");
        // The reference solves A(κ) = r for the decimal r; the f64 r differs from it by up to half an
        // ulp, which κ amplifies by its condition number r / (κ A'(κ)) (about 2κ as r → 1).
        let condition = r / (expected * special::a1_derivative(expected).unwrap());
        let tolerance = TOLERANCE + condition * f64::EPSILON;
        let error = common::relative_error(got, expected);
        assert!(
            error <= tolerance,
            "A^-1({r}) = {got}, reference {expected}, error {error:e} > {tolerance:e}"
        );
    }
}

#[test]
fn inverse_of_a1_rejects_values_outside_its_range() {
    for r in [-0.1, 1.0, 1.5, f64::NAN, f64::INFINITY] {
        let error = special::a1_inverse(r).expect_err("outside [0, 1)");
        assert!(error.to_string().contains("[0, 1)"), "{error}");
    }
}
