//! `approx` comparisons for the types whose equality is that of one stored nalgebra value. Here and
//! in the other `approx` impls the `_ne` methods are written out (the negations approx provides)
//! so that the generated docs carry text of their own: approx's default docs link to items that
//! rustdoc cannot resolve in this crate and would render as literal brackets.

/// Implements `AbsDiffEq` and `RelativeEq` for `$ty` by comparing `self.$field`, with
/// `T::default_epsilon()` and `T::default_max_relative()` as defaults.
macro_rules! impl_approx_by_field {
    ($ty:ty, [$($generics:tt)*], $($field:ident).+) => {
        impl<$($generics)*> approx::AbsDiffEq for $ty {
            type Epsilon = T;
            fn default_epsilon() -> T {
                T::default_epsilon()
            }
            fn abs_diff_eq(&self, other: &Self, epsilon: T) -> bool {
                self.$($field).+.abs_diff_eq(&other.$($field).+, epsilon)
            }
            /// The negation of `abs_diff_eq`.
            fn abs_diff_ne(&self, other: &Self, epsilon: T) -> bool {
                !self.abs_diff_eq(other, epsilon)
            }
        }

        impl<$($generics)*> approx::RelativeEq for $ty {
            fn default_max_relative() -> T {
                T::default_max_relative()
            }
            fn relative_eq(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
                self.$($field).+.relative_eq(&other.$($field).+, epsilon, max_relative)
            }
            /// The negation of `relative_eq`.
            fn relative_ne(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
                !self.relative_eq(other, epsilon, max_relative)
            }
        }
    };
}
pub(crate) use impl_approx_by_field;
