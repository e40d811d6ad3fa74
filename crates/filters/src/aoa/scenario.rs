//! [`SquareTrack`]: the paper's Sec. 4.3 test as an experiment-layer [`Scenario`].

use super::anchor::{Anchor, square_track_anchors};
use super::data::DataModel;
use super::direction::AzEl;
use super::filter::Prior;
use super::model::{Position, Readings};
use super::process::{DELTA_LIMIT, DELTA_MIN, RandomWalk};
use liebayes_experiments::{ExperimentError, MAX_EPOCHS, Scenario, Step};
use liebayes_operators::OperatorError;
use nalgebra::Vector3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

/// How the true position moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TruthModel {
    /// Along the square, counter-clockwise from the origin, each step of random length (the
    /// paper's equation (12)): the filters' random walk (13) is then only an approximation of the
    /// motion, so even the optimal filter under (13) is not consistent with this truth.
    #[default]
    Square,
    /// The filters' own random walk (13) from the origin: the truth the filters assume, where a
    /// consistent filter's NEES is χ²(3).
    RandomWalk,
}

/// The track's settings; the default is the paper's: a 5 m square, q_xy = 0.5 m/√s, q_z = 0.1 m/√s,
/// δ = 0.25 s, a prior standard deviation of 0.5 m, and 64 steps (one lap on average: the mean
/// step of equation (12) is 0.313 m and the lap 20 m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackConfig {
    /// The side of the square (m).
    pub side: f64,
    /// The horizontal process noise q_xy (m/√s): the truth's step length (12) and the filters'
    /// random walk (13).
    pub q_xy: f64,
    /// The filters' vertical process noise q_z (m/√s); the truth stays in the plane z = 0.
    pub q_z: f64,
    /// The time between measurements δ (s).
    pub delta: f64,
    /// The filters' prior standard deviation per axis (m); a run's prior mean is drawn from
    /// `N(start, σ₀² I)` ([`TrackConfig::prior`]).
    pub prior_std: f64,
    /// The number of steps (measurement epochs) of a run.
    pub epochs: usize,
    /// How the truth moves.
    pub truth: TruthModel,
}

impl Default for TrackConfig {
    fn default() -> Self {
        Self {
            side: 5.0,
            q_xy: 0.5,
            q_z: 0.1,
            delta: 0.25,
            prior_std: 0.5,
            epochs: 64,
            truth: TruthModel::Square,
        }
    }
}

/// The largest side of the square (m).
pub const SIDE_LIMIT: f64 = 1e6;

