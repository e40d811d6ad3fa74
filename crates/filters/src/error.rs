//! [`FilterError`]: what can go wrong in building or running an application's filter, with the
//! lower crates' errors kept as its sources.

use crate::attitude::DataError;
use liebayes_densities::DensityError;
use liebayes_experiments::RunFailure;
use liebayes_manifolds::Readable;
use liebayes_operators::{MAX_ELEMENTS, OperatorError};
use thiserror::Error;

/// The filters crate's error: a setting out of its range, bad data, or a step of a filter that
/// failed (with the sample where it failed). The errors of the lower crates convert into it with
/// `?` and stay reachable through [`std::error::Error::source`].
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FilterError {
    /// A setting of a filter or a scenario is outside its range.
    #[error("{origin}: the setting `{setting}` is {value}, expected {expected}")]
    Setting {
        /// The settings' type or the constructor.
        origin: &'static str,
        /// The setting's name.
        setting: &'static str,
        /// Its value, as text.
        value: String,
        /// Its accepted range, in words.
        expected: &'static str,
    },
    /// A log or a file that cannot be used.
    #[error(transparent)]
    Data(#[from] DataError),
    /// An operator (a propagation or an update) refused its input or its result.
    #[error(transparent)]
    Operator(#[from] OperatorError),
    /// A density outside its family's range.
    #[error(transparent)]
    Density(#[from] DensityError),
    /// A run of a filter over a log stopped at a sample.
    #[error("{origin}: sample {sample} (t = {} s): {source}", Readable(*.time))]
    Step {
        /// The log (a file name or a trial).
        origin: String,
        /// The index of the sample.
        sample: usize,
        /// Its time (s).
        time: f64,
        /// The step's error.
        source: OperatorError,
    },
}

impl FilterError {
    /// The failure of a run over the log `origin`.
    pub fn step(origin: &str, failure: RunFailure) -> Self {
        FilterError::Step {
            origin: origin.to_owned(),
            sample: failure.step,
            time: failure.time,
            source: failure.error,
        }
    }
}

/// `Ok` for a `value` in [1.5e-154, 1e150], else [`FilterError::Setting`]: positive, and with a
/// square that is a positive normal number up to 1e300, so that a standard deviation's variance
/// (and a time's or a bound's square) neither underflows to 0 nor overflows (σ = 1e-200 passed and
/// made every step of the talk's filter fail on 0/0).
pub(crate) fn positive_setting(
    origin: &'static str,
    setting: &'static str,
    value: f64,
) -> Result<(), FilterError> {
    setting_in(
        origin,
        setting,
        value,
        (1.5e-154, 1e150),
        "a positive number in [1.5e-154, 1e150] (its square a normal number)",
    )
}

/// `Ok` for a `value` in the closed `range`, else [`FilterError::Setting`] saying `expected` (NaN
/// is outside every range).
pub(crate) fn setting_in(
    origin: &'static str,
    setting: &'static str,
    value: f64,
    (low, high): (f64, f64),
    expected: &'static str,
) -> Result<(), FilterError> {
    if (low..=high).contains(&value) {
        Ok(())
    } else {
        Err(FilterError::Setting {
            origin,
            setting,
            value: Readable(value).to_string(),
            expected,
        })
    }
}

/// The range of a standard deviation that becomes a variance of the production attitude filter's
/// Gaussian (an initial σ or bound, a process noise's, a measurement's): [1e-30, 1e4]. Both ends
/// are where the steps keep working, not only where the Gaussian is valid: a `ManifoldGaussian`
/// takes entries and `tr P⁻¹` up to [`MAX_SCALE`](liebayes_densities::MAX_SCALE) = 1e100 (σ = 1e-60
/// made `tr P⁻¹` 1e120 and every step fail), but a variance far from the filter's others loses to
/// rounding first. Measured on simulated runs (moving and still, 9D and 6D, one setting at a
/// time, the others at their defaults): at σ = 1e-45 the rest bias σ made a rest update's
/// covariance not positive definite 7 s into a still run, and at 1e7 the initial tilt σ (1e8: the
/// initial bias and field-offset σ) made the first propagation or update fail; every setting ran
/// 70 s at 1e-30 (but the initial heading σ, which has its own lower bound) and at 1e4, and 17 s
/// at 1e6. 1e4 (the largest angular rate a reading may have) keeps a margin of 100 and is far
/// above any physical σ in these units (rad, rad/s, m/s, m); 1e-30 is far below any sensor's.
/// At the ends of the rate range, 1e-3 and 1e6 Hz, every setting at either end of its range ran
/// 2000 samples in 9D and 6D with either propagation, once a block's attitude noise was capped
/// at a uniform rotation's
/// ([`UNIFORM_ROTATION_VARIANCE`](crate::attitude::UNIFORM_ROTATION_VARIANCE): σ_g = 1e4 at
/// 1e-3 Hz failed every block after the second).
pub(crate) const SIGMA_RANGE: (f64, f64) = (1e-30, 1e4);

/// `Ok` for a standard deviation `value` in [`SIGMA_RANGE`], else [`FilterError::Setting`].
pub(crate) fn sigma_setting(
    origin: &'static str,
    setting: &'static str,
    value: f64,
) -> Result<(), FilterError> {
    setting_in(
        origin,
        setting,
        value,
        SIGMA_RANGE,
        "a standard deviation in [1e-30, 1e4] (its square a variance the filter's Gaussian can \
         hold beside its others)",
    )
}

/// Checks a count of particles (or cells, named by `what`) before anything is drawn.
pub(crate) fn check_count(what: &'static str, n: usize) -> Result<(), OperatorError> {
    if n == 0 {
        return Err(OperatorError::OutOfRange {
            what,
            value: 0.0,
            range: "at least 1",
        });
    }
    if n > MAX_ELEMENTS {
        return Err(OperatorError::TooLarge {
            what,
            value: n,
            max: MAX_ELEMENTS,
        });
    }
    Ok(())
}

/// n draws of `draw`, the count checked and the memory reserved first.
pub(crate) fn draws<T>(n: usize, mut draw: impl FnMut() -> T) -> Result<Vec<T>, OperatorError> {
    check_count("number of particles", n)?;
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
