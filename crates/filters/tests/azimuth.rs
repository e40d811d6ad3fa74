//! The exact azimuth filter against its brute-force reference (a bank of Kalman filters over a grid of
//! azimuths, from the operators crate), against the general composite, against the reference vectors
//! `azimuth_vectors.json`, and at its edges. Every run goes through the experiment layer's `replay`,
//! two filters side by side through `Paired`.

use liebayes_densities::{Density, Gaussian, HarmonicGaussian};
use liebayes_experiments::{
    AsIs, Metric, Paired, PairedEstimate, Recursive, RecursiveFilter, Reduction, RunScores,
    Scenario, Scorer, Step, replay,
};
use liebayes_filters::azimuth::{
    AzimuthDensity, AzimuthEstimate, AzimuthScenario, Config, Motion, PositionAzimuth,
    PositionMeasurement, VelocityInput, VelocityProcess, exact, grid_filter, log_joint,
    particle_filter,
};
use liebayes_manifolds::{Manifold, So2};
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::kalman::LinearProcess;
use liebayes_operators::rao_blackwell::RotatedMeasurement;
use liebayes_operators::{OperatorError, Propagate};
use liebayes_reference::{numbers, reference};
use nalgebra::{Matrix2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

/// Relative agreement demanded of the exact filter and its references at every angle and epoch.
const TOLERANCE: f64 = 1e-9;

fn models(config: &Config) -> (VelocityProcess, PositionMeasurement) {
    (
        VelocityProcess::new(config.q).unwrap(),
        PositionMeasurement::new(config.sigma_m).unwrap(),
    )
}

/// A run of a scenario, recorded.
fn run(
    motion: Motion,
    config: &Config,
    seed: u64,
) -> Vec<Step<PositionAzimuth, VelocityInput, Vector2<f64>>> {
    let scenario = AzimuthScenario::new(motion, *config).unwrap();
    scenario
        .simulate(&mut ChaCha8Rng::seed_from_u64(seed))
        .unwrap()
        .collect()
}

/// The exact filter from the scenario's prior, its density as its estimate.
fn exact_density(
    config: &Config,
) -> Recursive<AzimuthDensity, VelocityProcess, PositionMeasurement> {
    let (process, measurement) = models(config);
    exact(process, measurement, Vector2::zeros(), config.sigma0)
        .unwrap()
        .estimated_by(AsIs)
}

/// The largest value of a metric over the epochs of a run (NaN epochs skipped).
fn worst(scores: &RunScores, name: &str) -> f64 {
    (0..scores.epochs())
        .filter_map(|k| scores.get(name, k))
        .filter(|v| !v.is_nan())
        .fold(0.0, f64::max)
}

/// The exact density against the grid of Kalman filters, cell by cell.
struct GridAgreement;

impl Scorer<PositionAzimuth, PairedEstimate<AzimuthDensity, CircularGrid<Gaussian<2>>>>
    for GridAgreement
{
    fn metrics(&self) -> Vec<Metric> {
        ["joint", "mean", "covariance"]
            .map(|name| Metric::new(name, Reduction::Mean, ""))
            .to_vec()
    }

    fn score(
        &self,
        _: &PositionAzimuth,
        pair: &PairedEstimate<AzimuthDensity, CircularGrid<Gaussian<2>>>,
        values: &mut [f64],
    ) {
        let (exact, grid) = (&pair.first, &pair.second);
        let grid_joint =
            log_joint(grid, pair.log_evidence[1]).expect("an update's log evidence is finite");
        values.fill(0.0);
        for (j, cell) in grid.cells().iter().enumerate() {
            let a = grid.rotation(j);
            let log_pdf = exact.azimuth().log_pdf(&a);
            let joint = log_pdf + pair.log_evidence[0];
            let scale = 1.0 + log_pdf.abs() + pair.log_evidence[0].abs();
            let mean = exact.conditional_mean(&a);
            values[0] = values[0].max((joint - grid_joint[j]).abs() / scale);
            values[1] = values[1].max((cell.mean() - mean).amax() / (1.0 + mean.amax()));
            values[2] = values[2].max(
                (cell.covariance() - Matrix2::identity() * exact.sigma2()).amax() / exact.sigma2(),
            );
        }
    }
}

/// At every epoch of a full 500 s run of each scenario, at each of 90 grid azimuths Aⱼ:
/// * the Kalman filter's mean equals `a + c cos Aⱼ − c^× sin Aⱼ` and its covariance `σ² I`;
/// * the grid's `ln p(Aⱼ, z₁..ₖ)` (its cell weight with its summed trapezoid evidence) equals the
///   exact filter's `ln p(Aⱼ | z₁..ₖ) + Σ ln p(zᵢ | earlier z)`, which checks the von Mises posterior
///   pointwise and the closed-form log evidence together (second harmonics, were they excited,
///   would show here).
#[test]
fn exact_filter_equals_the_grid_of_kalman_filters_at_every_epoch() {
    let config = Config::default();
    let (process, measurement) = models(&config);
    for (seed, motion) in (0..).zip(Motion::ALL) {
        let grid = grid_filter(90, process, measurement, Vector2::zeros(), config.sigma0)
            .unwrap()
            .estimated_by(AsIs);
        let mut pair = Paired::new(exact_density(&config), grid);
        let scores = replay(&mut pair, run(motion, &config, seed), &GridAgreement).unwrap();
        assert_eq!(scores.epochs(), 500);
        for name in ["joint", "mean", "covariance"] {
            let error = worst(&scores, name);
            assert!(error <= TOLERANCE, "{}: {name} {error:e}", motion.name());
        }
        eprintln!(
            "{}: worst relative disagreement with the grid of Kalman filters {:.1e} (final kappa {:.3e})",
            motion.name(),
            ["joint", "mean", "covariance"]
                .map(|n| worst(&scores, n))
                .into_iter()
                .fold(0.0, f64::max),
            pair.first().density().azimuth().concentration()
        );
    }
}

/// The closed-form estimate against the trapezoid sums of a fine grid, at every epoch where the
/// grid resolves the posterior (σ_A at least 10 grid spacings).
struct MomentAgreement {
    spacing: f64,
}

impl Scorer<PositionAzimuth, PairedEstimate<AzimuthEstimate, AzimuthEstimate>> for MomentAgreement {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("mean", Reduction::Mean, ""),
            Metric::new("covariance", Reduction::Mean, ""),
        ]
    }

    fn score(
        &self,
        _: &PositionAzimuth,
        pair: &PairedEstimate<AzimuthEstimate, AzimuthEstimate>,
        values: &mut [f64],
    ) {
        let (e, g) = (&pair.first, &pair.second);
        if e.sigma_a().is_some_and(|s| s <= 10.0 * self.spacing) {
            values.fill(f64::NAN);
            return;
        }
        let scale = 1.0 + g.cov_r.amax();
        values[0] = (e.mean_r - g.mean_r).amax() / scale.sqrt();
        values[1] = (e.cov_r - g.cov_r).amax() / scale;
    }
}

