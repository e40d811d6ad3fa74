//! [`Se23`]: extended poses, the group SE₂(3) of rotation, velocity and position.

use crate::error::{ManifoldError, check_finite};
use crate::lie_group::{GroupAction, LieGroup, impl_manifold_for_group};
use crate::manifold::{Jacobian, Tangent};
use crate::pose::{
    check_bottom_rows, impl_pose_comparisons, linear_saturating, mul_saturating, saturated,
};
use crate::real::Real;
use crate::rotation_vector;
use crate::se3::Se3;
use crate::se3::{coupling, exp_translation, v_inverse_times};
use crate::so3::So3;
use nalgebra::{Matrix3, Matrix5, Vector3};

/// An extended pose, an element of SE₂(3): a rotation `R` ([`So3`], a unit quaternion), a velocity
/// `v` and a position `p`, the state of an inertial navigation filter (Barrau and Bonnabel's group of
/// "double direct isometries").
///
/// # Group structure
/// `(R₁, v₁, p₁) · (R₂, v₂, p₂) = (R₁ R₂, v₁ + R₁ v₂, p₁ + R₁ p₂)` and
/// `(R, v, p)⁻¹ = (Rᵀ, −Rᵀ v, −Rᵀ p)`; the matrix of the element is the 5×5
/// `[[R, v, p], [0, 1, 0], [0, 0, 1]]` ([`to_matrix`](Self::to_matrix)). It acts on points of R³ like
/// the pose `(R, p)`, `g · x = R x + p` (the velocity does not move points; this is manif's action).
/// The rotation compares up to the quaternion sign, like [`So3`].
///
/// # Tangent coordinates
/// `ξ = [ρ; φ; ν]`: **position block ρ first, rotation vector φ in the middle, velocity block ν
/// last**, the order of manif's `SE_2_3` (its `lin`, `ang`, `lin2`). `hat(ξ)` is the 5×5 matrix
/// `[[hat(φ), ν, ρ], [0, 0, 0], [0, 0, 0]]` (the columns follow the element's matrix, velocity
/// before position) and `exp(ξ) = (exp(φ), V(φ) ν, V(φ) ρ)` with `V(φ)` the left Jacobian of SO(3),
/// as for [`Se3`]. Perturbations act on the right like everywhere in the crate, `x ⊞ ξ = x · exp(ξ)`,
/// so ρ and ν are displacements in the body frame of `x`.
///
/// `log` returns the rotation vector of [`So3::log`] (angle in [0, π], accurate at π),
/// `ρ = V(φ)⁻¹ p` and `ν = V(φ)⁻¹ v`, regular on that whole range. exp is injective for θ = |φ| < π;
/// `DIM` = 9.
///
/// # Example
/// ```
/// use liebayes_manifolds::{LieGroup, Manifold, Se23, So3};
/// use nalgebra::{SVector, Vector3};
///
/// let x = Se23::new(
///     So3::from_axis_angle(&Vector3::z(), 0.5)?,
///     Vector3::new(1.0, 0.0, 0.0),
///     Vector3::new(0.0, 2.0, 3.0),
/// )?;
/// // A body-frame velocity correction of 0.1 along x: the last block of the tangent.
/// let mut dx = SVector::<f64, 9>::zeros();
/// dx[6] = 0.1;
/// let y = x.retract(&dx);
/// let forward = x.rotation().rotate(&Vector3::x()) * 0.1;
/// assert!((y.velocity() - (x.velocity() + forward)).norm() < 1e-15);
/// assert_eq!(y.position(), x.position());
/// assert!((x.local(&y) - dx).norm() < 1e-15);
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Se23<T: Real> {
    rotation: So3<T>,
    velocity: Vector3<T>,
    position: Vector3<T>,
}

/// Construction.
impl<T: Real> Se23<T> {
    /// The extended pose `(R, v, p)`, checked for finiteness (of the velocity, the position and the
    /// rotation's quaternion).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`].
    pub fn new(
        rotation: So3<T>,
        velocity: Vector3<T>,
        position: Vector3<T>,
    ) -> Result<Self, ManifoldError> {
        check_finite("rotation", rotation.to_quaternion_wxyz().iter())?;
        check_finite("velocity", velocity.iter())?;
        check_finite("position", position.iter())?;
        Ok(Self::new_unchecked(rotation, velocity, position))
    }

