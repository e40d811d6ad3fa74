//! The filter law suite on filters whose verdicts are known: a scalar Kalman filter on a random
//! walk passes every law; the same filter over-confident by a factor of 4 in variance fails the
//! consistency law; a filter that ignores the measurement noise it is told to assume fails both
//! mis-specification laws; a filter that half-applies a bad step fails the all-or-nothing law.
#![cfg(feature = "proptest")]

use liebayes_experiments::testing::{
    FilterLawSubject, check_all_or_nothing, check_consistent, check_misspecified_caught,
    check_misspecified_moves,
};
use liebayes_experiments::{
    ExperimentError, Nis, RecursiveFilter, Scenario, Step, Update, filter_laws,
};
use liebayes_operators::OperatorError;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The random walk's step variance.
const Q: f64 = 0.01;
/// The measurement noise's variance.
const R: f64 = 0.04;
/// The prior variance (the walk starts at 0).
const P0: f64 = 1.0;

/// `x' = x + w`, `z = x + v`, 30 steps, a measurement at each.
struct Walk;

impl Scenario for Walk {
    type Truth = f64;
    type Input = ();
    type Measurement = f64;
    type Steps<'s> = std::vec::IntoIter<Step<f64, (), f64>>;

    fn epochs(&self) -> usize {
        30
    }

    fn simulate<'s>(&'s self, rng: &'s mut ChaCha8Rng) -> Result<Self::Steps<'s>, ExperimentError> {
        let mut normal = || rng.sample::<f64, _>(StandardNormal);
        let mut x = P0.sqrt() * normal();
        let mut steps = Vec::new();
        for k in 1..=30 {
            x += Q.sqrt() * normal();
            steps.push(Step {
                time: f64::from(k),
                input: (),
                truth: x,
                measurement: Some(x + R.sqrt() * normal()),
            });
        }
        Ok(steps.into_iter())
    }
}

/// A scalar Kalman filter assuming the measurement variance `r`; with `sloppy`, a measurement it
/// refuses has already moved its mean (a half-applied step).
#[derive(Clone, Copy, Debug)]
struct Scalar {
    mean: f64,
    variance: f64,
    r: f64,
    sloppy: bool,
}

impl RecursiveFilter for Scalar {
    type Input = ();
    type Measurement = f64;
    type Estimate = (f64, f64);

    fn predict(&mut self, (): &()) -> Result<(), OperatorError> {
        self.variance += Q;
        Ok(())
    }

    fn update(&mut self, z: &f64) -> Result<Update, OperatorError> {
        let s = self.variance + self.r;
        let nu = z - self.mean;
        let gain = self.variance / s;
        if self.sloppy {
            self.mean += gain * nu;
        }
        if !(nu.is_finite() && nu.abs() < 1e100) {
            return Err(OperatorError::NonFinite {
                what: "innovation",
                value: nu,
            });
        }
        if !self.sloppy {
            self.mean += gain * nu;
        }
        self.variance *= 1.0 - gain;
        Ok(Update {
            log_evidence: -0.5 * (nu * nu / s + (2.0 * std::f64::consts::PI * s).ln()),
            nis: Some(Nis {
                value: nu * nu / s,
                dof: 1,
            }),
        })
    }

    fn estimate(&self) -> Result<(f64, f64), OperatorError> {
        Ok((self.mean, self.variance))
    }
}

/// How a subject's filter is wrong.
#[derive(Clone, Copy, Debug)]
enum Flaw {
    /// Not at all.
    None,
    /// It assumes a measurement variance 4 times too small, whatever it is told.
    OverConfident,
    /// It assumes the true measurement noise, whatever it is told.
    IgnoresNoise,
    /// A measurement it refuses has moved its mean.
    HalfApplied,
}

struct Subject(Flaw);

impl FilterLawSubject for Subject {
    type Scenario = Walk;
    type Filter = Scalar;

    fn scenario(&self) -> &Walk {
        &Walk
    }

    fn filter(
        &self,
        noise: f64,
        _rng: &mut ChaCha8Rng,
    ) -> Result<Scalar, Box<dyn std::error::Error + Send + Sync>> {
        let r = match self.0 {
            Flaw::None | Flaw::HalfApplied => R * noise * noise,
            Flaw::OverConfident => R * noise * noise / 4.0,
            Flaw::IgnoresNoise => R,
        };
        Ok(Scalar {
            mean: 0.0,
            variance: P0,
            r,
            sloppy: matches!(self.0, Flaw::HalfApplied),
        })
    }

    fn nees(&self, truth: &f64, estimate: &(f64, f64)) -> Option<Nis> {
        Some(Nis {
            value: (truth - estimate.0).powi(2) / estimate.1,
            dof: 1,
        })
    }

    fn valid(&self, estimate: &(f64, f64)) -> bool {
        estimate.0.is_finite() && estimate.1.is_finite() && estimate.1 > 0.0
    }

    fn corrupt_input(&self, (): &(), _value: f64) {}

    fn corrupt_measurement(&self, _z: &f64, value: f64) -> f64 {
        value
    }

    fn runs(&self) -> u64 {
        400
    }
}

filter_laws!(the_kalman_filter, Subject(Flaw::None));

#[test]
fn the_kalman_filter_also_moves_the_statistic_when_mis_specified() {
    check_misspecified_moves(&Subject(Flaw::None));
}

#[test]
#[should_panic(expected = "outside its band")]
fn an_over_confident_filter_fails_the_consistency_law() {
    check_consistent(&Subject(Flaw::OverConfident));
}

#[test]
#[should_panic(expected = "passes")]
fn a_filter_ignoring_its_noise_fails_the_band_law() {
    check_misspecified_caught(&Subject(Flaw::IgnoresNoise));
}

#[test]
#[should_panic(expected = "not 2 times the true model's")]
fn a_filter_ignoring_its_noise_fails_the_moves_law() {
    check_misspecified_moves(&Subject(Flaw::IgnoresNoise));
}

#[test]
fn a_half_applied_step_fails_the_all_or_nothing_law() {
    let subject = Subject(Flaw::HalfApplied);
    assert!(check_all_or_nothing(&subject, 0, 5, true, f64::NAN).is_err());
    assert!(check_all_or_nothing(&subject, 0, 5, true, f64::INFINITY).is_err());
    // Its genuine steps are fine.
    assert!(check_all_or_nothing(&subject, 0, 5, true, 0.5).is_ok());
    assert!(check_all_or_nothing(&Subject(Flaw::None), 0, 5, true, f64::NAN).is_ok());
}
