//! What the poses [`Se2`](crate::Se2), [`Se3`](crate::Se3) and [`Se23`](crate::Se23) share: the
//! accurate `θ − sin θ`, products that cannot overflow into NaN for huge translations, the check of a
//! homogeneous matrix's bottom rows, and the comparisons and nalgebra conversions written once.

use crate::error::ManifoldError;
use crate::real::Real;
use nalgebra::{SMatrix, SVector};

/// `1/(2k+3)!` for k = 0..=8: the coefficients of `(θ − sin θ)/θ³ = Σ (−1)^k θ^(2k) / (2k+3)!`.
const INVERSE_ODD_FACTORIALS: [f64; 9] = [
    1.0 / 6.0,
    1.0 / 120.0,
    1.0 / 5040.0,
    1.0 / 362_880.0,
    1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    1.0 / 1_307_674_368_000.0,
    1.0 / 355_687_428_096_000.0,
    1.0 / 121_645_100_408_832_000.0,
];

/// `(θ − sin θ)/θ` for every finite θ (even in θ; `sin_theta` is `sin θ`), to a few ulp.
///
/// Below [`SINE_DEFECT_SERIES_ANGLE`](crate::constants::Thresholds::SINE_DEFECT_SERIES_ANGLE) it is
/// the Taylor series `θ² Σ_(k=0..8) (−1)^k θ^(2k)/(2k+3)!` (first omitted term θ¹⁸/21!, below 1e-19
/// relative at 1), above it the difference, which loses at most 12 eps there. Bounded by 1.22 for
/// every θ, so the coefficients built from it stay finite for huge angles.
#[inline]
pub(crate) fn theta_minus_sin_over_theta<T: Real>(theta: T, sin_theta: T) -> T {
    if theta.abs() < T::SINE_DEFECT_SERIES_ANGLE {
        let t2 = theta * theta;
        // Horner from the highest term: c₀ − θ²(c₁ − θ²(c₂ − …)).
        let sum = INVERSE_ODD_FACTORIALS
            .iter()
            .rev()
            .fold(T::zero(), |acc, &c| T::lit(c) - t2 * acc);
        t2 * sum
    } else {
        (theta - sin_theta) / theta
    }
}

/// `t` with coordinates beyond the scalar's range (±∞ from an overflowing sum) saturated at the
/// largest finite value.
#[inline]
pub(crate) fn saturated<T: Real, const N: usize>(t: SVector<T, N>) -> SVector<T, N> {
    if t.iter().all(|x| nalgebra::ComplexField::is_finite(x)) {
        t
    } else {
        let max = T::max_finite();
        t.map(|x| x.clamp(-max, max))
    }
}

/// `f(v)` for a map `f` linear in `v`, free of overflow into NaN for every finite `v`.
///
/// When a component of `v` exceeds
/// [`LARGE_COORDINATE`](crate::constants::Thresholds::LARGE_COORDINATE), `f` is evaluated at
/// `v / s` with `s = max |v_i|` and the result multiplied back by `s`, saturating at the largest finite
/// value (`f` must have coefficients of moderate size, as every pose formula has).
#[inline]
pub(crate) fn linear_saturating<T: Real, const N: usize, const R: usize, const C: usize>(
    v: &SVector<T, N>,
    f: impl Fn(&SVector<T, N>) -> SMatrix<T, R, C>,
) -> SMatrix<T, R, C> {
    if v.amax() <= T::LARGE_COORDINATE {
        f(v)
    } else {
        linear_huge(v, f)
    }
}

/// [`linear_saturating`] for inputs beyond the large-coordinate bound.
#[cold]
#[inline(never)]
fn linear_huge<T: Real, const N: usize, const R: usize, const C: usize>(
    v: &SVector<T, N>,
    f: impl Fn(&SVector<T, N>) -> SMatrix<T, R, C>,
) -> SMatrix<T, R, C> {
    let s = v.amax();
    let max = T::max_finite();
    f(&(v / s)).map(|x| (x * s).clamp(-max, max))
}