    /// The extended pose `(R, v, p)` without any check (hot paths).
    #[inline]
    pub const fn new_unchecked(
        rotation: So3<T>,
        velocity: Vector3<T>,
        position: Vector3<T>,
    ) -> Self {
        Self {
            rotation,
            velocity,
            position,
        }
    }

    /// The extended pose with rotation matrix `r`, velocity `v` and position `p`, checked for
    /// finiteness, orthonormality of `r` and determinant +1 (tolerances of
    /// [`constants`](crate::constants)).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotOrthonormal`] or
    /// [`ManifoldError::NotProperRotation`].
    pub fn from_parts(
        rotation: &Matrix3<T>,
        velocity: &Vector3<T>,
        position: &Vector3<T>,
    ) -> Result<Self, ManifoldError> {
        check_finite("velocity", velocity.iter())?;
        check_finite("position", position.iter())?;
        Ok(Self::new_unchecked(
            So3::from_matrix(rotation)?,
            *velocity,
            *position,
        ))
    }

    /// The extended pose of a 5×5 matrix `[[R, v, p], [0, 1, 0], [0, 0, 1]]`, checked for finiteness,
    /// bottom rows `[0, 0, 0, 1, 0]` and `[0, 0, 0, 0, 1]` within
    /// [`ORTHONORMAL_TOLERANCE`](crate::constants::Thresholds::ORTHONORMAL_TOLERANCE), and a rotation
    /// block as in [`from_parts`](Self::from_parts).
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], [`ManifoldError::NotHomogeneous`],
    /// [`ManifoldError::NotOrthonormal`] or [`ManifoldError::NotProperRotation`].
    pub fn from_matrix(m: &Matrix5<T>) -> Result<Self, ManifoldError> {
        check_finite("extended pose matrix", m.iter())?;
        check_bottom_rows::<_, 5, 2>(m)?;
        let (r, v, p) = blocks(m);
        Self::from_parts(&r, &v, &p)
    }

    /// The extended pose of a matrix the caller guarantees to be one (hot paths): the bottom rows are
    /// ignored.
    #[inline]
    pub fn from_matrix_unchecked(m: &Matrix5<T>) -> Self {
        let (r, v, p) = blocks(m);
        Self::new_unchecked(So3::from_matrix_unchecked(&r), v, p)
    }

    /// The same element with the rotation's quaternion renormalised (after long chains of products).
    #[must_use]
    pub fn renormalized(&self) -> Self {
        Self::new_unchecked(self.rotation.renormalized(), self.velocity, self.position)
    }
}

/// Conversion and access.
impl<T: Real> Se23<T> {
    /// The rotation `R` (the attitude: body to world).
    #[inline]
    pub const fn rotation(&self) -> &So3<T> {
        &self.rotation
    }

    /// The velocity `v`.
    #[inline]
    pub const fn velocity(&self) -> &Vector3<T> {
        &self.velocity
    }

    /// The position `p` (the image of the origin under the action).
    #[inline]
    pub const fn position(&self) -> &Vector3<T> {
        &self.position
    }

    /// The rigid motion `(R, p)`, dropping the velocity: `x.pose().act(q) == x.act(q)`.
    #[inline]
    pub const fn pose(&self) -> Se3<T> {
        Se3::new_unchecked(self.rotation, self.position)
    }

    /// The 5×5 matrix `[[R, v, p], [0, 1, 0], [0, 0, 1]]`.
    pub fn to_matrix(&self) -> Matrix5<T> {
        let mut m = Matrix5::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&self.rotation.to_matrix());
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.velocity);
        m.fixed_view_mut::<3, 1>(0, 4).copy_from(&self.position);
        m
    }
}

/// The blocks `(R, v, p)` of a 5×5 matrix `[[R, v, p], [·, ·, ·]]`.
fn blocks<T: Real>(m: &Matrix5<T>) -> (Matrix3<T>, Vector3<T>, Vector3<T>) {
    (
        m.fixed_view::<3, 3>(0, 0).into_owned(),
        m.fixed_view::<3, 1>(0, 3).into_owned(),
        m.fixed_view::<3, 1>(0, 4).into_owned(),
    )
}

