//! The attitude filters by name: [`Method`] says which filter with which settings, and builds it
//! as an [`AttitudeFilter`], one type that every attitude filter is stepped as.

use super::ekf::{AttitudeEkf, AttitudeParams, Sensors};
use super::estimate::{AttitudeEstimate, ImuSample};
use super::madgwick::{BROAD_BETA, Madgwick};
use super::talk::{TalkFilter, TalkParams};
use crate::error::FilterError;
use liebayes_experiments::{RecursiveFilter, Smoothing, Update};
use liebayes_operators::OperatorError;
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;

/// An attitude filter with its settings.
// The EKF's settings are the largest variant; a method is built once per run, not stepped.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// The production filter ([`AttitudeEkf`]).
    Ekf {
        /// Its parameters.
        params: AttitudeParams,
        /// Its sensors.
        sensors: Sensors,
    },
    /// The production filter's offline estimate ([`AttitudeEkf::offline`]): every sample's
    /// smoothed estimate, given the whole log; scored by those.
    EkfOffline {
        /// Its parameters.
        params: AttitudeParams,
        /// Its sensors.
        sensors: Sensors,
    },
    /// The talk's Bingham / heat-kernel filter ([`TalkFilter`]).
    Talk {
        /// Its parameters.
        params: TalkParams,
        /// Its sensors.
        sensors: Sensors,
    },
    /// Madgwick's filter ([`Madgwick`]).
    Madgwick {
        /// Its gain β (rad/s).
        beta: f64,
        /// Its sensors.
        sensors: Sensors,
    },
}

/// The names [`Method::from_name`] accepts, in the order the reports list them.
pub const METHOD_NAMES: [&str; 8] = [
    "ekf-9d",
    "ekf-6d",
    "ekf-offline-9d",
    "ekf-offline-6d",
    "talk-9d",
    "talk-6d",
    "madgwick-9d",
    "madgwick-6d",
];

impl Method {
    /// The method of a name in [`METHOD_NAMES`] with its default settings (the EKF's
    /// [`AttitudeParams::default`], the offline EKF's [`AttitudeParams::offline`], the talk filter's [`TalkParams::default`], Madgwick's
    /// [`BROAD_BETA`]).
    ///
    /// # Errors
    /// [`FilterError::Setting`] for any other name, listing the accepted ones.
    ///
    /// # Example
    /// ```
    /// use liebayes_filters::attitude::Method;
    /// assert_eq!(Method::from_name("ekf-9d")?.label(), "EKF 9D");
    /// assert!(Method::from_name("kalman").is_err());
    /// # Ok::<(), liebayes_filters::FilterError>(())
    /// ```
    pub fn from_name(name: &str) -> Result<Self, FilterError> {
        let sensors = |suffix: &str| match suffix {
            "9d" => Some(Sensors::NineD),
            "6d" => Some(Sensors::SixD),
            _ => None,
        };
        let parsed = name.rsplit_once('-').and_then(|(filter, suffix)| {
            let sensors = sensors(suffix)?;
            match filter {
                "ekf" => Some(Method::Ekf {
                    params: AttitudeParams::default(),
                    sensors,
                }),
                "ekf-offline" => Some(Method::EkfOffline {
                    params: AttitudeParams::offline(),
                    sensors,
                }),
                "talk" => Some(Method::Talk {
                    params: TalkParams::default(),
                    sensors,
                }),
                "madgwick" => Some(Method::Madgwick {
                    beta: BROAD_BETA,
                    sensors,
                }),
                _ => None,
            }
        });
        parsed.ok_or_else(|| FilterError::Setting {
            origin: "attitude method",
            setting: "name",
            value: format!("{name:?}"),
            expected: "one of ekf-9d, ekf-6d, ekf-offline-9d, ekf-offline-6d, talk-9d, talk-6d, \
                       madgwick-9d, madgwick-6d",
        })
    }

    /// The sensors the method uses.
    pub fn sensors(&self) -> Sensors {
        match self {
            Method::Ekf { sensors, .. }
            | Method::EkfOffline { sensors, .. }
            | Method::Talk { sensors, .. }
            | Method::Madgwick { sensors, .. } => *sensors,
        }
    }

    /// A short label: `EKF 9D`, `EKF offline 9D`, `talk filter 6D`, `Madgwick 9D`.
    pub fn label(&self) -> String {
        let name = match self {
            Method::Ekf { .. } => "EKF",
            Method::EkfOffline { .. } => "EKF offline",
            Method::Talk { .. } => "talk filter",
            Method::Madgwick { .. } => "Madgwick",
        };
        let sensors = match self.sensors() {
            Sensors::NineD => "9D",
            Sensors::SixD => "6D",
        };
        format!("{name} {sensors}")
    }

