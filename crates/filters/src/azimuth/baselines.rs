//! The baselines the exact filter is compared with, all built from the operators crate, behind one
//! interface ([`AzimuthFilter`]) so that the Monte Carlo study runs any of them on the same data:
//!
//! * [`GaussianBaseline`]: the EKF or the UKF on the state `[r, A]` ∈ R² × SO(2) ([`PositionAzimuth`],
//!   the manifolds crate's product of Rn and So2), from the prior `A ~ N(0, π²/3)` (the uniform's
//!   variance);
//! * [`ParticleBaseline`]: the bootstrap particle filter on the same state;
//! * [`GridReference`]: the grid filter, a Kalman filter for r at each of n azimuths;
//! * [`MarginalizedBaseline`]: the marginalized particle filter, particles for A each with a Kalman
//!   filter for r.

use super::density::{check_measurement, variance_of};
use super::model::{PositionMeasurement, VelocityInput, VelocityProcess};
use super::scenario::normal2;
use super::{AzimuthDensity, GridReference};
use liebayes_densities::{Gaussian, ManifoldGaussian, special};
use liebayes_manifolds::{ProductManifold, Rn, So2};
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{ParticleSet, Resampling};
use liebayes_operators::rao_blackwell::condition_marginalized;
use liebayes_operators::{
    Condition, Ekf, MAX_ELEMENTS, MeasurementModel, OperatorError, ProcessModel, Propagate, Ukf,
};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2};
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

    /// The estimate if every number in it is finite.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] otherwise (moments that overflow: positions beyond about 1e154).
    fn checked(self) -> Result<Self, OperatorError> {
        match self
            .mean_r
            .iter()
            .chain(self.cov_r.iter())
            .chain(std::iter::once(&self.rho))
            .chain(self.azimuth.iter())
            .find(|v| !v.is_finite())
        {
            Some(&value) => Err(OperatorError::NonFinite {
                what: "azimuth filter estimate (E r or Cov r overflow: the positions are too \
                       large for their second moments)",
                value,
            }),
            None => Ok(self),
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
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a moment overflows (the exact filter's never do: its
    /// parameters are bounded).
    fn estimate(&self) -> Result<Estimate, OperatorError>;
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

    fn estimate(&self) -> Result<Estimate, OperatorError> {
        let e = self.estimates();
        Estimate {
            azimuth: e.mode,
            // e.kappa is finite or, if η overflowed, +∞, where A = 1.
            rho: special::a1(e.kappa).unwrap_or(1.0),
            mean_r: e.mean_r,
            cov_r: e.cov_r,
        }
        .checked()
    }
}

/// The state `[r, A]` ∈ R² × SO(2) of the Gaussian and particle baselines: r (platform axes) the first
/// factor, A the second, tangent `[δr; δA]`, `x ⊞ δ = (r + δr, A ⊞ δA)`.
pub type PositionAzimuth = ProductManifold<Rn<f64, 2>, So2<f64>, 2, 1, 3>;

/// The state with position r and azimuth A (r finite: the callers pass validated or finite values).
fn state(r: Vector2<f64>, azimuth: So2<f64>) -> PositionAzimuth {
    PositionAzimuth::new(Rn::new_unchecked(r), azimuth)
}

/// `r′ = r + v dt + w`, `A′ = A`, as a manifold process model (F = I).
struct Motion(VelocityProcess);

impl ProcessModel<PositionAzimuth, 3> for Motion {
    type Input = VelocityInput;

    fn transition(&self, x: &PositionAzimuth, input: &VelocityInput) -> PositionAzimuth {
        state(x.first().coords() + input.velocity * input.dt, *x.second())
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
        x.second().to_matrix() * x.first().coords()
    }

    fn noise(&self, _: &PositionAzimuth) -> Matrix2<f64> {
        Matrix2::identity() * self.0.variance()
    }

    fn jacobian(&self, x: &PositionAzimuth) -> Matrix2x3<f64> {
        let rotation = x.second().to_matrix();
        let r = x.first().coords();
        let turned = rotation * Vector2::new(-r.y, r.x);
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
    /// [`OperatorError::NonFinite`] for a non-finite r₀, [`OperatorError::OutOfRange`] for σ₀
    /// outside [1.5e-154, 1e150].
    pub fn new(kind: Linearisation, r0: Vector2<f64>, sigma0: f64) -> Result<Self, OperatorError> {
        let s2 = variance_of("initial position standard deviation sigma_0 (m)", sigma0)?;
        if let Some(&value) = r0.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "initial position r_0",
                value,
            });
        }
        Ok(Self {
            density: ManifoldGaussian::new(
                state(r0, So2::from_angle_unchecked(0.0)),
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
    fn estimate(&self) -> Result<Estimate, OperatorError> {
        let (p, mean) = (self.density.covariance(), self.density.mean());
        Estimate {
            azimuth: Some(mean.second().angle()),
            rho: (-0.5 * p[(2, 2)]).exp(),
            mean_r: *mean.first().coords(),
            cov_r: p.fixed_view::<2, 2>(0, 0).into_owned(),
        }
        .checked()
    }
}

/// The UKF scaling of the azimuth baseline (see [`GaussianBaseline`]).
fn unscented<Model, const M: usize>(model: Model) -> Result<Ukf<Model, M>, OperatorError> {
    Ukf::with_scaling(model, 0.1, 2.0, 0.0)
}

/// The bootstrap particle filter on `[r, A]` ([`PositionAzimuth`]): particles from the prior
/// `N(r₀, σ₀² I) × U[0, 2π)`, moved by the process with sampled noise, reweighted by
/// `N(z; R(A) r, σ_m² I)` and resampled systematically when the effective sample size falls below
/// half. A is constant, so after resampling its particles only lose diversity: the filter can collapse
/// on a wrong azimuth when too few particles start near the truth.
#[derive(Clone, Debug)]
pub struct ParticleBaseline {
    set: ParticleSet<PositionAzimuth>,
}

/// Checks a particle count before any particle is drawn.
fn check_count(n: usize) -> Result<(), OperatorError> {
    if n == 0 {
        return Err(OperatorError::OutOfRange {
            what: "number of particles",
            value: 0.0,
            range: "at least 1",
        });
    }
    if n > MAX_ELEMENTS {
        return Err(OperatorError::TooLarge {
            what: "number of particles",
            value: n,
            max: MAX_ELEMENTS,
        });
    }
    Ok(())
}

/// n draws of `draw`, the count checked and the memory reserved first.
fn draws<T>(n: usize, mut draw: impl FnMut() -> T) -> Result<Vec<T>, OperatorError> {
    check_count(n)?;
    let mut particles = Vec::new();
    particles
        .try_reserve_exact(n)
        .map_err(|_| OperatorError::TooLarge {
            what: "number of particles (their memory cannot be allocated)",
            value: n,
            max: MAX_ELEMENTS,
        })?;
    particles.extend((0..n).map(|_| draw()));
    Ok(particles)
}

impl ParticleBaseline {
    /// n particles from the prior.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for n = 0 or σ₀ outside [1.5e-154, 1e150],
    /// [`OperatorError::TooLarge`] for n above [`MAX_ELEMENTS`] or more than the memory holds,
    /// [`OperatorError::NonFinite`] for a non-finite r₀; all checked before any particle is drawn.
    pub fn new<R: Rng + ?Sized>(
        n: usize,
        r0: Vector2<f64>,
        sigma0: f64,
        rng: &mut R,
    ) -> Result<Self, OperatorError> {
        check_prior(r0, sigma0)?;
        let particles = draws(n, || {
            state(
                r0 + normal2(rng) * sigma0,
                So2::from_angle_unchecked(rng.random::<f64>() * 2.0 * PI),
            )
        })?;
        Ok(Self {
            set: ParticleSet::from_samples(particles)?,
        })
    }

    /// Moves every particle by `v dt` plus a draw of `N(0, q² dt I)`.
    ///
    /// # Errors
    /// As [`VelocityInput::validate`], or [`OperatorError::NonFinitePoint`] when a moved particle
    /// overflows; the particles are then unchanged.
    pub fn predict<R: Rng + ?Sized>(
        &mut self,
        model: &VelocityProcess,
        input: &VelocityInput,
        rng: &mut R,
    ) -> Result<(), OperatorError> {
        input.validate()?;
        let step = (model.noise_density() * input.dt).sqrt();
        self.set.propagate(rng, |x, rng| {
            state(
                x.first().coords() + input.velocity * input.dt + normal2(rng) * step,
                *x.second(),
            )
        })
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
        let log_evidence = self.set.condition(|x| {
            let predicted = x.second().to_matrix() * x.first().coords();
            -(z - predicted).norm_squared() / (2.0 * variance)
        })? - (2.0 * PI * variance).ln();
        self.set
            .resample_if_degenerate(0.5, Resampling::Systematic, rng);
        Ok(log_evidence)
    }

    /// The circular mean of A (`atan2` of the weighted mean of (cos A, sin A); 0 when that mean is
    /// zero).
    pub fn azimuth_mean(&self) -> f64 {
        let m = self.set.expectation(|x| azimuth_moment(x.second()));
        m.y.atan2(m.x)
    }

    /// The particles.
    pub fn particles(&self) -> &ParticleSet<PositionAzimuth> {
        &self.set
    }
}

/// `(cos A, sin A)`.
fn azimuth_moment(a: &So2<f64>) -> Vector2<f64> {
    Vector2::new(a.cos(), a.sin())
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

    fn estimate(&self) -> Result<Estimate, OperatorError> {
        let moment = self.set.expectation(|x| azimuth_moment(x.second()));
        let mean_r = self.set.expectation(|x| *x.first().coords());
        let cov_r = self.set.expectation(|x| {
            let d = x.first().coords() - mean_r;
            d * d.transpose()
        });
        Estimate::from_moment(moment, mean_r, cov_r).checked()
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

    fn estimate(&self) -> Result<Estimate, OperatorError> {
        let (mean_r, cov_r) = self.moments();
        Estimate::from_moment(self.grid().first_moment(), mean_r, cov_r).checked()
    }
}

/// The marginalized particle filter: particles `Aᵢ` from the uniform prior, each carrying an exact
/// Kalman filter `p(r | Aᵢ, z…)`, weighted by that filter's log evidence and resampled systematically
/// when the effective sample size falls below half. Exact given the particles; A is constant, so it
/// degenerates like the bootstrap filter, only later.
#[derive(Clone, Debug)]
pub struct MarginalizedBaseline {
    set: ParticleSet<(So2<f64>, Gaussian<2>)>,
}

impl MarginalizedBaseline {
    /// n particles, A uniform, each with the prior `N(r₀, σ₀² I)`.
    ///
    /// # Errors
    /// As [`ParticleBaseline::new`], all checked before any particle is drawn.
    pub fn new<R: Rng + ?Sized>(
        n: usize,
        r0: Vector2<f64>,
        sigma0: f64,
        rng: &mut R,
    ) -> Result<Self, OperatorError> {
        check_prior(r0, sigma0)?;
        let prior = Gaussian::new(r0, Matrix2::identity() * (sigma0 * sigma0))?;
        let particles = draws(n, || {
            (
                So2::from_angle_unchecked(rng.random::<f64>() * 2.0 * PI),
                prior.clone(),
            )
        })?;
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
        // The angle is copied and the Gaussian validates itself: nothing else to check.
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
            |a| LinearMeasurement::new(a.to_matrix(), noise),
            z,
        )?;
        self.set
            .resample_if_degenerate(0.5, Resampling::Systematic, &mut rng);
        Ok(())
    }

    fn estimate(&self) -> Result<Estimate, OperatorError> {
        let moment = self.set.expectation(|(a, _)| azimuth_moment(a));
        let mean_r = self.set.expectation(|(_, g)| *g.mean());
        let cov_r = self.set.expectation(|(_, g)| {
            let d = g.mean() - mean_r;
            g.covariance() + d * d.transpose()
        });
        Estimate::from_moment(moment, mean_r, cov_r).checked()
    }
}

/// Checks the prior of the particle baselines: r₀ finite, σ₀ in [1.5e-154, 1e150].
fn check_prior(r0: Vector2<f64>, sigma0: f64) -> Result<(), OperatorError> {
    variance_of("initial position standard deviation sigma_0 (m)", sigma0)?;
    match r0.iter().find(|v| !v.is_finite()) {
        Some(&value) => Err(OperatorError::NonFinite {
            what: "initial position r_0",
            value,
        }),
        None => Ok(()),
    }
}
