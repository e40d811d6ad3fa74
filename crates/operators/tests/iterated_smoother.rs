//! The iterated smoother against independent computations:
//!
//! * a linear model on R²: the RTS smoother and the dense solve of the whole trajectory's
//!   information matrix, means and marginal covariances to 1e-9, after one step;
//! * the block-tridiagonal solvers (nalgebra fixed-size, faer) against a dense Cholesky solve and
//!   inverse, to 1e-9;
//! * the cost never increases (property test over random nonlinear runs);
//! * a unicycle pose on SE(2) with range and bearing to two landmarks and a poor heading prior
//!   (standard deviation 1 rad): over
//!   120 runs the iterated smoother's RMSE is below the RTS smoother's, by a paired test;
//! * bad input returns a typed error and leaves the recorder unchanged.

use liebayes_densities::{Density, Gaussian, ManifoldGaussian};
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, Rn, Se2, So2};
use liebayes_operators::iterated_smoother::{
    Backend, BlockJacobian, BlockTridiagonal, GaussNewton, IteratedSmoother, Stop,
};
use liebayes_operators::{MeasurementFn, MeasurementModel, OperatorError, ProcessFn, ProcessModel};
use nalgebra::{
    DMatrix, DVector, Matrix1, Matrix2, Matrix3, RowVector2, SMatrix, SVector, Vector1, Vector2,
    Vector3,
};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// F and Q of the constant-velocity model on R² (time step 0.5).
fn linear_matrices() -> (Matrix2<f64>, Matrix2<f64>) {
    let dt = 0.5_f64;
    let f = Matrix2::new(1.0, dt, 0.0, 1.0);
    let q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.3;
    (f, q)
}

/// The constant-velocity model `x′ = F x + u + w` on R² with a position reading `z = H x + n`.
fn linear_models() -> (
    impl ProcessModel<Rn<f64, 2>, 2, Input = Vector2<f64>>,
    impl MeasurementModel<Rn<f64, 2>, 2, 1>,
) {
    let (f, q) = linear_matrices();
    let h = RowVector2::new(1.0, 0.0);
    let process = ProcessFn::new(
        move |x: &Rn<f64, 2>, u: &Vector2<f64>| Rn::new_unchecked(f * x.coords() + u),
        move |_, _| q,
    )
    .with_jacobian(move |_, _| f);
    let measurement = MeasurementFn::new(
        move |x: &Rn<f64, 2>| Vector1::new((h * x.coords())[0]),
        move |_| Matrix1::new(0.25),
    )
    .with_jacobian(move |_: &Rn<f64, 2>| SMatrix::<f64, 1, 2>::new(1.0, 0.0));
    (process, measurement)
}

