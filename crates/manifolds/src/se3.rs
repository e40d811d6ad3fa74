//! [`Se3`]: rigid motions of space.

use crate::error::{ManifoldError, check_finite};
use crate::lie_group::{GroupAction, LieGroup, impl_manifold_for_group};
use crate::manifold::{Jacobian, Tangent};
use crate::pose::{
    check_bottom_rows, impl_pose_comparisons_and_conversions, linear_saturating, mul_saturating,
    saturated, theta_minus_sin_over_theta,
};
use crate::real::Real;
use crate::rotation_vector;
use crate::so3::So3;
use nalgebra::{Matrix3, Matrix3x6, Matrix4, Matrix6, Vector3, Vector6};

/// A rigid motion of space, an element of SE(3): the map `p ↦ R p + t` with a rotation `R`
/// ([`So3`], a unit quaternion) and a translation `t`.
///
/// # Group structure
/// `(R₁, t₁) · (R₂, t₂) = (R₁ R₂, t₁ + R₁ t₂)` (apply the right factor first) and
/// `(R, t)⁻¹ = (Rᵀ, −Rᵀ t)`; the matrix of the motion is the homogeneous `[[R, t], [0, 1]]`
/// ([`to_homogeneous`](Self::to_homogeneous)). It acts on points of R³ by `g · p = R p + t`. The
/// rotation compares up to the quaternion sign, like [`So3`].
///
/// # Tangent coordinates
/// `v = [ρ; φ]`: **translation block ρ first, rotation vector φ last** (the order of manif and
/// Sophus; [`Se2`](crate::Se2) uses the same). `hat(v) = [[hat(φ), ρ], [0, 0]]` and
/// `exp(v) = (exp(φ), V(φ) ρ)` with `V(φ) = I + ((1 − cos θ)/θ²) hat(φ) + ((θ − sin θ)/θ³) hat(φ)²`,
/// θ = |φ|, the left Jacobian of SO(3). Perturbations act on the right like everywhere in the crate,
/// `x ⊞ v = x · exp(v)`, so ρ is a displacement in the body frame of `x`.
///
/// `log` returns the rotation vector of [`So3::log`] (angle in [0, π], accurate at π) and
/// `ρ = V(φ)⁻¹ t`, regular on that whole range (V is singular only at θ = 2πk, k ≥ 1). exp is
/// injective for θ < π; `DIM` = 6.
///
/// # Example
/// ```
/// use liebayes_manifolds::{GroupAction, LieGroup, Manifold, Se3, So3};
/// use nalgebra::{Vector3, Vector6};
///
/// let x = Se3::new(So3::from_axis_angle(&Vector3::z(), 0.5)?, Vector3::new(1.0, 2.0, 3.0))?;
/// // Move 0.1 forward along the body x axis: a right perturbation.
/// let y = x.retract(&Vector6::new(0.1, 0.0, 0.0, 0.0, 0.0, 0.0));
/// let forward = x.rotation().rotate(&Vector3::x()) * 0.1;
/// assert!((y.translation() - (x.translation() + forward)).norm() < 1e-15);
/// assert!((x.local(&y) - Vector6::new(0.1, 0.0, 0.0, 0.0, 0.0, 0.0)).norm() < 1e-15);
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Se3<T: Real> {
    rotation: So3<T>,
    translation: Vector3<T>,
}

