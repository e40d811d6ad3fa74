//! The baselines the exact filter is compared with, all built from the operators crate, behind one
//! interface ([`AzimuthFilter`]) so that the Monte Carlo study runs any of them on the same data:
//!
//! * [`GaussianBaseline`]: the EKF or the UKF on the state `[r, A]` ∈ R² × SO(2) ([`PositionAzimuth`]),
//!   from the prior `A ~ N(0, π²/3)` (the uniform's variance);
//! * [`ParticleBaseline`]: the bootstrap particle filter on `(r, A)`;
//! * [`GridReference`]: the grid filter, a Kalman filter for r at each of n azimuths;
//! * [`MarginalizedBaseline`]: the marginalized particle filter, particles for A each with a Kalman
//!   filter for r.

use super::density::check_measurement;
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use super::scenario::normal2;
use super::{AzimuthDensity, GridReference};
use liebayes_densities::{Gaussian, ManifoldGaussian, special};
use liebayes_manifolds::{Manifold, So2};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{ParticleSet, Resampling};
use liebayes_operators::rao_blackwell::condition_marginalized;
use liebayes_operators::{
    Condition, Ekf, MeasurementModel, OperatorError, ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use rand::{Rng, RngCore};
use std::f64::consts::PI;

/// What every azimuth filter reports after a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The circular mean of A in (−π, π], `None` when the filter holds A uniform (ρ = 0).
    pub azimuth: Option<f64>,
    /// The mean resultant length `ρ = |E e^(iA)|` in [0, 1].
    pub rho: f64,
    /// `E r`.
    pub mean_r: Vector2<f64>,
    /// `Cov r`.
    pub cov_r: Matrix2<f64>,
}

impl Estimate {
    /// The circular standard deviation `√(−2 ln ρ)` (σ of a wrapped normal with this ρ); `None` at ρ = 0.
    pub fn sigma_a(&self) -> Option<f64> {
        (self.rho > 0.0).then(|| (-2.0 * self.rho.ln()).sqrt())
    }

    /// From the first trigonometric moment `E (cos A, sin A)`.
    fn from_moment(moment: Vector2<f64>, mean_r: Vector2<f64>, cov_r: Matrix2<f64>) -> Self {
        let rho = moment.x.hypot(moment.y).min(1.0);
        Self {
            azimuth: (rho > 0.0).then(|| moment.y.atan2(moment.x)),
            rho,
            mean_r,
            cov_r,
        }
    }
}

/// A filter for azimuth alignment: the exact one or a baseline. Randomised filters draw from `rng`.
pub trait AzimuthFilter: Send {
    /// One propagation step.
    ///
    /// # Errors
    /// Invalid input, or a step the filter cannot take.
    fn predict(
        &mut self,
        process: &VelocityProcess,
        input: &VelocityInput,
        rng: &mut dyn RngCore,
    ) -> Result<(), OperatorError>;

    /// One position measurement.
    ///
    /// # Errors
    /// Invalid input, or a step the filter cannot take (a lost positive definiteness, particles that
    /// cannot explain the measurement).
    fn update(
        &mut self,
        measurement: &PositionMeasurement,
        z: &Vector2<f64>,
        rng: &mut dyn RngCore,
    ) -> Result<(), OperatorError>;

    /// The current estimate.
    fn estimate(&self) -> Estimate;
}

impl AzimuthFilter for AzimuthDensity {
    fn predict(
        &mut self,
        process: &VelocityProcess,
        input: &VelocityInput,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        AzimuthDensity::predict(self, process, input)
    }

    fn update(
        &mut self,
        measurement: &PositionMeasurement,
        z: &Vector2<f64>,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        AzimuthDensity::update(self, measurement, z)
    }

    fn estimate(&self) -> Estimate {
        let e = self.estimates();
        Estimate {
            azimuth: e.mode,
            // e.kappa is finite or, if η overflowed, +∞, where A = 1.
            rho: special::a1(e.kappa).unwrap_or(1.0),
            mean_r: e.mean_r,
            cov_r: e.cov_r,
        }
    }
}

