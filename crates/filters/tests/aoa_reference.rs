//! The angle-of-arrival models and filters against the independent reference vectors
//! `aoa_vectors.json` (mpmath and an independent numpy implementation): von Mises-Fisher log
//! densities from κ = 0 to 1e5, the unit-vector map, the flipping rule, the azimuth-elevation
//! densities, the adaptive σ table, the single-update example's EKF and UKF steps, and a whole
//! square-track run of the EKF and the UKF with both models, replayed through the experiment
//! layer.

use liebayes_densities::special::vmf_mean_resultant;
use liebayes_densities::{Density, VonMisesFisher};
use liebayes_experiments::Recursive;
use liebayes_experiments::{Metric, RecursiveFilter, Reduction, Scorer, Step, replay};
use liebayes_filters::aoa::{
    AdaptiveSigmas, Anchor, AngleNoise, AzEl, AzElModel, Position, PositionEstimate, Prior,
    RandomWalk, UnitVectorModel, WorldDirections, angle_ekf, angle_ukf, az_el_log_density,
    square_track_anchors, vmf_ekf, vmf_ukf,
};
use liebayes_filters::aoa::{
    PositionGaussian, PositionMoments, StackedAngles, StackedUnitVectors, UKF_LAMBDA,
};
use liebayes_manifolds::S2;
use liebayes_operators::particle::Likelihood;
use liebayes_operators::{Converted, SquareRoot, Ukf};
use liebayes_reference::{numbers, reference, relative_error};
use nalgebra::Vector3;
use serde_json::Value;

fn vector(v: &Value) -> Vector3<f64> {
    Vector3::from_column_slice(&numbers(v))
}

fn number(v: &Value) -> f64 {
    v.as_f64().expect("a number")
}

#[test]
fn von_mises_fisher_log_densities_replay_from_kappa_0_to_1e5() {
    let file = reference("aoa_vectors.json");
    let cases = file["vmf_logpdf"].as_array().unwrap();
    assert!(cases.len() >= 25);
    for case in cases {
        let (x, mu, kappa) = (
            vector(&case["x"]),
            vector(&case["mu"]),
            number(&case["kappa"]),
        );
        let expected = number(&case["logpdf"]);
        let vmf = VonMisesFisher::new(S2::new_unchecked(mu), kappa).unwrap();
        let density = vmf.log_pdf(&S2::new_unchecked(x));
        // One anchor at the origin, world axes: the particle filter's likelihood of the reading x
        // at a position along mu is the same density.
        let model = UnitVectorModel::new([Anchor::at(Vector3::zeros()).unwrap()], kappa.max(1e-12));
        let tolerance = 1e-11 * expected.abs().max(1.0);
        assert!(
            (density - expected).abs() <= tolerance,
            "log pdf at kappa {kappa} ({}): {density} vs {expected}",
            case["tag"]
        );
        if kappa >= 1e-8 {
            let likelihood = model
                .unwrap()
                .log_likelihood(&Position::new_unchecked(mu * 3.0), &WorldDirections([x]));
            assert!(
                (likelihood - expected).abs() <= tolerance,
                "likelihood at kappa {kappa}: {likelihood} vs {expected}"
            );
        }
    }
    for case in file["vmf_mean_resultant_A3"].as_array().unwrap() {
        let kappa = number(&case["kappa"]);
        let got = vmf_mean_resultant(kappa).unwrap();
        assert!(
            relative_error(got, number(&case["A3"])) < 1e-13,
            "A3({kappa}) = {got}"
        );
    }
}

#[test]
fn unit_vectors_and_the_flipping_rule_replay() {
    let file = reference("aoa_vectors.json");
    for case in file["to_unitvector"].as_array().unwrap() {
        let reading = AzEl::new(number(&case["az"]), number(&case["el"]));
        let u = reading.unit_vector();
        assert!((u - vector(&case["u"])).amax() < 1e-15, "{case}");
        // And back (away from the poles, where the azimuth is arbitrary).
        if reading.elevation.abs() < 1.5 {
            let back = AzEl::of_vector(&u).unwrap();
            assert!((back.unit_vector() - u).amax() < 1e-15);
        }
    }
    for case in file["flip"].as_array().unwrap() {
        let raw = AzEl::new(number(&case["az_raw"]), number(&case["el_raw"]));
        let flipped = raw.canonical();
        assert!(
            (flipped.azimuth - number(&case["az"])).abs() < 1e-14,
            "{case}: {flipped:?}"
        );
        assert!(
            (flipped.elevation - number(&case["el"])).abs() < 1e-14,
            "{case}: {flipped:?}"
        );
        assert!((flipped.unit_vector() - raw.unit_vector()).amax() < 1e-14);
        flipped.check_canonical().unwrap();
    }
}

