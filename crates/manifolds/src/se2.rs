//! [`Se2`]: rigid motions of the plane.

use crate::error::{ManifoldError, check_finite};
use crate::lie_group::{GroupAction, LieGroup, impl_manifold_for_group};
use crate::manifold::{Jacobian, Tangent};
use crate::pose::{
    check_bottom_rows, impl_pose_comparisons_and_conversions, linear_saturating, mul_saturating,
    saturated, theta_minus_sin_over_theta,
};
use crate::real::Real;
use crate::so2::So2;
use nalgebra::{Complex, Matrix2, Matrix3, UnitComplex, Vector2, Vector3};

/// A rigid motion of the plane, an element of SE(2): the map `p ↦ R p + t` with a rotation `R`
/// ([`So2`]) and a translation `t`.
///
/// # Group structure
/// `(R₁, t₁) · (R₂, t₂) = (R₁ R₂, t₁ + R₁ t₂)` (apply the right factor first) and
/// `(R, t)⁻¹ = (Rᵀ, −Rᵀ t)`; the matrix of the motion is the homogeneous `[[R, t], [0, 1]]`
/// ([`to_homogeneous`](Self::to_homogeneous)). It acts on points of R² by `g · p = R p + t`.
///
/// # Tangent coordinates
/// `v = [ρ; θ] = [ρ_x, ρ_y, θ]`: **translation block first, rotation angle last** (the order of manif
/// and Sophus; [`Se3`](crate::Se3) uses the same). `hat(v) = [[0, −θ, ρ_x], [θ, 0, ρ_y], [0, 0, 0]]`
/// and `exp(v) = (R(θ), V(θ) ρ)` with `V(θ) = (sin θ/θ) I + ((1 − cos θ)/θ) J`, where
/// `J = [[0, −1], [1, 0]]` is the quarter turn. Perturbations act on the right like everywhere in the
/// crate, `x ⊞ v = x · exp(v)`, so ρ is a displacement in the body frame of `x`.
///
/// `log` returns θ in (−π, π] and `ρ = V(θ)⁻¹ t`, regular on that whole range (V is singular only at
/// θ = 2πk, k ≠ 0). exp is injective for |θ| < π; `DIM` = 3.
///
/// # Example
/// ```
/// use liebayes_manifolds::{GroupAction, LieGroup, Se2};
/// use nalgebra::Vector2;
/// use std::f64::consts::FRAC_PI_2;
///
/// // A quarter turn about the origin, then one unit along x.
/// let x = Se2::from_angle_translation(FRAC_PI_2, Vector2::new(1.0, 0.0))?;
/// assert!((x.act(&Vector2::new(1.0, 0.0)) - Vector2::new(1.0, 1.0)).norm() < 1e-15);
/// assert!((Se2::exp(&x.log()).translation() - x.translation()).norm() < 1e-15);
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Se2<T: Real> {
    rotation: So2<T>,
    translation: Vector2<T>,
}