/// The closed-form moments (E r, Cov r, and through them the first and second circular moments)
/// against a fine grid's, over the first 120 s of each scenario.
#[test]
fn point_estimates_match_the_grid_moments() {
    let config = Config {
        steps: 1200,
        ..Config::default()
    };
    let (process, measurement) = models(&config);
    let n = 1440_usize;
    let scorer = MomentAgreement {
        spacing: 2.0 * std::f64::consts::PI / n as f64,
    };
    let mut compared = 0;
    for (seed, motion) in (10..).zip(Motion::ALL) {
        let exact = exact(process, measurement, Vector2::zeros(), config.sigma0).unwrap();
        let grid = grid_filter(n, process, measurement, Vector2::zeros(), config.sigma0).unwrap();
        let scores = replay(
            &mut Paired::new(exact, grid),
            run(motion, &config, seed),
            &scorer,
        )
        .unwrap();
        for name in ["mean", "covariance"] {
            assert!(worst(&scores, name) <= 1e-9, "{}: {name}", motion.name());
        }
        compared += (0..scores.epochs())
            .filter(|&k| scores.get("mean", k).is_some_and(f64::is_finite))
            .count();
    }
    assert!(
        compared >= 150,
        "only {compared} epochs were resolved by the grid"
    );
}

/// The reference's state and estimates after each update, against the filter's.
struct ReferenceScorer {
    epochs: Vec<Value>,
}