/// Azimuths near ±f64::MAX (finite, accepted: the model wraps them) made the difference overflow
/// to ∞, which wraps to NaN: `Ok(NaN)`, and a NaN standard error from the fit. Each is wrapped
/// first. Readings without noise left the fit's likelihood flat at the end of its range, and its
/// standard errors were +∞ inside Ok; that is now an error.
#[test]
fn huge_azimuths_and_noise_free_readings_give_numbers_or_errors() {
    let (y, y0) = (AzEl::new(1.7e308, 0.0), AzEl::new(-1.7e308, 0.0));
    let value = az_el_log_density(&y, &y0, 0.1, 0.1).unwrap();
    let wrapped = az_el_log_density(
        &AzEl::new(liebayes_manifolds::wrap_angle(1.7e308), 0.0),
        &AzEl::new(liebayes_manifolds::wrap_angle(-1.7e308), 0.0),
        0.1,
        0.1,
    )
    .unwrap();
    assert!(
        value.is_finite() && (value - wrapped).abs() < 1e-12,
        "{value} vs {wrapped}"
    );
    let exact = [(AzEl::new(0.3, 0.2), AzEl::new(0.3, 0.2)); 3];
    assert!(liebayes_filters::aoa::fit_angle_sigmas_to(&exact).is_err());
}

/// A predicted elevation of 1e154 gave NaN and one of 1e20 +∞, as a bare number: such a direction,
/// a non-finite reading and a σ outside its range are now errors.
#[test]
fn the_density_refuses_what_it_cannot_evaluate() {
    let y = AzEl::new(0.3, 0.2);
    for el0 in [1e154, 1e20, 2.0, f64::NAN] {
        assert!(az_el_log_density(&y, &AzEl::new(0.1, el0), 0.1, 0.1).is_err());
    }
    let y0 = AzEl::new(0.1, 0.1);
    assert!(az_el_log_density(&AzEl::new(f64::INFINITY, 0.0), &y0, 0.1, 0.1).is_err());
    for sigma in [0.0, 1e-300, 1e300, f64::NAN] {
        assert!(az_el_log_density(&y, &y0, sigma, 0.1).is_err());
        assert!(az_el_log_density(&y, &y0, 0.1, sigma).is_err());
    }
    // At the edges of the accepted ranges the density is a number; a reading past a pole has
    // density zero.
    for (s_az, s_el) in [(1e-9, 1e-9), (1e3, 1e3), (1e-9, 1e3)] {
        for el0 in [
            std::f64::consts::FRAC_PI_2,
            -std::f64::consts::FRAC_PI_2,
            0.0,
        ] {
            let value = az_el_log_density(&y, &AzEl::new(3.0, el0), s_az, s_el).unwrap();
            assert!(value.is_finite(), "{s_az} {s_el} {el0}: {value}");
        }
    }
    let past = az_el_log_density(&AzEl::new(0.0, 2.0), &y0, 0.1, 0.1).unwrap();
    assert_eq!(past, f64::NEG_INFINITY);
}

#[test]
fn azimuth_elevation_densities_replay() {
    let file = reference("aoa_vectors.json");
    for case in file["ae_logpdf"].as_array().unwrap() {
        let y = AzEl::new(number(&case["y_az"]), number(&case["y_el"]));
        let y0 = AzEl::new(number(&case["az0"]), number(&case["el0"]));
        let got = az_el_log_density(&y, &y0, number(&case["s_az"]), number(&case["s_el"])).unwrap();
        let expected = number(&case["logpdf"]);
        assert!(
            (got - expected).abs() < 1e-13 * expected.abs().max(1.0),
            "{case}: {got}"
        );
    }
}