/// On R² with a linear model the first Gauss-Newton step lands on the minimum: the means and
/// covariances equal the RTS smoother's, and the dense solve of the information matrix `Λ` of the
/// whole trajectory (built here from F, Q, H, R without the library's assembly).
#[test]
fn linear_model_equals_rts_after_one_step() {
    let (process, measurement) = linear_models();
    let (f, q) = linear_matrices();
    let u = Vector2::new(0.05, -0.02);
    let (m0, p0) = (Vector2::new(1.0, -0.5), Matrix2::new(2.0, 0.3, 0.3, 1.0));
    let prior = ManifoldGaussian::new(Rn::new_unchecked(m0), p0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let epochs = 40;
    let mut smoother = IteratedSmoother::with_capacity(prior, epochs - 1, epochs).unwrap();
    let mut zs = Vec::new();
    let mut truth = Vector2::new(1.0, 0.2);
    for k in 0..epochs {
        if k > 0 {
            truth = f * truth + u;
            smoother.propagate(&process, &u).unwrap();
        }
        let z = truth[0] + 0.5 * rng.sample::<f64, _>(rand_distr::StandardNormal);
        zs.push(z);
        smoother.condition(&measurement, &Vector1::new(z)).unwrap();
    }
    let settings = GaussNewton {
        max_iterations: 1,
        ..GaussNewton::default()
    };
    let result = smoother
        .smooth_with(&process, &measurement, &settings)
        .unwrap();
    assert!(result.report.iterations <= 1 && result.report.converged());
    let rts = smoother.forward().smooth().unwrap();

    // Λ and η of the joint density, dense.
    let n = 2 * epochs;
    let mut lambda = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut eta = DVector::<f64>::zeros(n);
    let (p0_inv, q_inv) = (p0.try_inverse().unwrap(), q.try_inverse().unwrap());
    let h = Vector2::new(1.0, 0.0);
    let mut add = |i: usize, j: usize, block: &Matrix2<f64>| {
        let mut view = lambda.view_mut((2 * i, 2 * j), (2, 2));
        view += block;
    };
    add(0, 0, &p0_inv);
    for k in 0..epochs - 1 {
        add(k, k, &(f.transpose() * q_inv * f));
        add(k, k + 1, &(-f.transpose() * q_inv));
        add(k + 1, k, &(-q_inv * f));
        add(k + 1, k + 1, &q_inv);
    }
    for k in 0..epochs {
        add(k, k, &(h * h.transpose() / 0.25));
    }
    eta.rows_mut(0, 2).copy_from(&(p0_inv * m0));
    for (k, z) in zs.iter().enumerate() {
        let mut ek = eta.rows_mut(2 * k, 2);
        ek += h * (z / 0.25);
        if k + 1 < epochs {
            ek -= f.transpose() * q_inv * u;
            let mut next = eta.rows_mut(2 * k + 2, 2);
            next += q_inv * u;
        }
    }
    let factor = lambda.cholesky().unwrap();
    let (mean, covariance) = (factor.solve(&eta), factor.inverse());

    for (k, (s, r)) in result.densities.iter().zip(&rts).enumerate() {
        let batch_mean = Vector2::new(mean[2 * k], mean[2 * k + 1]);
        let batch_cov = covariance.fixed_view::<2, 2>(2 * k, 2 * k).into_owned();
        for (reference_mean, reference_cov, name) in [
            (*r.mean().coords(), *r.covariance(), "RTS"),
            (batch_mean, batch_cov, "dense"),
        ] {
            let mean_error =
                (s.mean().coords() - reference_mean).amax() / (1.0 + reference_mean.amax());
            let cov_error = (s.covariance() - reference_cov).amax() / reference_cov.amax();
            assert!(
                mean_error < 1e-9 && cov_error < 1e-9,
                "epoch {k}, against {name}: mean off by {mean_error:e}, covariance by {cov_error:e}"
            );
        }
    }
}

/// A random whitened Jacobian of n epochs: in each epoch √0.1 I and a random block of its own,
/// and a random transition `[J₁ J₂]` between neighbours; its normal matrix `Λ = JᵀJ` is symmetric
/// positive definite and block-tridiagonal.
fn random_jacobian<const D: usize>(n: usize, seed: u64) -> BlockJacobian<D> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut random = || SMatrix::<f64, D, D>::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let mut jacobian = BlockJacobian::new(n).unwrap();
    for k in 0..n {
        let own = SMatrix::<f64, D, D>::identity() * 0.1_f64.sqrt();
        jacobian
            .add_rows(
                k,
                DMatrix::from_column_slice(D, D, own.as_slice()).as_view(),
            )
            .unwrap();
        let a = random();
        jacobian
            .add_rows(k, DMatrix::from_column_slice(D, D, a.as_slice()).as_view())
            .unwrap();
        if k + 1 < n {
            let (b, c) = (random(), random());
            jacobian.set_transition(k, b, c).unwrap();
        }
    }
    jacobian
}

/// A random symmetric positive definite block-tridiagonal matrix, the normal matrix of
/// [`random_jacobian`].
fn random_normal_matrix<const D: usize>(n: usize, seed: u64) -> BlockTridiagonal<D> {
    random_jacobian(n, seed).normal().unwrap()
}

