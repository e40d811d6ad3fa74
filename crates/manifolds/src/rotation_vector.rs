//! Functions of a rotation vector (the tangent coordinates of SO(3) and SU(2)), shared by
//! [`So3`](crate::So3) and [`Su2`](crate::Su2).
//!
//! With θ = |v|, U = hat(v / θ) and hat the cross-product matrix:
//!
//! * exp(v) = (cos(θ/2), sin(θ/2) v/θ) as a unit quaternion (Hamilton, scalar first);
//! * Jr(v) = I − ((1 − cos θ)/θ) U + ((θ − sin θ)/θ) U²;
//! * Jr⁻¹(v) = I + (θ/2) U + (1 − (θ/2) cot(θ/2)) U².
//!
//! Writing the coefficients against the unit-axis matrix U keeps them bounded for any finite v
//! (no 0 · ∞ for huge tangents), and every function works from the half angle θ/2 = |v/2|, which is
//! finite for every finite v (|v| itself overflows when the components approach the largest finite
//! value). Below [`Thresholds::EXP_SERIES_ANGLE`](crate::constants::Thresholds) exp takes its
//! coefficients from their Taylor series, and below
//! [`Thresholds::SERIES_ANGLE`](crate::constants::Thresholds) the Jacobians take the Taylor series
//! of the coefficients of hat(v) and hat(v)².

use crate::real::{Real, stable_norm as norm};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// The cross-product matrix: `hat(v) w = v × w`.
#[inline]
pub(crate) fn hat<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -v.z, v.y, v.z, z, -v.x, -v.y, v.x, z)
}

/// The vector of the antisymmetric part of `m` (the inverse of [`hat`] on skew matrices).
#[inline]
pub(crate) fn vee<T: Real>(m: &Matrix3<T>) -> Vector3<T> {
    Vector3::new(
        half_difference(m.m32, m.m23),
        half_difference(m.m13, m.m31),
        half_difference(m.m21, m.m12),
    )
}

/// `(a − b) / 2` as `a/2 − b/2`, finite for all finite `a` and `b` (the difference of two entries
/// near the scalar's largest value overflows; its half does not).
#[inline]
pub(crate) fn half_difference<T: Real>(a: T, b: T) -> T {
    let half = T::lit(0.5);
    a * half - b * half
}

/// `v / 2` and its norm θ/2, finite for every finite `v`.
#[inline]
fn half<T: Real>(v: &Vector3<T>) -> (Vector3<T>, T) {
    let half_v = v * T::lit(0.5);
    let h = norm(&half_v);
    (half_v, h)
}

/// The unit quaternion of a rotation vector, valid for every finite `v` (period 4π in θ).
///
/// Below [`EXP_SERIES_ANGLE`](crate::constants::Thresholds::EXP_SERIES_ANGLE) the half-angle
/// cosine and the quotient sin(h)/h (h = θ/2) come from their Taylor series in h² = |v/2|², which
/// needs no square root and no `sin_cos`; above it, from `sin_cos` of the stable norm.
#[inline]
pub(crate) fn exp<T: Real>(v: &Vector3<T>) -> UnitQuaternion<T> {
    let half_v = v * T::lit(0.5);
    let h2 = half_v.norm_squared();
    let limit = T::EXP_SERIES_ANGLE * T::lit(0.5);
    // A NaN or an overflowed h² fails the comparison and takes the closed form.
    let (c, k) = if h2 < limit * limit {
        // cos h = Σ (−h²)ⁿ / (2n)!, sin h / h = Σ (−h²)ⁿ / (2n + 1)!, n = 0..4 (Horner).
        let term = |a: f64| T::lit(a);
        let c = T::one()
            - h2 * (term(0.5)
                - h2 * (term(1.0 / 24.0) - h2 * (term(1.0 / 720.0) - h2 * term(1.0 / 40_320.0))));
        let k = T::one()
            - h2 * (term(1.0 / 6.0)
                - h2 * (term(1.0 / 120.0)
                    - h2 * (term(1.0 / 5040.0) - h2 * term(1.0 / 362_880.0))));
        (c, k)
    } else {
        // `h` is finite for every finite v (|v| itself may overflow) and at least 0.1 here.
        let h = norm(&half_v);
        let (s, c) = h.sin_cos();
        (c, s / h)
    };
    UnitQuaternion::new_unchecked(Quaternion::new(c, half_v.x * k, half_v.y * k, half_v.z * k))
}