/// The state `[r, A]` ∈ R² × SO(2) of the Gaussian baselines: `x ⊞ δ = (r + δ_r, A ⊞ δ_A)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionAzimuth {
    /// r, platform axes.
    pub r: Vector2<f64>,
    /// A.
    pub azimuth: So2<f64>,
}

impl Manifold<3> for PositionAzimuth {
    type Scalar = f64;

    fn retract(&self, v: &Vector3<f64>) -> Self {
        Self {
            r: self.r + Vector2::new(v.x, v.y),
            azimuth: self.azimuth.retract(&nalgebra::Vector1::new(v.z)),
        }
    }

    fn local(&self, other: &Self) -> Vector3<f64> {
        let d = other.r - self.r;
        Vector3::new(d.x, d.y, self.azimuth.local(&other.azimuth)[0])
    }

    fn is_finite(&self) -> bool {
        self.r.iter().all(|v| v.is_finite()) && self.azimuth.is_finite()
    }
}

/// `r′ = r + v dt + w`, `A′ = A`, as a manifold process model (F = I).
struct Motion(VelocityProcess);

impl ProcessModel<PositionAzimuth, 3> for Motion {
    type Input = VelocityInput;

    fn transition(&self, x: &PositionAzimuth, input: &VelocityInput) -> PositionAzimuth {
        PositionAzimuth {
            r: x.r + input.velocity * input.dt,
            azimuth: x.azimuth,
        }
    }

    fn noise(&self, _: &PositionAzimuth, input: &VelocityInput) -> Matrix3<f64> {
        let q = self.0.noise_density() * input.dt;
        Matrix3::new(q, 0.0, 0.0, 0.0, q, 0.0, 0.0, 0.0, 0.0)
    }

    fn jacobian(&self, _: &PositionAzimuth, _: &VelocityInput) -> Matrix3<f64> {
        Matrix3::identity()
    }
}

/// `z = R(A) r + n`, with `H = [R(A), R(A) r^×]` (∂R(A)/∂A = R(A) J, J r = r^×).
struct Observation(PositionMeasurement);

impl MeasurementModel<PositionAzimuth, 3, 2> for Observation {
    fn predict(&self, x: &PositionAzimuth) -> Vector2<f64> {
        x.azimuth.to_matrix() * x.r
    }

    fn noise(&self, _: &PositionAzimuth) -> Matrix2<f64> {
        Matrix2::identity() * self.0.variance()
    }

    fn jacobian(&self, x: &PositionAzimuth) -> Matrix2x3<f64> {
        let rotation = x.azimuth.to_matrix();
        let turned = rotation * Vector2::new(-x.r.y, x.r.x);
        let mut h = Matrix2x3::zeros();
        h.fixed_view_mut::<2, 2>(0, 0).copy_from(&rotation);
        h.set_column(2, &turned);
        h
    }
}

/// Which Gaussian approximation a [`GaussianBaseline`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Linearisation {
    /// The extended Kalman filter (first-order Taylor expansion at the mean).
    Extended,
    /// The unscented Kalman filter (α = 0.1, β = 2, κ = 0; see [`GaussianBaseline`]).
    Unscented,
}

/// The EKF or UKF on `[r, A]`, with the operators crate's manifold filters.
///
/// The UKF uses α = 0.1 (β = 2, κ = 0). With the default α = 1 the sigma points of the prior
/// `σ_A = π/√3` sit at `A ± √3 σ_A = A ± π`, the same rotation, so the measurement sigma points carry no
/// information on A and it is never corrected. α = 0.1 puts them at ±18°; of the values measured
/// (docs/filters/azimuth.md) it is the best over the three scenarios, and wider spreads (α = 0.5) leave
/// early errors that the constant azimuth never sheds.
#[derive(Clone, Debug)]
pub struct GaussianBaseline {
    density: ManifoldGaussian<PositionAzimuth, 3>,
    kind: Linearisation,
}