impl TrackConfig {
    /// Checks the settings: side in (0, 1e6] m, q_xy and q_z as [`RandomWalk::new`] (0 or
    /// [1e-100, 1e6] m/√s), δ in [[`DELTA_MIN`], [`DELTA_LIMIT`]] = [1e-6, 1e6] s, the prior as
    /// [`Prior::new`] (σ₀ in [1e-49, 1e6] m), epochs from 1 to [`MAX_EPOCHS`].
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] naming the field.
    pub fn validate(&self) -> Result<(), OperatorError> {
        if !(self.side > 0.0 && self.side <= SIDE_LIMIT) {
            return Err(OperatorError::OutOfRange {
                what: "side of the square track (m)",
                value: self.side,
                range: "(0, 1e6]",
            });
        }
        self.random_walk()?;
        if !(DELTA_MIN..=DELTA_LIMIT).contains(&self.delta) {
            return Err(OperatorError::OutOfRange {
                what: "time step delta (s)",
                value: self.delta,
                range: "[1e-6, 1e6]",
            });
        }
        Prior::new(Vector3::zeros(), self.prior_std)?;
        if self.epochs == 0 || self.epochs > MAX_EPOCHS {
            return Err(OperatorError::OutOfRange {
                what: "number of track steps",
                value: self.epochs as f64,
                range: "[1, 2^24]",
            });
        }
        Ok(())
    }

    /// The filters' random walk (13).
    ///
    /// # Errors
    /// As [`RandomWalk::new`].
    pub fn random_walk(&self) -> Result<RandomWalk, OperatorError> {
        RandomWalk::new(self.q_xy, self.q_z)
    }

    /// A run's prior: mean drawn from `N(start, σ₀² I)` with `rng` (the run's filter stream, so
    /// every filter of run k starts from the same prior, independent of the data), standard
    /// deviation σ₀.
    ///
    /// # Errors
    /// As [`Prior::new`].
    pub fn prior(&self, rng: &mut ChaCha8Rng) -> Result<Prior, OperatorError> {
        let offset = Vector3::from_fn(|_, _| StandardNormal.sample(&mut *rng));
        Prior::new(offset * self.prior_std, self.prior_std)
    }

    /// The mean and standard deviation of a step's length, equation (12):
    /// `q_xy √(2δ) Γ(3/2)` and `q_xy √(2δ (1 − Γ(3/2)²))`, `Γ(3/2) = √π/2`.
    ///
    /// # Errors
    /// As [`validate`](Self::validate) (the fields are public).
    pub fn step_length(&self) -> Result<(f64, f64), OperatorError> {
        self.validate()?;
        Ok(self.checked_step_length())
    }

    /// [`step_length`](Self::step_length) of a validated configuration.
    fn checked_step_length(&self) -> (f64, f64) {
        let gamma = PI.sqrt() / 2.0;
        let scale = self.q_xy * (2.0 * self.delta).sqrt();
        (scale * gamma, scale * (1.0 - gamma * gamma).sqrt())
    }

    /// The point at arc length s along the square, counter-clockwise from the origin (s taken
    /// modulo the perimeter).
    ///
    /// # Errors
    /// As [`validate`](Self::validate), and [`OperatorError::NonFinite`] for an s that is not
    /// finite.
    pub fn point_at(&self, s: f64) -> Result<Vector3<f64>, OperatorError> {
        self.validate()?;
        if !s.is_finite() {
            return Err(OperatorError::NonFinite {
                what: "arc length along the square track",
                value: s,
            });
        }
        Ok(self.checked_point_at(s))
    }

    /// [`point_at`](Self::point_at) of a validated configuration and a finite s.
    fn checked_point_at(&self, s: f64) -> Vector3<f64> {
        let a = self.side;
        let s = s.rem_euclid(4.0 * a);
        let (x, y) = if s < a {
            (s, 0.0)
        } else if s < 2.0 * a {
            (a, s - a)
        } else if s < 3.0 * a {
            (3.0 * a - s, a)
        } else {
            (0.0, 4.0 * a - s)
        };
        Vector3::new(x, y, 0.0)
    }
}

/// The square track of the paper's Sec. 4.3: the user walks counter-clockwise around a square from
/// the origin, each step of random length (12) (or, with [`TruthModel::RandomWalk`], follows the
/// filters' random walk from the origin), and N anchors read its direction with noise from a
/// [`DataModel`].
///
/// A run has [`TrackConfig::epochs`] steps, every one a measurement epoch; step k (time kδ) moves
/// the user, gives the filters the input δ (their random walk (13)) and a [`TrackReadings`]: the
/// readings of every anchor, or [`TrackReadings::AtAnchor`] for a position at an anchor (possible
/// only for the random walk, with probability zero: it has no direction from that anchor, so no
/// readings), or [`TrackReadings::Failed`] with the error of readings that could not be drawn. A
/// track filter ([`PositionFilter`](super::PositionFilter)) scores an epoch at an anchor on its
/// prediction, and fails its run at a failed epoch, so that a run always has its `epochs` epochs,
/// each at its own index (a reading error dropped the measurement, and every later epoch of the
/// run was then averaged with the next one's).
#[derive(Clone, Debug, PartialEq)]
pub struct SquareTrack<const N: usize> {
    anchors: [Anchor; N],
    data: DataModel,
    config: TrackConfig,
}