/// The rotation vector of a quaternion on the SU(2) principal branch: θ = 2 atan2(|xyz|, w) in [0, 2π].
///
/// At q = −1 exactly every axis is a logarithm; the x axis is returned.
/// The quaternion need not be exactly unit: atan2 is insensitive to the scale. A quaternion with a
/// NaN component has the NaN vector as its logarithm (never a finite rotation a check would pass).
#[inline]
pub(crate) fn log<T: Real>(q: &Quaternion<T>) -> Vector3<T> {
    let xyz = q.imag();
    let n = norm(&xyz);
    if n.to_f64().is_nan() || q.w.to_f64().is_nan() {
        return Vector3::repeat(T::lit(f64::NAN));
    }
    if n > T::zero() {
        // atan2(n, w) / n is accurate to a few ulp for every n > 0 (no cancellation), so no series
        // branch is needed near the identity. Near q = −1 with a subnormal n the factor overflows
        // (2π / 1.7e-308): there the unit axis xyz / n is taken first.
        let angle = T::lit(2.0) * n.atan2(q.w);
        let factor = angle / n;
        if nalgebra::ComplexField::is_finite(&factor) {
            xyz * factor
        } else {
            (xyz / n) * angle
        }
    } else if q.w >= T::zero() {
        Vector3::zeros()
    } else {
        Vector3::new(T::two_pi(), T::zero(), T::zero())
    }
}

/// Computes `I + p·U + r·U²` with U = hat(v/θ) and `(p, r) = closed_form(θ/2)`, or, below the series
/// threshold, `I + p·hat(v) + r·hat(v)²` with `(p, r) = series(θ²)`.
///
/// Both are `(1 − r n²) I + r a aᵀ + p hat(a)` with `a` the unit axis (n = 1) or `v` itself (n = θ),
/// since `hat(a)² = a aᵀ − |a|² I`; writing the entries out avoids two 3×3 products.
#[inline]
fn axis_polynomial<T: Real>(
    v: &Vector3<T>,
    closed_form: impl Fn(T) -> (T, T),
    series: impl Fn(T) -> (T, T),
) -> Matrix3<T> {
    let (half_v, h) = half(v);
    let (a, n2, (p, r)) = if h + h < T::SERIES_ANGLE {
        let t2 = T::lit(4.0) * h * h;
        (*v, t2, series(t2))
    } else {
        (half_v / h, T::one(), closed_form(h))
    };
    let d = T::one() - r * n2;
    let (rx, ry, rz) = (r * a.x, r * a.y, r * a.z);
    let (px, py, pz) = (p * a.x, p * a.y, p * a.z);
    Matrix3::new(
        d + rx * a.x,
        rx * a.y - pz,
        rx * a.z + py,
        rx * a.y + pz,
        d + ry * a.y,
        ry * a.z - px,
        rx * a.z - py,
        ry * a.z + px,
        d + rz * a.z,
    )
}

/// Coefficients of U and U² in Jr, `(−(1 − cos θ)/θ, (θ − sin θ)/θ)`, from the half angle h = θ/2 and
/// one `sin_cos(h)`: 1 − cos θ = 2 sin² h (no cancellation) and sin θ = 2 sin h cos h, so the
/// coefficients are `(−sin² h / h, 1 − sin h cos h / h)`.
#[inline]
fn right_jacobian_closed<T: Real>(h: T) -> (T, T) {
    let (s, c) = h.sin_cos();
    (-(s * s) / h, T::one() - s * c / h)
}

/// Coefficients of hat(v) and hat(v)² in Jr as series in t2 = θ²:
/// `−(1/2 − θ²/24 + θ⁴/720)` and `1/6 − θ²/120 + θ⁴/5040`.
#[inline]
fn right_jacobian_series<T: Real>(t2: T) -> (T, T) {
    (
        -(T::lit(0.5) - t2 / T::lit(24.0) + t2 * t2 / T::lit(720.0)),
        T::one() / T::lit(6.0) - t2 / T::lit(120.0) + t2 * t2 / T::lit(5040.0),
    )
}

