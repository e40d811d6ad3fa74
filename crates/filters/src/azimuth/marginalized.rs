//! The marginalized particle filter of azimuth alignment: particles for A, each carrying an exact
//! Kalman filter for r.

use super::estimate::{AzimuthEstimate, AzimuthMoments, azimuth_moment};
use super::model::check_filter_settings;
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use crate::error::{check_count, draws};
use liebayes_densities::Gaussian;
use liebayes_experiments::{Estimator, Recursive};
use liebayes_manifolds::So2;
use liebayes_operators::particle::{Given, ParticleSet, Sampled, SampledProcess};
use liebayes_operators::{OperatorError, Propagate};
use nalgebra::{Matrix2, Vector2};
use rand::{Rng, RngCore};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// The marginalized particle filter: particles `Aᵢ` from the uniform prior, each carrying an exact
/// Kalman filter `p(r | Aᵢ, z…)`, weighted by that filter's log evidence and resampled
/// systematically at the start of a propagation when the effective sample size has fallen below
/// half. Exact given the particles; A is constant, so it degenerates like the bootstrap filter,
/// only later.
pub type AzimuthMarginalized = Recursive<
    ParticleSet<(So2<f64>, Gaussian<2>)>,
    Sampled<VelocityProcess, ChaCha8Rng>,
    Given<PositionMeasurement>,
    AzimuthMoments,
>;

/// A particle's azimuth is constant; its Kalman filter for r propagates exactly (no draw).
impl SampledProcess<(So2<f64>, Gaussian<2>)> for VelocityProcess {
    type Input = VelocityInput;

    /// # Errors
    /// As the Gaussian propagation.
    fn sample<G: RngCore>(
        &self,
        (azimuth, density): &(So2<f64>, Gaussian<2>),
        input: &VelocityInput,
        _: &mut G,
    ) -> Result<(So2<f64>, Gaussian<2>), OperatorError> {
        Ok((*azimuth, density.propagate(self, input)?))
    }
}

/// The marginalized particle filter with n azimuth particles drawn uniformly with `rng` (which it
/// then keeps for its resampling), each with the prior `N(r₀, σ₀² I)`.
///
/// # Errors
/// As [`particle_filter`](super::particle_filter), all checked before any particle is drawn.
pub fn marginalized_filter(
    n: usize,
    process: VelocityProcess,
    measurement: PositionMeasurement,
    r0: Vector2<f64>,
    sigma0: f64,
    mut rng: ChaCha8Rng,
) -> Result<AzimuthMarginalized, OperatorError> {
    let variance = check_filter_settings(process, &measurement, r0, sigma0)?;
    check_count("number of particles", n)?;
    let prior = Gaussian::new(r0, Matrix2::identity() * variance)?;
    let particles = draws(n, || {
        (
            So2::from_angle_unchecked(rng.random::<f64>() * 2.0 * PI),
            prior.clone(),
        )
    })?;
    Ok(Recursive::with_estimator(
        ParticleSet::from_samples(particles)?,
        Sampled::new(process, rng),
        Given(measurement),
        AzimuthMoments,
    ))
}

/// `E (cos A, sin A)`, and the mixture's `E r` and `Cov r`.
impl Estimator<ParticleSet<(So2<f64>, Gaussian<2>)>> for AzimuthMoments {
    type Estimate = AzimuthEstimate;

    fn estimate(
        &self,
        set: &ParticleSet<(So2<f64>, Gaussian<2>)>,
    ) -> Result<AzimuthEstimate, OperatorError> {
        let moment = set.expectation(|(a, _)| azimuth_moment(a));
        let mean_r = set.expectation(|(_, g)| *g.mean());
        let cov_r = set.expectation(|(_, g)| {
            let d = g.mean() - mean_r;
            g.covariance() + d * d.transpose()
        });
        AzimuthEstimate::from_moment(moment, mean_r, cov_r).checked()
    }
}
