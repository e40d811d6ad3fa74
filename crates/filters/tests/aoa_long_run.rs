//! Long runs stay valid: every angle-of-arrival filter (the von Mises-Fisher and the
//! azimuth-elevation models, each as EKF, UKF, iterated EKF and particle filter) stepped through
//! many epochs keeps a finite mean and a finite symmetric positive semi-definite covariance
//! (definite for the Kalman filters) after every step, whether the step succeeded or was refused,
//! and a refused step leaves its estimate as it was.
//!
//! The readings are the square track's, run after run without resetting the filter (so the truth
//! jumps to a new start every 12 epochs), with every 7th reading set replaced by directions drawn
//! at random over the sphere: readings that no position explains.
//!
//! The test runs 5 000 epochs per filter; the long version is run by hand (the particle filters a
//! fiftieth of the epochs):
//! `LIEBAYES_LONG_RUN_STEPS=100000000 cargo test --release -p liebayes-filters --test
//! aoa_long_run -- --ignored --nocapture` (figures in docs/reliability.md);
//! `LIEBAYES_LONG_RUN_ONLY=IEKF-VMF` runs that one filter.

mod common;

use liebayes_experiments::Method as _;
use liebayes_filters::aoa::{
    Algorithm, AzEl, DataModel, ModelChoice, PositionEstimate, SquareTrack, TrackConfig,
    TrackFilter, TrackReadings,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Epochs of the test-sized runs.
const TEST_EPOCHS: u64 = 5_000;

/// The readings' concentration (about 2.9° per axis); the normal models take σ = 1/√κ.
const KAPPA: f64 = 400.0;

/// An estimate is valid: a finite mean and a valid covariance (positive definite when `definite`).
fn valid(e: &PositionEstimate, definite: bool) -> bool {
    e.mean.iter().all(|x| x.is_finite()) && common::valid_covariance(&e.covariance, definite)
}

/// Steps `filter` through `epochs` epochs of the track's runs, every 7th reading set replaced by
/// directions drawn at random over the sphere; returns the refused steps.
fn run(filter: &TrackFilter, epochs: u64) -> u64 {
    let track = SquareTrack::paper(DataModel::VonMisesFisher { kappa: KAPPA }).expect("the track");
    let track = SquareTrack::new(
        *track.anchors(),
        *track.data(),
        TrackConfig {
            epochs: 12,
            ..*track.config()
        },
    )
    .expect("a track");
    let definite = !matches!(filter.algorithm, Algorithm::Particle(_));
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut wild = ChaCha8Rng::seed_from_u64(6);
    let mut built = filter
        .on(&track)
        .expect("valid settings")
        .build(&mut rng)
        .expect("a filter");
    let mut corrupt = |z: &mut [AzEl], measured: u64| {
        if measured % 7 == 0 {
            for reading in z {
                *reading = AzEl {
                    azimuth: wild.random_range(-PI..PI),
                    elevation: wild.random_range(-1.5..1.5),
                };
            }
        }
    };
    common::run(
        &mut *built,
        &[track],
        epochs,
        &mut rng,
        |z, measured| {
            // The paper's track places every reading.
            if let TrackReadings::Readings(readings) = z {
                corrupt(readings, measured);
            }
        },
        |e| valid(e, definite),
    )
}

/// The six filters: each model with each algorithm (200 particles).
fn filters() -> Vec<TrackFilter> {
    let sigma = 1.0 / KAPPA.sqrt();
    let mut out = Vec::new();
    for model in [
        ModelChoice::Vmf { kappa: KAPPA },
        ModelChoice::AngleNominal {
            sigma_az: sigma,
            sigma_el: sigma,
        },
    ] {
        for algorithm in [
            Algorithm::Ekf,
            Algorithm::Ukf,
            Algorithm::IteratedEkf,
            Algorithm::Particle(200),
        ] {
            out.push(TrackFilter {
                algorithm,
                model: model.clone(),
            });
        }
    }
    out
}

#[test]
fn every_filter_stays_valid() {
    for filter in filters() {
        let refused = run(&filter, TEST_EPOCHS);
        eprintln!(
            "{}: {TEST_EPOCHS} epochs, {refused} refused",
            filter.label()
        );
    }
}

#[test]
#[ignore = "the long run, by hand: LIEBAYES_LONG_RUN_STEPS=100000000"]
fn long_runs() {
    let epochs = common::long_run_steps();
    let only = std::env::var("LIEBAYES_LONG_RUN_ONLY").ok();
    for filter in filters() {
        if only.as_ref().is_some_and(|label| *label != filter.label()) {
            continue;
        }
        // The particle filters, about ten times slower per epoch, a fiftieth of the epochs.
        let epochs = match filter.algorithm {
            Algorithm::Particle(_) => epochs / 50,
            _ => epochs,
        };
        let refused = run(&filter, epochs);
        eprintln!("{}: {epochs} epochs, {refused} refused", filter.label());
    }
}