/// Coefficients of U and U² in Jr⁻¹ from the half angle h = θ/2: `(h, 1 − h cot h)`. For huge θ the
/// second can exceed the scalar's range; it saturates at the largest finite value so that the matrix
/// stays NaN-free.
#[inline]
fn right_jacobian_inverse_closed<T: Real>(h: T) -> (T, T) {
    let (s, c) = h.sin_cos();
    let r = T::one() - h * c / s;
    let max = T::max_finite();
    (h, r.clamp(-max, max))
}

/// Coefficients of hat(v) and hat(v)² in Jr⁻¹ as series in t2 = θ²:
/// `1/2` and `1/12 + θ²/720 + θ⁴/30240`.
#[inline]
fn right_jacobian_inverse_series<T: Real>(t2: T) -> (T, T) {
    (
        T::lit(0.5),
        T::one() / T::lit(12.0) + t2 / T::lit(720.0) + t2 * t2 / T::lit(30240.0),
    )
}

/// Right Jacobian of SO(3)/SU(2): `Jr(v) = I − ((1 − cos θ)/θ) U + ((θ − sin θ)/θ) U²`.
#[inline]
pub(crate) fn right_jacobian<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    axis_polynomial(v, right_jacobian_closed, right_jacobian_series)
}

/// Inverse right Jacobian of SO(3)/SU(2): `Jr⁻¹(v) = I + (θ/2) U + (1 − (θ/2) cot(θ/2)) U²`.
///
/// Singular at θ = 2π k (k ≥ 1), where exp is not a local diffeomorphism; finite at θ = π.
#[inline]
pub(crate) fn right_jacobian_inverse<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    axis_polynomial(
        v,
        right_jacobian_inverse_closed,
        right_jacobian_inverse_series,
    )
}

/// `q v q*` for any finite `v`. nalgebra's formula doubles intermediate products, which overflow to NaN for
/// coordinates near the largest finite value; then the point is scaled down by its largest coordinate
/// first (one extra check on the fast path).
#[inline]
pub(crate) fn rotate<T: Real>(q: &UnitQuaternion<T>, v: &Vector3<T>) -> Vector3<T> {
    let r = q * v;
    if (r.x + r.y + r.z).is_finite() {
        r
    } else {
        rotate_huge(q, v)
    }
}

/// [`rotate`] for points whose coordinates overflow the direct formula: the unit point rotated and
/// scaled back, saturating at the largest finite value where the rotated point lies beyond it.
#[cold]
#[inline(never)]
fn rotate_huge<T: Real>(q: &UnitQuaternion<T>, v: &Vector3<T>) -> Vector3<T> {
    let scale = v.amax();
    crate::pose::saturated((q * (v / scale)) * scale)
}

/// The [`LieGroup`](crate::LieGroup) methods that SO(3) and SU(2) share: both store a unit quaternion
/// in a field `q` and use rotation vectors as tangent coordinates.
macro_rules! quaternion_group_methods {
    () => {
        #[inline]
        fn identity() -> Self {
            Self::from_unit_quaternion(nalgebra::UnitQuaternion::identity())
        }

        #[inline]
        fn compose(&self, other: &Self) -> Self {
            Self::from_unit_quaternion(self.q * other.q)
        }

        #[inline]
        fn inverse(&self) -> Self {
            Self::from_unit_quaternion(self.q.inverse())
        }

        /// `exp(v) = (cos(θ/2), sin(θ/2) v/θ)`, θ = |v|, with the Taylor series below the exp series angle.
        #[inline]
        fn exp(v: &$crate::Tangent<T, 3>) -> Self {
            Self::from_unit_quaternion($crate::rotation_vector::exp(v))
        }

        /// `Ad = R`, the rotation matrix.
        #[inline]
        fn adjoint(&self) -> $crate::Jacobian<T, 3, 3> {
            self.q.to_rotation_matrix().into_inner()
        }

        /// `Jr(v) = I − ((1 − cos θ)/θ²) hat(v) + ((θ − sin θ)/θ³) hat(v)²`.
        #[inline]
        fn right_jacobian(v: &$crate::Tangent<T, 3>) -> $crate::Jacobian<T, 3, 3> {
            $crate::rotation_vector::right_jacobian(v)
        }

        /// `Jr⁻¹(v) = I + hat(v)/2 + (1/θ² − cot(θ/2)/(2θ)) hat(v)²`; singular at θ = 2π k (k ≥ 1).
        #[inline]
        fn right_jacobian_inverse(v: &$crate::Tangent<T, 3>) -> $crate::Jacobian<T, 3, 3> {
            $crate::rotation_vector::right_jacobian_inverse(v)
        }

        /// `Ad(other⁻¹) = R(other)ᵀ`.
        #[inline]
        fn j_compose_self(&self, other: &Self) -> $crate::Jacobian<T, 3, 3> {
            other.q.to_rotation_matrix().into_inner().transpose()
        }
    };
}
pub(crate) use quaternion_group_methods;

