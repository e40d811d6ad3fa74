//! The navigation state, [`Navigation`], and the three ways a filter represents it, each a manifold
//! of dimension 15 with the biases as its last six tangent coordinates ([`NavigationState`]).

use liebayes_manifolds::{Left, LieGroup, Manifold, Rn, Se23, So3, product_manifold};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// A navigation state by its parts: the attitude (body to world), the velocity and the position
/// in the world frame (m/s, m), and the gyroscope (rad/s) and accelerometer (m/s²) biases. The
/// truth of a scenario and what every filter's state is read as.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Navigation {
    /// Body to world.
    pub rotation: So3<f64>,
    /// World frame (m/s).
    pub velocity: Vector3<f64>,
    /// World frame (m).
    pub position: Vector3<f64>,
    /// Gyroscope bias (rad/s).
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub accel_bias: Vector3<f64>,
}

impl Navigation {
    /// Every coordinate finite.
    pub fn is_finite(&self) -> bool {
        self.rotation.is_finite()
            && self
                .velocity
                .iter()
                .chain(&self.position)
                .chain(&self.gyro_bias)
                .chain(&self.accel_bias)
                .all(|v| v.is_finite())
    }
}

/// The dimension of a navigation state's tangent space: 9 for attitude, velocity and position, 6
/// for the biases.
pub const NAVIGATION_DIM: usize = 15;

/// A filter's representation of the navigation state: a manifold of dimension 15 whose tangent
/// coordinates (the filter's error) end with the six bias errors `[δb_g; δb_a]`, added. What differs
/// is how the first nine, the attitude, velocity and position errors, are defined: that is the whole
/// difference between the error-state EKF and the two invariant EKFs.
pub trait NavigationState: Manifold<NAVIGATION_DIM, Scalar = f64> + Clone + Send + Sync {
    /// The state of `navigation`.
    fn from_navigation(navigation: &Navigation) -> Self;

    /// Its parts.
    fn navigation(&self) -> Navigation;

    /// `E = ∂e/∂ξ` at ξ = 0, with ξ the first nine tangent coordinates and e = [δθ; δv; δp] the
    /// error-state EKF's error (`R exp(δθ)`, `v + δv`, `p + δp`): `x ⊞ ξ` is the state with
    /// attitude `R exp(δθ)`, velocity `v + δv` and position `p + δp` for `e = E ξ + O(|ξ|²)`. The
    /// strapdown step and the fix are differentiated once in e ([`Strapdown`](super::Strapdown),
    /// [`PositionFix`](super::PositionFix)); this and its inverse carry the result into each
    /// convention.
    fn navigation_error(navigation: &Navigation) -> SMatrix<f64, 9, 9>;

    /// `E⁻¹ = ∂ξ/∂e` at e = 0 ([`navigation_error`](Self::navigation_error)'s inverse, in closed
    /// form): the first nine coordinates of `y ⊟ x` for y with the error e from x, to first order.
    fn from_navigation_error(navigation: &Navigation) -> SMatrix<f64, 9, 9>;
}

/// The 9 × 9 matrix of 3 × 3 blocks, `(block row, block column, block)` given, zero elsewhere.
fn blocks(entries: &[(usize, usize, Matrix3<f64>)]) -> SMatrix<f64, 9, 9> {
    let mut m = SMatrix::<f64, 9, 9>::zeros();
    for (row, column, block) in entries {
        m.fixed_view_mut::<3, 3>(3 * row, 3 * column)
            .copy_from(block);
    }
    m
}

/// The biases of a state as one vector `[b_g; b_a]`.
pub(crate) fn stacked_biases(navigation: &Navigation) -> SVector<f64, 6> {
    SVector::<f64, 6>::from_fn(|i, _| {
        if i < 3 {
            navigation.gyro_bias[i]
        } else {
            navigation.accel_bias[i - 3]
        }
    })
}

/// The biases of a stacked vector `[b_g; b_a]`.
pub(crate) fn split_biases(biases: &SVector<f64, 6>) -> (Vector3<f64>, Vector3<f64>) {
    (
        biases.fixed_rows::<3>(0).into_owned(),
        biases.fixed_rows::<3>(3).into_owned(),
    )
}

product_manifold! {
    /// The error-state EKF's state: attitude with its error on the right (body frame,
    /// `R exp(δθ)`), velocity and position with additive errors, then the biases: tangent
    /// `[δθ; δv; δp; δb_g; δb_a]`.
    pub struct ErrorState<f64> {
        /// Body to world, errors on the right.
        pub attitude: So3<f64>,
        /// World frame (m/s).
        pub velocity: Rn<f64, 3>,
        /// World frame (m).
        pub position: Rn<f64, 3>,
        /// `[b_g; b_a]`.
        pub biases: Rn<f64, 6>,
    }
}

impl NavigationState for ErrorState {
    fn from_navigation(navigation: &Navigation) -> Self {
        Self::new(
            navigation.rotation,
            Rn::new_unchecked(navigation.velocity),
            Rn::new_unchecked(navigation.position),
            Rn::new_unchecked(stacked_biases(navigation)),
        )
    }

