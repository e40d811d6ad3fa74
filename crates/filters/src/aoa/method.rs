//! The filters a track study compares, by name ("PF-VMF", "EKF-AE-adaptive", …), the paper's rule
//! for their parameters, and the study of one of them on a [`SquareTrack`].

use super::data::DataModel;
use super::estimate::PositionScorer;
use super::filter::{
    angle_ekf, angle_particle_filter, angle_ukf, vmf_ekf, vmf_particle_filter, vmf_ukf,
};
use super::model::{AngleNoise, AzElModel, UnitVectorModel};
use super::noise::{AdaptiveSigmas, kappa_from_sigmas, sigma_from_kappa};
use super::scenario::SquareTrack;
use liebayes_experiments::{ExperimentError, Study, Summary};
use liebayes_operators::OperatorError;
use rand_chacha::ChaCha8Rng;

/// The filtering algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Algorithm {
    /// The particle filter (Algorithm 1) with this many particles.
    Particle(usize),
    /// The EKF.
    Ekf,
    /// The UKF (λ = 0.5).
    Ukf,
}

/// The measurement model a filter assumes, with its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelChoice {
    /// Von Mises-Fisher with concentration κ.
    Vmf {
        /// κ.
        kappa: f64,
    },
    /// Normal azimuth-elevation with the data's (or the converted) σ.
    AngleNominal {
        /// σ_az (rad).
        sigma_az: f64,
        /// σ_el (rad).
        sigma_el: f64,
    },
    /// Normal azimuth-elevation with maximum-likelihood σ.
    AngleFitted {
        /// σ_az (rad).
        sigma_az: f64,
        /// σ_el (rad).
        sigma_el: f64,
    },
    /// Normal azimuth-elevation with σ from the table at the predicted elevation.
    AngleAdaptive(AdaptiveSigmas),
}

impl ModelChoice {
    /// `VMF`, `AE-nominal`, `AE-fitted`, `AE-adaptive`.
    pub fn name(&self) -> &'static str {
        match self {
            ModelChoice::Vmf { .. } => "VMF",
            ModelChoice::AngleNominal { .. } => "AE-nominal",
            ModelChoice::AngleFitted { .. } => "AE-fitted",
            ModelChoice::AngleAdaptive(_) => "AE-adaptive",
        }
    }

    /// The paper's four filter models for data from `data`, given the fitted σ (see
    /// `fit_angle_sigmas`): for Model I data, AE-nominal takes the data's σ and VMF
    /// `κ = 1/max(σ_az², σ_el²)`; for Model II data, VMF takes the data's κ and AE-nominal
    /// `σ = 1/√κ` (equation (7)); AE-adaptive's table is Model I's at the nominal σ.
    ///
    /// # Errors
    /// As [`AdaptiveSigmas::model_one`].
    pub fn paper(data: &DataModel, fitted: (f64, f64)) -> Result<[ModelChoice; 4], OperatorError> {
        let (kappa, sigma_az, sigma_el) = match *data {
            DataModel::NormalWithFlip { sigma_az, sigma_el } => {
                (kappa_from_sigmas(sigma_az, sigma_el), sigma_az, sigma_el)
            }
            DataModel::VonMisesFisher { kappa } => {
                let sigma = sigma_from_kappa(kappa);
                (kappa, sigma, sigma)
            }
        };
        Ok([
            ModelChoice::Vmf { kappa },
            ModelChoice::AngleNominal { sigma_az, sigma_el },
            ModelChoice::AngleFitted {
                sigma_az: fitted.0,
                sigma_el: fitted.1,
            },
            ModelChoice::AngleAdaptive(AdaptiveSigmas::model_one(sigma_az, sigma_el)?),
        ])
    }
}

/// One filter of a track study: an algorithm with a measurement model.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackFilter {
    /// The algorithm.
    pub algorithm: Algorithm,
    /// The measurement model.
    pub model: ModelChoice,
}