/// The action of SO(3) or SU(2) on R³, `v ↦ q v q*`, with its Jacobians.
macro_rules! impl_rotation_action {
    ($ty:ident) => {
        impl<T: $crate::Real> $crate::GroupAction<3, 3> for $ty<T> {
            /// `q v q*`, finite for every finite point (saturating at the largest finite value
            /// where the rotated point lies beyond it).
            #[inline]
            fn act(&self, p: &nalgebra::Vector3<T>) -> nalgebra::Vector3<T> {
                $crate::rotation_vector::rotate(&self.q, p)
            }

            /// `−R hat(p)`, saturating like `act` for points near the scalar's
            /// largest value.
            #[inline]
            fn j_act_self(&self, p: &nalgebra::Vector3<T>) -> $crate::Jacobian<T, 3, 3> {
                let r = self.q.to_rotation_matrix().into_inner();
                -$crate::pose::linear_saturating(p, |p| r * $crate::rotation_vector::hat(p))
            }

            /// `R`.
            #[inline]
            fn j_act_point(&self, _p: &nalgebra::Vector3<T>) -> $crate::Jacobian<T, 3, 3> {
                self.q.to_rotation_matrix().into_inner()
            }
        }
    };
}
pub(crate) use impl_rotation_action;

#[cfg(test)]
mod tests {
    //! The coefficient functions against their Taylor series summed to convergence (an independent
    //! evaluation: general terms, not the truncated forms above), on both sides of the series
    //! threshold.
    use super::*;

    /// `(1 − cos θ)/θ² = Σ (−1)^k θ^(2k) / (2k+2)!`
    fn a_reference(theta: f64) -> f64 {
        taylor(theta, |k| 1.0 / factorial(2 * k + 2))
    }

    /// `(θ − sin θ)/θ³ = Σ (−1)^k θ^(2k) / (2k+3)!`
    fn b_reference(theta: f64) -> f64 {
        taylor(theta, |k| 1.0 / factorial(2 * k + 3))
    }

    /// `(1 − (θ/2) cot(θ/2))/θ² = Σ_(n≥1) |B_2n| θ^(2n−2) / (2n)!` (from x cot x = Σ (−4)^n B_2n x^(2n)/(2n)!),
    /// valid for θ < 2π.
    fn c_reference(theta: f64) -> f64 {
        // |B_2n| for n = 1..=15
        const B: [f64; 15] = [
            1.0 / 6.0,
            1.0 / 30.0,
            1.0 / 42.0,
            1.0 / 30.0,
            5.0 / 66.0,
            691.0 / 2730.0,
            7.0 / 6.0,
            3617.0 / 510.0,
            43867.0 / 798.0,
            174_611.0 / 330.0,
            854_513.0 / 138.0,
            236_364_091.0 / 2730.0,
            8_553_103.0 / 6.0,
            23_749_461_029.0 / 870.0,
            8_615_841_276_005.0 / 14322.0,
        ];
        B.iter()
            .enumerate()
            .map(|(i, b)| {
                let n = i32::try_from(i).unwrap() + 1;
                b * theta.powi(2 * n - 2) / factorial(usize::try_from(2 * n).unwrap())
            })
            .sum()
    }

    fn factorial(n: usize) -> f64 {
        (1..=n).map(|k| k as f64).product()
    }