impl GaussianBaseline {
    /// The prior `r ~ N(r₀, σ₀² I)`, `A ~ N(0, π²/3)` (the variance of the uniform azimuth).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite r₀, [`OperatorError::Density`] for a σ₀ that
    /// does not give a positive definite covariance.
    pub fn new(kind: Linearisation, r0: Vector2<f64>, sigma0: f64) -> Result<Self, OperatorError> {
        if let Some(&value) = r0.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "initial position r_0",
                value,
            });
        }
        let s2 = sigma0 * sigma0;
        let state = PositionAzimuth {
            r: r0,
            azimuth: So2::from_angle_unchecked(0.0),
        };
        Ok(Self {
            density: ManifoldGaussian::new(
                state,
                Matrix3::new(s2, 0.0, 0.0, 0.0, s2, 0.0, 0.0, 0.0, PI * PI / 3.0),
            )?,
            kind,
        })
    }

    /// The Gaussian on `[r, A]`.
    pub fn density(&self) -> &ManifoldGaussian<PositionAzimuth, 3> {
        &self.density
    }
}

impl AzimuthFilter for GaussianBaseline {
    fn predict(
        &mut self,
        process: &VelocityProcess,
        input: &VelocityInput,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        input.validate()?;
        let model = Motion(*process);
        self.density = match self.kind {
            Linearisation::Extended => self.density.propagate(&Ekf(model), input)?,
            Linearisation::Unscented => self.density.propagate(&unscented(model)?, input)?,
        };
        Ok(())
    }

    fn update(
        &mut self,
        measurement: &PositionMeasurement,
        z: &Vector2<f64>,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        let model = Observation(*measurement);
        self.density = match self.kind {
            Linearisation::Extended => self.density.condition(&Ekf(model), z)?,
            Linearisation::Unscented => self.density.condition(&unscented(model)?, z)?,
        }
        .posterior;
        Ok(())
    }

    /// A wrapped normal for A: ρ = exp(−P_AA / 2).
    fn estimate(&self) -> Estimate {
        let p = self.density.covariance();
        Estimate {
            azimuth: Some(self.density.mean().azimuth.angle()),
            rho: (-0.5 * p[(2, 2)]).exp(),
            mean_r: self.density.mean().r,
            cov_r: p.fixed_view::<2, 2>(0, 0).into_owned(),
        }
    }
}

/// The UKF scaling of the azimuth baseline (see [`GaussianBaseline`]).
fn unscented<Model, const M: usize>(model: Model) -> Result<Ukf<Model, M>, OperatorError> {
    Ukf::with_scaling(model, 0.1, 2.0, 0.0)
}

/// The bootstrap particle filter on `(r, A)`: particles from the prior `N(r₀, σ₀² I) × U[0, 2π)`, moved
/// by the process with sampled noise, reweighted by `N(z; R(A) r, σ_m² I)` and resampled systematically
/// when the effective sample size falls below half. A is constant, so after resampling its particles
/// only lose diversity: the filter can collapse on a wrong azimuth when too few particles start near
/// the truth.
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
        check_sigma0(sigma0)?;
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
        check_measurement(z)?;
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
        let m = self
            .set
            .expectation(|(_, a)| Vector2::new(a.cos(), a.sin()));
        m.y.atan2(m.x)
    }

    /// The particles.
    pub fn particles(&self) -> &ParticleSet<(Vector2<f64>, f64)> {
        &self.set
    }
}

impl AzimuthFilter for ParticleBaseline {
    fn predict(
        &mut self,
        process: &VelocityProcess,
        input: &VelocityInput,
        mut rng: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        ParticleBaseline::predict(self, process, input, &mut rng)
    }

    fn update(
        &mut self,
        measurement: &PositionMeasurement,
        z: &Vector2<f64>,
        mut rng: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        ParticleBaseline::update(self, measurement, z, &mut rng).map(|_| ())
    }

