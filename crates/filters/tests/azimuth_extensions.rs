//! Item 6 of the azimuth issue: the forms beyond the blog post's, each checked against brute force.
//!
//! * **Velocity matching** (world-frame velocity measured, position and velocity as the state): exact,
//!   the general composite `HarmonicGaussian<4>`, against a grid of 4-D Kalman filters.
//! * **3-D with known roll and pitch** (unknown heading about the vertical): exact,
//!   `HarmonicGaussian<3>` in the levelled frame, against a grid of 3-D Kalman filters.
//! * **Non-isotropic position noise**: not closed (the proof is in docs/filters/azimuth.md); the
//!   composite refuses the step, and the seven-number filter with the isotropic bound
//!   `σ_m² = λ_max(R_m)` stays consistent against the truth, as its docs claim.
//!
//! The composite and the grid are experiment-layer filters stepped together ([`Paired`]) through a
//! recorded trajectory by [`replay`]. The per-cell checks are pointwise (no quadrature): at each grid
//! azimuth, at every measurement epoch, the Kalman filter's mean and covariance must equal the
//! composite's conditional, and the Kalman filter's log evidence of the epoch the composite's step
//! written as harmonics of the azimuth.

use liebayes_densities::{Density, Gaussian, GenVonMises2, HarmonicGaussian};
use liebayes_experiments::{
    ExperimentError, Metric, Paired, PairedEstimate, Recursive, Reduction, RunScores, Scenario,
    Scorer, Shard, Step, StepOf, Study, replay,
};
use liebayes_filters::azimuth::AzimuthSteps;
use liebayes_filters::azimuth::{
    AzimuthScenario, AzimuthScorer, Config, Motion, PositionMeasurement, VelocityProcess, exact,
};
use liebayes_manifolds::So2;
use liebayes_operators::evaluation::{average_nees_band, estimation_error};
use liebayes_operators::grid::CircularGrid;
use liebayes_operators::kalman::{LinearMeasurement, LinearProcess};
use liebayes_operators::particle::Given;
use liebayes_operators::rao_blackwell::{Harmonics, RotatedMeasurement};
use liebayes_operators::{Condition, Conditioned, OperatorError};
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;
use std::sync::Mutex;

const CELLS: usize = 72;
const TOLERANCE: f64 = 1e-9;

fn rotation2(y: f64) -> Matrix2<f64> {
    let (s, c) = y.sin_cos();
    Matrix2::new(c, -s, s, c)
}

fn normal<const N: usize>(rng: &mut ChaCha8Rng) -> SVector<f64, N> {
    SVector::from_fn(|_, _| StandardNormal.sample(rng))
}

/// Two measurements taken at the same instant, conditioned in turn: the first always, the second
/// where there is one (the position fix of velocity matching every 5 s, the vertical part of a
/// levelled position fix). Its measurement is `(z₁, Option<z₂>)`.
#[derive(Clone, Debug)]
struct Then<A, B>(A, B);

/// `p(x | z₁, z₂)` with `ln p(z₁) + ln p(z₂ | z₁)`.
fn condition_in_turn<D, A, B>(
    density: &D,
    Then(first, second): &Then<A, B>,
    (z1, z2): &(
        <D as Condition<A>>::Measurement,
        Option<<D as Condition<B>>::Measurement>,
    ),
) -> Result<Conditioned<D>, OperatorError>
where
    D: Condition<A> + Condition<B>,
    <D as Condition<A>>::Measurement: Sized,
    <D as Condition<B>>::Measurement: Sized,
{
    let one = Condition::<A>::condition(density, first, z1)?;
    let Some(z2) = z2 else {
        return Ok(Conditioned {
            posterior: one.posterior,
            log_evidence: one.log_evidence,
            report: (),
        });
    };
    let two = Condition::<B>::condition(&one.posterior, second, z2)?;
    Ok(Conditioned {
        posterior: two.posterior,
        log_evidence: one.log_evidence + two.log_evidence,
        report: (),
    })
}

