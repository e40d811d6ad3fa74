//! Property-testing support, behind the `proptest` feature: strategies for every family, quadrature
//! on every space, and the density law suite the crate tests itself with.
//!
//! A user checking their own code draws densities from [`strategies`]; a user writing their own
//! family implements [`DensitySubject`] for it (usually in a few lines, from the rules of
//! [`quadrature`]) and runs the laws on it in one line:
//!
//! ```ignore
//! use liebayes_densities::density_laws;
//! use liebayes_densities::testing::strategies as st;
//!
//! // normalisation, mode, moments and sampler, plus the laws of the traits the family implements:
//! density_laws!(von_mises, st::von_mises(st::concentration()), product, kl, entropy,
//!     rotated(liebayes_manifolds::testing::strategies::so2::<f64>()));
//! ```
//!
//! Each law is also a function of [`laws`], to call inside a `proptest!` block of your own with your
//! own case count (`crates/densities/tests/laws.rs` runs every family of the crate this way; the
//! example `property_test_a_density` runs a wrapped Cauchy distribution written from scratch).

pub mod laws;
pub mod quadrature;
pub mod strategies;
mod subjects;

pub use laws::DensitySubject;
pub use subjects::manifold_neighbours;

#[doc(hidden)]
pub use proptest as __proptest;

/// The density law suite for one family, as a module of proptest tests named `$name`:
///
/// ```text
/// density_laws!(name, strategy [, law]*);
/// ```
///
/// with `strategy` a proptest strategy of densities implementing
/// [`DensitySubject`](crate::testing::DensitySubject). Always run (with
/// [`CASES`](crate::testing::laws::CASES) cases): `normalisation`, `mode`, `moments`; and `sampler`
/// ([`SAMPLER_CASES`](crate::testing::laws::SAMPLER_CASES) cases of
/// [`SAMPLES`](crate::testing::laws::SAMPLES) draws from a generator seeded with
/// [`SEED`](crate::testing::laws::SEED)). Optional laws, for the traits the family implements:
///
/// * `product`: [`check_product`](crate::testing::laws::check_product) on pairs of draws;
/// * `kl`: [`check_kl`](crate::testing::laws::check_kl) on pairs;
/// * `entropy`: [`check_entropy`](crate::testing::laws::check_entropy);
/// * `rotated(group_strategy)`: [`check_rotated`](crate::testing::laws::check_rotated) for group
///   elements from `group_strategy`;
/// * `finite(extreme_strategy)`: [`check_finite`](crate::testing::laws::check_finite) on densities
///   from a second strategy, for the ends of the accepted range that quadrature cannot resolve;
/// * `bad_input(raw_strategy)`: [`check_bad_input`](crate::testing::laws::check_bad_input) on what
///   a constructor makes of raw numbers of every magnitude, NaN and ±∞ among them (the `_raw`
///   strategies of [`strategies`](crate::testing::strategies)), with
///   [`BAD_INPUT_CASES`](crate::testing::laws::BAD_INPUT_CASES) cases.
///
/// The expansion refers to the caller's names through `use super::*`, so a strategy written with
/// the caller's imports works as it is.
#[macro_export]
#[cfg_attr(docsrs, doc(cfg(feature = "proptest")))]
macro_rules! density_laws {
    ($name:ident, $strategy:expr $(, $law:ident $(($($arg:expr),*))?)* $(,)?) => {
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            use $crate::testing::__proptest::prelude::*;

            $crate::testing::__proptest::proptest! {
                #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::CASES))]

                #[test]
                fn normalisation(p in $strategy) {
                    $crate::testing::laws::check_normalisation(&p)?;
                }

                #[test]
                fn mode(p in $strategy) {
                    $crate::testing::laws::check_mode(&p)?;
                }

                #[test]
                fn moments(p in $strategy) {
                    $crate::testing::laws::check_moments(&p)?;
                }
            }

            $crate::testing::__proptest::proptest! {
                #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::SAMPLER_CASES))]

                #[test]
                fn sampler(p in $strategy) {
                    $crate::testing::laws::check_sampler(
                        &p,
                        &mut $crate::testing::laws::rng(),
                        $crate::testing::laws::SAMPLES,
                    )?;
                }
            }

            $($crate::density_laws!(@law $law, ($strategy) $(, $($arg),*)?);)*
        }
    };
    (@law product, ($strategy:expr)) => {
        $crate::testing::__proptest::proptest! {
            #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::CASES))]

            #[test]
            fn product(p in $strategy, q in $strategy) {
                $crate::testing::laws::check_product(&p, &q)?;
            }
        }
    };
    (@law kl, ($strategy:expr)) => {
        $crate::testing::__proptest::proptest! {
            #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::CASES))]

            #[test]
            fn kl(p in $strategy, q in $strategy) {
                $crate::testing::laws::check_kl(&p, &q)?;
            }
        }
    };
    (@law entropy, ($strategy:expr)) => {
        $crate::testing::__proptest::proptest! {
            #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::CASES))]

            #[test]
            fn entropy(p in $strategy) {
                $crate::testing::laws::check_entropy(&p)?;
            }
        }
    };
    (@law rotated, ($strategy:expr), $group:expr) => {
        $crate::testing::__proptest::proptest! {
            #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::CASES))]

            #[test]
            fn rotated(p in $strategy, g in $group) {
                $crate::testing::laws::check_rotated(&p, &g)?;
            }
        }
    };
    (@law finite, ($strategy:expr), $extreme:expr) => {
        $crate::testing::__proptest::proptest! {
            #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::CASES))]

            #[test]
            fn finite(p in $extreme) {
                $crate::testing::laws::check_finite(&p, &mut $crate::testing::laws::rng())?;
            }
        }
    };
    (@law bad_input, ($strategy:expr), $raw:expr) => {
        $crate::testing::__proptest::proptest! {
            #![proptest_config(ProptestConfig::with_cases($crate::testing::laws::BAD_INPUT_CASES))]

            #[test]
            fn bad_input(built in $raw) {
                $crate::testing::laws::check_bad_input(&built, &mut $crate::testing::laws::rng())?;
            }
        }
    };
}