#[test]
fn the_adaptive_table_matches_the_reference_at_every_degree() {
    let file = reference("aoa_vectors.json");
    let table = &file["adaptive_table"];
    let sigma = 10f64.to_radians();
    let ours = AdaptiveSigmas::model_one(sigma, sigma).unwrap();
    let columns =
        ["sd_az_rad", "sd_el_rad", "mean_el_err_rad", "p_flip"].map(|c| numbers(&table[c]));
    let elevations = numbers(&table["el_deg"]);
    let mut worst = [0.0f64; 4];
    for (i, (el, row)) in ours.table().enumerate() {
        assert!((el.to_degrees() - elevations[i]).abs() < 1e-9);
        for c in 0..4 {
            worst[c] = worst[c].max((row[c] - columns[c][i]).abs());
        }
        // Interpolation at the grid points returns the grid values.
        let (az, el_sd) = ours.at(el).unwrap();
        assert!((az - row[0]).abs() < 1e-12 && (el_sd - row[1]).abs() < 1e-12);
    }
    assert!(
        worst.iter().all(|&w| w < 1e-6),
        "largest differences {worst:?}"
    );
}

/// The single-update example's prior and models (anchor at the origin, world axes).
fn single_update() -> (Prior, UnitVectorModel<1>, AzElModel<1>, Value) {
    let file = reference("aoa_vectors.json");
    let case = file["single_update"].clone();
    let prior = Prior::new(vector(&case["prior_mean"]), number(&case["prior_std"])).unwrap();
    let anchors = [Anchor::at(Vector3::zeros()).unwrap()];
    let sigma = number(&case["sigma_deg"]).to_radians();
    let vmf = UnitVectorModel::new(anchors, number(&case["kappa"])).unwrap();
    let ae = AzElModel::new(
        anchors,
        AngleNoise::Fixed {
            sigma_az: sigma,
            sigma_el: sigma,
        },
    )
    .unwrap();
    (prior, vmf, ae, case)
}

#[test]
fn single_update_ekf_and_ukf_replay_for_both_elevations() {
    let (prior, vmf, ae, case) = single_update();
    let walk = RandomWalk::new(0.0, 0.0).unwrap();
    for name in ["corrected", "literal"] {
        let c = &case["cases"][name];
        let reading = [AzEl::new(number(&c["y_az"]), number(&c["y_el"]))];
        assert!((reading[0].unit_vector() - vector(&c["u"])).amax() < 1e-15);
        let updates = &c["gaussian_filter_updates"];
        let check = |label: &str, got: Vector3<f64>| {
            let expected = vector(&updates[label]);
            assert!(
                (got - expected).amax() < 1e-9,
                "{name} {label}: {got} vs {expected}"
            );
        };
        let mut ekf = vmf_ekf::<1, 3>(vmf, walk, &prior).unwrap();
        ekf.update(&reading).unwrap();
        check("EKF-VMF", ekf.estimate().unwrap().mean);
        let mut ukf = vmf_ukf::<1, 3>(vmf, walk, &prior).unwrap();
        ukf.update(&reading).unwrap();
        check("UKF-VMF", ukf.estimate().unwrap().mean);
        if name == "corrected" {
            let mut ekf = angle_ekf::<1, 2>(ae.clone(), walk, &prior).unwrap();
            ekf.update(&reading).unwrap();
            check("EKF-AE", ekf.estimate().unwrap().mean);
            let mut ukf = angle_ukf::<1, 2>(ae.clone(), walk, &prior).unwrap();
            ukf.update(&reading).unwrap();
            check("UKF-AE", ukf.estimate().unwrap().mean);
        } else {
            // The literal elevation is not a canonical reading: the angle models refuse it.
            let mut ekf = angle_ekf::<1, 2>(ae.clone(), walk, &prior).unwrap();
            let before = ekf.clone();
            assert!(ekf.update(&reading).is_err());
            assert_eq!(ekf, before);
        }
    }
}

/// The UKF of the builders (λ = 0.5) with its sigma points along P's principal axes.
fn eigen_ukf<H, C, const M: usize>(
    model: H,
    conversion: C,
    walk: RandomWalk,
    prior: &Prior,
) -> Recursive<PositionGaussian, Ukf<RandomWalk>, Converted<Ukf<H, M>, C>, PositionMoments> {
    Recursive::with_estimator(
        prior.gaussian().unwrap(),
        Ukf::with_scaling(walk, 1.0, 0.0, UKF_LAMBDA)
            .unwrap()
            .with_square_root(SquareRoot::Eigen),
        Converted {
            model: Ukf::with_scaling(model, 1.0, 0.0, UKF_LAMBDA)
                .unwrap()
                .with_square_root(SquareRoot::Eigen),
            conversion,
        },
        PositionMoments,
    )
}

/// Writes the estimate's mean, to compare step by step.
struct Means;