    fn navigation(&self) -> Navigation {
        let (gyro_bias, accel_bias) = split_biases(self.biases().coords());
        Navigation {
            rotation: *self.attitude(),
            velocity: *self.velocity().coords(),
            position: *self.position().coords(),
            gyro_bias,
            accel_bias,
        }
    }

    /// The identity: the tangent is e.
    fn navigation_error(_: &Navigation) -> SMatrix<f64, 9, 9> {
        SMatrix::identity()
    }

    /// The identity.
    fn from_navigation_error(_: &Navigation) -> SMatrix<f64, 9, 9> {
        SMatrix::identity()
    }
}

product_manifold! {
    /// The left-invariant EKF's state: the extended pose on SE_2(3) with its error on the right,
    /// `X exp(ξ)` (body frame, the crate's convention; a position fix is a left-invariant
    /// observation of it, `p = X·[0; 0; 1]`), then the biases: tangent `[ρ; φ; ν; δb_g; δb_a]`
    /// ([`Se23`]'s order).
    pub struct LeftInvariant<f64> {
        /// Attitude, velocity and position, errors on the right.
        pub motion: Se23<f64>,
        /// `[b_g; b_a]`.
        pub biases: Rn<f64, 6>,
    }
}

product_manifold! {
    /// The right-invariant EKF's state: the extended pose on SE_2(3) with its error on the left,
    /// `exp(ξ) X` (world frame, [`Left`]), whose propagation without biases does not depend on the
    /// state at all, then the biases: tangent `[ρ; φ; ν; δb_g; δb_a]`.
    pub struct RightInvariant<f64> {
        /// Attitude, velocity and position, errors on the left.
        pub motion: Left<Se23<f64>>,
        /// `[b_g; b_a]`.
        pub biases: Rn<f64, 6>,
    }
}

/// The extended pose of a navigation state.
fn extended_pose(navigation: &Navigation) -> Se23<f64> {
    Se23::new_unchecked(
        navigation.rotation,
        navigation.velocity,
        navigation.position,
    )
}

/// The navigation state of an extended pose and stacked biases.
fn from_pose(motion: &Se23<f64>, biases: &SVector<f64, 6>) -> Navigation {
    let (gyro_bias, accel_bias) = split_biases(biases);
    Navigation {
        rotation: *motion.rotation(),
        velocity: *motion.velocity(),
        position: *motion.position(),
        gyro_bias,
        accel_bias,
    }
}

impl NavigationState for LeftInvariant {
    fn from_navigation(navigation: &Navigation) -> Self {
        Self::new(
            extended_pose(navigation),
            Rn::new_unchecked(stacked_biases(navigation)),
        )
    }

    fn navigation(&self) -> Navigation {
        from_pose(self.motion(), self.biases().coords())
    }

    /// `X exp(ξ) = (R exp(φ), v + R ν, p + R ρ) + O(|ξ|²)` for `ξ = [ρ; φ; ν]`: δθ = φ, δv = R ν,
    /// δp = R ρ.
    fn navigation_error(navigation: &Navigation) -> SMatrix<f64, 9, 9> {
        let r = navigation.rotation.to_matrix();
        blocks(&[(0, 1, Matrix3::identity()), (1, 2, r), (2, 0, r)])
    }

    /// ρ = Rᵀ δp, φ = δθ, ν = Rᵀ δv.
    fn from_navigation_error(navigation: &Navigation) -> SMatrix<f64, 9, 9> {
        let rt = navigation.rotation.to_matrix().transpose();
        blocks(&[(0, 2, rt), (1, 0, Matrix3::identity()), (2, 1, rt)])
    }
}

impl NavigationState for RightInvariant {
    fn from_navigation(navigation: &Navigation) -> Self {
        Self::new(
            Left::new(extended_pose(navigation)),
            Rn::new_unchecked(stacked_biases(navigation)),
        )
    }

    fn navigation(&self) -> Navigation {
        from_pose(self.motion().inner(), self.biases().coords())
    }

    /// `exp(ξ) X = (exp(φ) R, v + φ × v + ν, p + φ × p + ρ) + O(|ξ|²)` for `ξ = [ρ; φ; ν]`:
    /// δθ = Rᵀ φ, δv = ν − v̂ φ, δp = ρ − p̂ φ (x̂ the cross-product matrix).
    fn navigation_error(navigation: &Navigation) -> SMatrix<f64, 9, 9> {
        let rt = navigation.rotation.to_matrix().transpose();
        blocks(&[
            (0, 1, rt),
            (1, 1, -So3::hat(&navigation.velocity)),
            (1, 2, Matrix3::identity()),
            (2, 0, Matrix3::identity()),
            (2, 1, -So3::hat(&navigation.position)),
        ])
    }

    /// ρ = δp + p̂ R δθ, φ = R δθ, ν = δv + v̂ R δθ.
    fn from_navigation_error(navigation: &Navigation) -> SMatrix<f64, 9, 9> {
        let r = navigation.rotation.to_matrix();
        blocks(&[
            (0, 0, So3::hat(&navigation.position) * r),
            (0, 2, Matrix3::identity()),
            (1, 0, r),
            (2, 0, So3::hat(&navigation.velocity) * r),
            (2, 1, Matrix3::identity()),
        ])
    }
}
