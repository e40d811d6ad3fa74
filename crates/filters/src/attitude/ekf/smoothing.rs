//! The offline attitude estimate: the production filter's forward pass recorded, the
//! Rauch-Tung-Striebel backward pass over its epochs, and each sample's orientation integrated
//! from the smoothed state of the epoch before it.
//!
//! An *epoch* is a density of the filter's Gaussian: after each covariance propagation (a block's
//! end, or a partial block before a heading update) and each renewal of the field offset, with the
//! updates made at it. A filter built by [`AttitudeEkf::offline`](super::AttitudeEkf::offline)
//! keeps, for every transition `k → k+1`, the filtered density of epoch k and the prediction with
//! its cross-covariance `Cov(δ_k, δ_k+1)` ([`Prediction`]), and every sample's gyroscope. At the
//! end of the run ([`Smoothing::release`]) the backward pass
//! ([`smooth_records`]) gives every epoch's smoothed density, and sample j after epoch k (at
//! sample `s_k`, up to the next epoch) the strapdown from it with the smoothed bias `b_k`:
//! `R_j = R_k Π_{i = s_k+1..j} exp([ωᵢ − b_k]ₓ Δt)`, the orientation the filter's own strapdown
//! would have given from the smoothed state. Samples before the first epoch (in 9D, before the
//! heading is initialised) are integrated back from it. Each sample reports `R_j` carried over
//! the IMU's delay d, `R_j exp([ω_j − b_k]ₓ d)`, as the filter reports its own
//! ([`AttitudeParams::imu_delay`]), and its epoch's smoothed attitude covariance.

use super::model::{AttitudeState, STATE_DIM, attitude_block, in_rest};
use super::{AttitudeEkf, AttitudeParams, BIAS, Running};
use crate::attitude::estimate::AttitudeEstimate;
use liebayes_densities::ManifoldGaussian;
use liebayes_experiments::Smoothing;
use liebayes_operators::OperatorError;
use liebayes_operators::smoother::{Prediction, smooth_records};
use nalgebra::{UnitQuaternion, Vector3};

type Density = ManifoldGaussian<AttitudeState, STATE_DIM>;

/// What a step of the filter did to its Gaussian that the backward pass must know, kept in the
/// step's state until the step succeeds.
// Held inline in a journal whose room is reused from step to step: boxing the large variant would
// allocate at every epoch.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub(super) enum Entry {
    /// A transition from the density `before`, the epoch of sample `at`.
    Transition {
        before: Density,
        at: usize,
        prediction: Prediction<AttitudeState, STATE_DIM>,
    },
    /// The heading was initialised: the epochs before are not smoothed (their heading was
    /// unknown, and the initialisation is not a transition).
    Restart,
}

/// What the offline filter keeps of its forward pass.
#[derive(Clone, Debug, Default)]
pub(super) struct Record {
    /// The filtered density of each epoch that a transition left, its sample, the transition.
    filtered: Vec<Density>,
    epochs: Vec<usize>,
    transitions: Vec<Prediction<AttitudeState, STATE_DIM>>,
    /// The first epoch smoothed.
    start: usize,
    /// Every sample's gyroscope (rad/s).
    gyro: Vec<Vector3<f64>>,
    /// The samples whose smoothed estimates were released.
    released: usize,
}

/// What a record names when it cannot grow.
const RECORD: &str = "number of samples recorded by the offline attitude filter";

/// What the offline filter names when the smoothed estimates it releases cannot be allocated.
const RELEASED: &str = "number of smoothed estimates released by the offline attitude filter";

/// The most samples the offline attitude filter records: 2²⁴, the most steps a run of the
/// experiment layer records (about 16 hours at BROAD's 286 Hz; 24 bytes each).
pub const MAX_OFFLINE_SAMPLES: usize = 1 << 24;

/// The most epochs the offline attitude filter records: 2²⁰, about 6.3 GB at about 6 kB each
/// (11.6 hours of 0.04 s blocks, the offline default). An epoch can be as short as a sample (at a
/// low rate, or with a short block), so the samples' limit alone does not bound the record.
pub const MAX_OFFLINE_EPOCHS: usize = 1 << 20;

