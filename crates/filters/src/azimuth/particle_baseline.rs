//! The bootstrap particle filter on (r, A): the baseline the exact filter replaces.

use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use super::scenario::normal2;
use liebayes_operators::OperatorError;
use liebayes_operators::particle::{ParticleSet, Resampling};
use nalgebra::Vector2;
use rand::Rng;
use std::f64::consts::PI;

/// Particles `(r, A)` drawn from the prior `N(r₀, σ₀² I) × U[0, 2π)`, moved by the process with sampled
/// noise, reweighted by `N(z; R(A) r, σ_m² I)` and resampled systematically when the effective sample
/// size falls below half. A is constant, so after resampling its particles only lose diversity: the
/// filter can collapse on a wrong azimuth when too few particles start near the truth.
#[derive(Clone, Debug)]
pub struct ParticleBaseline {
    set: ParticleSet<(Vector2<f64>, f64)>,
}

impl ParticleBaseline {
    /// n particles from the prior.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for n = 0 or σ₀ not finite and positive.
    pub fn new<R: Rng + ?Sized>(
        n: usize,
        r0: Vector2<f64>,
        sigma0: f64,
        rng: &mut R,
    ) -> Result<Self, OperatorError> {
        if !(sigma0.is_finite() && sigma0 > 0.0) {
            return Err(OperatorError::OutOfRange {
                what: "initial position standard deviation sigma_0",
                value: sigma0,
                range: "(0, infinity)",
            });
        }
        let particles = (0..n)
            .map(|_| (r0 + normal2(rng) * sigma0, rng.random::<f64>() * 2.0 * PI))
            .collect();
        Ok(Self {
            set: ParticleSet::from_samples(particles)?,
        })
    }

    /// Moves every particle by `v dt` plus a draw of `N(0, q² dt I)`.
    ///
    /// # Errors
    /// As [`VelocityInput::validate`].
    pub fn predict<R: Rng + ?Sized>(
        &mut self,
        model: &VelocityProcess,
        input: &VelocityInput,
        rng: &mut R,
    ) -> Result<(), OperatorError> {
        input.validate()?;
        let step = (model.noise_density() * input.dt).sqrt();
        self.set.propagate(rng, |(r, a), rng| {
            (r + input.velocity * input.dt + normal2(rng) * step, *a)
        });
        Ok(())
    }

    /// Reweights by the measurement likelihood and resamples if degenerate; returns the log evidence
    /// estimate.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite z or when no particle can explain it.
    pub fn update<R: Rng + ?Sized>(
        &mut self,
        model: &PositionMeasurement,
        z: &Vector2<f64>,
        rng: &mut R,
    ) -> Result<f64, OperatorError> {
        if let Some(&value) = z.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "position measurement z",
                value,
            });
        }
        let variance = model.variance();
        let log_evidence = self.set.condition(|(r, a)| {
            let (s, c) = a.sin_cos();
            let predicted = Vector2::new(c * r.x - s * r.y, s * r.x + c * r.y);
            -(z - predicted).norm_squared() / (2.0 * variance)
        })? - (2.0 * PI * variance).ln();
        self.set
            .resample_if_degenerate(0.5, Resampling::Systematic, rng);
        Ok(log_evidence)
    }

    /// The circular mean of A (`atan2` of the weighted mean of (cos A, sin A)).
    pub fn azimuth_mean(&self) -> f64 {
        let c = self.set.expectation(|(_, a)| a.cos());
        let s = self.set.expectation(|(_, a)| a.sin());
        s.atan2(c)
    }

    /// The weighted mean of r.
    pub fn position_mean(&self) -> Vector2<f64> {
        Vector2::new(
            self.set.expectation(|(r, _)| r.x),
            self.set.expectation(|(r, _)| r.y),
        )
    }
}