impl SquareTrack<4> {
    /// The paper's test: [`square_track_anchors`], the default settings, readings from `data`.
    ///
    /// # Errors
    /// As [`SquareTrack::new`].
    pub fn paper(data: DataModel) -> Result<Self, OperatorError> {
        Self::new(square_track_anchors(), data, TrackConfig::default())
    }
}

impl<const N: usize> SquareTrack<N> {
    /// The track with `anchors`, readings from `data`, settings `config`.
    ///
    /// # Errors
    /// The data model's or the settings' check, or [`OperatorError::OutOfRange`] for an anchor on
    /// the track (its direction is undefined there) or for N = 0.
    pub fn new(
        anchors: [Anchor; N],
        data: DataModel,
        config: TrackConfig,
    ) -> Result<Self, OperatorError> {
        data.validate()?;
        config.validate()?;
        if N == 0 {
            return Err(OperatorError::OutOfRange {
                what: "number of anchors",
                value: 0.0,
                range: "at least 1",
            });
        }
        for anchor in &anchors {
            let distance = distance_to_square(anchor.position(), config.side);
            if distance.is_nan() || distance <= 1e-9 * config.side {
                return Err(OperatorError::OutOfRange {
                    what: "distance of an anchor from the track (m)",
                    value: distance,
                    range: "more than 1e-9 side: an anchor on the track has no direction there",
                });
            }
        }
        Ok(Self {
            anchors,
            data,
            config,
        })
    }

    /// The anchors.
    pub fn anchors(&self) -> &[Anchor; N] {
        &self.anchors
    }

    /// The data model.
    pub fn data(&self) -> &DataModel {
        &self.data
    }

    /// The settings.
    pub fn config(&self) -> &TrackConfig {
        &self.config
    }

    /// The measurement of a step at θ: [`TrackReadings::AtAnchor`] when θ is an anchor's position
    /// (checked before anything is drawn), else the [`readings`](Self::readings), or
    /// [`TrackReadings::Failed`] with their error.
    pub fn track_readings(&self, theta: &Vector3<f64>, rng: &mut impl Rng) -> TrackReadings<N> {
        // θ − s is exactly 0 only for θ = s (subnormal differences are kept).
        if self.anchors.iter().any(|a| theta == a.position()) {
            return TrackReadings::AtAnchor;
        }
        match self.readings(theta, rng) {
            Ok(readings) => TrackReadings::Readings(readings),
            Err(error) => TrackReadings::Failed(error),
        }
    }

    /// The readings of every anchor of the true position θ (world axes, m): each drawn from the
    /// data model ([`DataModel::sample`]) at the unit direction of θ in the anchor's axes,
    /// `R (θ − s)/|θ − s|`.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a coordinate of θ that is not finite;
    /// [`OperatorError::OutOfRange`] for a θ an anchor has no direction of: at the anchor
    /// (distance 0), or so far from it that the distance overflows (∞). As [`DataModel::sample`]
    /// otherwise.
    pub fn readings(
        &self,
        theta: &Vector3<f64>,
        rng: &mut impl Rng,
    ) -> Result<Readings<N>, OperatorError> {
        if let Some(&value) = theta.iter().find(|v| !v.is_finite()) {
            return Err(OperatorError::NonFinite {
                what: "true position theta (m)",
                value,
            });
        }
        let mut readings = [AzEl::default(); N];
        for (reading, anchor) in readings.iter_mut().zip(&self.anchors) {
            let Some((direction, _)) = anchor.direction(theta) else {
                return Err(OperatorError::OutOfRange {
                    what: "distance of the true position theta from an anchor (m)",
                    value: (theta - anchor.position()).norm(),
                    range: "(0, 1.8e308]: an anchor has no direction of a position at itself",
                });
            };
            *reading = self.data.sample(&direction, rng)?;
        }
        Ok(readings)
    }
}