/// What a record names when it cannot grow by its epochs.
const EPOCHS: &str = "number of epochs recorded by the offline attitude filter";

/// Refuses a step that would take the record past [`MAX_OFFLINE_SAMPLES`] samples (with its one
/// sample) or [`MAX_OFFLINE_EPOCHS`] epochs (with the two transitions a step can make).
fn check_room(samples: usize, epochs: usize) -> Result<(), OperatorError> {
    let (samples, epochs) = (samples.saturating_add(1), epochs.saturating_add(2));
    if samples > MAX_OFFLINE_SAMPLES {
        return Err(OperatorError::TooLarge {
            what: RECORD,
            value: samples,
            max: MAX_OFFLINE_SAMPLES,
        });
    }
    if epochs > MAX_OFFLINE_EPOCHS {
        return Err(OperatorError::TooLarge {
            what: EPOCHS,
            value: epochs,
            max: MAX_OFFLINE_EPOCHS,
        });
    }
    Ok(())
}

impl Record {
    /// Room for one more sample and the entries a step makes (at most two transitions: a
    /// propagation and a renewal of the field offset), so that keeping them cannot fail.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] beyond [`MAX_OFFLINE_SAMPLES`] samples or
    /// [`MAX_OFFLINE_EPOCHS`] epochs, or when the record cannot grow.
    pub(super) fn reserve(&mut self) -> Result<(), OperatorError> {
        check_room(self.gyro.len(), self.transitions.len())?;
        let samples = self.gyro.len().saturating_add(1);
        let too_large = |_| OperatorError::TooLarge {
            what: RECORD,
            value: samples,
            max: MAX_OFFLINE_SAMPLES,
        };
        self.gyro.try_reserve(1).map_err(too_large)?;
        self.filtered.try_reserve(2).map_err(too_large)?;
        self.epochs.try_reserve(2).map_err(too_large)?;
        self.transitions.try_reserve(2).map_err(too_large)
    }

    /// Keeps a successful step's sample (a prediction's gyroscope, if any) and entries (within the
    /// room [`reserve`](Self::reserve) made).
    pub(super) fn keep(&mut self, gyro: Option<&Vector3<f64>>, entries: &mut Vec<Entry>) {
        if let Some(gyro) = gyro {
            self.gyro.push(*gyro);
        }
        for entry in entries.drain(..) {
            match entry {
                Entry::Transition {
                    before,
                    at,
                    prediction,
                } => {
                    self.filtered.push(before);
                    self.epochs.push(at);
                    self.transitions.push(prediction);
                }
                Entry::Restart => self.start = self.transitions.len(),
            }
        }
    }

    /// Appends every sample's smoothed estimate to `out`, the current state `now` being the last
    /// epoch's filtered density; `dt` the sampling interval, `params` the filter's (for the
    /// covariance it reports).
    fn smooth(
        &mut self,
        now: &Running,
        dt: f64,
        params: &AttitudeParams,
        out: &mut Vec<AttitudeEstimate>,
    ) -> Result<(), OperatorError> {
        // The current density is the last epoch's, for the backward pass only (room for it even
        // when the record is full).
        self.filtered
            .try_reserve(1)
            .map_err(|_| OperatorError::TooLarge {
                what: EPOCHS,
                value: self.filtered.len().saturating_add(1),
                max: MAX_OFFLINE_EPOCHS,
            })?;
        self.filtered.push(now.density.clone());
        let smoothed = smooth_records(
            &self.filtered[self.start..],
            &self.transitions[self.start..],
        );
        self.filtered.pop();
        let smoothed = smoothed?;
        let epochs: Vec<usize> = self.epochs[self.start..]
            .iter()
            .copied()
            .chain([now.at])
            .collect();
        // Up to MAX_OFFLINE_SAMPLES estimates (about 1.9 GB): memory the system cannot give is
        // an error, not an abort.
        let refused = |count: usize| {
            move |_| OperatorError::TooLarge {
                what: RELEASED,
                value: count,
                max: MAX_OFFLINE_SAMPLES,
            }
        };
        out.try_reserve_exact(self.gyro.len())
            .map_err(refused(self.gyro.len()))?;
        let delay = params.imu_delay;
        for (k, (density, &at)) in smoothed.iter().zip(&epochs).enumerate() {
            let end = epochs.get(k + 1).map_or(self.gyro.len(), |&next| next);
            let (orientation, bias) = epoch_state(density);
            let covariance = Some(params.reported(&attitude_block(density.covariance())));
            // Sample j's estimate, carried over the IMU's delay as the filter's is.
            let estimate = |q: UnitQuaternion<f64>, j: usize| AttitudeEstimate {
                orientation: q * turn(&self.gyro[j], &bias, delay),
                covariance,
            };
            if k == 0 {
                // The samples before the first epoch, integrated back from it.
                let mut q = orientation;
                let mut before = Vec::new();
                before.try_reserve_exact(at).map_err(refused(at))?;
                for j in (1..=at.min(self.gyro.len() - 1)).rev() {
                    q *= turn(&self.gyro[j], &bias, dt).inverse();
                    before.push(estimate(q, j - 1));
                }
                out.extend(before.into_iter().rev());
            }
            let mut q = orientation;
            for j in at..end.max(at) {
                if j > at {
                    q *= turn(&self.gyro[j], &bias, dt);
                }
                out.push(estimate(q, j));
            }
        }
        Ok(())
    }
}