/// Both backends' solves and marginal covariances, factored from the normal matrix and from its
/// square root, against nalgebra's dense Cholesky solve and inverse of the assembled matrix.
fn check_solvers<const D: usize>(n: usize, seed: u64) {
    let jacobian = random_jacobian::<D>(n, seed);
    let matrix = jacobian.normal().unwrap();
    let dense = matrix.to_dense().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 1);
    let rhs: Vec<SVector<f64, D>> = (0..n)
        .map(|_| SVector::from_fn(|_, _| rng.random_range(-1.0..1.0)))
        .collect();
    let stacked = DVector::from_iterator(n * D, rhs.iter().flat_map(|b| b.iter().copied()));
    let factor = dense.clone().cholesky().unwrap();
    let (x, inverse) = (factor.solve(&stacked), factor.inverse());
    for backend in [Backend::FixedSize, Backend::Faer] {
        for (route, blocks) in [
            ("normal", matrix.factor_with(backend).unwrap()),
            ("square root", jacobian.factor_with(backend).unwrap()),
        ] {
            assert_eq!(blocks.backend(), backend);
            let solution = blocks.solve(&rhs).unwrap();
            let marginals = blocks.marginal_covariances().unwrap();
            for k in 0..n {
                let reference = x.rows(k * D, D);
                let error = (solution[k] - reference).amax() / (1.0 + reference.amax());
                assert!(
                    error < 1e-9,
                    "{backend:?} from the {route}, D = {D}, block {k}: solve off by {error:e}"
                );
                let reference = inverse.fixed_view::<D, D>(k * D, k * D);
                let error = (marginals[k] - reference).amax() / reference.amax();
                assert!(
                    error < 1e-9,
                    "{backend:?} from the {route}, D = {D}, block {k}: marginal off by {error:e}"
                );
            }
        }
    }
}

#[test]
fn block_solvers_agree_with_a_dense_solve() {
    check_solvers::<1>(1, 1);
    check_solvers::<1>(30, 2);
    check_solvers::<3>(25, 3);
    check_solvers::<6>(12, 4);
    check_solvers::<31>(5, 5);
    // The default picks the backend by dimension: faer from 15 on.
    assert_eq!(Backend::for_dimension(14), Backend::FixedSize);
    assert_eq!(Backend::for_dimension(15), Backend::Faer);
    assert_eq!(
        random_normal_matrix::<3>(2, 6).factor().unwrap().backend(),
        Backend::FixedSize
    );
    assert_eq!(
        random_normal_matrix::<31>(2, 7).factor().unwrap().backend(),
        Backend::Faer
    );
}

#[test]
fn block_solvers_refuse_bad_matrices() {
    let m =
        BlockTridiagonal::<1>::new(vec![Matrix1::new(1.0); 2], vec![Matrix1::new(2.0)]).unwrap();
    for backend in [Backend::FixedSize, Backend::Faer] {
        assert!(matches!(
            m.factor_with(backend),
            Err(OperatorError::NotPositiveDefinite { .. })
        ));
    }
    assert!(matches!(
        BlockTridiagonal::<1>::new(vec![Matrix1::new(1.0); 2], vec![]),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        BlockTridiagonal::<1>::new(vec![], vec![]),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        BlockTridiagonal::<1>::new(vec![Matrix1::new(f64::NAN)], vec![]),
        Err(OperatorError::NonFinite { .. })
    ));
    let factor = BlockTridiagonal::<1>::new(vec![Matrix1::new(2.0)], vec![])
        .unwrap()
        .factor()
        .unwrap();
    assert!(matches!(
        factor.solve(&[Vector1::new(1.0); 2]),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        factor.solve(&[Vector1::new(f64::INFINITY)]),
        Err(OperatorError::NonFinite { .. })
    ));
    // Positive definite but nearly singular (diagonal 1e-310): x = b / 1e-310 and Λ⁻¹ overflow,
    // an error rather than an infinite result.
    let tiny =
        BlockTridiagonal::<1>::new(vec![Matrix1::new(1e-310); 2], vec![Matrix1::new(0.0)]).unwrap();
    for backend in [Backend::FixedSize, Backend::Faer] {
        let factor = tiny.factor_with(backend).unwrap();
        assert!(matches!(
            factor.solve(&[Vector1::new(1.0); 2]),
            Err(OperatorError::NonFinite { .. })
        ));
        assert!(matches!(
            factor.marginal_covariances(),
            Err(OperatorError::NonFinite { .. })
        ));
        let small = factor.solve(&[Vector1::new(1e-300); 2]).unwrap();
        assert!(small.iter().all(|x| x[0].is_finite() && x[0] > 1e9));
    }
}