/// Construction.
impl<T: Real> Se2<T> {
    /// The motion `p ↦ R p + t`, checked for finiteness (of the translation and of the rotation's
    /// cosine and sine).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn new(rotation: So2<T>, translation: Vector2<T>) -> Result<Self, ManifoldError> {
        check_finite("rotation", [rotation.cos(), rotation.sin()].iter())?;
        check_finite("translation", translation.iter())?;
        Ok(Self::new_unchecked(rotation, translation))
    }

    /// The motion `p ↦ R p + t` without any check (hot paths).
    #[inline]
    pub const fn new_unchecked(rotation: So2<T>, translation: Vector2<T>) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// The rotation by `angle` radians followed by the translation `t`, checked for finiteness.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn from_angle_translation(
        angle: T,
        translation: Vector2<T>,
    ) -> Result<Self, ManifoldError> {
        Self::new(So2::from_angle(angle)?, translation)
    }

    /// The motion with rotation matrix `r` and translation `t`, checked for finiteness,
    /// orthonormality of `r` and determinant +1 (tolerances of [`constants`](crate::constants)).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotOrthonormal`] or
    /// [`ManifoldError::NotProperRotation`].
    pub fn from_parts(
        rotation: &Matrix2<T>,
        translation: &Vector2<T>,
    ) -> Result<Self, ManifoldError> {
        check_finite("translation", translation.iter())?;
        Ok(Self::new_unchecked(
            So2::from_matrix(rotation)?,
            *translation,
        ))
    }

    /// The motion of a homogeneous 3×3 matrix `[[R, t], [0, 1]]`, checked for finiteness, a bottom row
    /// `[0, 0, 1]` within
    /// [`ORTHONORMAL_TOLERANCE`](crate::constants::Thresholds::ORTHONORMAL_TOLERANCE), and a rotation
    /// block as in [`from_parts`](Self::from_parts).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotHomogeneous`],
    /// [`ManifoldError::NotOrthonormal`] or [`ManifoldError::NotProperRotation`].
    pub fn from_matrix(m: &Matrix3<T>) -> Result<Self, ManifoldError> {
        check_finite("homogeneous matrix", m.iter())?;
        check_bottom_rows::<_, 3, 1>(m)?;
        Self::from_parts(
            &m.fixed_view::<2, 2>(0, 0).into_owned(),
            &m.fixed_view::<2, 1>(0, 2).into_owned(),
        )
    }

    /// The motion of a homogeneous matrix the caller guarantees to be one (hot paths): the bottom row
    /// is ignored.
    #[inline]
    pub fn from_matrix_unchecked(m: &Matrix3<T>) -> Self {
        Self::new_unchecked(
            So2::from_cos_sin_unchecked(m.m11, m.m21),
            Vector2::new(m.m13, m.m23),
        )
    }

    /// The same motion with the rotation's `cos² + sin² = 1` restored.
    #[must_use]
    pub fn renormalized(&self) -> Self {
        Self::new_unchecked(self.rotation.renormalized(), self.translation)
    }
}

/// Conversion and access.
impl<T: Real> Se2<T> {
    /// The rotation `R`.
    #[inline]
    pub const fn rotation(&self) -> &So2<T> {
        &self.rotation
    }

    /// The translation `t` (the image of the origin).
    #[inline]
    pub const fn translation(&self) -> &Vector2<T> {
        &self.translation
    }

    /// The homogeneous matrix `[[R, t], [0, 1]]`.
    #[inline]
    pub fn to_homogeneous(&self) -> Matrix3<T> {
        let (c, s) = (self.rotation.cos(), self.rotation.sin());
        let (z, o) = (T::zero(), T::one());
        Matrix3::new(c, -s, self.translation.x, s, c, self.translation.y, z, z, o)
    }
}

/// `J v`: the quarter turn `[−v_y, v_x]`.
#[inline]
fn quarter_turn<T: Real>(v: &Vector2<T>) -> Vector2<T> {
    Vector2::new(-v.y, v.x)
}

/// `a I + b J` applied to `v`.
#[inline]
fn complex_times<T: Real>(a: T, b: T, v: &Vector2<T>) -> Vector2<T> {
    Vector2::new(a * v.x - b * v.y, b * v.x + a * v.y)
}

/// `(sin θ/θ, (1 − cos θ)/θ)`, the coefficients of `V(θ) = a I + b J`, from `(s, c) = sin_cos(θ/2)`:
/// `sin θ = 2 s c` and `1 − cos θ = 2 s²` (no cancellation). Taylor series to θ⁵ below the series
/// angle.
#[inline]
fn v_coefficients<T: Real>(theta: T, s: T, c: T) -> (T, T) {
    if theta.abs() < T::SERIES_ANGLE {
        let t2 = theta * theta;
        (
            T::one() - t2 / T::lit(6.0) + t2 * t2 / T::lit(120.0),
            theta * (T::lit(0.5) - t2 / T::lit(24.0) + t2 * t2 / T::lit(720.0)),
        )
    } else {
        let two_s = s + s;
        (two_s * c / theta, two_s * s / theta)
    }
}