/// The orientation and gyro bias of a density's mean.
fn epoch_state(density: &Density) -> (UnitQuaternion<f64>, Vector3<f64>) {
    let mean = density.mean();
    let bias = mean
        .second()
        .coords()
        .fixed_rows::<3>(in_rest(BIAS.start))
        .into_owned();
    (*mean.first().inner().as_unit_quaternion(), bias)
}

/// One sample's strapdown rotation `exp([ω − b]ₓ Δt)`.
fn turn(gyro: &Vector3<f64>, bias: &Vector3<f64>, dt: f64) -> UnitQuaternion<f64> {
    crate::attitude::rotation(&((gyro - bias) * dt))
}

/// The offline filter's smoothed estimates: every sample's at the end of the run (from every
/// sample of it), none before. A filter built by [`AttitudeEkf::new`] does not smooth
/// ([`RecursiveFilter::smoothing`](liebayes_experiments::RecursiveFilter::smoothing) is `None`).
/// A release whose estimates' memory the system cannot give is [`OperatorError::TooLarge`], with
/// `out` as it was.
impl Smoothing for AttitudeEkf {
    type Estimate = AttitudeEstimate;

    fn release(&mut self, end: bool, out: &mut Vec<AttitudeEstimate>) -> Result<(), OperatorError> {
        let (Some(record), Some(now)) = (&mut self.record, &self.state) else {
            return Ok(());
        };
        if !end || record.released == record.gyro.len() {
            return Ok(());
        }
        let first = out.len();
        if let Err(e) = record.smooth(now, self.settings.dt, &self.settings.params, out) {
            out.truncate(first);
            return Err(e);
        }
        // Each sample's estimate is released once.
        out.drain(first..first + record.released);
        record.released = record.gyro.len();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step is refused past either limit (the samples', or the epochs' with the two a step
    /// can make) and allowed up to it.
    #[test]
    fn the_record_holds_at_most_its_limits() {
        assert!(check_room(MAX_OFFLINE_SAMPLES - 1, MAX_OFFLINE_EPOCHS - 2).is_ok());
        let refused = |samples, epochs| match check_room(samples, epochs) {
            Err(OperatorError::TooLarge { what, value, max }) => (what, value, max),
            other => panic!("{other:?}"),
        };
        assert_eq!(
            refused(MAX_OFFLINE_SAMPLES, 0),
            (RECORD, MAX_OFFLINE_SAMPLES + 1, MAX_OFFLINE_SAMPLES)
        );
        // One epoch a sample (a low rate): the epochs' limit comes first.
        assert_eq!(
            refused(MAX_OFFLINE_EPOCHS - 1, MAX_OFFLINE_EPOCHS - 1),
            (EPOCHS, MAX_OFFLINE_EPOCHS + 1, MAX_OFFLINE_EPOCHS)
        );
    }
}