/// The product `a b`, free of overflow into NaN for all finite factors: when the product of the
/// largest entries exceeds [`LARGE_COORDINATE`](crate::constants::Thresholds::LARGE_COORDINATE),
/// the plain product is kept where it is finite, and an entry that overflows is summed again with
/// its row of `a` and its column of `b` scaled to entries of at most 1, scaled back and saturated
/// at the largest finite value. So an entry keeps its own precision: a small entry beside huge ones
/// (the rotation block of a pose with a translation of 1e300) is not lost to a common scale.
#[inline]
pub(crate) fn mul_saturating<T: Real, const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<T, R, K>,
    b: &SMatrix<T, K, C>,
) -> SMatrix<T, R, C> {
    if a.amax() * b.amax() <= T::LARGE_COORDINATE {
        a * b
    } else {
        mul_huge(a, b)
    }
}

/// `l a r` (a conjugation `R a Rᵀ` or `H a H⁻¹`), free of overflow into NaN or ±∞ for finite
/// factors: below the large-coordinate bound the plain products; beyond it each entry
/// `Σₖₘ lᵢₖ aₖₘ rₘⱼ` is summed term by term, and one that overflows is summed again with row i of
/// `l`, `a` and column j of `r` each divided by its largest magnitude (so that terms that cancel in
/// the exact result cancel here too) and the scales put back, saturating at the largest finite
/// value. Every entry keeps its own precision, whatever the size of the others.
#[inline]
pub(crate) fn conjugate_saturating<T: Real, const N: usize>(
    l: &SMatrix<T, N, N>,
    a: &SMatrix<T, N, N>,
    r: &SMatrix<T, N, N>,
) -> SMatrix<T, N, N> {
    let (sl, sa, sr) = (l.amax(), a.amax(), r.amax());
    if sl * sa * sr <= T::LARGE_COORDINATE {
        return l * a * r;
    }
    conjugate_huge(l, a, r, [sl, sa, sr])
}

/// [`conjugate_saturating`] for factors beyond the large-coordinate bound.
#[cold]
#[inline(never)]
fn conjugate_huge<T: Real, const N: usize>(
    l: &SMatrix<T, N, N>,
    a: &SMatrix<T, N, N>,
    r: &SMatrix<T, N, N>,
    [_, sa, _]: [T; 3],
) -> SMatrix<T, N, N> {
    SMatrix::from_fn(|i, j| {
        let entry = |(sl, sa, sr): (T, T, T)| {
            (0..N)
                .flat_map(|k| (0..N).map(move |m| (k, m)))
                .fold(T::zero(), |sum, (k, m)| {
                    sum + (l[(i, k)] / sl) * (a[(k, m)] / sa) * (r[(m, j)] / sr)
                })
        };
        let plain = entry((T::one(), T::one(), T::one()));
        if plain.is_finite() {
            return plain;
        }
        let (sl, sr) = (l.row(i).amax(), r.column(j).amax());
        // The plain sum overflowed, so no scale is zero.
        scaled_back(entry((sl, sa, sr)), [sl, sa, sr])
    })
}

/// [`mul_saturating`] for factors beyond the large-coordinate bound.
#[cold]
#[inline(never)]
fn mul_huge<T: Real, const R: usize, const K: usize, const C: usize>(
    a: &SMatrix<T, R, K>,
    b: &SMatrix<T, K, C>,
) -> SMatrix<T, R, C> {
    let mut product = a * b;
    for ((i, j), entry) in (0..C)
        .flat_map(|j| (0..R).map(move |i| (i, j)))
        .zip(product.iter_mut())
    {
        if !entry.is_finite() {
            // The plain sum overflowed, so neither scale is zero.
            let (sa, sb) = (a.row(i).amax(), b.column(j).amax());
            let unit = (0..K).fold(T::zero(), |sum, k| {
                sum + (a[(i, k)] / sa) * (b[(k, j)] / sb)
            });
            *entry = scaled_back(unit, [sa, sb, T::one()]);
        }
    }
    product
}

/// `unit` times the product of `scales`, the smaller scales first (so that a finite result is not
/// lost to an intermediate overflow), saturating at the largest finite value.
fn scaled_back<T: Real>(unit: T, mut scales: [T; 3]) -> T {
    scales.sort_by(|x, y| x.partial_cmp(y).unwrap_or(std::cmp::Ordering::Equal));
    let max = T::max_finite();
    (unit * scales[0] * scales[1] * scales[2]).clamp(-max, max)
}