/// The composite's exact steps, in turn: the rotated measurement, then the second one.
impl<const N: usize, B> Condition<Then<RotatedMeasurement<N>, B>> for HarmonicGaussian<N>
where
    HarmonicGaussian<N>: Condition<B>,
    <HarmonicGaussian<N> as Condition<B>>::Measurement: Sized,
{
    type Measurement = (
        Vector2<f64>,
        Option<<HarmonicGaussian<N> as Condition<B>>::Measurement>,
    );
    type Report = ();

    fn condition(
        &self,
        model: &Then<RotatedMeasurement<N>, B>,
        z: &Self::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_in_turn::<Self, RotatedMeasurement<N>, B>(self, model, z)
    }
}

/// A grid cell's Kalman updates, in turn: the measurement of a 2-vector, then the second one.
impl<const N: usize, const K: usize>
    Condition<Then<LinearMeasurement<N, 2>, LinearMeasurement<N, K>>> for Gaussian<N>
{
    type Measurement = (Vector2<f64>, Option<SVector<f64, K>>);
    type Report = ();

    fn condition(
        &self,
        model: &Then<LinearMeasurement<N, 2>, LinearMeasurement<N, K>>,
        z: &Self::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_in_turn::<Self, LinearMeasurement<N, 2>, LinearMeasurement<N, K>>(self, model, z)
    }
}

/// The composite and its brute-force grid of Kalman filters (`CELLS` azimuths), each its own
/// density as estimate, stepped together.
type Pair<const N: usize, M, G, F> = Paired<
    Recursive<HarmonicGaussian<N>, LinearProcess<N>, M>,
    Recursive<CircularGrid<Gaussian<N>>, Given<G>, Given<F>>,
>;

/// The pair from the prior `N(μ, P)` for x and a uniform azimuth: `model` is the composite's
/// measurement model, `model_at` the same measurement given the azimuth, a cell's Kalman model.
fn composite_and_grid<const N: usize, M, F, C>(
    prior: &Gaussian<N>,
    process: &LinearProcess<N>,
    model: M,
    model_at: F,
) -> Pair<N, M, impl Fn(&So2<f64>) -> Result<LinearProcess<N>, OperatorError> + use<N, M, F, C>, F>
where
    F: Fn(&So2<f64>) -> Result<C, OperatorError>,
{
    let uniform = GenVonMises2::from_natural(Vector2::zeros(), Vector2::zeros()).unwrap();
    let cell_process = process.clone();
    Paired::new(
        Recursive::new(
            HarmonicGaussian::independent(uniform, prior).unwrap(),
            process.clone(),
            model,
        ),
        Recursive::new(
            CircularGrid::uniform(CELLS, prior.clone()).unwrap(),
            Given(move |_: &So2<f64>| Ok(cell_process.clone())),
            Given(model_at),
        ),
    )
}

/// What the grid and the composite held at the previous epoch (the prior before the first).
struct Previous {
    angle: GenVonMises2,
    log_weights: Vec<f64>,
    log_evidence: [f64; 2],
}

/// The per-cell comparison of a [`Pair`] at each epoch, relative to the size of what is compared:
///
/// * `mean`: the cell's Kalman mean against the composite's conditional mean `B φ(θⱼ)`;
/// * `covariance`: the cell's covariance against the composite's Σ;
/// * `evidence`: the cell's log evidence of the epoch, `ln p(z | θⱼ, past)`, recovered from the
///   grid as `Δ ln wⱼ + Δ ln p(z)` (its weights are normalised; propagation leaves them alone),
///   against the composite's step as harmonics of the azimuth, [`Harmonics::at`]`(θⱼ)`, with
///   `η₁, η₂` the increments of its natural parameters and the constant its log evidence less the
///   change of `ln Z`: so the composite's posterior angle and evidence are checked at every cell
///   (second harmonics included), not only the formula they come from;
/// * `heading_error` (deg): the direction of the composite's η₁ against the true azimuth.
struct CellByCell {
    previous: Mutex<Previous>,
}

impl CellByCell {
    fn new<const N: usize, M, G, F>(pair: &Pair<N, M, G, F>) -> Self {
        Self {
            previous: Mutex::new(Previous {
                angle: pair.first().density().angle().clone(),
                log_weights: pair.second().density().log_weights().to_vec(),
                log_evidence: [0.0; 2],
            }),
        }
    }
}