impl Scorer<Option<usize>, AzimuthDensity> for ReferenceScorer {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("state", Reduction::Mean, ""),
            Metric::new("mode", Reduction::Mean, ""),
            Metric::new("sigma", Reduction::Mean, ""),
        ]
    }

    fn score(&self, epoch: &Option<usize>, filter: &AzimuthDensity, values: &mut [f64]) {
        let epoch = &self.epochs[epoch.expect("a measurement step has its epoch")];
        let state = &epoch["after_update"];
        let estimate = filter.estimate();
        let got = [
            filter.eta().as_slice(),
            filter.a().as_slice(),
            filter.c().as_slice(),
            &[filter.sigma2(), filter.azimuth().concentration()],
            estimate.mean_r.as_slice(),
            estimate.cov_r.as_slice(),
        ]
        .concat();
        let expected_estimates = &epoch["estimates"];
        let expected = [
            numbers(&state["eta"]),
            numbers(&state["a"]),
            numbers(&state["c"]),
            numbers(&state["sigma2"]),
            numbers(&expected_estimates["kappa"]),
            numbers(&expected_estimates["mean_r"]),
            numbers(&expected_estimates["cov_r"]),
        ]
        .concat();
        assert_eq!(got.len(), expected.len());
        values[0] = got
            .iter()
            .zip(&expected)
            .map(|(g, e)| (g - e).abs() / (1.0 + e.abs()))
            .fold(0.0, f64::max);
        (values[1], values[2]) = match (estimate.azimuth, expected_estimates["mode"].as_f64()) {
            (None, None) => (0.0, 0.0),
            (Some(m), Some(e)) => {
                let sigma = expected_estimates["sigma_a"].as_f64().unwrap();
                (
                    So2::from_angle_unchecked(e).local(&m)[0].abs(),
                    (estimate.sigma_a().unwrap() - sigma).abs() / (1.0 + sigma),
                )
            }
            // A mode where the reference has none, or the converse: an infinite disagreement.
            _ => (f64::INFINITY, f64::INFINITY),
        };
    }
}

