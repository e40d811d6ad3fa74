//! The navigation state, [`Navigation`], and the three ways a filter represents it, each a manifold
//! of dimension 15 with the biases as its last six tangent coordinates ([`NavigationState`]).

use liebayes_manifolds::{Manifold, ProductManifold, Rn, So3};
use nalgebra::{SVector, Vector3};

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

/// The error-state EKF's state: attitude with its error on the right (body frame, `R exp(δθ)`),
/// velocity and position with additive errors, then the biases: tangent
/// `[δθ; δv; δp; δb_g; δb_a]`.
pub type ErrorState = ProductManifold<
    ProductManifold<So3<f64>, Rn<f64, 6>, 3, 6, 9>,
    Rn<f64, 6>,
    9,
    6,
    NAVIGATION_DIM,
>;

impl NavigationState for ErrorState {
    fn from_navigation(navigation: &Navigation) -> Self {
        let linear = SVector::<f64, 6>::from_fn(|i, _| {
            if i < 3 {
                navigation.velocity[i]
            } else {
                navigation.position[i - 3]
            }
        });
        Self::new(
            ProductManifold::new(navigation.rotation, Rn::new_unchecked(linear)),
            Rn::new_unchecked(stacked_biases(navigation)),
        )
    }

    fn navigation(&self) -> Navigation {
        let (motion, biases) = (self.first(), self.second());
        let linear = motion.second().coords();
        let (gyro_bias, accel_bias) = split_biases(biases.coords());
        Navigation {
            rotation: *motion.first(),
            velocity: linear.fixed_rows::<3>(0).into_owned(),
            position: linear.fixed_rows::<3>(3).into_owned(),
            gyro_bias,
            accel_bias,
        }
    }
}