    /// Builds the filter for samples at `rate` Hz.
    ///
    /// # Errors
    /// The filter's constructor's errors: a setting out of its range.
    pub fn build(&self, rate: f64) -> Result<AttitudeFilter, FilterError> {
        Ok(match self {
            Method::Ekf { params, sensors } => {
                AttitudeFilter::Ekf(AttitudeEkf::new(params.clone(), *sensors, rate)?)
            }
            Method::EkfOffline { params, sensors } => {
                AttitudeFilter::Ekf(AttitudeEkf::offline(params.clone(), *sensors, rate)?)
            }
            Method::Talk { params, sensors } => {
                AttitudeFilter::Talk(TalkFilter::new(params, *sensors, rate)?)
            }
            Method::Madgwick { beta, sensors } => {
                AttitudeFilter::Madgwick(Madgwick::new(*beta, *sensors, rate)?)
            }
        })
    }

    /// Checks the settings (by building the filter at 100 Hz) before any run.
    ///
    /// # Errors
    /// As [`build`](Self::build).
    pub fn validate(&self) -> Result<(), FilterError> {
        self.build(100.0).map(|_| ())
    }
}

/// Any attitude filter, stepped through [`RecursiveFilter`] by dispatch to the one it holds.
// Held inline: one filter per run, and no indirection in its per-sample steps.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum AttitudeFilter {
    /// The production filter (causal or offline).
    Ekf(AttitudeEkf),
    /// The talk's filter.
    Talk(TalkFilter),
    /// Madgwick's filter.
    Madgwick(Madgwick),
}

impl RecursiveFilter for AttitudeFilter {
    type Input = ImuSample;
    type Measurement = Vector3<f64>;
    type Estimate = AttitudeEstimate;

    fn predict(&mut self, input: &ImuSample) -> Result<(), OperatorError> {
        match self {
            AttitudeFilter::Ekf(f) => f.predict(input),
            AttitudeFilter::Talk(f) => f.predict(input),
            AttitudeFilter::Madgwick(f) => f.predict(input),
        }
    }

    fn update(&mut self, z: &Vector3<f64>) -> Result<Update, OperatorError> {
        match self {
            AttitudeFilter::Ekf(f) => f.update(z),
            AttitudeFilter::Talk(f) => f.update(z),
            AttitudeFilter::Madgwick(f) => f.update(z),
        }
    }

    fn estimate(&self) -> Result<AttitudeEstimate, OperatorError> {
        match self {
            AttitudeFilter::Ekf(f) => f.estimate(),
            AttitudeFilter::Talk(f) => f.estimate(),
            AttitudeFilter::Madgwick(f) => f.estimate(),
        }
    }

    fn smoothing(&mut self) -> Option<&mut dyn Smoothing<Estimate = AttitudeEstimate>> {
        match self {
            AttitudeFilter::Ekf(f) => f.smoothing(),
            AttitudeFilter::Talk(_) | AttitudeFilter::Madgwick(_) => None,
        }
    }
}

/// A method for samples at a rate: what a [`Study`](liebayes_experiments::Study) builds each run's
/// filter from ([`Study::run_method`](liebayes_experiments::Study::run_method)).
#[derive(Clone, Debug, PartialEq)]
pub struct AtRate {
    /// The method.
    pub method: Method,
    /// The samples' rate (Hz).
    pub rate: f64,
}

impl liebayes_experiments::Method for AtRate {
    type Filter = AttitudeFilter;

    fn label(&self) -> String {
        self.method.label()
    }

    /// As [`Method::build`] at the rate.
    fn validate(&self) -> Result<(), OperatorError> {
        self.method
            .build(self.rate)
            .map(|_| ())
            .map_err(operator_error)
    }

    fn build(&self, _rng: &mut ChaCha8Rng) -> Result<AttitudeFilter, OperatorError> {
        self.method.build(self.rate).map_err(operator_error)
    }
}

/// A construction error as the experiment layer reports it: a setting out of range names the
/// setting and its value (NaN where the value is not a number).
fn operator_error(e: FilterError) -> OperatorError {
    match e {
        FilterError::Operator(e) | FilterError::Step { source: e, .. } => e,
        FilterError::Setting {
            setting,
            value,
            expected,
            ..
        } => OperatorError::OutOfRange {
            what: setting,
            value: value.parse().unwrap_or(f64::NAN),
            range: expected,
        },
        FilterError::Density(e) => OperatorError::Density(e),
        FilterError::Data(_) => OperatorError::OutOfRange {
            what: "attitude method settings",
            value: f64::NAN,
            range: "settings within their documented ranges",
        },
    }
}