impl<const N: usize>
    Scorer<So2<f64>, PairedEstimate<HarmonicGaussian<N>, CircularGrid<Gaussian<N>>>>
    for CellByCell
{
    fn metrics(&self) -> Vec<Metric> {
        vec![
            Metric::new("mean", Reduction::Mean, ""),
            Metric::new("covariance", Reduction::Mean, ""),
            Metric::new("evidence", Reduction::Mean, ""),
            Metric::new("heading_error", Reduction::RootMeanSquare, "deg"),
        ]
    }

    fn score(
        &self,
        truth: &So2<f64>,
        estimate: &PairedEstimate<HarmonicGaussian<N>, CircularGrid<Gaussian<N>>>,
        values: &mut [f64],
    ) {
        let (composite, grid) = (&estimate.first, &estimate.second);
        let mut previous = self.previous.lock().unwrap();
        let ((eta1, eta2), (before1, before2)) =
            (composite.angle().natural(), previous.angle.natural());
        let step = Harmonics {
            constant: estimate.log_evidence[0]
                - previous.log_evidence[0]
                - (composite.angle().log_normalizer() - previous.angle.log_normalizer()),
            eta1: eta1 - before1,
            eta2: eta2 - before2,
        };
        let grid_evidence = estimate.log_evidence[1] - previous.log_evidence[1];
        let (mut mean, mut covariance, mut evidence) = (0.0_f64, 0.0_f64, 0.0_f64);
        for (j, cell) in grid.cells().iter().enumerate() {
            let expected_mean =
                composite.conditional_mean(&So2::from_angle_unchecked(grid.angle(j)));
            mean = mean.max((cell.mean() - expected_mean).amax() / (1.0 + expected_mean.amax()));
            covariance = covariance.max(
                (cell.covariance() - composite.covariance()).amax()
                    / (1.0 + cell.covariance().amax()),
            );
            let expected = step.at(grid.angle(j)).unwrap();
            let cell_evidence = grid.log_weights()[j] - previous.log_weights[j] + grid_evidence;
            evidence = evidence.max((cell_evidence - expected).abs() / (1.0 + expected.abs()));
        }
        *previous = Previous {
            angle: composite.angle().clone(),
            log_weights: grid.log_weights().to_vec(),
            log_evidence: estimate.log_evidence,
        };
        let heading = So2::from_angle_unchecked(eta1.y.atan2(eta1.x));
        values.copy_from_slice(&[
            mean,
            covariance,
            evidence,
            estimation_error(truth, &heading)[0].to_degrees(),
        ]);
    }
}

/// Checks the scores of a [`CellByCell`] replay: `epochs` epochs, every comparison within
/// [`TOLERANCE`] at every one of them; returns the worst comparison and the final heading error
/// (deg).
fn agreement(scores: &RunScores, epochs: usize) -> (f64, f64) {
    assert_eq!(scores.epochs(), epochs);
    let mut worst = 0.0_f64;
    for k in 0..epochs {
        for name in ["mean", "covariance", "evidence"] {
            let value = scores.get(name, k).unwrap();
            assert!(
                value <= TOLERANCE,
                "composite and grid disagree by {value:e} in {name} at epoch {k}"
            );
            worst = worst.max(value);
        }
    }
    (worst, scores.get("heading_error", epochs - 1).unwrap())
}