/// Construction.
impl<T: Real> Se3<T> {
    /// The motion `p ↦ R p + t`, checked for finiteness (of the translation and of the rotation's
    /// quaternion).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn new(rotation: So3<T>, translation: Vector3<T>) -> Result<Self, ManifoldError> {
        check_finite("rotation", rotation.to_quaternion_wxyz().iter())?;
        check_finite("translation", translation.iter())?;
        Ok(Self::new_unchecked(rotation, translation))
    }

    /// The motion `p ↦ R p + t` without any check (hot paths).
    #[inline]
    pub const fn new_unchecked(rotation: So3<T>, translation: Vector3<T>) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// The motion with rotation matrix `r` and translation `t`, checked for finiteness,
    /// orthonormality of `r` and determinant +1 (tolerances of [`constants`](crate::constants)).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotOrthonormal`] or
    /// [`ManifoldError::NotProperRotation`].
    pub fn from_parts(
        rotation: &Matrix3<T>,
        translation: &Vector3<T>,
    ) -> Result<Self, ManifoldError> {
        check_finite("translation", translation.iter())?;
        Ok(Self::new_unchecked(
            So3::from_matrix(rotation)?,
            *translation,
        ))
    }

    /// The motion of a homogeneous 4×4 matrix `[[R, t], [0, 1]]`, checked for finiteness, a bottom row
    /// `[0, 0, 0, 1]` within
    /// [`ORTHONORMAL_TOLERANCE`](crate::constants::Thresholds::ORTHONORMAL_TOLERANCE), and a rotation
    /// block as in [`from_parts`](Self::from_parts).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotHomogeneous`],
    /// [`ManifoldError::NotOrthonormal`] or [`ManifoldError::NotProperRotation`].
    pub fn from_matrix(m: &Matrix4<T>) -> Result<Self, ManifoldError> {
        check_finite("homogeneous matrix", m.iter())?;
        check_bottom_rows::<_, 4, 1>(m)?;
        Self::from_parts(
            &m.fixed_view::<3, 3>(0, 0).into_owned(),
            &m.fixed_view::<3, 1>(0, 3).into_owned(),
        )
    }

    /// The motion of a homogeneous matrix the caller guarantees to be one (hot paths): the bottom row
    /// is ignored.
    #[inline]
    pub fn from_matrix_unchecked(m: &Matrix4<T>) -> Self {
        Self::new_unchecked(
            So3::from_matrix_unchecked(&m.fixed_view::<3, 3>(0, 0).into_owned()),
            m.fixed_view::<3, 1>(0, 3).into_owned(),
        )
    }

    /// The same motion with the rotation's quaternion renormalised (after long chains of products).
    #[must_use]
    pub fn renormalized(&self) -> Self {
        Self::new_unchecked(self.rotation.renormalized(), self.translation)
    }
}

/// Conversion and access.
impl<T: Real> Se3<T> {
    /// The rotation `R`.
    #[inline]
    pub const fn rotation(&self) -> &So3<T> {
        &self.rotation
    }

    /// The translation `t` (the image of the origin).
    #[inline]
    pub const fn translation(&self) -> &Vector3<T> {
        &self.translation
    }

    /// The homogeneous matrix `[[R, t], [0, 1]]`.
    pub fn to_homogeneous(&self) -> Matrix4<T> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&self.rotation.to_matrix());
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }
}

/// The translation and rotation blocks `(ρ, φ)` of a tangent.
#[inline]
fn split<T: Real>(v: &Tangent<T, 6>) -> (Vector3<T>, Vector3<T>) {
    (
        Vector3::new(v[0], v[1], v[2]),
        Vector3::new(v[3], v[4], v[5]),
    )
}

/// `[[a, b], [0, d]]` from 3×3 blocks.
#[inline]
fn upper_block_triangular<T: Real>(a: &Matrix3<T>, b: &Matrix3<T>, d: &Matrix3<T>) -> Matrix6<T> {
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(a);
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(b);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(d);
    m
}

/// `V(φ) ρ`, the translation of `exp([ρ; φ])`; `V(φ) = Jl(φ) = Jr(−φ)` of SO(3). Saturating for
/// translations beyond the scalar's range.
#[inline]
pub(crate) fn exp_translation<T: Real>(phi: &Vector3<T>, rho: &Vector3<T>) -> Vector3<T> {
    let v = rotation_vector::right_jacobian(&-phi);
    linear_saturating(rho, |rho| v * rho)
}

/// `V(φ)⁻¹ t`: the translation block of the tangent with rotation block φ reaching translation `t`,
/// with `V(φ)⁻¹ = Jr⁻¹(−φ) = I − hat(φ)/2 + (1/θ² − cot(θ/2)/(2θ)) hat(φ)²`. Regular for θ < 2π.
#[inline]
pub(crate) fn v_inverse_times<T: Real>(phi: &Vector3<T>, t: &Vector3<T>) -> Vector3<T> {
    let v_inv = rotation_vector::right_jacobian_inverse(&-phi);
    linear_saturating(t, |t| v_inv * t)
}

