//! `ExactSum` against an independent exact sum (fixed point in i128 for values of bounded exponent),
//! and its merge law: any split into shards, merged in any order, gives the same bits as one sum.

use liebayes_experiments::ExactSum;
use proptest::prelude::*;

/// Fixed-point scale of the oracle: every value below is a multiple of 2⁻⁸².
const SCALE: i32 = 82;

/// The exact sum of values with |x| < 2³¹ and exponents of their lowest bit at least −82, in i128
/// (at most 2¹¹³ per value, so 2¹³ values fit), rounded once by the integer-to-float conversion.
fn oracle(values: &[f64]) -> f64 {
    let total: i128 = values
        .iter()
        .map(|&x| {
            let scaled = x * 2f64.powi(SCALE);
            assert!(
                scaled.fract() == 0.0 && scaled.abs() < 2f64.powi(120),
                "{x} out of range"
            );
            #[allow(clippy::cast_possible_truncation)] // an integer below 2^120, checked above
            let integer = scaled as i128;
            integer
        })
        .sum();
    total as f64 * 2f64.powi(-SCALE)
}

/// Values of 53 significant bits with exponents in [−30, 30], either sign: sums of them cancel and
/// round in every way.
fn bounded() -> impl Strategy<Value = f64> {
    (any::<u64>(), -30..30_i32, any::<bool>()).prop_map(|(bits, exponent, negative)| {
        let mantissa = (bits >> 11) | (1 << 52);
        let x = mantissa as f64 * 2f64.powi(exponent - 52);
        if negative { -x } else { x }
    })
}

/// Any finite f64, from subnormals to MAX.
fn finite() -> impl Strategy<Value = f64> {
    any::<f64>().prop_filter("finite", |x| x.is_finite())
}

fn sum(values: &[f64]) -> ExactSum {
    values.iter().copied().collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn equals_the_exact_sum_rounded_once(values in prop::collection::vec(bounded(), 0..200)) {
        prop_assert_eq!(sum(&values).value().to_bits(), oracle(&values).to_bits());
    }

    /// IEEE addition of two values is their exact sum rounded once: an oracle over the whole range,
    /// subnormals and overflow included.
    #[test]
    fn two_values_sum_as_ieee_addition(a in finite(), b in finite(), scale in -1100..1000_i32) {
        let b_scaled = b * 2f64.powi(scale.clamp(-1022, 1023));
        for (x, y) in [(a, b), (a, b_scaled), (a, -a * 0.75)] {
            if y.is_finite() {
                // An exact zero is +0 (IEEE gives −0 for −0 + −0).
                prop_assert_eq!(sum(&[x, y]).value().to_bits(), (x + y + 0.0).to_bits(), "{} + {}", x, y);
            }
        }
    }

    #[test]
    fn shards_merge_to_the_same_bits_in_any_order(
        values in prop::collection::vec(finite(), 0..120),
        cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..6),
        permutation_seed in any::<u64>(),
    ) {
        let whole = sum(&values).value();
        let mut bounds: Vec<usize> = cuts.iter().map(|i| i.index(values.len() + 1)).collect();
        bounds.extend([0, values.len()]);
        bounds.sort_unstable();
        let mut shards: Vec<ExactSum> = bounds.windows(2).map(|w| sum(&values[w[0]..w[1]])).collect();
        // Merge the shards in a shuffled order.
        let mut state = permutation_seed | 1;
        for i in (1..shards.len()).rev() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            shards.swap(i, usize::try_from(state % (i as u64 + 1)).unwrap());
        }
        let mut merged = ExactSum::new();
        for shard in &shards {
            merged.merge(shard).unwrap();
        }
        prop_assert_eq!(merged.value().to_bits(), whole.to_bits());
        let mut reversed: Vec<f64> = values.clone();
        reversed.reverse();
        prop_assert_eq!(sum(&reversed).value().to_bits(), whole.to_bits());
    }
}

#[test]
fn cancellation_that_defeats_a_float_sum_is_exact() {
    assert_eq!(sum(&[1e308, 1e308, -1e308, -1e308, 1.0]).value(), 1.0);
    assert_eq!(sum(&[1e300, 1.0, -1e300]).value(), 1.0);
    assert_eq!(sum(&[1.0, 1e-300, -1.0]).value(), 1e-300);
    assert_eq!(sum(&[0.1; 10]).value(), oracle(&[0.1; 10]));
    assert_eq!(sum(&[-1.0, 0.5]).value(), -0.5);
    assert_eq!(sum(&[2.5, -2.5]).value().to_bits(), 0.0_f64.to_bits());
}