/// Velocity matching: state `x = [r; v]` (platform axes), `v̇ = a + w` with a measured acceleration
/// and white acceleration noise; the world-frame velocity `z = R(A) v + n` every second and, every 5 s,
/// the world position `R(A) r + n`. Kronecker-structured covariances keep both projections isotropic.
#[test]
fn velocity_matching_is_exact() {
    let (dt, qa, sigma_v, sigma_p) = (0.1, 0.05, 0.1, 2.0);
    let i2 = Matrix2::identity();
    let block = |a: f64, b: f64, c: f64| {
        let mut m = SMatrix::<f64, 4, 4>::zeros();
        m.fixed_view_mut::<2, 2>(0, 0).copy_from(&(i2 * a));
        m.fixed_view_mut::<2, 2>(0, 2).copy_from(&(i2 * b));
        m.fixed_view_mut::<2, 2>(2, 0).copy_from(&(i2 * b));
        m.fixed_view_mut::<2, 2>(2, 2).copy_from(&(i2 * c));
        m
    };
    let mut transition = block(1.0, 0.0, 1.0);
    transition
        .fixed_view_mut::<2, 2>(0, 2)
        .copy_from(&(i2 * dt));
    let q = qa * qa;
    let process = LinearProcess::new(
        transition,
        block(q * dt.powi(3) / 3.0, q * dt * dt / 2.0, q * dt),
    )
    .unwrap();
    let velocity_h = SMatrix::<f64, 2, 4>::from_columns(&[
        Vector2::zeros(),
        Vector2::zeros(),
        Vector2::x(),
        Vector2::y(),
    ]);
    let position_h = SMatrix::<f64, 2, 4>::from_columns(&[
        Vector2::x(),
        Vector2::y(),
        Vector2::zeros(),
        Vector2::zeros(),
    ]);

    // The trajectory: step k moves over [(k − 1) dt, k dt] and measures at k dt, the velocity
    // every 10 steps and the position with it every 50.
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let azimuth = rng.random::<f64>() * 2.0 * PI;
    let world = rotation2(azimuth);
    let noise = process.noise().cholesky().unwrap().l();
    let mut truth =
        SVector::<f64, 4>::from_column_slice(&[0.0, 0.0, 0.5, 0.0]) + normal::<4>(&mut rng) * 0.3;
    let steps: Vec<_> = (1..=600_u32)
        .map(|k| {
            let t = f64::from(k - 1) * dt;
            let (s, c) = (2.0 * PI * t / 20.0).sin_cos();
            let accel = Vector2::new(c, s) * 0.3;
            let mut u = SVector::<f64, 4>::zeros();
            u.fixed_rows_mut::<2>(0).copy_from(&(accel * dt * dt / 2.0));
            u.fixed_rows_mut::<2>(2).copy_from(&(accel * dt));
            truth = transition * truth + u + noise * normal::<4>(&mut rng);
            let measurement = (k % 10 == 0).then(|| {
                let velocity = world * truth.fixed_rows::<2>(2) + normal::<2>(&mut rng) * sigma_v;
                let position = (k % 50 == 0)
                    .then(|| world * truth.fixed_rows::<2>(0) + normal::<2>(&mut rng) * sigma_p);
                (velocity, position)
            });
            Step {
                time: f64::from(k) * dt,
                input: u,
                truth: So2::from_angle_unchecked(azimuth),
                measurement,
            }
        })
        .collect();

    let mut pair =
        composite_and_grid(
            &Gaussian::new(
                SVector::from_column_slice(&[0.0, 0.0, 0.5, 0.0]),
                block(0.09, 0.0, 0.09),
            )
            .unwrap(),
            &process,
            Then(
                RotatedMeasurement::new(velocity_h, sigma_v).unwrap(),
                RotatedMeasurement::new(position_h, sigma_p).unwrap(),
            ),
            move |a: &So2<f64>| -> Result<
                Then<LinearMeasurement<4, 2>, LinearMeasurement<4, 2>>,
                OperatorError,
            > {
                Ok(Then(
                    LinearMeasurement::new(a.to_matrix() * velocity_h, i2 * sigma_v * sigma_v)?,
                    LinearMeasurement::new(a.to_matrix() * position_h, i2 * sigma_p * sigma_p)?,
                ))
            },
        );
    let scorer = CellByCell::new(&pair);
    let scores = replay(&mut pair, steps, &scorer).unwrap();
    let (worst, heading_error) = agreement(&scores, 60);
    eprintln!(
        "velocity matching: worst {worst:.1e}, |eta2| {:.2e}, heading error {heading_error:.3} deg",
        pair.first().density().angle().natural().1.norm(),
    );
    assert!(heading_error.abs() < 5.0);
}