/// Replays the independent reference: the state after every update and the point estimates.
#[test]
fn replays_the_reference_vectors() {
    let file = reference("azimuth_vectors.json");
    let params = &file["params"];
    let number = |key: &str| params[key].as_f64().unwrap();
    let (process, measurement) = (
        VelocityProcess::new(number("q")).unwrap(),
        PositionMeasurement::new(number("sigma_m")).unwrap(),
    );
    let dt = number("dt");
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let every = number("meas_every") as usize;
    let mut total = 0;
    for (name, scenario) in file["scenarios"].as_object().unwrap() {
        let velocities: Vec<Vec<f64>> = scenario["velocities"]
            .as_array()
            .unwrap()
            .iter()
            .map(numbers)
            .collect();
        let epochs = scenario["epochs"].as_array().unwrap().clone();
        // Step 0 measures the start; step k moves with the velocity of step k - 1, then measures
        // when k is a multiple of `every`: the reference's order (measure, then move).
        let steps: Vec<Step<Option<usize>, VelocityInput, Vector2<f64>>> = (0..velocities.len())
            .map(|k| {
                let epoch = (k % every == 0).then_some(k / every);
                Step {
                    time: k as f64 * dt,
                    input: match k {
                        0 => VelocityInput {
                            velocity: Vector2::zeros(),
                            dt: 0.0,
                        },
                        _ => VelocityInput {
                            velocity: Vector2::new(velocities[k - 1][0], velocities[k - 1][1]),
                            dt,
                        },
                    },
                    truth: epoch,
                    measurement: epoch.map(|e| {
                        let z = numbers(&epochs[e]["z"]);
                        Vector2::new(z[0], z[1])
                    }),
                }
            })
            .collect();
        let scorer = ReferenceScorer {
            epochs: epochs.clone(),
        };
        let mut filter = Recursive::new(
            AzimuthDensity::new(Vector2::zeros(), number("sigma0")).unwrap(),
            process,
            measurement,
        );
        let scores = replay(&mut filter, steps, &scorer).unwrap();
        assert_eq!(scores.epochs(), epochs.len());
        for metric in ["state", "mode", "sigma"] {
            let error = worst(&scores, metric);
            assert!(error <= 1e-9, "{name}: {metric} {error:e}");
        }
        total += scores.epochs();
    }
    assert_eq!(total, 90);
}

/// Static scenario from the origin: η stays exactly 0 (the measurements carry no azimuth
/// information): κ = 0, no azimuth, no σ_A, finite moments and log evidence, and
/// `Cov r = (σ² + |c|²/2) I`.
#[test]
fn static_scenario_reports_an_unobservable_azimuth_without_nan() {
    let config = Config::default();
    let mut filter = exact_density(&config);
    let scores = replay(&mut filter, run(Motion::Static, &config, 5), &NoMetrics).unwrap();
    assert!((0..scores.epochs()).all(|k| scores.get("log_evidence", k).unwrap().is_finite()));
    let density = filter.density();
    let estimate = density.estimate();
    assert_eq!(density.azimuth().concentration(), 0.0);
    assert!(estimate.azimuth.is_none() && estimate.sigma_a().is_none());
    assert_eq!(estimate.mean_r, Vector2::zeros());
    let expected = Matrix2::identity() * (density.sigma2() + density.c().norm_squared() / 2.0);
    assert!((estimate.cov_r - expected).amax() <= 1e-12 * expected.amax());
}

/// No metrics of its own: the replay's log evidence and NIS only.
struct NoMetrics;

impl<T, E> Scorer<T, E> for NoMetrics {
    fn metrics(&self) -> Vec<Metric> {
        Vec::new()
    }

    fn score(&self, _: &T, _: &E, _: &mut [f64]) {}
}