/// The blocks `(ρ, φ, ν)` of a tangent `[ρ; φ; ν]`.
#[inline]
fn split<T: Real>(xi: &Tangent<T, 9>) -> (Vector3<T>, Vector3<T>, Vector3<T>) {
    (
        xi.fixed_rows::<3>(0).into_owned(),
        xi.fixed_rows::<3>(3).into_owned(),
        xi.fixed_rows::<3>(6).into_owned(),
    )
}

/// The tangent `[ρ; φ; ν]`.
#[inline]
fn join<T: Real>(rho: &Vector3<T>, phi: &Vector3<T>, nu: &Vector3<T>) -> Tangent<T, 9> {
    Tangent::from_fn(|i, _| match i {
        0..3 => rho[i],
        3..6 => phi[i - 3],
        _ => nu[i - 6],
    })
}

/// The 9×9 matrix `[[d, a, 0], [0, d, 0], [0, b, d]]` from 3×3 blocks: the shape of the adjoint and
/// of the Jacobians in the order `[ρ; φ; ν]`.
#[inline]
fn arrow<T: Real>(d: &Matrix3<T>, a: &Matrix3<T>, b: &Matrix3<T>) -> Jacobian<T, 9, 9> {
    let mut m = Jacobian::<T, 9, 9>::zeros();
    for k in [0, 3, 6] {
        m.fixed_view_mut::<3, 3>(k, k).copy_from(d);
    }
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(a);
    m.fixed_view_mut::<3, 3>(6, 3).copy_from(b);
    m
}

impl<T: Real> LieGroup<9> for Se23<T> {
    /// Matrices `[[hat(φ), ν, ρ], [0, 0, 0], [0, 0, 0]]`.
    type Algebra = Matrix5<T>;

    #[inline]
    fn identity() -> Self {
        Self::new_unchecked(So3::identity(), Vector3::zeros(), Vector3::zeros())
    }

    /// `(R₁ R₂, v₁ + R₁ v₂, p₁ + R₁ p₂)`; a velocity or position beyond the scalar's range saturates
    /// at its largest finite value.
    #[inline]
    fn compose(&self, other: &Self) -> Self {
        let moved = |own: &Vector3<T>, theirs: &Vector3<T>| {
            saturated(own + linear_saturating(theirs, |x| self.rotation.rotate(x)))
        };
        Self::new_unchecked(
            self.rotation.compose(&other.rotation),
            moved(&self.velocity, &other.velocity),
            moved(&self.position, &other.position),
        )
    }

    /// `(Rᵀ, −Rᵀ v, −Rᵀ p)`; saturating like [`compose`](Self::compose).
    #[inline]
    fn inverse(&self) -> Self {
        let r_inv = self.rotation.inverse();
        let back = |x: &Vector3<T>| -linear_saturating(x, |x| r_inv.rotate(x));
        Self::new_unchecked(r_inv, back(&self.velocity), back(&self.position))
    }

    /// `(exp(φ), V(φ) ν, V(φ) ρ)`, with the Taylor series of the coefficients below the series
    /// angle. Valid for every finite tangent: velocities and positions beyond the scalar's range
    /// saturate at its largest finite value.
    fn exp(xi: &Tangent<T, 9>) -> Self {
        let (rho, phi, nu) = split(xi);
        Self::new_unchecked(
            So3::exp(&phi),
            exp_translation(&phi, &nu),
            exp_translation(&phi, &rho),
        )
    }

    /// `[V(φ)⁻¹ p; φ; V(φ)⁻¹ v]` with φ the principal rotation vector of [`So3::log`] (angle in
    /// [0, π]; at π the stored axis sign), where `V(φ)⁻¹` is regular.
    fn log(&self) -> Tangent<T, 9> {
        let phi = self.rotation.log();
        join(
            &v_inverse_times(&phi, &self.position),
            &phi,
            &v_inverse_times(&phi, &self.velocity),
        )
    }