/// The coupling block `Q(ρ, φ)` of `Jr([ρ; φ]) = [[Jr(φ), Q], [0, Jr(φ)]]`, with P = hat(ρ), Φ = hat(φ):
///
/// `Q = −P/2 + c₂ (ΦP + PΦ − ΦPΦ) − c₃ (Φ²P + PΦ² − 3ΦPΦ) + c₄ (ΦPΦ² + Φ²PΦ)`,
/// `c₂ = (θ − sin θ)/θ³`, `c₃ = (θ² + 2 cos θ − 2)/(2θ⁴)`, `c₄ = (2θ − 3 sin θ + θ cos θ)/(2θ⁵)`
///
/// (Barfoot and Furgale's left-Jacobian block at (−ρ, −φ); derived in docs/manifolds/poses.md).
/// With `ΦPΦ = −(φ·ρ)Φ` and `Φ² = φφᵀ − θ² I` the products collapse to vectors: for an axis `a`
/// (φ itself below the series angle, the unit axis φ/θ above) and `d = a·ρ`,
///
/// `Q = β P + γ d hat(a) + k₁ (ρaᵀ + aρᵀ) − 2d (δ I + k₄ aaᵀ)`
///
/// with, against the unit axis, `β = −(1 − cos θ)/θ²`, `γ = E − 1 + 2(1 − cos θ)/θ²`, `k₁ = E/θ`,
/// `δ = ((1 − cos θ) − E)/(2θ)`, `k₄ = (3E − (1 − cos θ))/(2θ)`, where `E = (θ − sin θ)/θ` comes from
/// [`theta_minus_sin_over_theta`] and `1 − cos θ = 2 sin²(θ/2)`: each accurate to a few eps absolute
/// and bounded for huge θ. Against φ itself they are the Taylor series to θ⁴ of `θ²c₃ − 1/2`,
/// `c₂ − 2c₃`, `c₂`, `c₂ − θ²c₄` and `c₄`.
///
/// For a finite φ whose norm overflows (components near the largest finite value) the block is
/// taken at φ/2: every coefficient is within O(1/θ) < 1e-307 of its limit at either angle. A φ with
/// an infinite or NaN component has no block: every entry is NaN.
pub(crate) fn coupling<T: Real>(rho: &Vector3<T>, phi: &Vector3<T>) -> Matrix3<T> {
    let theta = crate::real::stable_norm(phi);
    if !nalgebra::ComplexField::is_finite(&theta) {
        if phi.iter().all(|x| nalgebra::ComplexField::is_finite(x)) {
            return coupling(rho, &(phi * T::lit(0.5)));
        }
        return Matrix3::repeat(T::lit(f64::NAN));
    }
    let (a, [beta, gamma, k1, delta, k4]) = if theta < T::SERIES_ANGLE {
        let t2 = theta * theta;
        let t4 = t2 * t2;
        let series = |c0: f64, c2: f64, c4: f64| T::lit(c0) + t2 * T::lit(c2) + t4 * T::lit(c4);
        (
            *phi,
            [
                series(-1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0),
                series(1.0 / 12.0, -1.0 / 180.0, 1.0 / 6720.0),
                series(1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0),
                series(1.0 / 6.0, -1.0 / 60.0, 1.0 / 1680.0),
                series(1.0 / 120.0, -1.0 / 2520.0, 1.0 / 120_960.0),
            ],
        )
    } else {
        let (s, c) = (theta * T::lit(0.5)).sin_cos();
        let versine = (s + s) * s; // 1 − cos θ without cancellation
        let e = theta_minus_sin_over_theta(theta, (s + s) * c);
        let two_theta = theta + theta;
        let beta = -(versine / theta / theta);
        (
            phi / theta,
            [
                beta,
                e - T::one() - beta - beta,
                e / theta,
                (versine - e) / two_theta,
                (T::lit(3.0) * e - versine) / two_theta,
            ],
        )
    };
    let d = a.dot(rho);
    let symmetric = rho * a.transpose() + a * rho.transpose();
    rotation_vector::hat(&(rho * beta + a * (gamma * d))) + symmetric * k1
        - (Matrix3::identity() * delta + a * a.transpose() * k4) * (d + d)
}

