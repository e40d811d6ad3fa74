//! [`S2`]: the unit sphere in R³ (directions), a manifold but not a group.

use crate::error::{ManifoldError, checked_unit, normalized, unit_to_rounding};
use crate::manifold::{Manifold, Tangent};
use crate::real::{Real, stable_norm};
use nalgebra::{Matrix3x2, Unit, Vector3};

/// A unit vector of R³, a point of the sphere S².
///
/// Tangent vectors at `x` have two coordinates in the orthonormal [`tangent_basis`](Self::tangent_basis)
/// `B(x) = [b1 b2]` (right-handed: `b1 × b2 = x`), so that
/// `retract(x, u) = exp_x(B(x) u)` and `local(x, y) = B(x)ᵀ log_x(y)`, with the sphere's
/// exponential `exp_x(w) = cos|w| x + sin|w| w/|w|` ([`exp_at`](Self::exp_at)) and its inverse
/// [`log_at`](Self::log_at). The injectivity radius is π; at the antipode of `x` every direction is a
/// logarithm and `b1 π` is returned.
///
/// The basis is the branch-free construction of Duff et al. (2017), continuous everywhere except across
/// the plane z = 0, where it switches between the charts of the two poles. `DIM` = 2.
///
/// # Example
/// ```
/// use liebayes_manifolds::{Manifold, S2};
/// use nalgebra::{Vector2, Vector3};
/// let north = S2::new(Vector3::z())?;
/// // A quarter turn along the first tangent direction reaches the equator.
/// let equator = north.retract(&Vector2::new(std::f64::consts::FRAC_PI_2, 0.0));
/// assert!((north.angle_to(&equator) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
/// assert!((north.local(&equator) - Vector2::new(std::f64::consts::FRAC_PI_2, 0.0)).norm() < 1e-15);
/// # Ok::<(), liebayes_manifolds::ManifoldError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct S2<T: Real> {
    n: Unit<Vector3<T>>,
}

/// Construction.
impl<T: Real> S2<T> {
    /// The point `v`, checked for finiteness and unit norm (`abs(|v| − 1)` at most
    /// [`UNIT_NORM_TOLERANCE`](crate::constants::Thresholds::UNIT_NORM_TOLERANCE), 1e-9 in f64);
    /// stored as given when unit to rounding (`abs(|v|² − 1)` at most
    /// [`UNIT_ROUNDING_TOLERANCE`](crate::constants::Thresholds::UNIT_ROUNDING_TOLERANCE), 32 eps),
    /// else as `v / |v|`.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`] or [`ManifoldError::NotUnit`].
    pub fn new(v: Vector3<T>) -> Result<Self, ManifoldError> {
        checked_unit("unit vector", &v, "S2::from_vector_normalizing").map(Self::new_unchecked)
    }

    /// The direction `v / |v|` of `v`, of any finite length `|v| ≥`
    /// [`MIN_DIRECTION_NORM`](crate::constants::Thresholds::MIN_DIRECTION_NORM) (1e-150 in f64, 1e-18 in
    /// f32; a shorter vector's direction is rounding noise): the renormalisation helper.
    ///
    /// # Errors
    /// [`ManifoldError::NonFinite`], or [`ManifoldError::ZeroVector`] for `|v|` below
    /// `MIN_DIRECTION_NORM` (zero included).
    pub fn from_vector_normalizing(v: &Vector3<T>) -> Result<Self, ManifoldError> {
        normalized("direction vector", v).map(Self::new_unchecked)
    }

    /// The point `v`, unchecked: the caller guarantees unit norm (hot paths).
    #[inline]
    pub fn new_unchecked(v: Vector3<T>) -> Self {
        Self {
            n: Unit::new_unchecked(v),
        }
    }

    /// Wraps a nalgebra unit vector as it is, without a check (no cost): nalgebra's unit types are
    /// unit by construction except when its own `new_unchecked`, or normalising zero, made them
    /// NaN. [`S2::new`] checks its vector.
    #[inline]
    pub const fn from_unit_vector(n: Unit<Vector3<T>>) -> Self {
        Self { n }
    }
}

/// Geometry.
impl<T: Real> S2<T> {
    /// The unit vector.
    #[inline]
    pub fn as_vector(&self) -> &Vector3<T> {
        self.n.as_ref()
    }

    /// The orthonormal tangent basis `[b1 b2]` at this point, with `b1 × b2 = x`.
    #[inline]
    pub fn tangent_basis(&self) -> Matrix3x2<T> {
        let (x, y, z) = (self.n.x, self.n.y, self.n.z);
        let sign = if z >= T::zero() { T::one() } else { -T::one() };
        let a = -T::one() / (sign + z);
        let b = x * y * a;
        Matrix3x2::new(
            T::one() + sign * x * x * a,
            b,
            sign * b,
            sign + y * y * a,
            -sign * x,
            -y,
        )
    }