/// `(E r, Cov r)` by quadrature over A: the von Mises weights `exp(κ (cos(A − μ) − 1))` on 4000
/// trapezoid points (exponentially accurate for this periodic integrand while κ ≤ 500), mixing the
/// conditional Gaussians `N(a + c cos A − c^× sin A, σ² I)`. Independent of the closed form.
fn moments_by_quadrature(density: &AzimuthDensity) -> (Vector2<f64>, Matrix2<f64>) {
    let (eta, n) = (density.eta(), 4000);
    let (kappa, mu) = (eta.norm(), eta.y.atan2(eta.x));
    let angles = (0..n).map(|j| 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(n));
    let weights: Vec<f64> = angles
        .clone()
        .map(|t| (kappa * ((t - mu).cos() - 1.0)).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    let means: Vec<Vector2<f64>> = angles
        .map(|t| density.conditional_mean(&So2::from_angle_unchecked(t)))
        .collect();
    let mean: Vector2<f64> = means
        .iter()
        .zip(&weights)
        .map(|(m, w)| m * *w)
        .sum::<Vector2<f64>>()
        / total;
    let spread: Matrix2<f64> = means
        .iter()
        .zip(&weights)
        .map(|(m, w)| (m - mean) * (m - mean).transpose() * *w)
        .sum::<Matrix2<f64>>()
        / total;
    (mean, spread + Matrix2::identity() * density.sigma2())
}

/// The smaller eigenvalue of a symmetric 2 × 2 matrix in closed form, `m − √(d² + b²)`, on the
/// matrix scaled to unit size (so that no square overflows or underflows).
fn smallest_eigenvalue(cov: &Matrix2<f64>) -> f64 {
    let scale = cov.amax();
    let unit = cov / scale;
    (0.5 * (unit[(0, 0)] + unit[(1, 1)])
        - (0.5 * (unit[(0, 0)] - unit[(1, 1)])).hypot(unit[(0, 1)]))
        * scale
}

/// Cov r is σ² I plus two positive semi-definite terms with non-negative coefficients, so it is
/// positive definite with eigenvalues at least σ² at every κ: from 0 and the smallest subnormal to
/// 1e300, in every mean direction, for world-fixed parts c from 0 to 1e6 m (and 2.2e7 m, the end of
/// a 1e8-step line run, from κ = 1e6), including κ above about 1e8 where A′(κ) = 1 − A/κ − A² is
/// lost to cancellation: its rounding, a few 1e-16, times |c|² = 5e14 exceeds σ² = 0.1. Up to
/// κ = 500 the moments are also checked against quadrature.
#[test]
fn point_estimates_are_positive_definite_at_any_concentration() {
    let sigma2 = 0.1;
    let mut kappas = vec![0.0, 4.9e-324, 1e-310, 1e-300];
    kappas.extend((-100..=300).map(|k| 10_f64.powi(k)));
    kappas.extend([2.6e9, 0.37, 3.3, 47.0, 499.0]);
    let mut checked_by_quadrature = 0;
    for &kappa in &kappas {
        for mu in [0.0, 1.0, std::f64::consts::PI, -2.0] {
            for c in [
                Vector2::zeros(),
                Vector2::new(1.0, -2.0),
                Vector2::new(1e3, 5e2),
                Vector2::new(-3e5, 1e6),
                Vector2::new(-1e7, 2e7),
            ] {
                // The offset at the end of a 1e8-step line run, with the concentrations it has there
                // (smaller κ with such a c is a covariance of condition number above 1e16).
                if c.norm() > 1e7 && kappa < 1e6 {
                    continue;
                }
                let eta = Vector2::new(mu.cos(), mu.sin()) * kappa;
                let density =
                    AzimuthDensity::from_parts(eta, Vector2::new(1.0, 1.0), c, sigma2).unwrap();
                let e = density.estimate();
                let cov = e.cov_r;
                assert!(cov.iter().chain(e.mean_r.iter()).all(|v| v.is_finite()));
                assert_eq!(cov[(0, 1)], cov[(1, 0)]);
                assert!(
                    nalgebra::Cholesky::new(cov).is_some(),
                    "kappa {kappa}, mu {mu}, c {c:?}: {cov:?}"
                );
                let (low, scale) = (smallest_eigenvalue(&cov), cov.amax());
                assert!(
                    low >= sigma2 * (1.0 - 1e-9) - 8.0 * f64::EPSILON * scale,
                    "kappa {kappa}, mu {mu}, c {c:?}: eigenvalue {low}"
                );
                if (0.3..=500.0).contains(&kappa) {
                    let (mean, reference) = moments_by_quadrature(&density);
                    let tolerance = 1e-9 * (1.0 + reference.amax());
                    assert!((e.mean_r - mean).amax() <= tolerance, "kappa {kappa}");
                    assert!(
                        (cov - reference).amax() <= tolerance,
                        "kappa {kappa}, mu {mu}, c {c:?}: {cov:?} vs {reference:?}"
                    );
                    checked_by_quadrature += 1;
                }
            }
        }
    }
    assert!(checked_by_quadrature >= 60, "{checked_by_quadrature}");
}

/// σ_A² = −2 ln A(κ) against high-precision values (mpmath at 700 digits: the Bessel functions
/// below κ = 1e6, their asymptotic expansion above), from the smallest subnormal κ to 1e300. The
/// direct formula lost every digit of 1 − A beyond κ ≈ 1e16 (σ_A = 0) and most of them from 1e8.
#[test]
// The references are written with the digits mpmath gave; the compiler rounds them to f64.
#[allow(clippy::excessive_precision)]
fn the_circular_deviation_is_accurate_at_any_concentration() {
    for (kappa, expected) in [
        (4.940_656_458_412_465_4e-324, 1_490.266_438_203_882_42),
        (1e-300, 1_382.937_350_157_547_3),
        (1e-12, 56.648_336_592_976_987),
        (1e-8, 38.227_655_849_024_621_6),
        (0.5, 2.833_510_332_421_631_54),
        (30.0, 0.033_906_687_779_056_670_9),
        (1000.0, 0.001_000_500_458_959_497_04),
        (1e6, 1.000_000_500_000_458_33e-6),
        (1e8, 1.000_000_005_000_000_05e-8),
        (2.6e9, 3.846_153_846_893_491_12e-10),
        (1e12, 1.000_000_000_000_5e-12),
        (1e20, 1e-20),
        (1e300, 1e-300),
    ] {
        let density = AzimuthDensity::from_parts(
            Vector2::new(0.0, kappa),
            Vector2::zeros(),
            Vector2::zeros(),
            1.0,
        )
        .unwrap();
        let sigma = density.estimate().sigma_a().unwrap();
        assert!(
            (sigma * sigma / expected - 1.0).abs() < 1e-12,
            "kappa {kappa:e}: {} vs {expected:e}",
            sigma * sigma
        );
    }
}

#[test]
fn bad_input_is_refused_and_leaves_the_density_unchanged() {
    assert!(PositionMeasurement::new(0.0).is_err());
    assert!(PositionMeasurement::new(f64::NAN).is_err());
    assert!(VelocityProcess::new(-0.1).is_err());
    assert!(AzimuthDensity::new(Vector2::zeros(), 0.0).is_err());
    assert!(AzimuthDensity::new(Vector2::new(f64::NAN, 0.0), 1.0).is_err());
    let measurement = PositionMeasurement::new(1.0).unwrap();
    let process = VelocityProcess::new(0.1).unwrap();
    let mut filter = Recursive::new(
        AzimuthDensity::new(Vector2::new(1.0, 2.0), 1.0).unwrap(),
        process,
        measurement,
    );
    let before = *filter.density();
    let err = filter.update(&Vector2::new(f64::NAN, 0.0)).unwrap_err();
    assert!(err.to_string().contains("position measurement"), "{err}");
    let err = filter
        .predict(&VelocityInput {
            velocity: Vector2::zeros(),
            dt: -1.0,
        })
        .unwrap_err();
    assert!(err.to_string().contains("dt"), "{err}");
    assert_eq!(*filter.density(), before);
}

/// The particle filter against the exact one on the same data: the gap between their summed log
/// evidence, and the particle filter's azimuth error.
struct EvidenceGap;

impl Scorer<PositionAzimuth, PairedEstimate<AzimuthEstimate, AzimuthEstimate>> for EvidenceGap {
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("gap", Reduction::Mean, ""),
            Metric::new("particle_azimuth_error", Reduction::RootMeanSquare, "rad"),
        ]
    }

    fn score(
        &self,
        truth: &PositionAzimuth,
        pair: &PairedEstimate<AzimuthEstimate, AzimuthEstimate>,
        values: &mut [f64],
    ) {
        values[0] = pair.log_evidence[1] - pair.log_evidence[0];
        values[1] = pair
            .second
            .azimuth
            .map_or(f64::NAN, |a| truth.second().local(&a)[0]);
    }
}