/// `(θ/2) cot(θ/2)`, with `V(θ)⁻¹ = α I − (θ/2) J`, from `(s, c) = sin_cos(θ/2)`; series
/// `1 − θ²/12 − θ⁴/720` below the series angle. Infinite at θ = 2πk (k ≠ 0), where V is singular;
/// for huge θ it saturates at the largest finite value.
#[inline]
fn v_inverse_coefficient<T: Real>(theta: T, s: T, c: T) -> T {
    if theta.abs() < T::SERIES_ANGLE {
        let t2 = theta * theta;
        T::one() - t2 / T::lit(12.0) - t2 * t2 / T::lit(720.0)
    } else {
        let max = T::max_finite();
        (theta * T::lit(0.5) * c / s).clamp(-max, max)
    }
}

/// The last column of Jr above the rotation entry, `C ρ + D J ρ` with `C = (θ − sin θ)/θ²` and
/// `D = (1 − cos θ)/θ²`, from `(s, c) = sin_cos(θ/2)`; series to θ⁴ (relative) below the series angle.
#[inline]
fn coupling<T: Real>(theta: T, s: T, c: T, rho: &Vector2<T>) -> Vector2<T> {
    let (cc, dd) = if theta.abs() < T::SERIES_ANGLE {
        let t2 = theta * theta;
        (
            theta * (T::one() / T::lit(6.0) - t2 / T::lit(120.0) + t2 * t2 / T::lit(5040.0)),
            T::lit(0.5) - t2 / T::lit(24.0) + t2 * t2 / T::lit(720.0),
        )
    } else {
        let two_s = s + s;
        (
            theta_minus_sin_over_theta(theta, two_s * c) / theta,
            two_s * s / theta / theta,
        )
    };
    linear_saturating(rho, |rho| complex_times(cc, dd, rho))
}

/// `V(θ) ρ`, the translation of `exp([ρ; θ])`, valid (saturating) for every finite input.
#[inline]
fn v_times<T: Real>(theta: T, s: T, c: T, rho: &Vector2<T>) -> Vector2<T> {
    let (a, b) = v_coefficients(theta, s, c);
    linear_saturating(rho, |rho| complex_times(a, b, rho))
}

/// `V(θ)⁻¹ t`: the translation block of the tangent with rotation angle θ reaching translation `t`.
/// Regular for |θ| < 2π; saturating for huge `t`.
#[inline]
pub(crate) fn v_inverse_times<T: Real>(theta: T, t: &Vector2<T>) -> Vector2<T> {
    let (s, c) = (theta * T::lit(0.5)).sin_cos();
    let alpha = v_inverse_coefficient(theta, s, c);
    linear_saturating(t, |t| complex_times(alpha, -theta * T::lit(0.5), t))
}

#[inline]
fn split<T: Real>(v: &Tangent<T, 3>) -> (Vector2<T>, T) {
    (Vector2::new(v.x, v.y), v.z)
}

impl<T: Real> LieGroup<3> for Se2<T> {
    /// Matrices `[[0, −θ, ρ_x], [θ, 0, ρ_y], [0, 0, 0]]`.
    type Algebra = Matrix3<T>;

    #[inline]
    fn identity() -> Self {
        Self::new_unchecked(So2::identity(), Vector2::zeros())
    }

    /// `(R₁ R₂, t₁ + R₁ t₂)`; a translation beyond the scalar's range saturates at its largest finite
    /// value (never ±∞ or NaN).
    #[inline]
    fn compose(&self, other: &Self) -> Self {
        let r = self.rotation.as_unit_complex();
        Self::new_unchecked(
            self.rotation.compose(&other.rotation),
            saturated(self.translation + linear_saturating(&other.translation, |t| r * t)),
        )
    }

    /// `(Rᵀ, −Rᵀ t)`; saturating like [`compose`](Self::compose).
    #[inline]
    fn inverse(&self) -> Self {
        let r_inv = self.rotation.inverse();
        let r = r_inv.as_unit_complex();
        Self::new_unchecked(r_inv, -linear_saturating(&self.translation, |t| r * t))
    }

