//! Bad input never panics, hangs or silently yields NaN in the angle-of-arrival application: the
//! models, the filters and the scenario are fed NaN, ±∞, ±MAX, subnormals, zeros and huge sizes,
//! each call on its own thread under a time limit. A call returns an error or a finite result, and
//! a filter is exactly as it was after a step that failed (`LIEBAYES_FUZZ_CASES` runs it long).

use liebayes_experiments::{RecursiveFilter, Scenario};
use liebayes_filters::aoa::{
    Anchor, AngleNoise, AzEl, AzElModel, DataModel, Prior, RandomWalk, SquareTrack, TrackConfig,
    UnitVectorModel, angle_ekf, angle_particle_filter, angle_ukf, square_track_anchors, vmf_ekf,
    vmf_particle_filter, vmf_ukf,
};
use liebayes_operators::MAX_ELEMENTS;
use liebayes_reference::fuzz::{self, size, value};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn vector() -> impl Strategy<Value = Vector3<f64>> {
    (value(), value(), value()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn readings() -> impl Strategy<Value = [AzEl; 4]> {
    proptest::array::uniform4((value(), value()).prop_map(|(a, e)| AzEl::new(a, e)))
}

/// A step of `filter` either fails and leaves it unchanged, or leaves a finite estimate.
fn step<F>(filter: &mut F, delta: f64, z: &[AzEl; 4]) -> Result<(), TestCaseError>
where
    F: RecursiveFilter<
            Input = f64,
            Measurement = [AzEl; 4],
            Estimate = liebayes_filters::aoa::PositionEstimate,
        > + Clone
        + PartialEq
        + std::fmt::Debug,
{
    let before = filter.clone();
    if fuzz::counted(filter.predict(&delta)).is_none() {
        prop_assert_eq!(&*filter, &before);
    }
    let before = filter.clone();
    if fuzz::counted(filter.update(z)).is_none() {
        prop_assert_eq!(&*filter, &before);
    }
    if let Some(e) = fuzz::counted(filter.estimate()) {
        prop_assert!(
            e.mean
                .iter()
                .chain(e.covariance.iter())
                .all(|v| v.is_finite())
        );
    }
    Ok(())
}

#[test]
fn models_and_kalman_filters() {
    fuzz::run(
        "aoa_kalman",
        (
            vector(),
            value(),
            value(),
            value(),
            value(),
            value(),
            vector(),
            value(),
            readings(),
        ),
        |(anchor, kappa, sigma, q, mean_scale, std, m0, delta, z)| {
            fuzz::case("aoa_kalman", move || -> Result<(), TestCaseError> {
                let mut anchors = square_track_anchors();
                if let Some(a) = fuzz::counted(Anchor::at(anchor)) {
                    anchors[0] = a;
                }
                let Some(prior) = fuzz::counted(Prior::new(m0 * mean_scale.abs().min(1e3), std))
                else {
                    return Ok(());
                };
                let walk = fuzz::counted(RandomWalk::new(q, q))
                    .unwrap_or(RandomWalk::new(0.5, 0.1).unwrap());
                if let Some(vmf) = fuzz::counted(UnitVectorModel::new(anchors, kappa)) {
                    if let Some(mut f) = fuzz::counted(vmf_ekf::<4, 12>(vmf, walk, &prior)) {
                        step(&mut f, delta, &z)?;
                    }
                    if let Some(mut f) = fuzz::counted(vmf_ukf::<4, 12>(vmf, walk, &prior)) {
                        step(&mut f, delta, &z)?;
                    }
                }
                let noise = AngleNoise::Fixed {
                    sigma_az: sigma,
                    sigma_el: sigma.abs(),
                };
                if let Some(ae) = fuzz::counted(AzElModel::new(anchors, noise)) {
                    if let Some(mut f) = fuzz::counted(angle_ekf::<4, 8>(ae.clone(), walk, &prior))
                    {
                        step(&mut f, delta, &z)?;
                    }
                    if let Some(mut f) = fuzz::counted(angle_ukf::<4, 8>(ae, walk, &prior)) {
                        step(&mut f, delta, &z)?;
                    }
                }
                Ok(())
            });
        },
    );
}

#[test]
fn particle_filters_and_scenarios() {
    fuzz::run(
        "aoa_particles",
        (
            size(MAX_ELEMENTS),
            value(),
            vector(),
            value(),
            value(),
            readings(),
            value(),
            value(),
        ),
        |(n, kappa, m0, std, delta, z, side, sigma)| {
            fuzz::case("aoa_particles", move || -> Result<(), TestCaseError> {
                let anchors = square_track_anchors();
                let walk = RandomWalk::new(0.5, 0.1).unwrap();
                if let Some(prior) = fuzz::counted(Prior::new(m0, std)) {
                    let rng = ChaCha8Rng::seed_from_u64(1);
                    if let Some(vmf) = fuzz::counted(UnitVectorModel::new(anchors, kappa)) {
                        if let Some(mut f) =
                            fuzz::counted(vmf_particle_filter(vmf, walk, &prior, n, rng.clone()))
                        {
                            let before = (
                                f.density().particles().to_vec(),
                                f.density().log_weights().to_vec(),
                            );
                            if fuzz::counted(f.update(&z)).is_none() {
                                prop_assert_eq!(f.density().particles(), &before.0[..]);
                                prop_assert_eq!(f.density().log_weights(), &before.1[..]);
                            }
                            let _ = fuzz::counted(f.predict(&delta));
                            let _ = fuzz::counted(f.estimate());
                        }
                    }
                    let noise = AngleNoise::Fixed {
                        sigma_az: 0.2,
                        sigma_el: 0.2,
                    };
                    let ae = AzElModel::new(anchors, noise).unwrap();
                    if let Some(mut f) =
                        fuzz::counted(angle_particle_filter(ae, walk, &prior, n, rng))
                    {
                        let _ = fuzz::counted(f.update(&z));
                        let _ = fuzz::counted(f.estimate());
                    }
                }
                let config = TrackConfig {
                    side,
                    delta: delta.abs(),
                    ..TrackConfig::default()
                };
                let data = DataModel::NormalWithFlip {
                    sigma_az: sigma,
                    sigma_el: 0.1,
                };
                if let Some(track) = fuzz::counted(SquareTrack::new(anchors, data, config)) {
                    let mut sim = ChaCha8Rng::seed_from_u64(2);
                    for s in track.simulate(&mut sim).unwrap().take(3) {
                        prop_assert!(s.truth.coords().iter().all(|v| v.is_finite()));
                        for r in s.measurement.unwrap() {
                            prop_assert!(r.check_canonical().is_ok());
                        }
                    }
                }
                Ok(())
            });
        },
    );
}