/// The particle filter on the same data: with 2000 particles over 60 s of the line scenario it finds
/// the azimuth (within 5°); over the first 5 measurements, while its particles are still diverse, its
/// log evidence estimates agree with the exact ones within 0.1 each (later, measurements in the tails
/// of the degenerating constant-azimuth particles miss by more than 1, as docs/filters/azimuth.md
/// says); and it refuses a non-finite measurement, unchanged.
#[test]
fn particle_filter_tracks_the_exact_filter() {
    let config = Config {
        steps: 600,
        ..Config::default()
    };
    let (process, measurement) = models(&config);
    let particles = |seed| {
        particle_filter(
            2000,
            process,
            measurement,
            Vector2::zeros(),
            config.sigma0,
            ChaCha8Rng::seed_from_u64(seed),
        )
        .unwrap()
    };
    let exact = exact(process, measurement, Vector2::zeros(), config.sigma0).unwrap();
    let scores = replay(
        &mut Paired::new(exact, particles(22)),
        run(Motion::Line, &config, 21),
        &EvidenceGap,
    )
    .unwrap();
    let mut previous = 0.0;
    for k in 0..5 {
        let gap = scores.get("gap", k).unwrap();
        assert!(
            (gap - previous).abs() < 0.1,
            "epoch {k}: step gap {}",
            gap - previous
        );
        previous = gap;
    }
    let error = scores
        .get("particle_azimuth_error", scores.epochs() - 1)
        .unwrap();
    assert!(error.abs() < 5f64.to_radians(), "azimuth error {error}");
    let mut filter = particles(23);
    let before = filter.density().particles().to_vec();
    assert!(filter.update(&Vector2::new(f64::NAN, 0.0)).is_err());
    assert_eq!(filter.density().particles(), &before[..]);
}