    fn hat(xi: &Tangent<T, 9>) -> Matrix5<T> {
        let (rho, phi, nu) = split(xi);
        let mut m = Matrix5::zeros();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&rotation_vector::hat(&phi));
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&nu);
        m.fixed_view_mut::<3, 1>(0, 4).copy_from(&rho);
        m
    }

    /// `[a₁₅, a₂₅, a₃₅, vee(antisymmetric part of the rotation block), a₁₄, a₂₄, a₃₄]`.
    fn vee(a: &Matrix5<T>) -> Tangent<T, 9> {
        let (r, v, p) = blocks(a);
        join(&p, &rotation_vector::vee(&r), &v)
    }

    /// `M a M⁻¹` with the 5×5 matrices of `self` and its inverse; saturating, never NaN, for entries
    /// whose products overflow.
    fn conjugate_algebra(&self, a: &Matrix5<T>) -> Matrix5<T> {
        crate::pose::conjugate_saturating(&self.to_matrix(), a, &self.inverse().to_matrix())
    }

    /// `[[R, hat(p) R, 0], [0, R, 0], [0, hat(v) R, R]]` in the order `[ρ; φ; ν]`.
    fn adjoint(&self) -> Jacobian<T, 9, 9> {
        let r = self.rotation.to_matrix();
        let coupled = |x: &Vector3<T>| mul_saturating(&rotation_vector::hat(x), &r);
        arrow(&r, &coupled(&self.position), &coupled(&self.velocity))
    }

    /// `Jr([ρ; φ; ν]) = [[Jr(φ), Q(ρ, φ), 0], [0, Jr(φ), 0], [0, Q(ν, φ), Jr(φ)]]` with Jr(φ) of
    /// SO(3) and the coupling block Q of [`Se3`]'s right Jacobian, once for each linear block;
    /// saturating, never NaN, for huge tangents.
    fn right_jacobian(xi: &Tangent<T, 9>) -> Jacobian<T, 9, 9> {
        let (rho, phi, nu) = split(xi);
        let q = |x: &Vector3<T>| linear_saturating(x, |x| coupling(x, &phi));
        arrow(&rotation_vector::right_jacobian(&phi), &q(&rho), &q(&nu))
    }

    /// `Jr⁻¹ = [[Jr⁻¹(φ), −Jr⁻¹ Q(ρ, φ) Jr⁻¹, 0], [0, Jr⁻¹(φ), 0], [0, −Jr⁻¹ Q(ν, φ) Jr⁻¹, Jr⁻¹(φ)]]`;
    /// singular at θ = 2πk (k ≥ 1), saturating (never NaN) for huge tangents.
    fn right_jacobian_inverse(xi: &Tangent<T, 9>) -> Jacobian<T, 9, 9> {
        let (rho, phi, nu) = split(xi);
        let j_inv = rotation_vector::right_jacobian_inverse(&phi);
        let off = |x: &Vector3<T>| {
            let q = linear_saturating(x, |x| coupling(x, &phi));
            -mul_saturating(&mul_saturating(&j_inv, &q), &j_inv)
        };
        arrow(&j_inv, &off(&rho), &off(&nu))
    }
}

impl_manifold_for_group!(Se23, 9, |x| {
    crate::Manifold::is_finite(&x.rotation)
        && x.velocity.iter().all(nalgebra::ComplexField::is_finite)
        && x.position.iter().all(nalgebra::ComplexField::is_finite)
});

impl<T: Real> GroupAction<9, 3> for Se23<T> {
    /// `R x + p` (the velocity does not act on points), saturating at the largest finite value.
    #[inline]
    fn act(&self, x: &Vector3<T>) -> Vector3<T> {
        saturated(self.rotation.rotate(x) + self.position)
    }

    /// `[R, −R hat(x), 0]`: the position block moves the point along the body axes, the rotation
    /// block turns it about the body origin, the velocity block does not move it; saturating for
    /// points near the largest value.
    fn j_act_self(&self, x: &Vector3<T>) -> Jacobian<T, 3, 9> {
        let r = self.rotation.to_matrix();
        let mut j = Jacobian::<T, 3, 9>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        j.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&-linear_saturating(x, |x| r * rotation_vector::hat(x)));
        j
    }

    /// `R`.
    #[inline]
    fn j_act_point(&self, _x: &Vector3<T>) -> Jacobian<T, 3, 3> {
        self.rotation.to_matrix()
    }
}

impl_pose_comparisons!(Se23, velocity, position);