impl TrackFilter {
    /// `PF-VMF`, `EKF-AE-adaptive`, … (the particle count is not part of the label).
    pub fn label(&self) -> String {
        let algorithm = match self.algorithm {
            Algorithm::Particle(_) => "PF",
            Algorithm::Ekf => "EKF",
            Algorithm::Ukf => "UKF",
        };
        format!("{algorithm}-{}", self.model.name())
    }

    /// Runs the study of this filter on `track` (four anchors: the Kalman filters stack 12 or 8
    /// values), every run from the prior [`TrackConfig::prior`](super::TrackConfig::prior) drawn from
    /// the run's filter stream, scored by [`PositionScorer`].
    ///
    /// # Errors
    /// A model parameter out of range (before any run, as [`ExperimentError::Scenario`]), or
    /// [`Study::run`]'s errors.
    pub fn study(
        &self,
        track: &SquareTrack<4>,
        study: &Study,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError> {
        let setting =
            |e: OperatorError| ExperimentError::Scenario(format!("{}: {e}", self.label()));
        let config = *track.config();
        let process = config.random_walk().map_err(setting)?;
        let anchors = *track.anchors();
        let scorer = PositionScorer;
        if let Algorithm::Particle(0) = self.algorithm {
            return Err(setting(OperatorError::OutOfRange {
                what: "number of particles",
                value: 0.0,
                range: "at least 1",
            }));
        }
        let noise = match &self.model {
            ModelChoice::Vmf { kappa } => {
                let model = UnitVectorModel::new(anchors, *kappa).map_err(setting)?;
                return match self.algorithm {
                    Algorithm::Particle(n) => study.run(
                        track,
                        &|rng: &mut ChaCha8Rng| {
                            let prior = config.prior(rng)?;
                            vmf_particle_filter(model, process, &prior, n, rng.clone())
                        },
                        &scorer,
                        progress,
                    ),
                    Algorithm::Ekf => study.run(
                        track,
                        &|rng: &mut ChaCha8Rng| {
                            vmf_ekf::<4, 12>(model, process, &config.prior(rng)?)
                        },
                        &scorer,
                        progress,
                    ),
                    Algorithm::Ukf => study.run(
                        track,
                        &|rng: &mut ChaCha8Rng| {
                            vmf_ukf::<4, 12>(model, process, &config.prior(rng)?)
                        },
                        &scorer,
                        progress,
                    ),
                };
            }
            ModelChoice::AngleNominal { sigma_az, sigma_el }
            | ModelChoice::AngleFitted { sigma_az, sigma_el } => AngleNoise::Fixed {
                sigma_az: *sigma_az,
                sigma_el: *sigma_el,
            },
            ModelChoice::AngleAdaptive(table) => AngleNoise::Adaptive(table.clone()),
        };
        let model = AzElModel::new(anchors, noise).map_err(setting)?;
        match self.algorithm {
            Algorithm::Particle(n) => study.run(
                track,
                &|rng: &mut ChaCha8Rng| {
                    let prior = config.prior(rng)?;
                    angle_particle_filter(model.clone(), process, &prior, n, rng.clone())
                },
                &scorer,
                progress,
            ),
            Algorithm::Ekf => study.run(
                track,
                &|rng: &mut ChaCha8Rng| {
                    angle_ekf::<4, 8>(model.clone(), process, &config.prior(rng)?)
                },
                &scorer,
                progress,
            ),
            Algorithm::Ukf => study.run(
                track,
                &|rng: &mut ChaCha8Rng| {
                    angle_ukf::<4, 8>(model.clone(), process, &config.prior(rng)?)
                },
                &scorer,
                progress,
            ),
        }
    }
}

/// The root mean square, over a study's runs, of each run's RMSE of `position_error` over its
/// track: `√(mean of the runs' mean squared errors)`; `None` when no run has a value.
pub fn track_rmse(summary: &Summary) -> Option<f64> {
    let values = summary.run_values("position_error")?;
    let (sum, n) = values
        .values()
        .iter()
        .filter(|(_, v)| v.is_finite())
        .fold((0.0, 0_u32), |(s, n), (_, v)| (s + v * v, n + 1));
    (n > 0).then(|| (sum / f64::from(n)).sqrt())
}

/// How [`particles_to_match`] searches: within `(1 + tolerance)` of the reference RMSE, tolerance in
/// (0, 10]; counts from `low` to `high`; stopping when the bracket is within the relative
/// `resolution`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchSettings {
    /// The RMSE tolerance (0.01: within 1 %).
    pub tolerance: f64,
    /// The smallest count tried.
    pub low: u64,
    /// The largest count tried.
    pub high: u64,
    /// The relative width at which the bisection stops, in (0, 1].
    pub resolution: f64,
}