#[test]
fn the_ends_of_the_range() {
    assert_eq!(ExactSum::new().value(), 0.0);
    assert_eq!(sum(&[5e-324]).value(), 5e-324);
    assert_eq!(sum(&[-5e-324, -5e-324]).value(), -1e-323);
    assert_eq!(
        sum(&[f64::MIN_POSITIVE, -5e-324]).value(),
        f64::MIN_POSITIVE - 5e-324
    );
    assert_eq!(sum(&[f64::MAX, -f64::MAX, f64::MAX]).value(), f64::MAX);
    assert_eq!(sum(&[f64::MAX, f64::MAX]).value(), f64::INFINITY);
    assert_eq!(sum(&[-f64::MAX, -f64::MAX]).value(), f64::NEG_INFINITY);
    // Ties round to even: 1 + 2^-53 is halfway between 1 and the next f64.
    assert_eq!(sum(&[1.0, 2f64.powi(-53)]).value(), 1.0);
    assert_eq!(
        sum(&[1.0, 2f64.powi(-53), 1e-300]).value(),
        1.0 + f64::EPSILON
    );
    assert_eq!(
        sum(&[1.0 + f64::EPSILON, 2f64.powi(-53)]).value(),
        1.0 + 2.0 * f64::EPSILON
    );
}

#[test]
fn non_finite_values_follow_ieee() {
    assert!(sum(&[1.0, f64::NAN]).value().is_nan());
    assert!(sum(&[f64::INFINITY, f64::NEG_INFINITY]).value().is_nan());
    assert_eq!(sum(&[f64::INFINITY, -1e308, -1e308]).value(), f64::INFINITY);
    assert_eq!(sum(&[f64::NEG_INFINITY, 1.0]).value(), f64::NEG_INFINITY);
    let mut a = sum(&[f64::INFINITY]);
    a.merge(&sum(&[f64::NEG_INFINITY])).unwrap();
    assert!(a.value().is_nan());
}

/// Merging a sum with itself added its top limbs without a bound, so about 110 self-merges of a
/// sum holding `f64::MAX` overflowed an i64 (a panic with overflow checks, a wrong sign without
/// them). `merge` refuses a total of 2¹¹⁰² or more in magnitude with a typed error and leaves the
/// sum unchanged; every total below reads back from its file.
#[test]
fn a_merge_beyond_the_bound_is_refused() {
    let mut sum: ExactSum = [f64::MAX].into_iter().collect();
    let mut doublings = 0;
    let error = loop {
        let copy = sum.clone();
        let before = sum.clone();
        match sum.merge(&copy) {
            Ok(()) => doublings += 1,
            Err(error) => {
                assert_eq!(sum, before);
                break error;
            }
        }
        let back: ExactSum = serde_json::from_str(&serde_json::to_string(&sum).unwrap()).unwrap();
        assert_eq!(back, sum);
    };
    // f64::MAX < 2^1024: 2^78 of it stay below 2^1102, 2^79 do not.
    assert_eq!(doublings, 78);
    assert!(
        matches!(
            error,
            liebayes_experiments::ExperimentError::OutOfRange { .. }
        ),
        "{error}"
    );
    assert!(error.to_string().contains("2^1102"), "{error}");
    // A sum of the opposite sign still merges exactly.
    let mut negative: ExactSum = [-f64::MAX].into_iter().collect();
    negative.add(1.0);
    sum.merge(&negative).unwrap();
}

/// An exact sum's limbs are read into their 68 places and refused at the 69th
/// (before, the whole array was built, whatever its length, then refused).
#[test]
fn more_than_68_limbs_are_refused_at_the_69th() {
    let file = |limbs: usize| {
        format!(
            r#"{{"limbs": [{}], "nan": false, "positive_infinity": false, "negative_infinity": false}}"#,
            vec!["0"; limbs].join(",")
        )
    };
    assert_eq!(
        serde_json::from_str::<ExactSum>(&file(68)).unwrap(),
        ExactSum::new()
    );
    let errors = [69, 1_000_000].map(|n| {
        serde_json::from_str::<ExactSum>(&file(n))
            .unwrap_err()
            .to_string()
    });
    assert!(
        errors[0].contains("more than the limit of 68"),
        "{}",
        errors[0]
    );
    // Refused where the 69th limb is (the same place), not at the end of the array.
    assert_eq!(errors[0], errors[1]);
    let error = serde_json::from_str::<ExactSum>(&file(67)).unwrap_err();
    assert!(error.to_string().contains("68 limbs, not 67"), "{error}");
}
