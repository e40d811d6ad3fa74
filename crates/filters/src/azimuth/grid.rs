//! [`GridReference`]: the brute-force posterior of azimuth alignment, a bank of exact Kalman filters on
//! the operators crate's [`CircularGrid`].

use super::density::variance_of;
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use liebayes_densities::Gaussian;
use liebayes_manifolds::So2;
use liebayes_operators::OperatorError;
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use nalgebra::{Matrix2, Vector2};
use std::f64::consts::PI;

/// The azimuth posterior evaluated exactly at the n angles `Aⱼ = 2πj/n`: given A the model is linear and
/// Gaussian, so one Kalman filter per angle ([`liebayes_operators::kalman`], Joseph form) carries
/// `p(r | Aⱼ, z₁..ₖ)` exactly, and the grid's weights carry `p(Aⱼ | z₁..ₖ)` up to the trapezoid
/// normalisation. Nothing here knows the seven-number recursion, which is why it is a reference for it:
/// the two must agree at every angle, at every epoch.
///
/// With few cells it is also the *grid filter* baseline: moments over A are trapezoid sums,
/// exponentially accurate while the grid resolves the posterior (spacing well below σ_A) and a point-mass
/// approximation once it does not. Costs n Kalman steps per step.
#[derive(Clone, Debug)]
pub struct GridReference {
    grid: CircularGrid<Gaussian<2>>,
    /// `ln p(z₁..ₖ)` by the trapezoid rule, summed over the updates.
    log_evidence: f64,
}

impl GridReference {
    /// n filters, each with prior `N(r₀, σ₀² I)`, and the uniform azimuth prior.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for n = 0 or σ₀ outside [1.5e-154, 1e150],
    /// [`OperatorError::TooLarge`] for n above
    /// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS), or the Gaussian's errors for r₀.
    pub fn new(n: usize, r0: Vector2<f64>, sigma0: f64) -> Result<Self, OperatorError> {
        let variance = variance_of("initial position standard deviation sigma_0 (m)", sigma0)?;
        let prior = Gaussian::new(r0, Matrix2::identity() * variance)?;
        Ok(Self {
            grid: CircularGrid::uniform(n, prior)?,
            log_evidence: 0.0,
        })
    }

    /// The grid: angles, normalised cell masses and the per-angle Kalman filters `p(r | Aⱼ, z₁..ₖ)`.
    pub fn grid(&self) -> &CircularGrid<Gaussian<2>> {
        &self.grid
    }

    /// `ln p(Aⱼ, z₁..ₖ)` (a density in A) for every j: `ln wⱼ + ln p(z₁..ₖ) − ln(2π/n)`.
    pub fn log_joint(&self) -> Vec<f64> {
        let cell = (2.0 * PI / self.grid.len() as f64).ln();
        self.grid
            .log_weights()
            .iter()
            .map(|l| l + self.log_evidence - cell)
            .collect()
    }

    /// Conditions every filter on z with `H = R(Aⱼ)`, `R = σ_m² I`, reweighting each cell by its
    /// Kalman log evidence.
    ///
    /// # Errors
    /// The Kalman step's errors (a non-finite z).
    pub fn update(
        &mut self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
    ) -> Result<(), OperatorError> {
        let noise = Matrix2::identity() * model.variance();
        self.log_evidence += self.grid.condition_cells(
            |angle| LinearMeasurement::new(So2::from_angle_unchecked(angle).to_matrix(), noise),
            z,
        )?;
        Ok(())
    }

    /// Propagates every filter through `r′ = r + v dt + w`, `w ~ N(0, q² dt I)`.
    ///
    /// # Errors
    /// As [`VelocityInput::validate`].
    pub fn predict(
        &mut self,
        model: &VelocityProcess,
        input: &VelocityInput,
    ) -> Result<(), OperatorError> {
        input.validate()?;
        let process = LinearProcess::new(
            Matrix2::identity(),
            Matrix2::identity() * (model.noise_density() * input.dt),
        )?;
        self.grid
            .propagate_cells(|_| Ok(process.clone()), &(input.velocity * input.dt))
    }

    /// `ln p(z₁..ₖ)`, the trapezoid sums of the evidence over the grid, accumulated.
    pub fn log_evidence(&self) -> f64 {
        self.log_evidence
    }

    /// `(E r, Cov r)` by the trapezoid rule over the grid: the mixture of the per-angle Gaussians with
    /// the posterior weights.
    pub fn moments(&self) -> (Vector2<f64>, Matrix2<f64>) {
        let mean = self.grid.expectation(|_, f| *f.mean());
        let covariance = self.grid.expectation(|_, f| {
            let d = f.mean() - mean;
            f.covariance() + d * d.transpose()
        });
        (mean, covariance)
    }
}
