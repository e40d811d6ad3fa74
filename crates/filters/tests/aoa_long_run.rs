//! Long runs stay valid: every angle-of-arrival filter (the von Mises-Fisher and the
//! azimuth-elevation models, each as EKF, UKF and particle filter) stepped through many epochs keeps
//! a finite mean and a finite symmetric positive semi-definite covariance (definite for the Kalman
//! filters) after every step, whether the step succeeded or was refused, and a refused step leaves
//! its estimate as it was.
//!
//! The readings are the square track's, run after run without resetting the filter (so the truth
//! jumps to a new start every 12 epochs), with every 7th reading set replaced by directions drawn
//! at random over the sphere: readings that no position explains.
//!
//! The test runs 5 000 epochs per filter; the long version is run by hand (the particle filters a
//! fiftieth of the epochs):
//! `LIEBAYES_LONG_RUN_STEPS=100000000 cargo test --release -p liebayes-filters --test
//! aoa_long_run -- --ignored --nocapture` (figures in docs/reliability.md).

use liebayes_experiments::{Method as _, RecursiveFilter, Scenario};
use liebayes_filters::aoa::{
    Algorithm, AzEl, DataModel, ModelChoice, PositionEstimate, SquareTrack, TrackConfig,
    TrackFilter,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Epochs of the test-sized runs.
const TEST_EPOCHS: u64 = 5_000;

/// The readings' concentration (about 2.9° per axis); the normal models take σ = 1/√κ.
const KAPPA: f64 = 400.0;

/// An estimate is valid: a finite mean, a finite symmetric covariance with no negative eigenvalue
/// beyond rounding (relative to its largest entry, and absolute below f64::MIN_POSITIVE: particles
/// collapsed onto one point give a covariance of subnormal entries, whose eigenvalues carry
/// rounding of that size), positive definite when `definite`.
fn valid(e: &PositionEstimate, definite: bool) -> bool {
    let p = &e.covariance;
    let scale = p.amax();
    let eigenvalues = p.symmetric_eigenvalues();
    e.mean.iter().all(|x| x.is_finite())
        && p.iter().all(|x| x.is_finite())
        && (p - p.transpose()).amax() <= 1e-12 * scale
        && eigenvalues.min() >= -(1e-12 * scale).max(f64::MIN_POSITIVE)
        && (!definite || p.cholesky().is_some())
}

/// Steps `filter` through `epochs` epochs of the track's runs; returns the refused steps.
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
    let (mut done, mut refused) = (0_u64, 0_u64);
    while done < epochs {
        let steps: Vec<_> = track
            .simulate(&mut rng)
            .expect("a run of the track")
            .collect();
        for step in steps {
            if done == epochs {
                break;
            }
            let before = built.estimate().ok();
            if built.predict(&step.input).is_err() {
                refused += 1;
                assert_eq!(
                    built.estimate().ok(),
                    before,
                    "epoch {done}: a refused predict"
                );
            }
            if let Some(mut z) = step.measurement {
                if done % 7 == 0 {
                    for reading in &mut z {
                        *reading = AzEl {
                            azimuth: wild.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                            elevation: wild.random_range(-1.5..1.5),
                        };
                    }
                }
                let before = built.estimate().ok();
                if built.update(&z).is_err() {
                    refused += 1;
                    assert_eq!(
                        built.estimate().ok(),
                        before,
                        "epoch {done}: a refused update"
                    );
                }
            }
            let estimate = built.estimate().expect("an estimate");
            assert!(valid(&estimate, definite), "epoch {done}: {estimate:?}");
            done += 1;
        }
    }
    refused
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
        for algorithm in [Algorithm::Ekf, Algorithm::Ukf, Algorithm::Particle(200)] {
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
    let epochs = std::env::var("LIEBAYES_LONG_RUN_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000_000);
    for filter in filters() {
        // The particle filters, about ten times slower per epoch, a fiftieth of the epochs.
        let epochs = match filter.algorithm {
            Algorithm::Particle(_) => epochs / 50,
            _ => epochs,
        };
        let refused = run(&filter, epochs);
        eprintln!("{}: {epochs} epochs, {refused} refused", filter.label());
    }
}