impl Scorer<Position, PositionEstimate> for Means {
    fn metrics(&self) -> Vec<Metric> {
        ["x", "y", "z"]
            .map(|name| Metric::new(name, Reduction::Mean, "m"))
            .to_vec()
    }

    fn score(&self, _: &Position, estimate: &PositionEstimate, values: &mut [f64]) {
        values.copy_from_slice(estimate.mean.as_slice());
    }
}

#[test]
fn square_track_runs_of_the_kalman_filters_replay_step_by_step() {
    let file = reference("aoa_vectors.json");
    let replayed = &file["track_replay"];
    let track = &replayed["track"];
    let anchors = square_track_anchors();
    for (j, anchor) in anchors.iter().enumerate() {
        assert!((anchor.position() - vector(&replayed["anchors"][j])).amax() == 0.0);
        let rows = numbers(&replayed["rotations"][j]);
        let m = anchor.rotation_matrix();
        for r in 0..3 {
            for c in 0..3 {
                assert_eq!(m[(r, c)], rows[3 * r + c]);
            }
        }
    }
    let walk = RandomWalk::new(number(&track["q_xy"]), number(&track["q_z"])).unwrap();
    let delta = number(&track["delta"]);
    let kappa = number(&replayed["kappa"]);
    let sigma = number(&replayed["sigma_rad"]);
    let vmf = UnitVectorModel::new(anchors, kappa).unwrap();
    let ae = AzElModel::new(
        anchors,
        AngleNoise::Fixed {
            sigma_az: sigma,
            sigma_el: sigma,
        },
    )
    .unwrap();
    for data in ["I", "II"] {
        let case = &replayed["cases"][data];
        let prior = Prior::new(vector(&case["m0"]), number(&track["P0_std"])).unwrap();
        let (az, el) = (&case["y_az"], &case["y_el"]);
        let steps: Vec<Step<Position, f64, [AzEl; 4]>> =
            (0..case["truth"].as_array().unwrap().len())
                .map(|k| Step {
                    time: (k + 1) as f64 * delta,
                    input: delta,
                    truth: Position::new_unchecked(vector(&case["truth"][k])),
                    measurement: Some(std::array::from_fn(|j| {
                        AzEl::new(number(&az[k][j]), number(&el[k][j]))
                    })),
                })
                .collect();
        let mean_at = |scores: &liebayes_experiments::RunScores, k: usize| {
            Vector3::new(
                scores.get("x", k).unwrap(),
                scores.get("y", k).unwrap(),
                scores.get("z", k).unwrap(),
            )
        };
        let check = |label: &str, scores: liebayes_experiments::RunScores| {
            let expected = &case["estimates"][label];
            for k in 0..steps.len() {
                let (got, want) = (mean_at(&scores, k), vector(&expected[k]));
                assert!(
                    (got - want).amax() < 1e-8,
                    "Model {data} {label} step {k}: {got} vs {want}"
                );
            }
        };
        let mut f = vmf_ekf::<4, 12>(vmf, walk, &prior).unwrap();
        check("EKF-VMF", replay(&mut f, steps.clone(), &Means).unwrap());
        let mut f = angle_ekf::<4, 8>(ae.clone(), walk, &prior).unwrap();
        check(
            "EKF-AE-nominal",
            replay(&mut f, steps.clone(), &Means).unwrap(),
        );
        // The reference's UKF spreads its sigma points along P's principal axes.
        let mut f = eigen_ukf(vmf, StackedUnitVectors::<4, 12>, walk, &prior);
        check("UKF-VMF", replay(&mut f, steps.clone(), &Means).unwrap());
        let mut f = eigen_ukf(ae.clone(), StackedAngles::<4, 8>, walk, &prior);
        check(
            "UKF-AE-nominal",
            replay(&mut f, steps.clone(), &Means).unwrap(),
        );
        // With the Cholesky factor (the builders' default) the sigma points differ, and so do the
        // runs, but the unit-vector UKF stays within centimetres.
        let mut f = vmf_ukf::<4, 12>(vmf, walk, &prior).unwrap();
        let cholesky = replay(&mut f, steps.clone(), &Means).unwrap();
        let expected = &case["estimates"]["UKF-VMF"];
        for k in 0..steps.len() {
            let difference = (mean_at(&cholesky, k) - vector(&expected[k])).amax();
            assert!(difference < 0.05, "Model {data} step {k}: {difference}");
        }
    }
}