    fn estimate(&self) -> Estimate {
        let moment = self
            .set
            .expectation(|(_, a)| Vector2::new(a.cos(), a.sin()));
        let mean_r = self.set.expectation(|(r, _)| *r);
        let cov_r = self
            .set
            .expectation(|(r, _)| (r - mean_r) * (r - mean_r).transpose());
        Estimate::from_moment(moment, mean_r, cov_r)
    }
}

impl AzimuthFilter for GridReference {
    fn predict(
        &mut self,
        process: &VelocityProcess,
        input: &VelocityInput,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        GridReference::predict(self, process, input)
    }

    fn update(
        &mut self,
        measurement: &PositionMeasurement,
        z: &Vector2<f64>,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        GridReference::update(self, measurement, z)
    }

    fn estimate(&self) -> Estimate {
        let (mean_r, cov_r) = self.moments();
        Estimate::from_moment(self.grid().first_moment(), mean_r, cov_r)
    }
}

/// The marginalized particle filter: particles `Aᵢ` from the uniform prior, each carrying an exact
/// Kalman filter `p(r | Aᵢ, z…)`, weighted by that filter's log evidence and resampled systematically
/// when the effective sample size falls below half. Exact given the particles; A is constant, so it
/// degenerates like the bootstrap filter, only later.
#[derive(Clone, Debug)]
pub struct MarginalizedBaseline {
    set: ParticleSet<(f64, Gaussian<2>)>,
}

impl MarginalizedBaseline {
    /// n particles, A uniform, each with the prior `N(r₀, σ₀² I)`.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for n = 0, the Gaussian's errors for r₀ and σ₀.
    pub fn new<R: Rng + ?Sized>(
        n: usize,
        r0: Vector2<f64>,
        sigma0: f64,
        rng: &mut R,
    ) -> Result<Self, OperatorError> {
        check_sigma0(sigma0)?;
        let prior = Gaussian::new(r0, Matrix2::identity() * (sigma0 * sigma0))?;
        let particles = (0..n)
            .map(|_| (rng.random::<f64>() * 2.0 * PI, prior.clone()))
            .collect();
        Ok(Self {
            set: ParticleSet::from_samples(particles)?,
        })
    }
}

impl AzimuthFilter for MarginalizedBaseline {
    fn predict(
        &mut self,
        process: &VelocityProcess,
        input: &VelocityInput,
        _: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        input.validate()?;
        let model = LinearProcess::new(
            Matrix2::identity(),
            Matrix2::identity() * (process.noise_density() * input.dt),
        )?;
        let offset = input.velocity * input.dt;
        self.set
            .try_propagate(|(a, density)| Ok((*a, density.propagate(&model, &offset)?)))
    }

    fn update(
        &mut self,
        measurement: &PositionMeasurement,
        z: &Vector2<f64>,
        mut rng: &mut dyn RngCore,
    ) -> Result<(), OperatorError> {
        let noise = Matrix2::identity() * measurement.variance();
        condition_marginalized(
            &mut self.set,
            |a| LinearMeasurement::new(So2::from_angle_unchecked(*a).to_matrix(), noise),
            z,
        )?;
        self.set
            .resample_if_degenerate(0.5, Resampling::Systematic, &mut rng);
        Ok(())
    }

    fn estimate(&self) -> Estimate {
        let moment = self
            .set
            .expectation(|(a, _)| Vector2::new(a.cos(), a.sin()));
        let mean_r = self.set.expectation(|(_, g)| *g.mean());
        let cov_r = self.set.expectation(|(_, g)| {
            let d = g.mean() - mean_r;
            g.covariance() + d * d.transpose()
        });
        Estimate::from_moment(moment, mean_r, cov_r)
    }
}

fn check_sigma0(sigma0: f64) -> Result<(), OperatorError> {
    if sigma0.is_finite() && sigma0 > 0.0 {
        Ok(())
    } else {
        Err(OperatorError::OutOfRange {
            what: "initial position standard deviation sigma_0",
            value: sigma0,
            range: "(0, infinity)",
        })
    }
}
