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

/// The two adjacent doubles r whose `d = 1 − r` straddles 1e-9, where `a1_inverse` switches from
/// Newton's method (d ≥ 1e-9) to the asymptotic inverse `1/(2d) + ¼`, with κ solving
/// `1 − I₁(κ)/I₀(κ) = d` for the exact d: mpmath at `mp.dps = 60` (`besseli`), by
/// `k ← k − (1/D(k) − 1/d)/2` from `1/(2d) + ¼` (1/D has slope 2 + O(1/κ²)), to 45 digits.
#[allow(clippy::unreadable_literal, clippy::excessive_precision)]
const AT_THE_SWITCH: [(f64, f64); 2] = [
    (0.999_999_998_999_999_9, 499999958.87981792381),
    (0.999_999_999, 500000014.39096613202),
];

/// Both sides of the switch to the asymptotic inverse agree with the reference to 4 ulp (d = 1 − r is
/// exact, and κ's condition number with respect to d is 1, so the only errors are the method's and
/// the rounding of 1 − A): the switch leaves no step beyond rounding (measured: 5e-17 and 6e-17).
#[test]
fn inverse_of_a1_is_continuous_at_the_asymptotic_switch() {
    let (below, above) = (AT_THE_SWITCH[0].0, AT_THE_SWITCH[1].0);
    assert_eq!(above.to_bits(), below.to_bits() + 1);
    assert!(1.0 - below >= 1e-9 && 1.0 - above < 1e-9);
    for (r, expected) in AT_THE_SWITCH {
        let got = special::a1_inverse(r).expect("r in [0, 1)");
        let error = common::relative_error(got, expected);
        assert!(
            error <= 4.0 * f64::EPSILON,
            "A^-1({r}) = {got}, mpmath {expected}, error {error:e}"
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

/// κ with `coth κ − 1/κ = r` for the f64 value of r, solved with mpmath at 50 digits (findroot on the
/// closed form; below r = 1e-10 on its series `κ/3 − κ³/45 + 2κ⁵/945`), the digits as mpmath printed
/// them.
#[allow(clippy::unreadable_literal, clippy::excessive_precision)]
const INVERSE_A3: [(f64, f64); 14] = [
    (1e-300, 3.0000000000000000752e-300),
    (1e-12, 2.9999999999999999397e-12),
    (1e-06, 3.0000000000017998642e-6),
    (0.001, 0.0030000018000016972071),
    (0.1, 0.30181714920633811476),
    (0.3, 0.95314947285740590895),
    (0.4999, 1.7962391006706549795),
    (0.5, 1.7967559847237130411),
    (0.7, 3.3035444901007656993),
    (0.9, 9.9999995877689540078),
    (0.99, 99.999999999999911182),
    (0.999999, 999999.99997124433548),
    (0.9999999999, 9999999172.5963584688),
    (0.99999999999999, 100079991719344.35556),
];

#[test]
fn inverse_of_the_vmf_mean_resultant_matches_mpmath() {
    for (r, expected) in INVERSE_A3 {
        let got = special::vmf_mean_resultant_inverse(r).expect("r in [0, 1)");
        let error = common::relative_error(got, expected);
        assert!(
            error <= 1e-13,
            "A3^-1({r}) = {got}, mpmath {expected}, error {error:e}"
        );
        // A wrong inverse (the 2-D one) is far off: the check can fail.
        if r > 0.01 {
            let other = special::a1_inverse(r).expect("r in [0, 1)");
            assert!(common::relative_error(other, expected) > 1e-3, "{r}");
        }
    }
    for r in [-0.1, 1.0, 1.5, f64::NAN, f64::INFINITY] {
        let error = special::vmf_mean_resultant_inverse(r).expect_err("outside [0, 1)");
        assert!(error.to_string().contains("[0, 1)"), "{error}");
    }
}

#[test]
fn inverse_of_the_vmf_mean_resultant_round_trips() {
    let mut kappa = 1e-300_f64;
    while kappa < 1e15 {
        let r = special::vmf_mean_resultant(kappa).unwrap();
        if r < 1.0 {
            let back = special::vmf_mean_resultant_inverse(r).unwrap();
            // r's rounding (half an ulp) is amplified by the condition number r / (κ A₃'(κ)), about
            // κ as r → 1.
            let tolerance = 1e-13 + 2.0 * kappa.max(1.0) * f64::EPSILON;
            let error = common::relative_error(back, kappa);
            assert!(
                error <= tolerance,
                "kappa {kappa}: back {back}, error {error:e}"
            );
        }
        kappa *= 3.7;
    }
}
