//! The grid filter on the circle and the Rao-Blackwellized composites against brute force.
//!
//! `HarmonicGaussian` is checked against a bank of exact Kalman filters on a grid of angles, cell by
//! cell: each cell's Kalman log evidence must equal the composite's harmonics at that angle, and each
//! cell's posterior must equal the composite's conditional at that angle. The priors have random
//! feature matrices B, so the second harmonics are excited (unlike the azimuth filter's special case).

use liebayes_densities::special;
use liebayes_densities::{
    Density, DensityError, Gaussian, GenVonMises2, HarmonicGaussian, VonMises, harmonic_features,
};
use liebayes_manifolds::So2;
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::grid::Diffusion;
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::{Given, LikelihoodFn, ParticleSet, Reweight};
use liebayes_operators::rao_blackwell::{
    Harmonics, RotatedMeasurement, linear_harmonics, rotated_harmonics,
};
use liebayes_operators::{Condition, OperatorError, Propagate};
use nalgebra::{Matrix2, Matrix2x3, Vector2, Vector3};
use proptest::prelude::*;

const CELLS: usize = 512;

/// The matrix of a rotation, written out (not by the manifolds crate).
fn rotation(y: &So2<f64>) -> Matrix2<f64> {
    let (s, c) = y.angle().sin_cos();
    Matrix2::new(c, -s, s, c)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

/// The grid of per-angle Kalman filters for a composite: weights p(y) at the cells, payload p(x | y).
fn grid_of(prior: &HarmonicGaussian<2>) -> CircularGrid<Gaussian<2>> {
    CircularGrid::from_log_density(
        CELLS,
        |y| prior.angle().log_pdf(&So2::from_angle_unchecked(y)),
        |y| {
            Gaussian::new(
                prior.conditional_mean(&So2::from_angle_unchecked(y)),
                *prior.covariance(),
            )
            .unwrap()
        },
    )
    .unwrap()
}

/// The composite's grid conditioned with `Given(model_at)`, after checking each cell's Kalman log
/// evidence against the composite's harmonics at its angle; returns the grid and its log evidence.
fn conditioned_grid(
    prior: &HarmonicGaussian<2>,
    harmonics: &Harmonics,
    model_at: impl Fn(&So2<f64>) -> Result<LinearMeasurement<2, 2>, OperatorError>,
    z: &Vector2<f64>,
) -> Result<(CircularGrid<Gaussian<2>>, f64), TestCaseError> {
    let mut grid = grid_of(prior);
    let mut worst = 0.0_f64;
    for (j, cell) in grid.cells().iter().enumerate() {
        let l = cell
            .condition(&model_at(&grid.rotation(j)).unwrap(), z)
            .unwrap()
            .log_evidence;
        worst = worst.max((l - harmonics.at(grid.angle(j)).unwrap()).abs() / (1.0 + l.abs()));
    }
    prop_assert!(worst < 1e-9, "per-angle log evidence off by {worst:e}");
    let evidence = grid.condition_in_place(&Given(model_at), z).unwrap();
    Ok((grid, evidence.log_evidence))
}

/// Checks a conditioned composite against the conditioned grid, cell by cell and in total.
fn agree(
    posterior: &HarmonicGaussian<2>,
    evidence: f64,
    grid: &CircularGrid<Gaussian<2>>,
    grid_evidence: f64,
) -> Result<(), TestCaseError> {
    for (j, cell) in grid.cells().iter().enumerate() {
        let y = So2::from_angle_unchecked(grid.angle(j));
        let mean = posterior.conditional_mean(&y);
        prop_assert!((cell.mean() - mean).amax() < 1e-9 * (1.0 + mean.amax()));
        prop_assert!((cell.covariance() - posterior.covariance()).amax() < 1e-9);
    }
    prop_assert!(
        close(evidence, grid_evidence, 1e-9),
        "{evidence} vs {grid_evidence}"
    );
    let (mean, cov) = posterior.marginal_moments();
    let grid_mean = grid.expectation(|_, g| *g.mean());
    let grid_cov = grid.expectation(|_, g| {
        g.covariance() + (g.mean() - grid_mean) * (g.mean() - grid_mean).transpose()
    });
    prop_assert!((mean - grid_mean).amax() < 1e-8 * (1.0 + mean.amax()));
    prop_assert!((cov - grid_cov).amax() < 1e-8 * (1.0 + cov.amax()));
    Ok(())
}

fn composite() -> impl Strategy<Value = HarmonicGaussian<2>> {
    (
        proptest::array::uniform4(-1.5..1.5f64),
        proptest::array::uniform6(-3.0..3.0f64),
        proptest::array::uniform3(-1.0..1.0f64),
    )
        .prop_map(|(eta, b, l)| {
            let angle = GenVonMises2::from_natural(
                Vector2::new(eta[0], eta[1]),
                Vector2::new(eta[2], eta[3]),
            )
            .unwrap();
            let lower = Matrix2::new(1.0 + l[0].abs(), 0.0, l[1], 0.8 + l[2].abs());
            HarmonicGaussian::new(
                angle,
                Matrix2x3::from_row_slice(&b),
                lower * lower.transpose(),
            )
            .unwrap()
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn linear_measurements_match_the_grid_of_kalman_filters(
        prior in composite(),
        h in proptest::array::uniform4(-1.5..1.5f64),
        z in proptest::array::uniform2(-4.0..4.0f64),
    ) {
        let model = LinearMeasurement::new(Matrix2::new(h[0], h[1], h[2], h[3]), Matrix2::new(0.5, 0.1, 0.1, 0.4)).unwrap();
        let z = Vector2::from(z);
        let step = prior.condition(&model, &z).unwrap();
        let harmonics = linear_harmonics(&prior, &model, &z).unwrap();
        let (grid, grid_evidence) = conditioned_grid(&prior, &harmonics, |_: &So2<f64>| Ok(model.clone()), &z)?;
        agree(&step.posterior, step.log_evidence, &grid, grid_evidence)?;
    }

    #[test]
    fn rotated_measurements_match_the_grid_of_kalman_filters(
        prior in composite(),
        sigma2 in 0.3..3.0f64,
        z in proptest::array::uniform2(-4.0..4.0f64),
    ) {
        let prior = HarmonicGaussian::new(prior.angle().clone(), *prior.features(), Matrix2::identity() * sigma2).unwrap();
        let model = RotatedMeasurement::new(Matrix2::identity(), 0.8).unwrap();
        let z = Vector2::from(z);
        let step = prior.condition(&model, &z).unwrap();
        let harmonics = rotated_harmonics(&prior, &model, &z).unwrap();
        let noise = Matrix2::identity() * model.variance();
        let (grid, grid_evidence) =
            conditioned_grid(&prior, &harmonics, |y: &So2<f64>| LinearMeasurement::new(rotation(y), noise), &z)?;
        agree(&step.posterior, step.log_evidence, &grid, grid_evidence)?;
    }
}

#[test]
fn propagation_is_the_per_angle_kalman_propagation() {
    let angle =
        GenVonMises2::from_natural(Vector2::new(1.0, 0.5), Vector2::new(-0.3, 0.2)).unwrap();
    let prior = HarmonicGaussian::new(
        angle,
        Matrix2x3::new(1.0, 2.0, -1.0, 0.5, 0.0, 3.0),
        Matrix2::new(1.0, 0.2, 0.2, 0.5),
    )
    .unwrap();
    let process =
        LinearProcess::new(Matrix2::new(1.0, 0.1, 0.0, 0.9), Matrix2::identity() * 0.01).unwrap();
    let u = Vector2::new(0.3, -0.2);
    let next = prior.propagate(&process, &u).unwrap();
    for y in [0.0, 1.0, 2.5, -3.0].map(So2::from_angle_unchecked) {
        let per_angle = Gaussian::new(prior.conditional_mean(&y), *prior.covariance())
            .unwrap()
            .propagate(&process, &u)
            .unwrap();
        assert!((per_angle.mean() - next.conditional_mean(&y)).amax() < 1e-14);
        assert!((per_angle.covariance() - next.covariance()).amax() < 1e-14);
    }
    assert_eq!(next.angle(), prior.angle());
}

/// A rotated measurement far finer than the position (σ_m = 1e-8 against Σ = I): S = 1 + 1e-16
/// rounds to 1, and `Σ − Σ Hᵀ H Σ / S` cancelled to 0, so the update and every later one was
/// refused. In Joseph's form the posterior is σ_m² I, the exact value to rounding, over 1 000
/// updates of a still platform (each then σ_m²/k).
#[test]
fn a_rotated_measurement_finer_than_rounding_keeps_its_variance() {
    let mut density = HarmonicGaussian::independent(
        GenVonMises2::from_natural(Vector2::zeros(), Vector2::zeros()).unwrap(),
        &Gaussian::new(Vector2::new(1.0, 0.0), Matrix2::identity()).unwrap(),
    )
    .unwrap();
    let sigma: f64 = 1e-8;
    let model = RotatedMeasurement::new(Matrix2::identity(), sigma).unwrap();
    let still = LinearProcess::new(Matrix2::identity(), Matrix2::zeros()).unwrap();
    let z = Vector2::new(0.3f64.cos(), 0.3f64.sin());
    for k in 1..=1000 {
        let step = density
            .condition(&model, &z)
            .unwrap_or_else(|e| panic!("update {k}: {e}"));
        density = step.posterior.propagate(&still, &Vector2::zeros()).unwrap();
        let variance = density.covariance()[(0, 0)];
        let exact = sigma * sigma / f64::from(k);
        assert!((variance / exact - 1.0).abs() <= 1e-9, "{k}: {variance:e}");
        assert!(density.covariance()[(0, 1)].abs() <= 1e-12 * variance);
    }
}

#[test]
fn anisotropic_rotated_measurements_are_refused() {
    let prior = HarmonicGaussian::independent(
        GenVonMises2::from_natural(Vector2::zeros(), Vector2::zeros()).unwrap(),
        &Gaussian::new(Vector2::zeros(), Matrix2::new(1.0, 0.0, 0.0, 2.0)).unwrap(),
    )
    .unwrap();
    let model = RotatedMeasurement::new(Matrix2::identity(), 1.0).unwrap();
    assert!(matches!(
        prior.condition(&model, &Vector2::new(1.0, 0.0)),
        Err(OperatorError::NotClosed { .. })
    ));
    assert!(RotatedMeasurement::new(Matrix2::identity(), 0.0).is_err());
    assert!(matches!(
        HarmonicGaussian::new(prior.angle().clone(), Matrix2x3::zeros(), Matrix2::zeros()),
        Err(DensityError::OutOfRange { .. })
    ));
}

#[test]
fn marginalized_particles_on_the_grid_points_equal_the_grid() {
    // Equally weighted particles at the cell rotations carry the same numbers as a uniform grid.
    let prior = Gaussian::new(Vector2::new(1.0, -2.0), Matrix2::identity() * 2.0).unwrap();
    let mut grid = CircularGrid::uniform(64, prior.clone()).unwrap();
    let mut particles =
        ParticleSet::from_samples((0..64).map(|j| (grid.rotation(j), prior.clone())).collect())
            .unwrap();
    let z = Vector2::new(0.5, 2.0);
    let model = Given(|y: &So2<f64>| LinearMeasurement::new(rotation(y), Matrix2::identity()));
    let from_grid = grid.condition_in_place(&model, &z).unwrap().log_evidence;
    let from_particles = particles
        .condition_in_place(&model, &z)
        .unwrap()
        .log_evidence;
    assert_eq!(from_grid, from_particles);
    assert_eq!(particles.log_weights(), grid.log_weights());
    for ((_, p), g) in particles.particles().iter().zip(grid.cells()) {
        assert_eq!((p.mean(), p.covariance()), (g.mean(), g.covariance()));
    }
}

/// The marginalized particle filter's step against its definition, computed independently: each
/// particle's Gaussian conditioned by the Kalman filter with its label's model, the weights
/// `wᵢ p(z | yᵢ) / Σⱼ wⱼ p(z | yⱼ)` and the log evidence `ln Σⱼ wⱼ p(z | yⱼ)` by direct sums.
#[test]
fn marginalized_particles_are_per_particle_kalman_filters() {
    let labels = [0.3, 2.0, -1.0, 2.9, -2.5];
    let weights = [0.1, 0.4, 0.2, 0.25, 0.05];
    let payload = |k: usize| {
        let k = k as f64;
        Gaussian::new(
            Vector2::new(1.0 - k, 0.5 * k),
            Matrix2::new(1.0 + k, 0.3, 0.3, 2.0),
        )
        .unwrap()
    };
    let model_at = |y: &f64| {
        LinearMeasurement::new(
            rotation(&So2::from_angle_unchecked(*y)) * 2.0,
            Matrix2::new(0.5, 0.1, 0.1, 0.7),
        )
    };
    let z = Vector2::new(1.5, -0.5);
    let mut set = ParticleSet::from_weighted_samples(
        labels
            .iter()
            .enumerate()
            .map(|(k, y)| (*y, payload(k)))
            .collect(),
        &weights,
    )
    .unwrap();
    let step = set.condition_in_place(&Given(model_at), &z).unwrap();
    let kalman: Vec<_> = labels
        .iter()
        .enumerate()
        .map(|(k, y)| payload(k).condition(&model_at(y).unwrap(), &z).unwrap())
        .collect();
    let total: f64 = kalman
        .iter()
        .zip(weights)
        .map(|(k, w)| w * k.log_evidence.exp())
        .sum();
    assert!(
        (step.log_evidence - total.ln()).abs() < 1e-14 * total.ln().abs(),
        "{} vs {}",
        step.log_evidence,
        total.ln()
    );
    for (((y, g), k), (w, l)) in set
        .particles()
        .iter()
        .zip(&kalman)
        .zip(weights.iter().zip(set.log_weights()))
    {
        assert!(labels.contains(y));
        assert_eq!(
            (g.mean(), g.covariance()),
            (k.posterior.mean(), k.posterior.covariance())
        );
        let expected = w * k.log_evidence.exp() / total;
        assert!(
            (l.exp() - expected).abs() < 1e-15,
            "{} vs {expected}",
            l.exp()
        );
    }
    // The labels stay in order, each with its own posterior.
    let order: Vec<f64> = set.particles().iter().map(|(y, _)| *y).collect();
    assert_eq!(order, labels);
}

/// The bank of Kalman filters on a grid: propagated with each cell's process and conditioned with
/// each cell's measurement through `Given`, against a loop over the cells with the Kalman filter and
/// the normalisation written out.
#[test]
fn a_grid_of_kalman_filters_is_a_loop_over_its_cells() {
    let n = 12;
    let prior = |t: f64| Gaussian::new(Vector2::new(t.cos(), 1.0), Matrix2::identity()).unwrap();
    let log_density = |t: f64| 0.7 * (t - 0.4).cos();
    let mut grid = CircularGrid::from_log_density(n, log_density, prior).unwrap();
    let process_at = |y: &So2<f64>| {
        LinearProcess::new(
            Matrix2::new(1.0, 0.1 * y.angle().sin(), 0.0, 0.9),
            Matrix2::identity() * (0.1 + 0.05 * y.angle().cos()),
        )
    };
    let measurement_at =
        |y: &So2<f64>| LinearMeasurement::new(rotation(y), Matrix2::identity() * 0.4);
    let (u, z) = (Vector2::new(0.2, -0.1), Vector2::new(0.8, 0.6));
    grid.propagate_in_place(&Given(process_at), &u).unwrap();
    let step = grid.condition_in_place(&Given(measurement_at), &z).unwrap();

    let angles: Vec<f64> = (0..n)
        .map(|j| 2.0 * std::f64::consts::PI * j as f64 / n as f64)
        .collect();
    let prior_weights: Vec<f64> = angles.iter().map(|t| log_density(*t).exp()).collect();
    let prior_total: f64 = prior_weights.iter().sum();
    let mut cells = Vec::new();
    let mut joint = Vec::new();
    for (t, w) in angles.iter().zip(&prior_weights) {
        let r = So2::from_angle_unchecked(*t);
        let moved = prior(*t).propagate(&process_at(&r).unwrap(), &u).unwrap();
        let updated = moved.condition(&measurement_at(&r).unwrap(), &z).unwrap();
        joint.push(w / prior_total * updated.log_evidence.exp());
        cells.push(updated.posterior);
    }
    let evidence: f64 = joint.iter().sum();
    assert!((step.log_evidence - evidence.ln()).abs() < 1e-14 * (1.0 + evidence.ln().abs()));
    for ((cell, expected), (l, p)) in grid
        .cells()
        .iter()
        .zip(&cells)
        .zip(grid.log_weights().iter().zip(&joint))
    {
        assert!((cell.mean() - expected.mean()).amax() < 1e-15);
        assert!((cell.covariance() - expected.covariance()).amax() < 1e-15);
        assert!((l.exp() - p / evidence).abs() < 1e-15);
    }
}

#[test]
fn grid_bayes_and_diffusion_match_the_von_mises_algebra() {
    // Prior VM(0.5, 3) times likelihood VM(2.0, 5): the product's first moment and evidence are known.
    let prior = VonMises::new(So2::from_angle_unchecked(0.5), 3.0).unwrap();
    let likelihood = VonMises::new(So2::from_angle_unchecked(2.0), 5.0).unwrap();
    let mut grid = CircularGrid::from_log_density(
        256,
        |t| prior.log_pdf(&So2::from_angle_unchecked(t)),
        |_| (),
    )
    .unwrap();
    let bearing = Reweight(LikelihoodFn::new(|t: &So2<f64>, l: &VonMises| l.log_pdf(t)));
    let evidence = grid
        .condition_in_place(&bearing, &likelihood)
        .unwrap()
        .log_evidence;
    let eta = prior.natural() + likelihood.natural();
    let kappa = eta.norm();
    let exact_evidence = special::log_i0(kappa).unwrap()
        - special::log_i0(3.0).unwrap()
        - special::log_i0(5.0).unwrap()
        - (2.0 * std::f64::consts::PI).ln();
    assert!(
        (evidence - exact_evidence).abs() < 1e-12,
        "{evidence} vs {exact_evidence}"
    );
    let exact_moment = eta / kappa * special::a1(kappa).unwrap();
    assert!((grid.first_moment() - exact_moment).amax() < 1e-12);

    // Diffusion by a von Mises kernel of concentration 4 multiplies the first moment by A₁(4).
    let kernel = VonMises::new(So2::from_angle_unchecked(0.0), 4.0).unwrap();
    let diffusion = Diffusion(|w: &So2<f64>| kernel.log_pdf(w).exp());
    let by_value = grid.propagate(&diffusion, &()).unwrap();
    grid.propagate_in_place(&diffusion, &()).unwrap();
    assert_eq!(by_value.log_weights(), grid.log_weights());
    assert!((grid.first_moment() - exact_moment * special::a1(4.0).unwrap()).amax() < 1e-12);

    assert!(CircularGrid::uniform(0, ()).is_err());
    let nan = Reweight(LikelihoodFn::new(|_: &So2<f64>, (): &()| f64::NAN));
    assert!(grid.condition_in_place(&nan, &()).is_err());
    assert!(
        grid.propagate_in_place(&Diffusion(|_: &So2<f64>| -1.0), &())
            .is_err()
    );
    let (s, c) = 0.5_f64.sin_cos();
    let features = harmonic_features(&So2::from_angle_unchecked(0.5));
    assert!((features - Vector3::new(1.0, c, s)).amax() <= f64::EPSILON);
}

/// A failed Bayes or propagation step leaves the grid exactly as it was.
#[test]
fn failed_grid_steps_leave_the_grid_unchanged() {
    let prior = Gaussian::new(Vector2::new(1.0, 0.0), Matrix2::identity()).unwrap();
    let mut grid = CircularGrid::uniform(16, prior).unwrap();
    let z = Vector2::new(0.5, 1.0);
    let measurement =
        Given(|y: &So2<f64>| LinearMeasurement::new(rotation(y), Matrix2::identity()));
    grid.condition_in_place(&measurement, &z).unwrap();
    let (weights, cells) = (grid.log_weights().to_vec(), grid.cells().to_vec());
    // Models that fail half-way round the circle.
    let failing = Given(|y: &So2<f64>| {
        if y.angle() < 0.0 {
            LinearMeasurement::new(rotation(y), Matrix2::new(f64::NAN, 0.0, 0.0, 1.0))
        } else {
            LinearMeasurement::new(rotation(y), Matrix2::identity())
        }
    });
    assert!(grid.condition_in_place(&failing, &z).is_err());
    let failing_process = Given(|y: &So2<f64>| {
        LinearProcess::new(
            Matrix2::identity(),
            Matrix2::identity() * if y.angle() < 0.0 { -1.0 } else { 1.0 },
        )
    });
    assert!(
        grid.propagate_in_place(&failing_process, &Vector2::zeros())
            .is_err()
    );
    let nan_half = Reweight(LikelihoodFn::new(|y: &So2<f64>, (): &()| {
        if y.angle() < 0.0 { f64::NAN } else { 0.0 }
    }));
    assert!(grid.condition_in_place(&nan_half, &()).is_err());
    assert_eq!(grid.log_weights(), &weights[..]);
    for (a, b) in grid.cells().iter().zip(&cells) {
        assert_eq!((a.mean(), a.covariance()), (b.mean(), b.covariance()));
    }
}

/// A measurement 1e200 from its prediction: the harmonics overflowed to ±∞ and `at` returned NaN,
/// as Ok. Now the harmonics are refused, and `at` never returns NaN (a finite value, or the ±∞ of
/// an exact value that overflows).
#[test]
fn harmonics_that_overflow_are_refused_and_at_is_never_nan() {
    let angle = GenVonMises2::from_natural(Vector2::new(1.0, 0.0), Vector2::zeros()).unwrap();
    let prior = HarmonicGaussian::new(
        angle,
        Matrix2x3::new(1.0, 2.0, -1.0, 0.5, 0.0, 3.0),
        Matrix2::identity(),
    )
    .unwrap();
    let z = Vector2::new(1e200, -1e200);
    let linear = LinearMeasurement::new(Matrix2::identity(), Matrix2::identity()).unwrap();
    let rotated = RotatedMeasurement::new(Matrix2::identity(), 1.0).unwrap();
    for error in [
        linear_harmonics(&prior, &linear, &z).unwrap_err(),
        rotated_harmonics(&prior, &rotated, &z).unwrap_err(),
    ] {
        assert!(matches!(error, OperatorError::NonFinite { .. }), "{error}");
    }
    // At y = 0 the exact value MAX + MAX − MAX is MAX (summed left to right, it overflowed); at
    // y = π/2, MAX + MAX overflows: +∞, the exact value's sign.
    let huge = Harmonics {
        constant: f64::MAX,
        eta1: Vector2::new(f64::MAX, f64::MAX),
        eta2: Vector2::new(-f64::MAX, 0.0),
    };
    assert_eq!(huge.at(0.0).unwrap(), f64::MAX);
    assert_eq!(huge.at(std::f64::consts::FRAC_PI_2).unwrap(), f64::INFINITY);
    assert!(huge.at(f64::NAN).is_err());
    let nan = Harmonics {
        constant: f64::NAN,
        ..huge
    };
    assert!(nan.at(0.0).is_err());
    // Angles beyond f64::MAX / 2: the double angle overflowed and sin_cos(∞) was NaN, as Ok. The
    // second harmonic now comes from the single angle, and agrees with cos 2y, sin 2y elsewhere.
    let second = Harmonics {
        constant: 0.0,
        eta1: Vector2::zeros(),
        eta2: Vector2::new(1.0, 0.5),
    };
    for y in [f64::MAX, -f64::MAX, 9e307] {
        let value = second.at(y).unwrap();
        assert!(value.abs() <= 1.2, "{y:e}: {value}");
    }
    for y in [0.3_f64, -2.9, 1e6] {
        let (s2, c2) = (2.0 * y).sin_cos();
        assert!(
            (second.at(y).unwrap() - (c2 + 0.5 * s2)).abs() < 1e-9,
            "{y}"
        );
    }
}

/// A diffusion step is a direct O(n²) convolution: a grid above `MAX_DIFFUSION_CELLS` cells is
/// refused at once (2²⁴ cells took 2.8e14 products, days), and the grid is unchanged.
#[test]
fn a_diffusion_beyond_its_cell_limit_is_refused() {
    use liebayes_operators::grid::MAX_DIFFUSION_CELLS;
    let mut grid = CircularGrid::uniform(MAX_DIFFUSION_CELLS + 1, ()).unwrap();
    let before = grid.log_weights().to_vec();
    let error = grid
        .propagate_in_place(&Diffusion(|_: &So2<f64>| 1.0), &())
        .unwrap_err();
    assert!(matches!(error, OperatorError::TooLarge { .. }), "{error}");
    assert_eq!(grid.log_weights(), before);
}

/// The kernel scaled and tiny weights kept: a subnormal kernel (8, 1)·5e-324 rounded its products
/// in the subnormal range and diffused (0.9, 0.1) to (0.778, 0.222) instead of (0.811, 0.189); a
/// kernel of (1e308, 1e308) summed to +∞ and was refused; and the identity kernel set a log weight
/// of −800 to −∞ (its exponential underflowed). Each is now exact to rounding.
#[test]
fn diffusion_is_exact_for_every_kernel_scale_and_tiny_weights() {
    let two = |a: f64, b: f64| move |w: &So2<f64>| if w.angle().abs() < 1.0 { a } else { b };
    let weights = [0.9_f64.ln(), 0.1_f64.ln()];
    let exact = [0.9 * 8.0 + 0.1, 0.9 + 0.1 * 8.0].map(|v: f64| (v / 9.0).ln());
    for scale in [5e-324, 1.0, 1e300] {
        let mut grid = CircularGrid::from_log_weights(&weights, vec![(), ()]).unwrap();
        grid.propagate_in_place(&Diffusion(two(8.0 * scale, scale)), &())
            .unwrap();
        for (got, want) in grid.log_weights().iter().zip(exact) {
            assert!((got - want).abs() < 1e-15, "scale {scale}: {got} vs {want}");
        }
    }
    let mut grid = CircularGrid::from_log_weights(&weights, vec![(), ()]).unwrap();
    grid.propagate_in_place(&Diffusion(two(1e308, 1e308)), &())
        .unwrap();
    assert!(
        grid.log_weights()
            .iter()
            .all(|l| (l - 0.5_f64.ln()).abs() < 1e-15)
    );
    let mut grid = CircularGrid::from_log_weights(&[0.0, -800.0], vec![(), ()]).unwrap();
    grid.propagate_in_place(&Diffusion(two(1.0, 0.0)), &())
        .unwrap();
    assert!(
        grid.log_weights()[0].abs() < 1e-15,
        "{:?}",
        grid.log_weights()
    );
    assert!(
        (grid.log_weights()[1] + 800.0).abs() < 1e-12,
        "{:?}",
        grid.log_weights()
    );
}