    fn taylor(theta: f64, coefficient: impl Fn(usize) -> f64) -> f64 {
        (0..40)
            .map(|k| {
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                sign * coefficient(k) * theta.powi(i32::try_from(2 * k).unwrap())
            })
            .sum()
    }

    fn assert_rel(got: f64, expected: f64, tol: f64, what: &str) {
        let err = ((got - expected) / expected).abs();
        assert!(
            err <= tol,
            "{what}: got {got:e}, expected {expected:e}, relative error {err:e} > {tol:e}"
        );
    }

    #[test]
    fn series_match_the_converged_taylor_sums_below_the_threshold() {
        for theta in [0.0, 1e-8, 1e-4, 1e-3, 5e-3, 0.0099] {
            let t2 = theta * theta;
            let (p, r) = right_jacobian_series(t2);
            assert_rel(
                -p,
                a_reference(theta),
                4.0 * f64::EPSILON,
                "Jr hat coefficient",
            );
            assert_rel(
                r,
                b_reference(theta),
                4.0 * f64::EPSILON,
                "Jr hat^2 coefficient",
            );
            let (p, r) = right_jacobian_inverse_series(t2);
            assert_rel(p, 0.5, 0.0, "Jr^-1 hat coefficient");
            assert_rel(
                r,
                c_reference(theta),
                4.0 * f64::EPSILON,
                "Jr^-1 hat^2 coefficient",
            );
        }
    }

    #[test]
    fn closed_forms_match_the_converged_taylor_sums_above_the_threshold() {
        // The closed forms of b and c cancel like eps/θ² just above the threshold (see constants).
        for theta in [0.01, 0.05, 0.3, 1.0, 2.0, 3.0, std::f64::consts::PI, 4.5] {
            let cancellation = 8.0 * f64::EPSILON / (theta * theta).min(1.0);
            let (p, r) = right_jacobian_closed(theta / 2.0);
            assert_rel(
                -p / theta,
                a_reference(theta),
                8.0 * f64::EPSILON,
                "Jr U coefficient",
            );
            assert_rel(
                r / (theta * theta),
                b_reference(theta),
                cancellation,
                "Jr U^2 coefficient",
            );
            let (p, r) = right_jacobian_inverse_closed(theta / 2.0);
            assert_rel(p, theta / 2.0, 0.0, "Jr^-1 U coefficient");
            // The Bernoulli series converges like (θ/2π)^(2n): 15 terms reach 1e-24 for θ <= 1. Above,
            // the law Jr(v) Jr^-1(v) = I (tests/laws.rs) checks this coefficient at every angle.
            if theta <= 1.0 {
                assert_rel(
                    r / (theta * theta),
                    c_reference(theta),
                    cancellation,
                    "Jr^-1 U^2 coefficient",
                );
            }
        }
    }

    /// exp's half-angle cosine and sine, on both sides of its series threshold (0.2) and along
    /// an oblique axis, against the converged Taylor sums of cos h and sin h / h.
    #[test]
    fn exp_matches_the_converged_taylor_sums_on_both_sides_of_its_threshold() {
        let axis = Vector3::new(2.0, -3.0, 6.0) / 7.0;
        for theta in [0.0, 1e-9, 1e-4, 0.0099, 0.05, 0.1999, 0.2, 0.2001, 0.7, 2.0] {
            let q = exp(&(axis * theta));
            let h = theta / 2.0;
            let cos = taylor(h, |k| 1.0 / factorial(2 * k));
            let sinc = taylor(h, |k| 1.0 / factorial(2 * k + 1));
            assert_rel(q.w, cos, 2.0 * f64::EPSILON, "exp scalar part");
            for (got, a) in [(q.i, axis.x), (q.j, axis.y), (q.k, axis.z)] {
                if theta > 0.0 {
                    assert_rel(got, sinc * h * a, 4.0 * f64::EPSILON, "exp vector part");
                } else {
                    assert_eq!(got, 0.0);
                }
            }
            let single = exp(&(axis * theta).cast::<f32>());
            assert_rel(
                f64::from(single.w),
                cos,
                2.0 * f64::from(f32::EPSILON),
                "f32 scalar",
            );
        }
    }
}
