//! Directions as an angle-of-arrival receiver reports them: azimuth and elevation in the anchor's
//! axes, the map to unit vectors, and the rule that gives every direction one representation.
//!
//! Convention (the paper's equation (3)): elevation `el ∈ [−π/2, π/2]` from the anchor's xy-plane,
//! positive towards its z-axis (the poles are `el = ±π/2`), azimuth `az ∈ [−π, π)` from its x-axis
//! towards its y-axis, and `u(az, el) = [cos az cos el, sin az cos el, sin el]`.

use liebayes_manifolds::wrap_angle;
use liebayes_operators::OperatorError;
use nalgebra::Vector3;
use std::f64::consts::{FRAC_PI_2, PI};

/// One direction reading: azimuth and elevation (rad) in the anchor's axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AzEl {
    /// Azimuth (rad), in [−π, π) once [`canonical`](Self::canonical).
    pub azimuth: f64,
    /// Elevation (rad), in [−π/2, π/2] once [`canonical`](Self::canonical).
    pub elevation: f64,
}

impl AzEl {
    /// The reading `(azimuth, elevation)` as given (not reduced; see [`canonical`](Self::canonical)).
    pub const fn new(azimuth: f64, elevation: f64) -> Self {
        Self { azimuth, elevation }
    }

    /// The unit vector `[cos az cos el, sin az cos el, sin el]` (equation (3)), for any finite
    /// angles.
    pub fn unit_vector(&self) -> Vector3<f64> {
        let (sa, ca) = self.azimuth.sin_cos();
        let (se, ce) = self.elevation.sin_cos();
        Vector3::new(ca * ce, sa * ce, se)
    }

    /// The azimuth and elevation of a nonzero finite vector, of any length (f64::MAX and
    /// subnormal components included): `el = atan2(z, ρ)`, `az = atan2(y, x)` wrapped to
    /// [−π, π), `ρ = √(x² + y²)`, computed on v scaled by an exact power of two when its largest
    /// component is above 2⁵⁰⁰ or below 2⁻⁵⁰⁰ (so (MAX, MAX, MAX) has `el = atan(1/√2)`, where ρ
    /// overflowed to ∞ and gave 0). At a pole the azimuth is 0.
    ///
    /// `None` for a zero vector (it has no direction) or one with a NaN or infinite component.
    pub fn of_vector(v: &Vector3<f64>) -> Option<Self> {
        // `amax` skips a NaN: every component is checked.
        let largest = v.amax();
        if !(v.iter().all(|c| c.is_finite()) && largest > 0.0) {
            return None;
        }
        // Powers of two scale exactly: the angles are those of v itself.
        let v = if largest > 2f64.powi(500) {
            v * 2f64.powi(-600)
        } else if largest < 2f64.powi(-500) {
            v * 2f64.powi(600)
        } else {
            *v
        };
        let squared = v.x * v.x + v.y * v.y;
        // √(x² + y²) unless the squares underflow, where hypot keeps the ratio.
        let rho = if squared.is_normal() {
            squared.sqrt()
        } else {
            v.x.hypot(v.y)
        };
        Some(Self {
            azimuth: wrap_angle(v.y.atan2(v.x)),
            elevation: v.z.atan2(rho),
        })
    }

    /// The same direction in the one representation with `el ∈ [−π/2, π/2]`, `az ∈ [−π, π)`: the
    /// elevation is reduced to [−π, π); above π/2 it becomes `π − el`, below −π/2 `−π − el`, and then
    /// the azimuth gets π added (the paper's flipping rule, written in equation (3)'s convention).
    /// A reading that passed over a pole becomes the direction it points at.
    #[must_use]
    pub fn canonical(&self) -> Self {
        let el = wrap_angle(self.elevation);
        let (el, flip) = if el > FRAC_PI_2 {
            (PI - el, PI)
        } else if el < -FRAC_PI_2 {
            (-PI - el, PI)
        } else {
            (el, 0.0)
        };
        Self {
            azimuth: wrap_angle(self.azimuth + flip),
            elevation: el,
        }
    }

    /// Checks that both angles are finite.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] naming the angle.
    pub fn check_finite(&self) -> Result<(), OperatorError> {
        for (what, value) in [
            ("angle-of-arrival azimuth (rad)", self.azimuth),
            ("angle-of-arrival elevation (rad)", self.elevation),
        ] {
            if !value.is_finite() {
                return Err(OperatorError::NonFinite { what, value });
            }
        }
        Ok(())
    }

    /// Checks that the reading is finite and in the canonical ranges (`el ∈ [−π/2, π/2]`; any finite
    /// azimuth, which the models wrap).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`], or [`OperatorError::OutOfRange`] for an elevation outside
    /// [−π/2, π/2] (use [`canonical`](Self::canonical) first).
    pub fn check_canonical(&self) -> Result<(), OperatorError> {
        self.check_finite()?;
        if self.elevation.abs() > FRAC_PI_2 {
            return Err(OperatorError::OutOfRange {
                what: "angle-of-arrival elevation (rad)",
                value: self.elevation,
                range: "[-pi/2, pi/2] (reduce the reading with AzEl::canonical)",
            });
        }
        Ok(())
    }
}