impl<T: Real> LieGroup<6> for Se3<T> {
    /// Matrices `[[hat(φ), ρ], [0, 0]]`.
    type Algebra = Matrix4<T>;

    #[inline]
    fn identity() -> Self {
        Self::new_unchecked(So3::identity(), Vector3::zeros())
    }

    /// `(R₁ R₂, t₁ + R₁ t₂)`; a translation beyond the scalar's range saturates at its largest
    /// finite value.
    #[inline]
    fn compose(&self, other: &Self) -> Self {
        Self::new_unchecked(
            self.rotation.compose(&other.rotation),
            saturated(
                self.translation
                    + linear_saturating(&other.translation, |t| self.rotation.rotate(t)),
            ),
        )
    }

    /// `(Rᵀ, −Rᵀ t)`; saturating like [`compose`](Self::compose) (a rotated translation's
    /// coordinates can exceed the original's by up to √3).
    #[inline]
    fn inverse(&self) -> Self {
        let r_inv = self.rotation.inverse();
        Self::new_unchecked(
            r_inv,
            -linear_saturating(&self.translation, |t| r_inv.rotate(t)),
        )
    }

    /// `(exp(φ), V(φ) ρ)`, with the Taylor series of the coefficients below the series angle. Valid
    /// for every finite tangent: translations beyond the scalar's range saturate at its largest
    /// finite value.
    fn exp(v: &Tangent<T, 6>) -> Self {
        let (rho, phi) = split(v);
        Self::new_unchecked(So3::exp(&phi), exp_translation(&phi, &rho))
    }

    /// `[V(φ)⁻¹ t; φ]` with φ the principal rotation vector of [`So3::log`] (angle in [0, π]; at π
    /// the stored axis sign), where `V(φ)⁻¹` is regular: at θ = π it is `I − (π/2) U + U²`.
    fn log(&self) -> Tangent<T, 6> {
        let phi = self.rotation.log();
        let rho = v_inverse_times(&phi, &self.translation);
        Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
    }

    fn hat(v: &Tangent<T, 6>) -> Matrix4<T> {
        let (rho, phi) = split(v);
        let mut m = Matrix4::zeros();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&rotation_vector::hat(&phi));
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&rho);
        m
    }

    /// `[a₁₄, a₂₄, a₃₄, vee(antisymmetric part of the rotation block)]`.
    fn vee(a: &Matrix4<T>) -> Tangent<T, 6> {
        let phi = rotation_vector::vee(&a.fixed_view::<3, 3>(0, 0).into_owned());
        Vector6::new(a.m14, a.m24, a.m34, phi.x, phi.y, phi.z)
    }

    /// `H a H⁻¹` with the homogeneous matrices of `self` and its inverse; saturating, never NaN,
    /// for entries whose products overflow.
    fn conjugate_algebra(&self, a: &Matrix4<T>) -> Matrix4<T> {
        crate::pose::conjugate_saturating(
            &self.to_homogeneous(),
            a,
            &self.inverse().to_homogeneous(),
        )
    }

    /// `[[R, hat(t) R], [0, R]]`.
    fn adjoint(&self) -> Jacobian<T, 6, 6> {
        let r = self.rotation.to_matrix();
        upper_block_triangular(
            &r,
            &mul_saturating(&rotation_vector::hat(&self.translation), &r),
            &r,
        )
    }

    /// `Jr([ρ; φ]) = [[Jr(φ), Q(ρ, φ)], [0, Jr(φ)]]` with Jr(φ) of SO(3) and the coupling block Q
    /// (see docs/manifolds/poses.md); saturating, never NaN, for huge translations.
    fn right_jacobian(v: &Tangent<T, 6>) -> Jacobian<T, 6, 6> {
        let (rho, phi) = split(v);
        let j = rotation_vector::right_jacobian(&phi);
        let q = linear_saturating(&rho, |rho| coupling(rho, &phi));
        upper_block_triangular(&j, &q, &j)
    }

    /// `Jr⁻¹([ρ; φ]) = [[Jr⁻¹(φ), −Jr⁻¹(φ) Q Jr⁻¹(φ)], [0, Jr⁻¹(φ)]]`; singular at θ = 2πk (k ≥ 1),
    /// saturating (never NaN) for huge tangents.
    fn right_jacobian_inverse(v: &Tangent<T, 6>) -> Jacobian<T, 6, 6> {
        let (rho, phi) = split(v);
        let j_inv = rotation_vector::right_jacobian_inverse(&phi);
        let q = linear_saturating(&rho, |rho| coupling(rho, &phi));
        let off = -mul_saturating(&mul_saturating(&j_inv, &q), &j_inv);
        upper_block_triangular(&j_inv, &off, &j_inv)
    }
}

