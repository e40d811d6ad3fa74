//! [`Anchor`]: a receiver at a known position with known axes, and the direction of a position as
//! it sees it (the paper's Algorithm 2, with the anchor rotation its equations (5) and (9) omit).

use crate::scaled::unit_and_norm;
use liebayes_manifolds::So3;
use liebayes_operators::OperatorError;
use nalgebra::{Matrix3, Vector3};

/// The largest anchor coordinate (m): positions and their differences stay far from overflow when
/// squared.
pub const POSITION_LIMIT: f64 = 1e100;

/// An anchor: its position s (world axes, m) and its rotation R from world axes to its own
/// (`R v` is the world vector v in the anchor's axes), in which it reports azimuth and elevation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    position: Vector3<f64>,
    rotation: So3<f64>,
    matrix: Matrix3<f64>,
}

impl Anchor {
    /// The anchor at `position` with the world-to-anchor rotation `rotation`.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] or [`OperatorError::OutOfRange`] for a coordinate that is not
    /// finite or beyond ±[`POSITION_LIMIT`].
    pub fn new(position: Vector3<f64>, rotation: So3<f64>) -> Result<Self, OperatorError> {
        for &value in position.iter() {
            if !value.is_finite() {
                return Err(OperatorError::NonFinite {
                    what: "anchor position (m)",
                    value,
                });
            }
            if value.abs() > POSITION_LIMIT {
                return Err(OperatorError::OutOfRange {
                    what: "anchor position coordinate (m)",
                    value,
                    range: "[-1e100, 1e100]",
                });
            }
        }
        Ok(Self {
            position,
            rotation,
            matrix: rotation.to_matrix(),
        })
    }

    /// The anchor at `position` with the axes of the world (R = I).
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn at(position: Vector3<f64>) -> Result<Self, OperatorError> {
        Self::new(position, So3::from_matrix_unchecked(&Matrix3::identity()))
    }

    /// The position s (world axes, m).
    pub fn position(&self) -> &Vector3<f64> {
        &self.position
    }

    /// The world-to-anchor rotation R.
    pub fn rotation(&self) -> &So3<f64> {
        &self.rotation
    }

    /// R as a matrix.
    pub fn rotation_matrix(&self) -> &Matrix3<f64> {
        &self.matrix
    }

    /// `R (θ − s)`: the vector from the anchor to θ in the anchor's axes; `None` where it is not
    /// finite (a non-finite θ, or an offset beyond f64's range, as for
    /// [`direction`](Self::direction)).
    pub fn local_offset(&self, theta: &Vector3<f64>) -> Option<Vector3<f64>> {
        let offset = self.matrix * (theta - self.position);
        offset.iter().all(|v| v.is_finite()).then_some(offset)
    }

    /// `R d` with `d = (θ − s)/|θ − s|`: the unit direction of θ in the anchor's axes, with the
    /// distance |θ − s|; `None` at the anchor itself (or for a non-finite θ).
    pub fn direction(&self, theta: &Vector3<f64>) -> Option<(Vector3<f64>, f64)> {
        unit_and_distance(&(theta - self.position)).map(|(d, distance)| (self.matrix * d, distance))
    }

    /// The Jacobian of `R d` with respect to θ (Algorithm 2): `R (I − d dᵀ) / |θ − s|`, with
    /// `d = (θ − s)/|θ − s|`; `None` at the anchor, for a non-finite θ, and where it overflows
    /// (a target closer than about 1e-308 m).
    pub fn direction_jacobian(&self, theta: &Vector3<f64>) -> Option<Matrix3<f64>> {
        let (d, distance) = unit_and_distance(&(theta - self.position))?;
        let jacobian = self.matrix * (Matrix3::identity() - d * d.transpose()) / distance;
        jacobian.iter().all(|v| v.is_finite()).then_some(jacobian)
    }
}

/// `(v/|v|, |v|)` for a nonzero finite v whose norm is finite; where `|v|²` under- or overflows,
/// computed on `v / max|vᵢ|` so that the unit vector stays unit (a target 2e-162 m from its anchor
/// gave |d| = 0.905).
pub(super) fn unit_and_distance(v: &Vector3<f64>) -> Option<(Vector3<f64>, f64)> {
    let squared = v.norm_squared();
    if squared.is_normal() {
        let distance = squared.sqrt();
        return Some((v / distance, distance));
    }
    let (unit, distance) = unit_and_norm(v)?;
    distance.is_finite().then_some((unit, distance))
}

/// `v/|v|` for a nonzero finite v, also where |v| itself overflows (a direction needs no length).
pub(super) fn unit_direction(v: &Vector3<f64>) -> Option<Vector3<f64>> {
    let squared = v.norm_squared();
    if squared.is_normal() {
        return Some(v / squared.sqrt());
    }
    unit_and_norm(v).map(|(unit, _)| unit)
}

/// The four anchors of the square-track test (the paper's Sec. 4.3, made consistent): at
/// (−2.5, 0, 0), (7.5, 0, 0), (−2.5, 5, 0) and (7.5, 5, 0) on the extensions of the square's sides
/// y = 0 and y = 5, each rotated so that its pole (local z-axis) points along the world x-axis
/// (R maps world x to local z): along those two sides the user passes exactly through the poles of
/// two anchors, which is where azimuth-elevation models break down.
pub fn square_track_anchors() -> [Anchor; 4] {
    // Rows: local x, y, z in world axes.
    let south = Matrix3::new(0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0);
    let north = Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0);
    let anchor = |x: f64, y: f64, m: &Matrix3<f64>| Anchor {
        position: Vector3::new(x, y, 0.0),
        rotation: So3::from_matrix_unchecked(m),
        matrix: *m,
    };
    [
        anchor(-2.5, 0.0, &south),
        anchor(7.5, 0.0, &south),
        anchor(-2.5, 5.0, &north),
        anchor(7.5, 5.0, &north),
    ]
}