/// The linear process of the composite over the step of a velocity input: `r += v dt`,
/// `Q = q² dt I`.
struct LinearVelocity(VelocityProcess);

impl Propagate<LinearVelocity> for HarmonicGaussian<2> {
    type Input = VelocityInput;

    fn propagate(
        &self,
        model: &LinearVelocity,
        input: &VelocityInput,
    ) -> Result<Self, OperatorError> {
        let linear = LinearProcess::new(
            Matrix2::identity(),
            Matrix2::identity() * (model.0.noise_density() * input.dt),
        )?;
        self.propagate(&linear, &(input.velocity * input.dt))
    }
}

/// The composite against the seven numbers, and their summed log evidence.
struct CompositeAgreement;

impl Scorer<PositionAzimuth, PairedEstimate<AzimuthDensity, HarmonicGaussian<2>>>
    for CompositeAgreement
{
    fn metrics(&self) -> Vec<Metric> {
        vec![Metric::new("disagreement", Reduction::Mean, "")]
    }

    fn score(
        &self,
        _: &PositionAzimuth,
        pair: &PairedEstimate<AzimuthDensity, HarmonicGaussian<2>>,
        values: &mut [f64],
    ) {
        let (exact, composite) = (&pair.first, &pair.second);
        let expected = exact.to_composite().unwrap();
        let scale = 1.0 + expected.features().amax();
        let eta_scale = 1.0 + exact.eta().norm();
        let [e, c] = pair.log_evidence;
        values[0] = [
            (composite.features() - expected.features()).amax() / scale,
            (composite.covariance() - expected.covariance()).amax() / exact.sigma2(),
            (composite.angle().natural().0 - exact.eta()).amax() / eta_scale,
            composite.angle().natural().1.amax() / eta_scale,
            (c - e).abs() / (1.0 + e.abs()),
        ]
        .into_iter()
        .fold(0.0, f64::max);
    }
}