    /// `(R(θ), V(θ) ρ)` from one `sin_cos(θ/2)`, with the Taylor series of V below the series angle.
    /// Valid for every finite tangent: translations beyond the scalar's range saturate at its largest
    /// finite value.
    fn exp(v: &Tangent<T, 3>) -> Self {
        let (rho, theta) = split(v);
        let (s, c) = (theta * T::lit(0.5)).sin_cos();
        // cos θ = 1 − 2 s², sin θ = 2 s c: a unit complex number to rounding, accurate at 0 and π.
        let rotation = So2::from_unit_complex(UnitComplex::new_unchecked(Complex::new(
            T::one() - (s + s) * s,
            (s + s) * c,
        )));
        Self::new_unchecked(rotation, v_times(theta, s, c, &rho))
    }

    /// `[V(θ)⁻¹ t; θ]` with θ = atan2(sin, cos) in (−π, π] (a half turn gives +π, also with sine −0) and
    /// `V(θ)⁻¹ = (θ/2) cot(θ/2) I − (θ/2) J`, regular on that whole range (at θ = π it is −(π/2) J).
    fn log(&self) -> Tangent<T, 3> {
        // `So2::angle` keeps the principal branch (−π, π] also for a half turn stored with sine −0.
        let theta = self.rotation.angle();
        let rho = v_inverse_times(theta, &self.translation);
        Vector3::new(rho.x, rho.y, theta)
    }

    #[inline]
    fn hat(v: &Tangent<T, 3>) -> Matrix3<T> {
        let z = T::zero();
        Matrix3::new(z, -v.z, v.x, v.z, z, v.y, z, z, z)
    }

    /// `[a₁₃, a₂₃, (a₂₁ − a₁₂)/2]`.
    #[inline]
    fn vee(a: &Matrix3<T>) -> Tangent<T, 3> {
        Vector3::new(
            a.m13,
            a.m23,
            crate::rotation_vector::half_difference(a.m21, a.m12),
        )
    }

    /// `H a H⁻¹` with the homogeneous matrices of `self` and its inverse, saturating at the
    /// largest finite value (a translation or `a` near overflow).
    fn conjugate_algebra(&self, a: &Matrix3<T>) -> Matrix3<T> {
        crate::pose::conjugate_saturating(
            &self.to_homogeneous(),
            a,
            &self.inverse().to_homogeneous(),
        )
    }

    /// `[[R, (t_y, −t_x)ᵀ], [0, 1]]`.
    fn adjoint(&self) -> Jacobian<T, 3, 3> {
        let (c, s) = (self.rotation.cos(), self.rotation.sin());
        let t = &self.translation;
        let (z, o) = (T::zero(), T::one());
        Matrix3::new(c, -s, t.y, s, c, -t.x, z, z, o)
    }

    /// `Jr([ρ; θ]) = [[V(−θ), C ρ + D J ρ], [0, 1]]` with `V(−θ) = (sin θ/θ) I − ((1 − cos θ)/θ) J`,
    /// `C = (θ − sin θ)/θ²` and `D = (1 − cos θ)/θ²` (derived in docs/manifolds/poses.md).
    fn right_jacobian(v: &Tangent<T, 3>) -> Jacobian<T, 3, 3> {
        let (rho, theta) = split(v);
        let (s, c) = (theta * T::lit(0.5)).sin_cos();
        let (a, b) = v_coefficients(theta, s, c);
        let col = coupling(theta, s, c, &rho);
        let (z, o) = (T::zero(), T::one());
        Matrix3::new(a, b, col.x, -b, a, col.y, z, z, o)
    }

    /// `Jr⁻¹([ρ; θ]) = [[W, −W (C ρ + D J ρ)], [0, 1]]` with `W = V(−θ)⁻¹ = (θ/2) cot(θ/2) I + (θ/2) J`;
    /// singular at θ = 2πk (k ≠ 0), saturating (never NaN) for huge tangents.
    fn right_jacobian_inverse(v: &Tangent<T, 3>) -> Jacobian<T, 3, 3> {
        let (rho, theta) = split(v);
        let (s, c) = (theta * T::lit(0.5)).sin_cos();
        let alpha = v_inverse_coefficient(theta, s, c);
        let half = theta * T::lit(0.5);
        let w = Matrix2::new(alpha, -half, half, alpha);
        let col = -mul_saturating(&w, &coupling(theta, s, c, &rho));
        let (z, o) = (T::zero(), T::one());
        Matrix3::new(alpha, -half, col.x, half, alpha, col.y, z, z, o)
    }
}

