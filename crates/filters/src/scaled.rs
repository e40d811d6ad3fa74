//! Lengths and directions of vectors of any finite magnitude.

use nalgebra::Vector3;

/// `(v/|v|, |v|)` computed on `v / max|vᵢ|`, so that the squares of a tiny vector (1e-300) do not
/// underflow nor those of a huge one overflow (the length itself may overflow to +∞); `None` for a
/// zero or non-finite v.
pub(crate) fn unit_and_norm(v: &Vector3<f64>) -> Option<(Vector3<f64>, f64)> {
    let scale = v.amax();
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let scaled = v / scale;
    let norm = scaled.norm();
    Some((scaled / norm, norm * scale))
}