/// The exact filter is the operators crate's general composite (`HarmonicGaussian`) specialised: the
/// composite, propagated with the linear process and conditioned on the rotated measurement, holds the
/// same numbers at every epoch of all three scenarios, its second harmonics stay zero (to rounding),
/// and the two summed log evidences agree.
#[test]
fn exact_filter_is_the_general_composite_specialised() {
    let config = Config::default();
    let (process, _) = models(&config);
    let rotated = RotatedMeasurement::new(Matrix2::identity(), config.sigma_m).unwrap();
    for (seed, motion) in (30..).zip(Motion::ALL) {
        let exact = exact_density(&config);
        let composite = Recursive::new(
            exact.density().to_composite().unwrap(),
            LinearVelocity(process),
            rotated.clone(),
        );
        let scores = replay(
            &mut Paired::new(exact, composite),
            run(motion, &config, seed),
            &CompositeAgreement,
        )
        .unwrap();
        let error = worst(&scores, "disagreement");
        assert!(error <= TOLERANCE, "{}: {error:e}", motion.name());
        eprintln!(
            "{}: composite vs seven numbers, worst {error:.1e}",
            motion.name()
        );
    }
}

/// At each measurement of a long run: how far Cov r's smaller eigenvalue is above σ² (up to the
/// rounding of its entries), NaN when Cov r fails a Cholesky factorisation.
struct Definiteness;

impl Scorer<PositionAzimuth, AzimuthDensity> for Definiteness {
    fn metrics(&self) -> Vec<Metric> {
        vec![Metric::new("margin", Reduction::Mean, "")]
    }

    fn score(&self, _: &PositionAzimuth, density: &AzimuthDensity, values: &mut [f64]) {
        let cov = density.estimate().cov_r;
        values[0] = if nalgebra::Cholesky::new(cov).is_some() {
            smallest_eigenvalue(&cov) / density.sigma2() - 1.0
                + 1e-9
                + 8.0 * f64::EPSILON * cov.amax() / density.sigma2()
        } else {
            f64::NAN
        };
    }
}

/// The line scenario run for `LIEBAYES_LONG_STEPS` steps (default 10⁸, 10⁷ measurements; about a
/// minute in release): κ grows to about 5e9 and |c| to 2.2e7 m. At every measurement Cov r must
/// pass a Cholesky factorisation and have its smaller eigenvalue at least σ² (up to the rounding
/// of its entries), and every step must succeed. Ignored by default:
/// `cargo test --release -p liebayes-filters --test azimuth -- --ignored --nocapture long_line_run`.
#[test]
#[ignore = "a long run: 10^8 steps, about a minute in release"]
fn long_line_run_stays_positive_definite() {
    let steps = std::env::var("LIEBAYES_LONG_STEPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000_000);
    let config = Config {
        steps,
        ..Config::default()
    };
    let scenario = AzimuthScenario::new(Motion::Line, config).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut filter = exact_density(&config);
    let mut truth = None;
    let steps_run = scenario
        .simulate(&mut rng)
        .unwrap()
        .inspect(|s| truth = Some(s.truth));
    let scores = replay(&mut filter, steps_run, &Definiteness).unwrap();
    let margins: Vec<f64> = (0..scores.epochs())
        .map(|k| scores.get("margin", k).unwrap())
        .collect();
    assert!(
        margins.iter().all(|m| *m >= 0.0),
        "a covariance lost its definiteness"
    );
    let density = filter.density();
    let e = density.estimate();
    let truth = truth.unwrap();
    let error = truth.second().local(&e.azimuth.unwrap())[0];
    eprintln!(
        "line run of {steps} steps: final kappa {:.3e}, |c| {:.3e} m, sigma^2 {:.3e}, \
         smallest eigenvalue of Cov r {:.6e}, azimuth error {error:.3e} rad ({:.2} sigma_A)",
        density.azimuth().concentration(),
        density.c().norm(),
        density.sigma2(),
        smallest_eigenvalue(&e.cov_r),
        error.abs() / e.sigma_a().unwrap(),
    );
    assert!(error.abs() <= 5.0 * e.sigma_a().unwrap());
}