/// `R_y(pitch) R_x(roll)`: body to levelled axes.
fn levelling(roll: f64, pitch: f64) -> Matrix3<f64> {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
    let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
    ry * rx
}

/// 3-D with known roll and pitch: body-frame velocity levelled by the known attitude, then the
/// position in the levelled frame `z = R_z(A) r + n` (isotropic 3-D noise): a rotated measurement of the
/// horizontal part and an ordinary one of the vertical part, both exact.
#[test]
fn three_dimensional_with_known_roll_and_pitch_is_exact() {
    let (dt, q, sigma_m) = (0.1, 0.1, 1.0);
    let process =
        LinearProcess::new(Matrix3::identity(), Matrix3::identity() * (q * q * dt)).unwrap();
    let horizontal_h = SMatrix::<f64, 2, 3>::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let vertical = LinearMeasurement::new(
        SMatrix::<f64, 1, 3>::new(0.0, 0.0, 1.0),
        SMatrix::<f64, 1, 1>::new(sigma_m * sigma_m),
    )
    .unwrap();
    let heading = |y: f64| {
        let (s, c) = y.sin_cos();
        Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
    };

    // Step k moves over [(k − 1) dt, k dt]; the position is measured every 10 steps.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let azimuth = rng.random::<f64>() * 2.0 * PI;
    let mut truth = normal::<3>(&mut rng);
    let steps: Vec<_> = (1..=1200_u32)
        .map(|k| {
            let t = f64::from(k - 1) * dt;
            let body_velocity = Vector3::new(1.0, 0.3 * (0.2 * t).sin(), 0.1);
            let levelled = levelling(0.3 * (0.5 * t).sin(), 0.2 * (0.3 * t).cos()) * body_velocity;
            truth += levelled * dt + normal::<3>(&mut rng) * (q * dt.sqrt());
            let measurement = (k % 10 == 0).then(|| {
                let z = heading(azimuth) * truth + normal::<3>(&mut rng) * sigma_m;
                (Vector2::new(z.x, z.y), Some(SVector::<f64, 1>::new(z.z)))
            });
            Step {
                time: f64::from(k) * dt,
                input: levelled * dt,
                truth: So2::from_angle_unchecked(azimuth),
                measurement,
            }
        })
        .collect();

    let cell_vertical = vertical.clone();
    let mut pair =
        composite_and_grid(
            &Gaussian::new(Vector3::zeros(), Matrix3::identity()).unwrap(),
            &process,
            Then(
                RotatedMeasurement::new(horizontal_h, sigma_m).unwrap(),
                vertical,
            ),
            move |a: &So2<f64>| -> Result<
                Then<LinearMeasurement<3, 2>, LinearMeasurement<3, 1>>,
                OperatorError,
            > {
                Ok(Then(
                    LinearMeasurement::new(
                        heading(a.angle()).fixed_view::<2, 3>(0, 0).into_owned(),
                        Matrix2::identity() * sigma_m * sigma_m,
                    )?,
                    cell_vertical.clone(),
                ))
            },
        );
    let scorer = CellByCell::new(&pair);
    let scores = replay(&mut pair, steps, &scorer).unwrap();
    let (worst, heading_error) = agreement(&scores, 120);
    eprintln!("3-D known roll/pitch: worst {worst:.1e}, heading error {heading_error:.3} deg");
    assert!(heading_error.abs() < 5.0);
}

/// The circle scenario with the position noise `R_m = diag(1, 0.16)` in place of the simulator's
/// isotropic noise: every measurement redrawn from the true state, from a stream of its own.
struct Anisotropic(AzimuthScenario);

/// The steps of an [`Anisotropic`] run.
struct AnisotropicSteps<'s> {
    steps: AzimuthSteps<'s>,
    noise: ChaCha8Rng,
}

impl Iterator for AnisotropicSteps<'_> {
    type Item = StepOf<AzimuthScenario>;

    fn next(&mut self) -> Option<Self::Item> {
        let mut step = self.steps.next()?;
        if step.measurement.is_some() {
            let n = normal::<2>(&mut self.noise);
            step.measurement = Some(
                step.truth.second().to_matrix() * step.truth.first().coords()
                    + Vector2::new(n.x, 0.4 * n.y),
            );
        }
        Some(step)
    }
}

