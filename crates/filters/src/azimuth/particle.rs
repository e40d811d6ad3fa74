//! The bootstrap particle filter on `[r, A]` ([`PositionAzimuth`]), stepped by the operators crate's
//! particle set: sampled propagation and reweighting.

use super::PositionAzimuth;
use super::estimate::{AzimuthEstimate, AzimuthMoments, azimuth_moment};
use super::gaussian::state;
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess, check_filter_settings};
use super::scenario::normal2;
use liebayes_experiments::{Estimator, Recursive};
use liebayes_manifolds::So2;
use liebayes_operators::OperatorError;
use liebayes_operators::particle::{Likelihood, ParticleSet, Reweight, Sampled, SampledProcess};
use nalgebra::Vector2;
use rand::{Rng, RngCore};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// The bootstrap particle filter: particles from the prior `N(r₀, σ₀² I) × U[0, 2π)`, moved by the
/// process with sampled noise, reweighted by `N(z; R(A) r, σ_m² I)`, and resampled systematically
/// at the start of a propagation when the effective sample size has fallen below half (so the
/// estimate after an update is the weighted one). A is constant, so after resampling its particles
/// only lose diversity: the filter can collapse on a wrong azimuth when too few particles start
/// near the truth.
pub type AzimuthParticleFilter = Recursive<
    ParticleSet<PositionAzimuth>,
    Sampled<VelocityProcess, ChaCha8Rng>,
    Reweight<PositionMeasurement>,
    AzimuthMoments,
>;

/// `r′ = r + v dt + N(0, q² dt I)`, `A′ = A`.
impl SampledProcess<PositionAzimuth> for VelocityProcess {
    type Input = VelocityInput;

    /// # Errors
    /// As [`VelocityInput::validate`], or [`OperatorError::NonFinite`] when the moved position
    /// overflows.
    fn sample<G: RngCore>(
        &self,
        x: &PositionAzimuth,
        input: &VelocityInput,
        rng: &mut G,
    ) -> Result<PositionAzimuth, OperatorError> {
        input.validate()?;
        let step = (self.noise_density() * input.dt).sqrt();
        let r = x.first().coords() + input.velocity * input.dt + normal2(rng) * step;
        if let Some(&value) = r.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "a particle's position after the motion (v dt is too large)",
                value,
            });
        }
        Ok(state(r, *x.second()))
    }
}

/// `ln p(z | r, A) = −|z − R(A) r|² / (2σ_m²) − ln(2π σ_m²)`.
impl Likelihood<PositionAzimuth> for PositionMeasurement {
    type Measurement = Vector2<f64>;

    fn log_likelihood(&self, x: &PositionAzimuth, z: &Vector2<f64>) -> f64 {
        let predicted = x.second().to_matrix() * x.first().coords();
        -(z - predicted).norm_squared() / (2.0 * self.variance()) - self.log_normaliser()
    }
}

/// The particle filter with n particles drawn from the prior with `rng`, which it then keeps for
/// its own draws.
///
/// # Errors
/// The settings check every azimuth filter shares (as [`ekf`](super::ekf): r₀ finite within
/// ±1e100, σ₀ and σ_m in [1e-49, 1e49], q at most 1e49), then [`OperatorError::OutOfRange`] for
/// n = 0 and [`OperatorError::TooLarge`] for n above
/// [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS) or more than the memory holds; all checked
/// before any particle is drawn.
pub fn particle_filter(
    n: usize,
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
    mut rng: ChaCha8Rng,
) -> Result<AzimuthParticleFilter, OperatorError> {
    check_filter_settings(process, &measurement, r0, sigma0)?;
    let particles = crate::error::draws(n, || {
        state(
            r0 + normal2(&mut rng) * sigma0,
            So2::from_angle_unchecked(rng.random::<f64>() * 2.0 * PI),
        )
    })?;
    Ok(Recursive::with_estimator(
        ParticleSet::from_samples(particles)?,
        Sampled::new(process, rng),
        Reweight(measurement),
        AzimuthMoments,
    ))
}

/// The weighted moments: `E (cos A, sin A)`, `E r`, `Cov r`.
impl Estimator<ParticleSet<PositionAzimuth>> for AzimuthMoments {
    type Estimate = AzimuthEstimate;

    fn estimate(
        &self,
        set: &ParticleSet<PositionAzimuth>,
    ) -> Result<AzimuthEstimate, OperatorError> {
        let moment = set.expectation(|x| azimuth_moment(x.second()));
        let mean_r = set.expectation(|x| *x.first().coords());
        let cov_r = set.expectation(|x| {
            let d = x.first().coords() - mean_r;
            d * d.transpose()
        });
        AzimuthEstimate::from_moment(moment, mean_r, cov_r).checked()
    }
}