/// The unicycle: `x′ = x · exp([v dt, 0, ω dt])` on SE(2), with range and bearing to two
/// landmarks.
struct Unicycle {
    landmarks: [Vector2<f64>; 2],
    q: Matrix3<f64>,
    r: SMatrix<f64, 4, 4>,
}

/// Range and bearing of each landmark seen from x (in its body frame).
fn range_bearing(x: &Se2<f64>, landmarks: &[Vector2<f64>; 2]) -> SVector<f64, 4> {
    let inverse = x.inverse();
    let [a, b] = landmarks.map(|l| inverse.act(&l));
    SVector::<f64, 4>::new(a.norm(), a[1].atan2(a[0]), b.norm(), b[1].atan2(b[0]))
}

impl Unicycle {
    fn process(&self) -> impl ProcessModel<Se2<f64>, 3, Input = Vector2<f64>> + use<> {
        let q = self.q;
        ProcessFn::new(
            |x: &Se2<f64>, u: &Vector2<f64>| x.retract(&Vector3::new(u[0], 0.0, u[1])),
            move |_, _| q,
        )
    }

    fn measurement(&self) -> impl MeasurementModel<Se2<f64>, 3, 4> + use<> {
        let (landmarks, r) = (self.landmarks, self.r);
        MeasurementFn::new(move |x: &Se2<f64>| range_bearing(x, &landmarks), move |_| r)
            .with_residual(|z: &SVector<f64, 4>, p: &SVector<f64, 4>| {
                let mut residual = z - p;
                for i in [1, 3] {
                    residual[i] =
                        So2::from_angle_unchecked(p[i]).local(&So2::from_angle_unchecked(z[i]))[0];
                }
                residual
            })
    }
}

/// A simulated run: the models, the true poses, and the recorder after the forward pass.
type Run = (
    Unicycle,
    Vec<Se2<f64>>,
    IteratedSmoother<Se2<f64>, Vector2<f64>, 3, 4>,
);

/// One simulated run of `epochs` steps from a prior with heading standard deviation `heading_sd`.
fn unicycle_run(seed: u64, heading_sd: f64, epochs: usize) -> Run {
    let (rr, rb) = (0.05, 0.02);
    let model = Unicycle {
        landmarks: [Vector2::new(4.0, 3.0), Vector2::new(-2.0, 5.0)],
        q: Matrix3::from_diagonal(&Vector3::new(0.05, 0.02, 0.02)).map(|v| v * v),
        r: SMatrix::<f64, 4, 4>::from_diagonal(&SVector::<f64, 4>::new(rr, rb, rr, rb))
            .map(|v| v * v),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let prior = ManifoldGaussian::new(
        Se2::from_angle_translation(0.0, Vector2::zeros()).unwrap(),
        Matrix3::from_diagonal(&Vector3::new(0.3, 0.3, heading_sd)).map(|v| v * v),
    )
    .unwrap();
    let mut truth = prior.sample(&mut rng);
    let (process, measurement) = (model.process(), model.measurement());
    let noise = Gaussian::new(SVector::<f64, 4>::zeros(), model.r).unwrap();
    let mut smoother = IteratedSmoother::with_capacity(prior, epochs, epochs + 1).unwrap();
    let mut truths = Vec::with_capacity(epochs + 1);
    let u = Vector2::new(0.5, 0.15);
    for k in 0..=epochs {
        if k > 0 {
            truth = ManifoldGaussian::new(process.transition(&truth, &u), model.q)
                .unwrap()
                .sample(&mut rng);
            smoother.propagate(&process, &u).unwrap();
        }
        let z = range_bearing(&truth, &model.landmarks) + noise.sample(&mut rng);
        smoother.condition(&measurement, &z).unwrap();
        truths.push(truth);
    }
    (model, truths, smoother)
}

/// The root mean squared tangent error `|x̂ ⊟ x|` over a run's epochs.
fn rmse<'a>(estimates: impl Iterator<Item = &'a Se2<f64>>, truths: &[Se2<f64>]) -> f64 {
    let sum: f64 = estimates
        .zip(truths)
        .map(|(e, t)| e.local(t).norm_squared())
        .sum();
    (sum / truths.len() as f64).sqrt()
}