impl_manifold_for_group!(Se3, 6, |x| {
    crate::Manifold::is_finite(&x.rotation)
        && x.translation.iter().all(nalgebra::ComplexField::is_finite)
});

impl<T: Real> GroupAction<6, 3> for Se3<T> {
    /// `R p + t`, saturating at the largest finite value (like [`compose`](Self::compose)).
    #[inline]
    fn act(&self, p: &Vector3<T>) -> Vector3<T> {
        saturated(self.rotation.rotate(p) + self.translation)
    }

    /// `[R, −R hat(p)]`: the translation block moves the point along the body axes, the rotation
    /// block turns it about the body origin; saturating for points near the largest value.
    fn j_act_self(&self, p: &Vector3<T>) -> Jacobian<T, 3, 6> {
        let r = self.rotation.to_matrix();
        let mut j = Matrix3x6::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        j.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&-linear_saturating(p, |p| r * rotation_vector::hat(p)));
        j
    }

    /// `R`.
    #[inline]
    fn j_act_point(&self, _p: &Vector3<T>) -> Jacobian<T, 3, 3> {
        self.rotation.to_matrix()
    }
}

impl_pose_comparisons_and_conversions!(Se3, So3, UnitQuaternion, 3);

#[cfg(test)]
mod tests {
    //! The coupling block against its defining series, summed to convergence: with ad([ρ; φ]) =
    //! [[Φ, P], [0, Φ]], `Jr = Σ (−ad)^n/(n+1)!`, whose upper-right block is
    //! `Q = Σ_(n≥1) (−1)^n/(n+1)! Σ_(i+j=n−1) Φ^i P Φ^j`, an evaluation independent of the closed form
    //! and of its series branch.
    use super::*;

    fn reference(rho: &Vector3<f64>, phi: &Vector3<f64>) -> Matrix3<f64> {
        let p = rotation_vector::hat(rho);
        let f = rotation_vector::hat(phi);
        let mut powers = vec![Matrix3::<f64>::identity()];
        for i in 1..60 {
            powers.push(powers[i - 1] * f);
        }
        let mut q = Matrix3::zeros();
        let mut factorial = 1.0;
        for n in 1..59_usize {
            factorial *= (n + 1) as f64;
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            let sum: Matrix3<f64> = (0..n).map(|i| powers[i] * p * powers[n - 1 - i]).sum();
            q += sum * (sign / factorial);
        }
        q
    }

    #[test]
    fn coupling_matches_its_defining_series_on_both_sides_of_the_threshold() {
        let rho = Vector3::new(0.7, -1.3, 2.1);
        let axis = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        for theta in [
            0.0, 1e-8, 1e-4, 1e-3, 0.0099, 0.01, 0.0101, 0.1, 0.5, 0.999, 1.0, 1.001, 2.0, 3.0,
        ] {
            let phi = axis * theta;
            let got = coupling(&rho, &phi);
            let expected = reference(&rho, &phi);
            // The reference sums terms up to e^θ |ρ| in size: its own rounding is about that times eps.
            let tol = 8.0 * f64::EPSILON * theta.exp() * rho.norm();
            let err = (got - expected).amax();
            assert!(
                err <= tol,
                "θ = {theta}: error {err:e} > {tol:e}\n{got}\n{expected}"
            );
        }
    }

    #[test]
    fn coupling_is_bounded_and_finite_for_huge_angles() {
        let rho = Vector3::new(1.0, -2.0, 0.5);
        for theta in [1e10_f64, 1e200, 1e308] {
            let q = coupling(&rho, &(Vector3::new(0.6, 0.0, 0.8) * theta));
            assert!(
                q.iter().all(|x| x.is_finite() && x.abs() <= 10.0),
                "θ = {theta}: {q}"
            );
        }
    }
}