/// What [`particles_to_match`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleSearch {
    /// The reference filter's [`track_rmse`] (m), the target.
    pub reference_rmse: f64,
    /// Every particle count tried, with its [`track_rmse`] (m; +∞ when no run gave one), its failed
    /// runs and its filter time per step (s), in the order tried.
    pub tried: Vec<(u64, f64, u64, f64)>,
    /// The smallest count found whose RMSE is within the tolerance, `None` if `high` is not.
    pub count: Option<u64>,
}

/// The smallest particle count in `[low, high]` (see [`SearchSettings`]) at which the particle filter with `model` comes
/// within `(1 + tolerance)` of the reference study's [`track_rmse`] on the same runs (the study's
/// seed and runs: run k of every study reads the same data), with no failed run, by doubling then
/// bisection to the relative `resolution`
/// ([`smallest_passing`](liebayes_experiments::search::smallest_passing)).
///
/// # Errors
/// [`ExperimentError::OutOfRange`] for a tolerance outside (0, 10] or NaN, a reference without
/// per-run errors, or `high` above [`MAX_ELEMENTS`](liebayes_operators::MAX_ELEMENTS); the search's
/// and the studies' errors otherwise.
pub fn particles_to_match(
    track: &SquareTrack<4>,
    model: &ModelChoice,
    study: &Study,
    reference: &Summary,
    settings: SearchSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<ParticleSearch, ExperimentError> {
    let SearchSettings {
        tolerance,
        low,
        high,
        resolution,
    } = settings;
    if !(tolerance > 0.0 && tolerance <= 10.0) {
        return Err(ExperimentError::OutOfRange {
            what: "RMSE tolerance",
            value: tolerance.to_string(),
            range: "(0, 10]",
        });
    }
    let limit = u64::try_from(liebayes_operators::MAX_ELEMENTS).unwrap_or(u64::MAX);
    if high > limit {
        return Err(ExperimentError::OutOfRange {
            what: "largest particle count",
            value: high.to_string(),
            range: "at most 2^30",
        });
    }
    let reference_rmse = track_rmse(reference).ok_or(ExperimentError::OutOfRange {
        what: "reference study",
        value: reference.label().name.clone(),
        range: "a study whose runs kept their position_error",
    })?;
    let mut tried = Vec::new();
    let count = liebayes_experiments::search::smallest_passing(low, high, resolution, |n| {
        // n ≤ high ≤ 2^30: it fits a usize.
        let particles = usize::try_from(n).unwrap_or(usize::MAX);
        let filter = TrackFilter {
            algorithm: Algorithm::Particle(particles),
            model: model.clone(),
        };
        let summary = filter.study(track, study, progress)?;
        let rmse = track_rmse(&summary).unwrap_or(f64::INFINITY);
        let seconds = summary.timing().mean().unwrap_or(f64::NAN);
        tried.push((n, rmse, summary.failure_count(), seconds));
        Ok::<_, ExperimentError>(
            summary.failure_count() == 0 && rmse <= reference_rmse * (1.0 + tolerance),
        )
    })?;
    Ok(ParticleSearch {
        reference_rmse,
        tried,
        count,
    })
}