/// Over 120 runs with a poor heading prior, the iterated smoother's RMSE is below the RTS
/// smoother's: the mean paired difference is positive beyond 3 standard errors.
#[test]
fn iterated_smoother_beats_rts_on_a_nonlinear_pose() {
    let (runs, epochs) = (120, 15);
    let mut differences = Vec::with_capacity(runs);
    let (mut rts_sum, mut iterated_sum, mut filtered_sum) = (0.0, 0.0, 0.0);
    for run in 0..runs {
        let (model, truths, smoother) = unicycle_run(1000 + run as u64, 1.0, epochs);
        let rts = smoother.forward().smooth().unwrap();
        let iterated = smoother
            .smooth(&model.process(), &model.measurement())
            .unwrap();
        assert!(
            iterated.report.stop != Stop::IterationLimit,
            "run {run}: {:?}",
            iterated.report
        );
        let e_filtered = rmse(
            smoother
                .forward()
                .filtered()
                .iter()
                .map(ManifoldGaussian::mean),
            &truths,
        );
        let e_rts = rmse(rts.iter().map(ManifoldGaussian::mean), &truths);
        let e_iterated = rmse(
            iterated.densities.iter().map(ManifoldGaussian::mean),
            &truths,
        );
        filtered_sum += e_filtered;
        rts_sum += e_rts;
        iterated_sum += e_iterated;
        differences.push(e_rts - e_iterated);
    }
    let n = runs as f64;
    let mean = differences.iter().sum::<f64>() / n;
    let sd = (differences.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    println!(
        "mean RMSE over {runs} runs: EKF {:.4}, RTS {:.4}, iterated {:.4}; paired difference \
         {mean:.4} ± {:.4} (standard error)",
        filtered_sum / n,
        rts_sum / n,
        iterated_sum / n,
        sd / n.sqrt()
    );
    assert!(
        mean > 3.0 * sd / n.sqrt(),
        "mean RMSE reduction {mean:e}, standard error {:e}",
        sd / n.sqrt()
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Every accepted step lowers (or keeps) J, from the RTS means on.
    #[test]
    fn cost_never_increases(seed in 0_u64..1_000_000, heading_sd in 0.05_f64..1.2) {
        let (model, _, smoother) = unicycle_run(seed, heading_sd, 8);
        let result = smoother.smooth(&model.process(), &model.measurement()).unwrap();
        let costs = &result.report.costs;
        prop_assert_eq!(costs.len(), result.report.iterations + 1);
        for pair in costs.windows(2) {
            prop_assert!(pair[1] <= pair[0], "{:?}", costs);
        }
        prop_assert!(result.report.cost().unwrap() <= costs[0]);
        prop_assert!(result.report.decrement.is_finite() && result.report.decrement >= 0.0);
    }
}

/// The iteration limit is respected; zero steps return the RTS means.
#[test]
fn iterations_are_bounded() {
    let (model, _, smoother) = unicycle_run(5, 0.8, 10);
    let (process, measurement) = (model.process(), model.measurement());
    let none = GaussNewton {
        max_iterations: 0,
        ..GaussNewton::default()
    };
    let result = smoother.smooth_with(&process, &measurement, &none).unwrap();
    assert_eq!(result.report.iterations, 0);
    let rts = smoother.forward().smooth().unwrap();
    for (s, r) in result.densities.iter().zip(&rts) {
        assert_eq!(s.mean().local(r.mean()), Vector3::zeros());
    }
    let one = GaussNewton {
        max_iterations: 1,
        tolerance: 0.0,
        ..GaussNewton::default()
    };
    let result = smoother.smooth_with(&process, &measurement, &one).unwrap();
    assert_eq!(result.report.iterations, 1);
    assert_eq!(result.report.stop, Stop::IterationLimit);
    for bad in [
        GaussNewton {
            tolerance: f64::NAN,
            ..GaussNewton::default()
        },
        GaussNewton {
            tolerance: -1.0,
            ..GaussNewton::default()
        },
        GaussNewton {
            max_iterations: 10_001,
            ..GaussNewton::default()
        },
        GaussNewton {
            max_halvings: 61,
            ..GaussNewton::default()
        },
    ] {
        assert!(
            smoother.smooth_with(&process, &measurement, &bad).is_err(),
            "{bad:?}"
        );
    }
}

/// NaN measurements and noise that is not positive definite return typed errors, and leave the
/// recorder unchanged.
#[test]
fn bad_input_returns_typed_errors() {
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(0.2), Matrix1::new(0.1)).unwrap();
    let mut smoother: IteratedSmoother<So2<f64>, f64, 1, 1> = IteratedSmoother::new(prior);
    let turn = ProcessFn::new(
        |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
        |_, _| Matrix1::new(1e-3),
    );
    let heading = MeasurementFn::new(
        |x: &So2<f64>| Vector1::new(x.angle()),
        |_| Matrix1::new(0.01),
    );
    assert!(matches!(
        smoother.condition(&heading, &Vector1::new(f64::NAN)),
        Err(OperatorError::NonFinite { .. })
    ));
    let negative = MeasurementFn::new(
        |x: &So2<f64>| Vector1::new(x.angle()),
        |_| Matrix1::new(-0.01),
    );
    assert!(matches!(
        smoother.condition(&negative, &Vector1::new(0.3)),
        Err(OperatorError::NotPositiveDefinite { .. })
    ));
    let not_pd = ProcessFn::new(
        |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
        |_, _| Matrix1::new(0.0),
    );
    assert!(matches!(
        smoother.propagate(&not_pd, &0.1),
        Err(OperatorError::NotPositiveDefinite { .. })
    ));
    let nan_noise = ProcessFn::new(
        |x: &So2<f64>, rate: &f64| x.retract(&Vector1::new(*rate)),
        |_, _| Matrix1::new(f64::NAN),
    );
    assert!(matches!(
        smoother.propagate(&nan_noise, &0.1),
        Err(OperatorError::NonFinite { .. })
    ));
    assert_eq!(smoother.forward().filtered().len(), 1);
    smoother.propagate(&turn, &0.1).unwrap();
    smoother.condition(&heading, &Vector1::new(0.3)).unwrap();
    assert!(smoother.smooth(&turn, &heading).unwrap().report.converged());
    // Models at smoothing that differ from the forward pass's, with a noise that is not positive
    // definite or a prediction that is not finite: refused.
    assert!(matches!(
        smoother.smooth(&not_pd, &heading),
        Err(OperatorError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        smoother.smooth(&turn, &negative),
        Err(OperatorError::NotPositiveDefinite { .. })
    ));
    let nan_prediction = MeasurementFn::new(
        |_: &So2<f64>| Vector1::new(f64::NAN),
        |_| Matrix1::new(0.01),
    )
    .with_jacobian(|_: &So2<f64>| Matrix1::new(1.0));
    assert!(matches!(
        smoother.smooth(&turn, &nan_prediction),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(matches!(
        IteratedSmoother::<So2<f64>, f64, 1, 1>::with_capacity(
            ManifoldGaussian::new(So2::from_angle_unchecked(0.0), Matrix1::new(1.0)).unwrap(),
            usize::MAX,
            0
        ),
        Err(OperatorError::TooLarge { .. })
    ));
}

/// The factorisation reads the lower triangle of each diagonal block: an asymmetric block
/// (`[[1, 5], [0, 1]]`) was solved as the identity, as Ok. It is refused when the matrix is built.
#[test]
fn an_asymmetric_diagonal_block_is_refused() {
    let error = BlockTridiagonal::new(vec![Matrix2::new(1.0, 5.0, 0.0, 1.0)], vec![]).unwrap_err();
    assert!(matches!(error, OperatorError::OutOfRange { .. }), "{error}");
    assert!(BlockTridiagonal::new(vec![Matrix2::new(2.0, 0.5, 0.5, 1.0)], vec![]).is_ok());
}

/// Trajectories whose normal matrix rounding leaves indefinite, smoothed from the square root of
/// it: a constant-velocity track (step 1, process noise 1e-10, prior I) over 1000 unmeasured
/// epochs, whose last position variance is 1e6 against a noise of 1e-10 (cond Λ about 1e19); and a
/// walk with process noise 1e-30 read with unit noise at each of 20 000 epochs (rows of 1e15
/// against rows of 1). Both models are linear, so the result is the RTS smoother's: means to 1e-6
/// standard deviations and covariances to a relative 1e-6 (measured: 2e-8 and 3e-12; the
/// covariances from the normal matrix could not be factored, and a QR without row pivoting gave
/// the walk a variance of 0.22 where 1/20 001 is exact).
#[test]
fn an_ill_conditioned_trajectory_is_smoothed_like_rts() {
    let q = 1e-10;
    let track = ProcessFn::new(
        |x: &Rn<f64, 2>, (): &()| Rn::new_unchecked(Matrix2::new(1.0, 1.0, 0.0, 1.0) * x.coords()),
        move |_, ()| Matrix2::new(1.0 / 3.0, 0.5, 0.5, 1.0) * q,
    )
    .with_jacobian(|_, ()| Matrix2::new(1.0, 1.0, 0.0, 1.0));
    let position = MeasurementFn::new(
        |x: &Rn<f64, 2>| Vector1::new(x.coords()[0]),
        |_| Matrix1::new(1.0),
    )
    .with_jacobian(|_: &Rn<f64, 2>| RowVector2::new(1.0, 0.0));
    let prior = ManifoldGaussian::new(
        Rn::new(Vector2::new(0.5, -0.2)).unwrap(),
        Matrix2::identity(),
    )
    .unwrap();
    let mut smoother = IteratedSmoother::new(prior);
    for _ in 0..1000 {
        smoother.propagate(&track, &()).unwrap();
    }
    check_against_rts(&smoother, &track, &position);

    let walk = ProcessFn::new(|x: &Rn<f64, 1>, (): &()| *x, |_, ()| Matrix1::new(1e-30))
        .with_jacobian(|_, ()| Matrix1::identity());
    let reading = MeasurementFn::new(|x: &Rn<f64, 1>| *x.coords(), |_| Matrix1::new(1.0))
        .with_jacobian(|_: &Rn<f64, 1>| Matrix1::identity());
    let prior =
        ManifoldGaussian::new(Rn::new(Vector1::new(0.0)).unwrap(), Matrix1::new(1.0)).unwrap();
    let mut smoother = IteratedSmoother::new(prior);
    for k in 0..20_000 {
        smoother.propagate(&walk, &()).unwrap();
        smoother
            .condition(&reading, &Vector1::new((f64::from(k) * 0.7).sin()))
            .unwrap();
    }
    check_against_rts(&smoother, &walk, &reading);
}

/// The iterated smoother's result against the RTS smoother of its forward pass.
fn check_against_rts<const D: usize, const M: usize>(
    smoother: &IteratedSmoother<Rn<f64, D>, (), D, M>,
    process: &impl ProcessModel<Rn<f64, D>, D, Input = ()>,
    measurement: &impl MeasurementModel<Rn<f64, D>, D, M>,
) {
    let iterated = smoother.smooth(process, measurement).unwrap();
    let rts = smoother.forward().smooth().unwrap();
    for (k, (a, b)) in iterated.densities.iter().zip(&rts).enumerate() {
        let scale = b.covariance().amax().sqrt();
        let mean = (a.mean().coords() - b.mean().coords()).amax() / scale;
        let covariance = (a.covariance() - b.covariance()).amax() / b.covariance().amax();
        assert!(
            mean < 1e-6 && covariance < 1e-6,
            "epoch {k}: mean off by {mean:e} σ, covariance by {covariance:e}"
        );
    }
}

/// A square root that leaves a state undetermined is refused, as are rows of the wrong width,
/// entries that are not finite and epochs past the last.
#[test]
fn block_jacobians_refuse_bad_rows() {
    // Epoch 1 has no rows at all: Λ is singular.
    let mut jacobian = BlockJacobian::<2>::new(2).unwrap();
    jacobian
        .add_rows(0, DMatrix::<f64>::identity(2, 2).as_view())
        .unwrap();
    for backend in [Backend::FixedSize, Backend::Faer] {
        assert!(matches!(
            jacobian.factor_with(backend),
            Err(OperatorError::NotPositiveDefinite { .. })
        ));
    }
    jacobian
        .set_transition(0, -Matrix2::identity(), Matrix2::identity())
        .unwrap();
    assert!(jacobian.factor().is_ok());
    assert!(matches!(
        BlockJacobian::<2>::new(0),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        jacobian.add_rows(0, DMatrix::<f64>::zeros(1, 3).as_view()),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        jacobian.add_rows(2, DMatrix::<f64>::zeros(1, 2).as_view()),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        jacobian.add_rows(0, DMatrix::from_element(1, 2, f64::NAN).as_view()),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(matches!(
        jacobian.set_transition(1, Matrix2::identity(), Matrix2::identity()),
        Err(OperatorError::OutOfRange { .. })
    ));
    assert!(matches!(
        jacobian.set_transition(0, Matrix2::identity() * f64::INFINITY, Matrix2::identity()),
        Err(OperatorError::NonFinite { .. })
    ));
    // Refused calls leave the rows as they were.
    assert_eq!(
        jacobian.normal().unwrap().diagonal()[1],
        Matrix2::identity()
    );
    // Entries whose products overflow: an error or finite factors, never a panic or a NaN.
    for huge in [1e200, f64::MAX] {
        let mut jacobian = BlockJacobian::<2>::new(3).unwrap();
        for k in 0..3 {
            jacobian
                .add_rows(k, DMatrix::from_element(2, 2, huge).as_view())
                .unwrap();
            if k < 2 {
                jacobian
                    .set_transition(k, Matrix2::identity() * -huge, Matrix2::identity())
                    .unwrap();
            }
        }
        for backend in [Backend::FixedSize, Backend::Faer] {
            if let Ok(factor) = jacobian.factor_with(backend) {
                if let Ok(marginals) = factor.marginal_covariances() {
                    assert!(marginals.iter().all(|m| m.iter().all(|v| v.is_finite())));
                }
            }
        }
    }
}

/// The square root of a walk with process noise 1e-30 (transition rows of 1e15) read with unit
/// noise at each of 2 000 epochs after a unit prior: every epoch's variance is 1/2 001 (to a
/// relative 1e-27), on both backends, the large rows reduced before the small ones.
#[test]
fn rows_of_very_different_scales_keep_the_small_ones() {
    let epochs = 2001;
    let mut jacobian = BlockJacobian::<1>::new(epochs).unwrap();
    let one = DMatrix::from_element(1, 1, 1.0);
    for k in 0..epochs {
        jacobian.add_rows(k, one.as_view()).unwrap();
        if k + 1 < epochs {
            jacobian
                .set_transition(k, Matrix1::new(-1e15), Matrix1::new(1e15))
                .unwrap();
        }
    }
    let exact = 1.0 / 2001.0;
    for backend in [Backend::FixedSize, Backend::Faer] {
        let marginals = jacobian
            .factor_with(backend)
            .unwrap()
            .marginal_covariances()
            .unwrap();
        for (k, variance) in marginals.iter().enumerate() {
            let error = (variance[0] - exact).abs() / exact;
            assert!(error < 1e-9, "{backend:?}, epoch {k}: off by {error:e}");
        }
    }
}