impl Scenario for Anisotropic {
    type Truth = <AzimuthScenario as Scenario>::Truth;
    type Input = <AzimuthScenario as Scenario>::Input;
    type Measurement = <AzimuthScenario as Scenario>::Measurement;
    type Steps<'s> = AnisotropicSteps<'s>;

    fn epochs(&self) -> usize {
        self.0.epochs()
    }

    /// The measurement noise's stream is seeded from the run's stream first.
    fn simulate<'s>(
        &'s self,
        rng: &'s mut ChaCha8Rng,
    ) -> Result<AnisotropicSteps<'s>, ExperimentError> {
        let noise = ChaCha8Rng::seed_from_u64(rng.random());
        Ok(AnisotropicSteps {
            steps: self.0.simulate(rng)?,
            noise,
        })
    }
}

/// Non-isotropic noise: the composite refuses (the family is not closed), and the seven-number filter
/// with the isotropic bound λ_max is consistent against the truth over 400 runs of the circle scenario
/// (120 s) with `R_m = diag(1, 0.16)`: at the last epoch its average NEES of r and its circular
/// consistency lie below the upper ends of their 95 % bands (it is conservative, so they may lie
/// below the lower ends).
#[test]
fn non_isotropic_noise_with_the_isotropic_bound_is_conservative() {
    let anisotropic = HarmonicGaussian::independent(
        GenVonMises2::from_natural(Vector2::new(1.0, 0.0), Vector2::zeros()).unwrap(),
        &Gaussian::new(Vector2::zeros(), Matrix2::new(1.0, 0.0, 0.0, 0.3)).unwrap(),
    )
    .unwrap();
    assert!(matches!(
        anisotropic.condition(
            &RotatedMeasurement::new(Matrix2::identity(), 1.0).unwrap(),
            &Vector2::new(1.0, 1.0)
        ),
        Err(OperatorError::NotClosed { .. })
    ));

    let noise = Matrix2::new(1.0, 0.0, 0.0, 0.16);
    let bound = PositionMeasurement::isotropic_bound(&noise).unwrap();
    assert!((bound.variance() - 1.0).abs() < 1e-15);
    assert!(PositionMeasurement::isotropic_bound(&Matrix2::new(1.0, 0.5, 0.0, 1.0)).is_err());
    let config = Config {
        steps: 1200,
        ..Config::default()
    };
    let process = VelocityProcess::new(config.q).unwrap();
    let runs = 400;
    let scenario = Anisotropic(AzimuthScenario::new(Motion::Circle, config).unwrap());
    let study = Study::new("exact, isotropic bound, circle", runs, 1000, Shard::WHOLE).unwrap();
    let summary = study
        .run(
            &scenario,
            &|_: &mut ChaCha8Rng| exact(process, bound, Vector2::zeros(), config.sigma0),
            &AzimuthScorer,
            &|_| {},
        )
        .unwrap();
    assert_eq!(summary.failure_count(), 0, "{:?}", summary.failures());
    let last = |metric: &str| {
        let stats = summary
            .series(metric)
            .unwrap()
            .epochs()
            .last()
            .unwrap()
            .clone();
        assert_eq!(
            stats.count(),
            runs,
            "{metric}: every run scored at the last epoch"
        );
        stats
    };
    let nees = last("nees_position");
    let (low, high) = average_nees_band(2, 400).unwrap();
    let average = nees.mean().unwrap();
    let circular = last("circular_consistency");
    let half = 1.96 * (circular.variance().unwrap() / runs as f64).sqrt();
    let band = (
        circular.mean().unwrap() - half,
        circular.mean().unwrap() + half,
    );
    eprintln!(
        "isotropic bound: average NEES {average:.3} (band [{low:.3}, {high:.3}]), circular consistency {:.3} [{:.3}, {:.3}]",
        circular.mean().unwrap(),
        band.0,
        band.1
    );
    assert!(average <= high, "over-confident position: NEES {average}");
    assert!(band.0 <= 1.0, "over-confident azimuth: {band:?}");
}
