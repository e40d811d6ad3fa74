//! The filters a track study compares, by name ("PF-VMF", "EKF-AE-adaptive", …), the paper's rule
//! for their parameters, and the study of one of them on a [`SquareTrack`].

use super::data::DataModel;
use super::estimate::{PositionEstimate, PositionScorer};
use super::filter::{
    angle_ekf, angle_iterated_ekf, angle_particle_filter, angle_ukf, vmf_ekf, vmf_iterated_ekf,
    vmf_particle_filter, vmf_ukf,
};
use super::model::{AngleNoise, AzElModel, Readings, UnitVectorModel};
use super::noise::{AdaptiveSigmas, kappa_from_sigmas, sigma_from_kappa};
use super::process::RandomWalk;
use super::scenario::TrackConfig;
use super::scenario::{SquareTrack, TrackReadings};
use liebayes_experiments::search::{SearchSettings, SizeSearch, smallest_to_match};
use liebayes_experiments::{ExperimentError, RecursiveFilter, Smoothing, Study, Summary, Update};
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
    /// The iterated EKF: the EKF's propagation, each update Gauss-Newton to the posterior's mode.
    IteratedEkf,
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
    /// As [`kappa_from_sigmas`] or [`sigma_from_kappa`] for the data's noise, and as
    /// [`AdaptiveSigmas::model_one`].
    pub fn paper(data: &DataModel, fitted: (f64, f64)) -> Result<[ModelChoice; 4], OperatorError> {
        let (kappa, sigma_az, sigma_el) = match *data {
            DataModel::NormalWithFlip { sigma_az, sigma_el } => {
                (kappa_from_sigmas(sigma_az, sigma_el)?, sigma_az, sigma_el)
            }
            DataModel::VonMisesFisher { kappa } => {
                let sigma = sigma_from_kappa(kappa)?;
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
            Algorithm::IteratedEkf => "IEKF",
        };
        format!("{algorithm}-{}", self.model.name())
    }

    /// This filter on `track`'s four anchors, with the track's random walk and prior: what a
    /// study builds each run's filter from.
    ///
    /// # Errors
    /// A model parameter out of range ([`UnitVectorModel::new`], [`AzElModel::new`]) or the
    /// track's random walk ([`TrackConfig::random_walk`](super::TrackConfig::random_walk)).
    pub fn on(&self, track: &SquareTrack<4>) -> Result<OnTrack, OperatorError> {
        let anchors = *track.anchors();
        let model = match &self.model {
            ModelChoice::Vmf { kappa } => BuiltModel::Vmf(UnitVectorModel::new(anchors, *kappa)?),
            ModelChoice::AngleNominal { sigma_az, sigma_el }
            | ModelChoice::AngleFitted { sigma_az, sigma_el } => {
                let noise = AngleNoise::Fixed {
                    sigma_az: *sigma_az,
                    sigma_el: *sigma_el,
                };
                BuiltModel::Angle(AzElModel::new(anchors, noise)?)
            }
            ModelChoice::AngleAdaptive(table) => BuiltModel::Angle(AzElModel::new(
                anchors,
                AngleNoise::Adaptive(table.clone()),
            )?),
        };
        Ok(OnTrack {
            label: self.label(),
            algorithm: self.algorithm,
            model,
            process: track.config().random_walk()?,
            config: *track.config(),
        })
    }

    /// Runs the study of this filter on `track` (four anchors: the Kalman filters stack 12 or 8
    /// values), every run from the prior [`TrackConfig::prior`](super::TrackConfig::prior) drawn from
    /// the run's filter stream, scored by [`PositionScorer`].
    ///
    /// # Errors
    /// A model parameter out of range (before any run, as [`ExperimentError::Scenario`]), a
    /// particle count refused ([`ExperimentError::Method`]), or [`Study::run_method`]'s errors.
    pub fn study(
        &self,
        track: &SquareTrack<4>,
        study: &Study,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Summary, ExperimentError> {
        let method = self
            .on(track)
            .map_err(|e| ExperimentError::Scenario(format!("{}: {e}", self.label())))?;
        study.run_method(track, &method, &PositionScorer, progress)
    }
}

/// Any filter of a track: each reports a [`PositionEstimate`], and takes a track's measurement
/// ([`TrackReadings`]) as [`OnTrackReadings`] says.
pub type PositionFilter = Box<
    dyn RecursiveFilter<Input = f64, Measurement = TrackReadings<4>, Estimate = PositionEstimate>
        + Send,
>;

/// A filter of readings ([`Readings`]) run on a track's measurements ([`TrackReadings`]):
/// [`TrackReadings::Readings`] is the filter's update; [`TrackReadings::AtAnchor`] leaves the
/// filter as it is and reports a log evidence of 0 (an empty measurement has likelihood 1) and no
/// NIS, so that the epoch is scored on the prediction and keeps its index; and
/// [`TrackReadings::Failed`] is the update's error (the run fails at that epoch), the filter left
/// as it was. Prediction, estimate and smoothing are the filter's.
#[derive(Clone, Debug)]
pub struct OnTrackReadings<F>(pub F);

impl<F, const N: usize> RecursiveFilter for OnTrackReadings<F>
where
    F: RecursiveFilter<Input = f64, Measurement = Readings<N>>,
{
    type Input = f64;
    type Measurement = TrackReadings<N>;
    type Estimate = F::Estimate;

    fn predict(&mut self, input: &f64) -> Result<(), OperatorError> {
        self.0.predict(input)
    }

    fn update(&mut self, z: &TrackReadings<N>) -> Result<Update, OperatorError> {
        match z {
            TrackReadings::Readings(readings) => self.0.update(readings),
            TrackReadings::AtAnchor => Ok(Update {
                log_evidence: 0.0,
                nis: None,
            }),
            TrackReadings::Failed(error) => Err(error.clone()),
        }
    }

    fn estimate(&self) -> Result<F::Estimate, OperatorError> {
        self.0.estimate()
    }

    fn smoothing(&mut self) -> Option<&mut dyn Smoothing<Estimate = F::Estimate>> {
        self.0.smoothing()
    }
}

/// A measurement model built for a track's anchors.
#[derive(Clone, Debug, PartialEq)]
enum BuiltModel {
    Vmf(UnitVectorModel<4>),
    Angle(AzElModel<4>),
}

/// A [`TrackFilter`] on a track ([`TrackFilter::on`]): its models built for the track's anchors,
/// the track's random walk and prior. What a study builds each run's filter from
/// ([`Study::run_method`]).
#[derive(Clone, Debug, PartialEq)]
pub struct OnTrack {
    label: String,
    algorithm: Algorithm,
    model: BuiltModel,
    process: RandomWalk,
    config: TrackConfig,
}

impl liebayes_experiments::Method for OnTrack {
    type Filter = PositionFilter;

    fn label(&self) -> String {
        self.label.clone()
    }

    fn validate(&self) -> Result<(), OperatorError> {
        match self.algorithm {
            Algorithm::Particle(n) => crate::error::check_count("number of particles", n),
            Algorithm::Ekf | Algorithm::Ukf | Algorithm::IteratedEkf => Ok(()),
        }
    }

    /// The run's filter from the run's prior, drawn from `rng`; the particle filters then draw
    /// their particles from `rng`'s copy.
    fn build(&self, rng: &mut ChaCha8Rng) -> Result<PositionFilter, OperatorError> {
        let prior = self.config.prior(rng)?;
        let process = self.process;
        Ok(match (&self.model, self.algorithm) {
            (BuiltModel::Vmf(model), Algorithm::Particle(n)) => Box::new(OnTrackReadings(
                vmf_particle_filter(*model, process, &prior, n, rng.clone())?,
            )),
            (BuiltModel::Vmf(model), Algorithm::Ekf) => {
                Box::new(OnTrackReadings(vmf_ekf::<4, 12>(*model, process, &prior)?))
            }
            (BuiltModel::Vmf(model), Algorithm::Ukf) => {
                Box::new(OnTrackReadings(vmf_ukf::<4, 12>(*model, process, &prior)?))
            }
            (BuiltModel::Vmf(model), Algorithm::IteratedEkf) => Box::new(OnTrackReadings(
                vmf_iterated_ekf::<4, 12>(*model, process, &prior)?,
            )),
            (BuiltModel::Angle(model), Algorithm::IteratedEkf) => Box::new(OnTrackReadings(
                angle_iterated_ekf::<4, 8>(model.clone(), process, &prior)?,
            )),
            (BuiltModel::Angle(model), Algorithm::Particle(n)) => Box::new(OnTrackReadings(
                angle_particle_filter(model.clone(), process, &prior, n, rng.clone())?,
            )),
            (BuiltModel::Angle(model), Algorithm::Ekf) => {
                Box::new(OnTrackReadings(angle_ekf::<4, 8>(
                    model.clone(),
                    process,
                    &prior,
                )?))
            }
            (BuiltModel::Angle(model), Algorithm::Ukf) => {
                Box::new(OnTrackReadings(angle_ukf::<4, 8>(
                    model.clone(),
                    process,
                    &prior,
                )?))
            }
        })
    }
}

/// The root mean square, over a study's runs, of each run's RMSE of `position_error` over its
/// track: `√(mean of the runs' mean squared errors)`; `None` when no run has a finite value.
/// Computed relative to the largest value, so it is finite (at most that value) however large
/// they are.
pub fn track_rmse(summary: &Summary) -> Option<f64> {
    let values = summary.run_values("position_error")?;
    let finite = || {
        values
            .values()
            .iter()
            .map(|&(_, v)| v)
            .filter(|v| v.is_finite())
    };
    let largest = finite().map(f64::abs).reduce(f64::max)?;
    if largest == 0.0 {
        return Some(0.0);
    }
    let (sum, n) = finite().fold((0.0, 0.0), |(s, n), v| {
        let r = v / largest;
        (s + r * r, n + 1.0)
    });
    Some((sum / n).sqrt().min(1.0) * largest)
}

/// The smallest particle count in `settings`' range at which the particle filter with `model`
/// comes within `(1 + tolerance)` of the reference study's [`track_rmse`] (m) on the same runs (the
/// study's seed and runs: run k of every study reads the same data), with no failed run, by
/// [`smallest_to_match`](liebayes_experiments::search::smallest_to_match).
///
/// # Errors
/// [`ExperimentError::OutOfRange`] for a reference without per-run errors and settings outside the
/// search's ranges; the studies' errors otherwise.
pub fn particles_to_match(
    track: &SquareTrack<4>,
    model: &ModelChoice,
    study: &Study,
    reference: &Summary,
    settings: SearchSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<SizeSearch, ExperimentError> {
    let reference_rmse = track_rmse(reference).ok_or(ExperimentError::OutOfRange {
        what: "reference study",
        value: reference.label().name.clone(),
        range: "a study whose runs kept their position_error",
    })?;
    smallest_to_match(
        reference_rmse,
        settings,
        |n| {
            // n ≤ high ≤ MAX_ELEMENTS: it fits a usize.
            let filter = TrackFilter {
                algorithm: Algorithm::Particle(usize::try_from(n).unwrap_or(usize::MAX)),
                model: model.clone(),
            };
            filter.study(track, study, progress)
        },
        track_rmse,
    )
}