/// Checks that the last `K` rows of a finite `N × N` matrix are those of the identity (`[0, …, 0, 1]`
/// for a homogeneous rigid motion, `K = 1`; the two rows `[0, 0, 0, 1, 0]`, `[0, 0, 0, 0, 1]` of an
/// extended pose, `K = 2`) within
/// [`ORTHONORMAL_TOLERANCE`](crate::constants::Thresholds::ORTHONORMAL_TOLERANCE).
pub(crate) fn check_bottom_rows<T: Real, const N: usize, const K: usize>(
    m: &SMatrix<T, N, N>,
) -> Result<(), ManifoldError> {
    let bottom = m.fixed_rows::<K>(N - K) - SMatrix::<T, N, N>::identity().fixed_rows::<K>(N - K);
    let deviation = bottom.amax();
    if deviation > T::ORTHONORMAL_TOLERANCE {
        return Err(ManifoldError::NotHomogeneous {
            deviation: deviation.to_f64(),
            tolerance: T::ORTHONORMAL_TOLERANCE.to_f64(),
        });
    }
    Ok(())
}

/// Equality and `approx` comparisons of a pose type with a field `rotation` (a rotation type with its
/// own equality: for SO(3), up to the quaternion sign) and the vector fields listed.
macro_rules! impl_pose_comparisons {
    ($ty:ident, $($vector:ident),+) => {
        /// Equal when the rotations are equal (as rotations) and the vectors are equal.
        impl<T: $crate::Real> PartialEq for $ty<T> {
            fn eq(&self, other: &Self) -> bool {
                self.rotation == other.rotation $(&& self.$vector == other.$vector)+
            }
        }

        impl<T: $crate::Real> approx::AbsDiffEq for $ty<T> {
            type Epsilon = T;
            fn default_epsilon() -> T {
                T::default_epsilon()
            }
            /// Compares the rotations (as rotations) and the vectors.
            fn abs_diff_eq(&self, other: &Self, epsilon: T) -> bool {
                self.rotation.abs_diff_eq(&other.rotation, epsilon)
                    $(&& self.$vector.abs_diff_eq(&other.$vector, epsilon))+
            }
            /// The negation of `abs_diff_eq`.
            fn abs_diff_ne(&self, other: &Self, epsilon: T) -> bool {
                !self.abs_diff_eq(other, epsilon)
            }
        }

        impl<T: $crate::Real> approx::RelativeEq for $ty<T> {
            fn default_max_relative() -> T {
                T::default_max_relative()
            }
            /// Compares the rotations (as rotations) and the vectors.
            fn relative_eq(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
                self.rotation.relative_eq(&other.rotation, epsilon, max_relative)
                    $(&& self.$vector.relative_eq(&other.$vector, epsilon, max_relative))+
            }
            /// The negation of `relative_eq`.
            fn relative_ne(&self, other: &Self, epsilon: T, max_relative: T) -> bool {
                !self.relative_eq(other, epsilon, max_relative)
            }
        }
    };
}
pub(crate) use impl_pose_comparisons;

/// [`impl_pose_comparisons`] and the nalgebra `Isometry` conversions of a rigid-motion type with
/// fields `rotation` and `translation`.
macro_rules! impl_pose_comparisons_and_conversions {
    ($ty:ident, $rotation:ident, $unit:ident, $dim:literal) => {
        $crate::pose::impl_pose_comparisons!($ty, translation);

        /// The same rigid motion, `p ↦ R p + t` (no cost, no check: nalgebra's unit types are trusted
        /// like the rotation type's own `From`).
        impl<T: $crate::Real> From<nalgebra::Isometry<T, nalgebra::$unit<T>, $dim>> for $ty<T> {
            #[inline]
            fn from(iso: nalgebra::Isometry<T, nalgebra::$unit<T>, $dim>) -> Self {
                Self::new_unchecked($rotation::from(iso.rotation), iso.translation.vector)
            }
        }

        /// The same rigid motion, `p ↦ R p + t` (no cost).
        impl<T: $crate::Real> From<$ty<T>> for nalgebra::Isometry<T, nalgebra::$unit<T>, $dim> {
            #[inline]
            fn from(x: $ty<T>) -> Self {
                nalgebra::Isometry::from_parts(
                    nalgebra::Translation::from(x.translation),
                    x.rotation.into(),
                )
            }
        }
    };
}
pub(crate) use impl_pose_comparisons_and_conversions;