    /// The sphere's exponential at this point: `cos|w| x + sin|w| w/|w|` for an ambient tangent vector
    /// `w` (its component along `x` is ignored), renormalised. Valid for every finite `w`, also when
    /// |w| exceeds the largest finite value (the angle is then taken modulo 2π from its half).
    #[must_use]
    pub fn exp_at(&self, w: &Vector3<T>) -> Self {
        let scale = w.amax();
        // `amax` skips a NaN unless it comes last: a NaN tangent must not read as zero.
        if scale == T::zero() && !w.iter().any(|x| x.to_f64().is_nan()) {
            return *self;
        }
        self.exp_scaled(&(w / scale), scale)
    }

    /// [`exp_at`](Self::exp_at) of `w · scale`, with `w` of order one so that nothing overflows.
    ///
    /// With the unit tangent direction u and the half angle h = θ/2, `cos θ = 1 − 2 sin² h` and
    /// `sin θ = 2 sin h cos h`: accurate at every angle (no series needed near 0) and finite for every
    /// finite `scale`.
    ///
    /// The point is taken unit to rounding (a point of [`new_unchecked`](Self::new_unchecked) may
    /// be off the sphere: with |x| = 1 + 2⁻³⁰, `w` along x projected to a tangent of the wrong sign
    /// and reached the antipode), and the projection `t = w − x (x · w)` is repeated where it
    /// cancelled (|t| below |w|/√2, w nearly along x): twice is enough for t to be orthogonal to x
    /// to its own rounding, so the sum below has unit length and is never 0.
    fn exp_scaled(&self, w: &Vector3<T>, scale: T) -> Self {
        let x = unit_to_rounding(self.as_vector());
        let mut t = w - x * x.dot(w);
        let mut n = stable_norm(&t);
        if n < stable_norm(w) * T::lit(std::f64::consts::FRAC_1_SQRT_2) {
            t -= x * x.dot(&t);
            n = stable_norm(&t);
        }
        if n == T::zero() {
            return Self::new_unchecked(x);
        }
        let h = scale * T::lit(0.5) * n;
        let (s, c) = h.sin_cos();
        let two_s = s + s;
        Self::new_unchecked((x * (T::one() - two_s * s) + t * (two_s * c / n)).normalize())
    }

    /// The sphere's logarithm at this point: the ambient tangent vector of length
    /// `atan2(|x × y|, x · y)` along the great circle from `x` to `y`. At the antipode, `π b1`.
    pub fn log_at(&self, other: &Self) -> Vector3<T> {
        let x = self.as_vector();
        let y = other.as_vector();
        let cross = x.cross(y);
        let theta = stable_norm(&cross).atan2(x.dot(y));
        // The direction of y's tangent part; scaled by its largest component first, so that a
        // subnormal direction (next to the antipode or to x itself) does not overflow θ/|direction|.
        let direction = cross.cross(x);
        let scale = direction.amax();
        if scale > T::zero() {
            let d = direction / scale;
            d * (theta / d.norm())
        } else if x.dot(y) >= T::zero() {
            Vector3::zeros()
        } else {
            self.tangent_basis().column(0) * T::pi()
        }
    }

    /// The great-circle angle `atan2(|x × y|, x · y)` in [0, π].
    pub fn angle_to(&self, other: &Self) -> T {
        let x = self.as_vector();
        let y = other.as_vector();
        stable_norm(&x.cross(y)).atan2(x.dot(y))
    }
}

impl<T: Real> Manifold<2> for S2<T> {
    type Scalar = T;

    /// `exp_x(B(x) u)`, valid for every finite `u`.
    fn retract(&self, u: &Tangent<T, 2>) -> Self {
        let scale = u.amax();
        // As in `exp_at`: a NaN tangent is not zero.
        if scale == T::zero() && !u.iter().any(|x| x.to_f64().is_nan()) {
            return *self;
        }
        self.exp_scaled(&(self.tangent_basis() * (u / scale)), scale)
    }

    /// `B(x)ᵀ log_x(y)`.
    fn local(&self, other: &Self) -> Tangent<T, 2> {
        self.tangent_basis().transpose() * self.log_at(other)
    }

    fn is_finite(&self) -> bool {
        self.n.iter().all(nalgebra::ComplexField::is_finite)
    }

    /// The great-circle angle.
    fn distance(&self, other: &Self) -> T {
        self.angle_to(other)
    }
}

crate::approx_impls::impl_approx_by_field!(S2<T>, [T: Real], n);

/// Unchecked, as [`from_unit_vector`](S2::from_unit_vector).
impl<T: Real> From<Unit<Vector3<T>>> for S2<T> {
    #[inline]
    fn from(n: Unit<Vector3<T>>) -> Self {
        Self::from_unit_vector(n)
    }
}

impl<T: Real> From<S2<T>> for Unit<Vector3<T>> {
    #[inline]
    fn from(x: S2<T>) -> Self {
        x.n
    }
}