impl_manifold_for_group!(Se2, 3, |x| {
    crate::Manifold::is_finite(&x.rotation)
        && x.translation.iter().all(nalgebra::ComplexField::is_finite)
});

impl<T: Real> GroupAction<3, 2> for Se2<T> {
    /// `R p + t`, saturating at the largest finite value (like [`compose`](Self::compose)).
    #[inline]
    fn act(&self, p: &Vector2<T>) -> Vector2<T> {
        saturated(self.rotation.as_unit_complex() * p + self.translation)
    }

    /// `[R, R J p]`: the translation block moves the point along the body axes, the angle turns it
    /// about the body origin; saturating for points near the largest value.
    #[inline]
    fn j_act_self(&self, p: &Vector2<T>) -> Jacobian<T, 2, 3> {
        let (c, s) = (self.rotation.cos(), self.rotation.sin());
        let turned = saturated(self.rotation.as_unit_complex() * quarter_turn(p));
        nalgebra::Matrix2x3::new(c, -s, turned.x, s, c, turned.y)
    }

    /// `R`.
    #[inline]
    fn j_act_point(&self, _p: &Vector2<T>) -> Jacobian<T, 2, 2> {
        self.rotation.to_matrix()
    }
}

impl_pose_comparisons_and_conversions!(Se2, So2, UnitComplex, 2);

#[cfg(test)]
mod tests {
    //! The coefficient functions against their Taylor series summed to convergence (general terms,
    //! not the truncated forms above), on both sides of the series threshold.
    use super::*;

    /// `Σ_(k≥0) (−1)^k θ^(2k + p) / (2k + q)!` over 40 terms.
    fn series(theta: f64, p: i32, q: u32) -> f64 {
        let factorial = |n: u32| (1..=n).map(f64::from).product::<f64>();
        (0..40_u32)
            .map(|k| {
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                sign * theta.powi(2 * i32::try_from(k).unwrap() + p) / factorial(2 * k + q)
            })
            .sum()
    }

    fn assert_rel(got: f64, expected: f64, tol: f64, what: &str) {
        let err = ((got - expected) / expected).abs();
        assert!(
            err <= tol,
            "{what}: {got:e} vs {expected:e}, relative {err:e}"
        );
    }

    #[test]
    fn coefficients_match_the_converged_series() {
        for theta in [1e-6_f64, 1e-3, 0.0099, 0.01, 0.1, 1.0, 2.0, 3.0] {
            let (s, c) = (theta / 2.0).sin_cos();
            let (a, b) = v_coefficients(theta, s, c);
            // sin θ/θ = Σ (−1)^k θ^2k/(2k+1)!, (1 − cos θ)/θ = Σ (−1)^k θ^(2k+1)/(2k+2)!.
            assert_rel(a, series(theta, 0, 1), 4.0 * f64::EPSILON, "sin θ/θ");
            assert_rel(b, series(theta, 1, 2), 4.0 * f64::EPSILON, "(1 − cos θ)/θ");
            let col = coupling(theta, s, c, &Vector2::new(1.0, 0.0));
            // (θ − sin θ)/θ² = Σ (−1)^k θ^(2k+1)/(2k+3)!, (1 − cos θ)/θ² = Σ (−1)^k θ^2k/(2k+2)!.
            assert_rel(
                col.x,
                series(theta, 1, 3),
                16.0 * f64::EPSILON,
                "(θ − sin θ)/θ²",
            );
            assert_rel(
                col.y,
                series(theta, 0, 2),
                4.0 * f64::EPSILON,
                "(1 − cos θ)/θ²",
            );
            // (θ/2) cot(θ/2) = (θ/2) cos(θ/2) / sin(θ/2): the quotient of the two converged sums.
            let half = theta / 2.0;
            let cot = series(half, 0, 0) / series(half, 1, 1);
            assert_rel(
                v_inverse_coefficient(theta, s, c),
                half * cot,
                8.0 * f64::EPSILON,
                "α",
            );
        }
    }
}