#[cfg(test)]
mod tests {
    //! `θ − sin θ` against the series summed to convergence and against the difference where it
    //! does not cancel, and the saturating products against direct products and at the range's end.
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    /// `(θ − sin θ)/θ = Σ_(k≥0) (−1)^k θ^(2k+2)/(2k+3)!`, summed over 40 terms (converged for θ ≤ 2).
    fn reference(theta: f64) -> f64 {
        let mut term = theta * theta / 6.0;
        let mut sum = 0.0;
        for k in 0..40 {
            sum += term;
            let n = f64::from(2 * k + 4);
            term *= -theta * theta / (n * (n + 1.0));
        }
        sum
    }

    #[test]
    fn theta_minus_sin_matches_the_converged_series() {
        for theta in [1e-8, 1e-4, 1e-2, 0.1, 0.5, 0.9, 0.999, 1.0, 1.5, 2.0] {
            let got = theta_minus_sin_over_theta(theta, f64::sin(theta));
            let expected = reference(theta);
            // Above the series threshold the difference loses eps θ / (θ − sin θ) ≈ 12 eps at 1.
            let tol = if theta < 1.0 { 4.0 } else { 16.0 } * f64::EPSILON;
            assert!(
                ((got - expected) / expected).abs() <= tol,
                "θ = {theta}: {got:e} vs {expected:e}"
            );
            assert_eq!(got, theta_minus_sin_over_theta(-theta, -f64::sin(theta)));
        }
        // f32 through the same code, against the f64 reference.
        for theta in [1e-3_f32, 0.3, 0.99, 1.0, 3.0] {
            let got = f64::from(theta_minus_sin_over_theta(theta, theta.sin()));
            let expected = reference(f64::from(theta));
            assert!(((got - expected) / expected).abs() <= 16.0 * f64::from(f32::EPSILON));
        }
        // Bounded and finite for huge angles.
        for theta in [1e10, 1e300, f64::MAX] {
            let e = theta_minus_sin_over_theta(theta, theta.sin());
            assert!((e - 1.0).abs() < 1e-9, "θ = {theta}: {e}");
        }
    }

    #[test]
    fn saturating_products_agree_with_plain_products_and_stay_finite() {
        let a = Matrix3::new(1.0, -2.0, 0.5, 0.3, 1.0, -1.0, 2.0, 0.0, 1.0);
        let v = Vector3::new(3.0, -1.0, 2.0);
        assert_eq!(linear_saturating(&v, |v| a * v), a * v);
        assert_eq!(mul_saturating(&a, &v), a * v);
        // Components near the largest finite value: +inf and −inf meet in the plain product.
        let b = Matrix3::new(2.0, 2.0, 0.0, 1.0, -1.0, 0.5, 0.0, 0.0, 1.0);
        let huge = Vector3::new(f64::MAX, -f64::MAX, f64::MAX);
        assert!((b * huge).x.is_nan());
        let r = linear_saturating(&huge, |v| b * v);
        assert_eq!(r, Vector3::new(0.0, f64::MAX, f64::MAX));
        let m = mul_saturating(&(b * 1e300), &huge);
        assert_eq!(m, Vector3::new(0.0, f64::MAX, f64::MAX));
        assert_eq!(mul_saturating(&Matrix3::zeros(), &huge), Vector3::zeros());
        // Scaled evaluation of an exactly representable product is exact.
        let s = Vector3::new(4e300, -2e300, 1e300);
        assert_eq!(linear_saturating(&s, |v| a * v), (a * (s / 4e300)) * 4e300);
    }

    #[test]
    fn bottom_row_check() {
        let mut m = Matrix3::<f64>::identity();
        assert!(check_bottom_rows::<_, 3, 1>(&m).is_ok());
        m[(2, 0)] = 1e-3;
        assert!(matches!(
            check_bottom_rows::<_, 3, 1>(&m),
            Err(ManifoldError::NotHomogeneous { .. })
        ));
        m[(2, 0)] = 0.0;
        m[(2, 2)] = 2.0;
        assert!(check_bottom_rows::<_, 3, 1>(&m).is_err());
        // Two rows: the last two of the identity.
        let mut e = nalgebra::Matrix5::<f64>::identity();
        e[(0, 3)] = 7.0;
        assert!(check_bottom_rows::<_, 5, 2>(&e).is_ok());
        e[(3, 4)] = 1e-3;
        assert!(check_bottom_rows::<_, 5, 2>(&e).is_err());
        assert!(check_bottom_rows::<_, 5, 1>(&e).is_ok());
    }
}