/// A step's measurement on a [`SquareTrack`]: the readings of every anchor, or why there are
/// none. A track filter ([`PositionFilter`](super::PositionFilter)) updates on the readings,
/// leaves an epoch at an anchor un-updated (scored on its prediction, log evidence 0: an empty
/// measurement has likelihood 1), and fails at a failed one with its error, leaving the filter as
/// it was.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackReadings<const N: usize> {
    /// Every anchor's reading.
    Readings(Readings<N>),
    /// The true position is at an anchor, which has no direction of it: no readings (the random
    /// walk's truth only, with probability zero).
    AtAnchor,
    /// The readings could not be drawn (an error of [`SquareTrack::readings`] other than the
    /// position at an anchor): the run fails at this epoch.
    Failed(OperatorError),
}

impl<const N: usize> TrackReadings<N> {
    /// The readings, `None` at an anchor or for a failed epoch.
    pub fn readings(&self) -> Option<&Readings<N>> {
        match self {
            TrackReadings::Readings(readings) => Some(readings),
            TrackReadings::AtAnchor | TrackReadings::Failed(_) => None,
        }
    }
}

/// The distance from p to the square [0, a]² in the plane z = 0 (its perimeter).
fn distance_to_square(p: &Vector3<f64>, a: f64) -> f64 {
    let (x, y) = (p.x, p.y);
    let inside = (0.0..=a).contains(&x) && (0.0..=a).contains(&y);
    let planar = if inside {
        x.min(a - x).min(y).min(a - y)
    } else {
        let dx = (-x).max(x - a).max(0.0);
        let dy = (-y).max(y - a).max(0.0);
        dx.hypot(dy)
    };
    planar.hypot(p.z)
}

/// The steps of one run of a [`SquareTrack`].
#[derive(Debug)]
pub struct TrackSteps<'s, const N: usize> {
    track: &'s SquareTrack<N>,
    rng: &'s mut ChaCha8Rng,
    travelled: f64,
    position: Vector3<f64>,
    k: usize,
}

impl<const N: usize> Iterator for TrackSteps<'_, N> {
    type Item = Step<Position, f64, TrackReadings<N>>;

    fn next(&mut self) -> Option<Self::Item> {
        let config = &self.track.config;
        if self.k >= config.epochs {
            return None;
        }
        self.k += 1;
        let theta = match config.truth {
            TruthModel::Square => {
                // The track validated its configuration, and a run's steps keep the arc length
                // finite.
                let (mean, std) = config.checked_step_length();
                let n: f64 = StandardNormal.sample(&mut *self.rng);
                self.travelled += mean + std * n;
                config.checked_point_at(self.travelled)
            }
            TruthModel::RandomWalk => {
                let scale =
                    Vector3::new(config.q_xy, config.q_xy, config.q_z) * config.delta.sqrt();
                let n = Vector3::from_fn(|_, _| StandardNormal.sample(&mut *self.rng));
                self.position += scale.component_mul(&n);
                self.position
            }
        };
        let measurement = self.track.track_readings(&theta, &mut *self.rng);
        Some(Step {
            time: self.k as f64 * config.delta,
            input: config.delta,
            truth: Position::new_unchecked(theta),
            measurement: Some(measurement),
        })
    }
}

impl<const N: usize> Scenario for SquareTrack<N> {
    type Truth = Position;
    type Input = f64;
    type Measurement = TrackReadings<N>;
    type Steps<'s> = TrackSteps<'s, N>;

    fn epochs(&self) -> usize {
        self.config.epochs
    }

    fn simulate<'s>(
        &'s self,
        rng: &'s mut ChaCha8Rng,
    ) -> Result<TrackSteps<'s, N>, ExperimentError> {
        Ok(TrackSteps {
            track: self,
            rng,
            travelled: 0.0,
            position: Vector3::zeros(),
            k: 0,
        })
    }
}
