//! The RTS smoother against independent computations:
//!
//! * linear models on R²: the batch least-squares solution (the joint Gaussian of the whole
//!   trajectory in information form, solved by one dense Cholesky factorisation), means and marginal
//!   covariances to 1e-9, with the EKF's and the UKF's recordings;
//! * SO(2) with a nonlinear drift, across the ±π cut: the exact smoothed posterior by forward-backward
//!   on a grid of 2048 angles; the smoothed means within a bound derived from the linearisation
//!   error, and to 1e-9 when the model is linear in the angle;
//! * SO(3): on simulated attitude trajectories the smoothed error is smaller than the filtered one.

use liebayes_densities::{Density, Gaussian, ManifoldGaussian};
use liebayes_manifolds::{GroupAction, LieGroup, Manifold, Rn, So2, So3};
use liebayes_operators::smoother::{RtsSmoother, smooth_records};
use liebayes_operators::{Ekf, MeasurementFn, OperatorError, ProcessFn, Ukf};
use nalgebra::{
    DMatrix, DVector, Matrix1, Matrix2, Matrix3, RowVector2, SMatrix, SVector, Vector1, Vector2,
    Vector3,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// `a ⊟ b` on SO(2): the difference a − b wrapped to (−π, π] by the group, not by hand.
fn wrapped(a: f64, b: f64) -> f64 {
    So2::from_angle_unchecked(b).local(&So2::from_angle_unchecked(a))[0]
}

/// The smoothed means and covariances of `x_{k+1} = F x_k + u + w`, `z_k = H x_k + n` (z_0 included)
/// from the information form of the joint density of `(x_0, …, x_K)`:
/// `Λ = blockdiag(P₀⁻¹) + Σ_k Aₖᵀ Q⁻¹ Aₖ + Σ_k Hₖᵀ R⁻¹ Hₖ` with `Aₖ = [… −F I …]`, and the
/// corresponding information vector; mean `Λ⁻¹ η`, covariances the diagonal blocks of `Λ⁻¹`.
#[allow(clippy::too_many_arguments)]
fn batch_least_squares(
    m0: &Vector2<f64>,
    p0: &Matrix2<f64>,
    f: &Matrix2<f64>,
    u: &Vector2<f64>,
    q: &Matrix2<f64>,
    h: &RowVector2<f64>,
    r: f64,
    zs: &[f64],
) -> Vec<(Vector2<f64>, Matrix2<f64>)> {
    let epochs = zs.len();
    let n = 2 * epochs;
    let mut lambda = DMatrix::<f64>::zeros(n, n);
    let mut eta = DVector::<f64>::zeros(n);
    let p0_inv = p0.try_inverse().unwrap();
    let q_inv = q.try_inverse().unwrap();
    let add = |lambda: &mut DMatrix<f64>, i: usize, j: usize, block: &Matrix2<f64>| {
        let mut view = lambda.view_mut((2 * i, 2 * j), (2, 2));
        view += block;
    };
    add(&mut lambda, 0, 0, &p0_inv);
    eta.rows_mut(0, 2).copy_from(&(p0_inv * m0));
    for k in 0..epochs - 1 {
        // (x_{k+1} − F x_k − u)ᵀ Q⁻¹ (…)
        add(&mut lambda, k, k, &(f.transpose() * q_inv * f));
        add(&mut lambda, k, k + 1, &(-f.transpose() * q_inv));
        add(&mut lambda, k + 1, k, &(-q_inv * f));
        add(&mut lambda, k + 1, k + 1, &q_inv);
        let mut ek = eta.rows_mut(2 * k, 2);
        ek -= f.transpose() * q_inv * u;
        let mut ek1 = eta.rows_mut(2 * k + 2, 2);
        ek1 += q_inv * u;
    }
    for (k, z) in zs.iter().enumerate() {
        add(&mut lambda, k, k, &(h.transpose() * h / r));
        let mut ek = eta.rows_mut(2 * k, 2);
        ek += h.transpose() * (z / r);
    }
    let factor = lambda.cholesky().unwrap();
    let mean = factor.solve(&eta);
    let covariance = factor.inverse();
    (0..epochs)
        .map(|k| {
            (
                Vector2::new(mean[2 * k], mean[2 * k + 1]),
                covariance.fixed_view::<2, 2>(2 * k, 2 * k).into_owned(),
            )
        })
        .collect()
}

#[test]
fn linear_smoothing_equals_batch_least_squares() {
    let dt = 0.5_f64;
    let f = Matrix2::new(1.0, dt, 0.0, 1.0);
    let q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.3;
    let u = Vector2::new(0.05, -0.02);
    let h = RowVector2::new(1.0, 0.0);
    let r = 0.25;
    let (m0, p0) = (Vector2::new(1.0, -0.5), Matrix2::new(2.0, 0.3, 0.3, 1.0));
    let process = ProcessFn::new(
        move |x: &Rn<f64, 2>, u: &Vector2<f64>| Rn::new_unchecked(f * x.coords() + u),
        move |_, _| q,
    )
    .with_jacobian(move |_, _| f);
    let measurement = MeasurementFn::new(
        move |x: &Rn<f64, 2>| Vector1::new((h * x.coords())[0]),
        move |_| Matrix1::new(r),
    );
    // Simulated measurements (their values do not matter for the identity, only that they vary).
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let noise = Gaussian::new(Vector1::zeros(), Matrix1::new(r)).unwrap();
    let mut truth = Vector2::new(1.0, 0.2);
    let zs: Vec<f64> = (0..40)
        .map(|k| {
            if k > 0 {
                truth = f * truth + u;
            }
            (h * truth)[0] + noise.sample(&mut rng)[0]
        })
        .collect();
    let batch = batch_least_squares(&m0, &p0, &f, &u, &q, &h, r, &zs);
    let prior = ManifoldGaussian::new(Rn::new_unchecked(m0), p0).unwrap();
    for unscented in [false, true] {
        let mut rts = RtsSmoother::with_capacity(prior.clone(), zs.len() - 1).unwrap();
        for (k, z) in zs.iter().enumerate() {
            if k > 0 {
                if unscented {
                    rts.propagate(&Ukf::new(&process), &u).unwrap();
                } else {
                    rts.propagate(&Ekf(&process), &u).unwrap();
                }
            }
            rts.condition(&Ekf(&measurement), &Vector1::new(*z))
                .unwrap();
        }
        let smoothed = rts.smooth().unwrap();
        assert_eq!(smoothed.len(), batch.len());
        for (k, (s, (mean, covariance))) in smoothed.iter().zip(&batch).enumerate() {
            let mean_error = (s.mean().coords() - mean).amax() / (1.0 + mean.amax());
            let cov_error = (s.covariance() - covariance).amax() / covariance.amax();
            assert!(
                mean_error < 1e-9 && cov_error < 1e-9,
                "epoch {k} (unscented {unscented}): mean off by {mean_error:e}, covariance by \
                 {cov_error:e}"
            );
        }
        // The last smoothed density is the last filtered one, and smoothing shrinks the others.
        assert_eq!(
            smoothed.last().unwrap().mean().coords(),
            rts.current().mean().coords()
        );
        assert!(smoothed[0].covariance()[(0, 0)] < rts.filtered()[0].covariance()[(0, 0)]);
        // The backward pass over a record kept elsewhere is the recorder's, and a record with
        // mismatched lengths is refused.
        assert_eq!(
            smooth_records(rts.filtered(), rts.transitions()).unwrap(),
            smoothed
        );
        assert!(matches!(
            smooth_records(&rts.filtered()[1..], rts.transitions()),
            Err(OperatorError::OutOfRange { .. })
        ));
    }
}

/// `θ′ = θ + ω + a sin θ + w`, `w ~ N(0, q)`: a drift on the circle, nonlinear for a ≠ 0.
fn drift(
    a: f64,
    omega: f64,
    q: f64,
) -> impl liebayes_operators::ProcessModel<So2<f64>, 1, Input = ()> {
    ProcessFn::new(
        move |x: &So2<f64>, (): &()| x.retract(&Vector1::new(omega + a * x.angle().sin())),
        move |_, ()| Matrix1::new(q),
    )
    .with_jacobian(move |x: &So2<f64>, (): &()| Matrix1::new(1.0 + a * x.angle().cos()))
}

/// Forward-backward on n cells `θⱼ = 2πj/n` with the transition density
/// `p(θ′ | θ) = Σ_m N(θ′ − f(θ) + 2πm; 0, q)` (wrapped normal) and likelihood `N(z ⊟ θ; 0, r)`:
/// returns, per epoch, the smoothed cell weights. The transition kernel is truncated at 12 standard
/// deviations (the omitted mass, below 1e-32, is far under the rounding of the weights).
// Cell indices of a grid of a few thousand cells and angles in (−2π, 2π): the casts are exact.
#[allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap
)]
fn grid_smoother(
    n: usize,
    prior: (f64, f64),
    f: impl Fn(f64) -> f64,
    q: f64,
    r: f64,
    zs: &[f64],
) -> Vec<Vec<f64>> {
    let cell = |j: usize| 2.0 * PI * j as f64 / n as f64;
    let gaussian = |d: f64, v: f64| (-0.5 * d * d / v).exp();
    let normalise = |w: &mut Vec<f64>| {
        let total: f64 = w.iter().sum();
        for v in w.iter_mut() {
            *v /= total;
        }
    };
    let likelihood =
        |z: f64| -> Vec<f64> { (0..n).map(|j| gaussian(wrapped(z, cell(j)), r)).collect() };
    let reach = (12.0 * q.sqrt() * n as f64 / (2.0 * PI)).ceil() as usize;
    // kernel(i) = (first cell, normalised weights) of p(θ′ | θᵢ) on the cells.
    let kernel: Vec<(isize, Vec<f64>)> = (0..n)
        .map(|i| {
            let image = f(cell(i));
            let centre = (image / (2.0 * PI) * n as f64).round() as isize;
            let first = centre - reach as isize;
            let mut weights = (0..=2 * reach)
                .map(|k| {
                    let theta = 2.0 * PI * (first + k as isize) as f64 / n as f64;
                    gaussian(wrapped(theta, image), q)
                })
                .collect();
            normalise(&mut weights);
            (first, weights)
        })
        .collect();
    let index = |j: isize| j.rem_euclid(n as isize) as usize;
    let (m0, p0) = prior;
    let mut filtered: Vec<Vec<f64>> = Vec::with_capacity(zs.len());
    let mut predicted: Vec<Vec<f64>> = Vec::with_capacity(zs.len());
    for (k, z) in zs.iter().enumerate() {
        let mut w: Vec<f64> = if k == 0 {
            (0..n).map(|j| gaussian(wrapped(cell(j), m0), p0)).collect()
        } else {
            let previous = &filtered[k - 1];
            let mut next = vec![0.0; n];
            for (i, (first, weights)) in kernel.iter().enumerate() {
                for (d, kw) in weights.iter().enumerate() {
                    next[index(first + d as isize)] += previous[i] * kw;
                }
            }
            next
        };
        normalise(&mut w);
        predicted.push(w.clone());
        for (v, l) in w.iter_mut().zip(likelihood(*z)) {
            *v *= l;
        }
        normalise(&mut w);
        filtered.push(w);
    }
    // Backward: p_s,k(θ) = p_f,k(θ) Σ_θ′ p(θ′ | θ) p_s,k+1(θ′) / p_p,k+1(θ′).
    let mut smoothed = vec![filtered[zs.len() - 1].clone()];
    for k in (0..zs.len() - 1).rev() {
        let next = smoothed.last().unwrap();
        let ratio: Vec<f64> = next
            .iter()
            .zip(&predicted[k + 1])
            .map(|(s, p)| if *p > 0.0 { s / p } else { 0.0 })
            .collect();
        let mut w: Vec<f64> = kernel
            .iter()
            .zip(&filtered[k])
            .map(|((first, weights), pf)| {
                pf * weights
                    .iter()
                    .enumerate()
                    .map(|(d, kw)| kw * ratio[index(first + d as isize)])
                    .sum::<f64>()
            })
            .collect();
        normalise(&mut w);
        smoothed.push(w);
    }
    smoothed.reverse();
    smoothed
}

/// The mean on the circle of grid weights: the fixed point of `m ← m + Σ wⱼ (θⱼ ⊟ m)` (the same
/// definition as the Gaussian's mean, `E[x ⊟ μ] = 0`), and the variance `Σ wⱼ (θⱼ ⊟ m)²`.
fn grid_mean(weights: &[f64], start: f64) -> (f64, f64) {
    let n = weights.len();
    let cell = |j: usize| 2.0 * PI * j as f64 / n as f64;
    let mut m = start;
    for _ in 0..50 {
        let step: f64 = weights
            .iter()
            .enumerate()
            .map(|(j, w)| w * wrapped(cell(j), m))
            .sum();
        m += step;
        if step.abs() < 1e-15 {
            break;
        }
    }
    let variance = weights
        .iter()
        .enumerate()
        .map(|(j, w)| w * wrapped(cell(j), m).powi(2))
        .sum();
    (m, variance)
}

/// Densities of a heading, one per epoch.
type Headings = Vec<ManifoldGaussian<So2<f64>, 1>>;

/// The EKF smoother on the drift model with a heading measurement; returns the smoothed densities,
/// and the filtered ones.
fn ekf_smoother(
    a: f64,
    omega: f64,
    q: f64,
    r: f64,
    prior: (f64, f64),
    zs: &[f64],
) -> Result<(Headings, Headings), OperatorError> {
    let process = drift(a, omega, q);
    let heading = MeasurementFn::new(
        |x: &So2<f64>| Vector1::new(x.angle()),
        move |_| Matrix1::new(r),
    )
    .with_residual(|z: &Vector1<f64>, p: &Vector1<f64>| Vector1::new(wrapped(z[0], p[0])))
    .with_jacobian(|_: &So2<f64>| Matrix1::new(1.0));
    let start = ManifoldGaussian::new(So2::from_angle_unchecked(prior.0), Matrix1::new(prior.1))?;
    let mut rts = RtsSmoother::new(start);
    for (k, z) in zs.iter().enumerate() {
        if k > 0 {
            rts.propagate(&Ekf(&process), &())?;
        }
        rts.condition(&Ekf(&heading), &Vector1::new(*z))?;
    }
    Ok((rts.smooth()?, rts.filtered().to_vec()))
}

/// Simulated headings of the drift model from `start`, wrapped to (−π, π].
fn simulate_headings(
    a: f64,
    omega: f64,
    q: f64,
    r: f64,
    start: f64,
    epochs: usize,
    seed: u64,
) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (w, n) = (
        Gaussian::new(Vector1::zeros(), Matrix1::new(q)).unwrap(),
        Gaussian::new(Vector1::zeros(), Matrix1::new(r)).unwrap(),
    );
    let mut theta = start;
    (0..epochs)
        .map(|k| {
            if k > 0 {
                theta += omega + a * theta.sin() + w.sample(&mut rng)[0];
            }
            wrapped(theta + n.sample(&mut rng)[0], 0.0)
        })
        .collect()
}

#[test]
fn so2_smoothing_equals_the_grid_when_the_model_is_linear_in_the_angle() {
    // a = 0: the model is linear on the circle's universal cover, so the smoother is exact up to the
    // Gaussian mass wrapped past ±π (below 1e-40 at these spreads) and the grid's quadrature
    // (spectrally accurate: 2048 cells put about 8 cells in the smallest standard deviation). The
    // trajectory crosses the cut.
    let (omega, q, r, prior) = (
        0.04,
        0.02_f64.powi(2),
        0.05_f64.powi(2),
        (2.9, 0.1_f64.powi(2)),
    );
    let zs = simulate_headings(0.0, omega, q, r, prior.0, 20, 5);
    let (smoothed, _) = ekf_smoother(0.0, omega, q, r, prior, &zs).unwrap();
    let grid = grid_smoother(2048, prior, |t| t + omega, q, r, &zs);
    for (k, (s, w)) in smoothed.iter().zip(&grid).enumerate() {
        let (m, v) = grid_mean(w, s.mean().angle());
        let error = wrapped(s.mean().angle(), m).abs();
        assert!(error < 1e-9, "epoch {k}: mean off by {error:e}");
        assert!(
            (s.covariance()[0] / v - 1.0).abs() < 1e-8,
            "epoch {k}: {} vs {v}",
            s.covariance()[0]
        );
    }
    assert!(
        zs.iter().any(|z| *z < 0.0) && zs.iter().any(|z| *z > 3.0),
        "the cut is crossed"
    );
}

/// With the drift `a sin θ` the EKF smoother is approximate. Its error against the exact smoother
/// (the grid) is bounded at leading order in the noise by the linearisation error of each step:
///
/// * a prediction's mean: `E[a sin(μ + δ)] − a sin μ = a sin μ (e^(−P/2) − 1)`, at most `|a| P_f / 2`;
/// * the skewness of the predicted density, third cumulant `κ₃ ≈ 3 F² f″ P_f²`, which moves the
///   posterior mean after a measurement by `R κ₃ (u² − 1) / (2 S²)` (the first Edgeworth term, u the
///   normalised innovation), at most `(3/8) |a| P_f |u² − 1|` since `R F² P_f ≤ S² / 4`;
/// * the backward step's linearisation, by the same two terms (it conditions the same linearised
///   joint density of two consecutive states).
///
/// The transition j → j + 1 thus errs by at most `e_j = 2 |a| P_f,j (1/2 + (3/8) |u_j+1² − 1|)`, and
/// that error reaches epoch k through the filter's and the smoother's gains, shrinking by
/// `ρ_i = max(|F_i (1 − K_i+1)|, |G_i|) < 1` at each transition i in between, so that epoch k's mean
/// is within `Σ_j e_j Π_i ρ_i` of the exact one. The next terms of the expansion are smaller by a
/// factor of order P ≈ 1e-3. (Measured: the errors are 3 to 8 % of the bound, which is itself below
/// a tenth of the posterior's standard deviation, so that a wrong gain or Jacobian would exceed it.)
#[test]
fn so2_smoothing_is_within_the_linearisation_error_of_the_grid() {
    let (a, omega, q, r, prior) = (
        0.3,
        0.1,
        0.03_f64.powi(2),
        0.05_f64.powi(2),
        (2.5, 0.1_f64.powi(2)),
    );
    let zs = simulate_headings(a, omega, q, r, prior.0, 25, 9);
    let (smoothed, filtered) = ekf_smoother(a, omega, q, r, prior, &zs).unwrap();
    let grid = grid_smoother(2048, prior, |t| t + omega + a * t.sin(), q, r, &zs);
    // Per transition j → j + 1: the linearisation error e_j and the contraction factor ρ_j, from
    // the filter's own quantities.
    let transitions: Vec<(f64, f64)> = (0..zs.len() - 1)
        .map(|j| {
            let (m, pf) = (filtered[j].mean().angle(), filtered[j].covariance()[0]);
            let f = 1.0 + a * m.cos();
            let pp = f * f * pf + q;
            let s = pp + r;
            let u2 = wrapped(zs[j + 1], m + omega + a * m.sin()).powi(2) / s;
            let e = 2.0 * a.abs() * pf * (0.5 + 0.375 * (u2 - 1.0).abs());
            let rho = (f * (1.0 - pp / s)).abs().max((pf * f / pp).abs());
            (e, rho)
        })
        .collect();
    for (k, (s, w)) in smoothed.iter().zip(&grid).enumerate() {
        // Errors made at transition j reach epoch k through the transitions between them.
        let bound: f64 = transitions
            .iter()
            .enumerate()
            .map(|(j, (e, _))| {
                let between = if k > j { j + 1..k } else { k..j };
                e * transitions[between].iter().map(|t| t.1).product::<f64>()
            })
            .sum();
        let (m, v) = grid_mean(w, s.mean().angle());
        let error = wrapped(s.mean().angle(), m).abs();
        assert!(
            error <= bound,
            "epoch {k}: mean error {error:e} above the bound {bound:e}"
        );
        // Not vacuous: the bound is a small fraction of the posterior's spread.
        assert!(
            bound < 0.2 * v.sqrt(),
            "epoch {k}: bound {bound:e}, standard deviation {:e}",
            v.sqrt()
        );
    }
    assert!(transitions.iter().all(|t| t.1 < 1.0));
}

/// `R′ = R Δ exp(w)` with a gyro increment Δ, and two directions measured in the body frame.
#[test]
fn so3_smoothing_reduces_the_error_on_average() {
    let increment = So3::exp(&Vector3::new(0.02, 0.05, -0.03));
    let q = Matrix3::identity() * 0.01_f64.powi(2);
    let process = ProcessFn::new(
        move |x: &So3<f64>, (): &()| x.compose(&increment),
        move |_, ()| q,
    );
    let sigma = 0.05;
    let directions = |x: &So3<f64>| {
        let g = x.inverse().act(&Vector3::new(0.0, 0.0, 1.0));
        let m = x.inverse().act(&Vector3::new(0.6, 0.0, 0.8));
        SVector::<f64, 6>::from_iterator(g.iter().chain(m.iter()).copied())
    };
    let sensors = MeasurementFn::new(directions, move |_| {
        SMatrix::<f64, 6, 6>::identity() * (sigma * sigma)
    });
    let (runs, epochs) = (40, 30);
    let (mut filtered_sq, mut smoothed_sq, mut paired) = (0.0, 0.0, Vec::new());
    for run in 0..runs {
        let mut rng = ChaCha8Rng::seed_from_u64(run);
        let prior = ManifoldGaussian::new(
            So3::exp(&Vector3::new(0.5, -1.0, 2.0)),
            Matrix3::identity() * 0.04,
        )
        .unwrap();
        let mut truth = prior.sample(&mut rng);
        let mut rts = RtsSmoother::with_capacity(prior, epochs).unwrap();
        let mut truths = Vec::with_capacity(epochs + 1);
        let noise = Gaussian::new(
            SVector::<f64, 6>::zeros(),
            SMatrix::<f64, 6, 6>::identity() * (sigma * sigma),
        )
        .unwrap();
        for k in 0..=epochs {
            if k > 0 {
                truth = ManifoldGaussian::new(truth.compose(&increment), q)
                    .unwrap()
                    .sample(&mut rng);
                rts.propagate(&Ukf::new(&process), &()).unwrap();
            }
            let z = directions(&truth) + noise.sample(&mut rng);
            rts.condition(&Ekf(&sensors), &z).unwrap();
            truths.push(truth);
        }
        let smoothed = rts.smooth().unwrap();
        for ((f, s), t) in rts.filtered().iter().zip(&smoothed).zip(&truths) {
            let (ef, es) = (
                f.mean().local(t).norm_squared(),
                s.mean().local(t).norm_squared(),
            );
            filtered_sq += ef;
            smoothed_sq += es;
            paired.push(ef - es);
        }
    }
    // The paired differences of squared errors: their mean must be positive beyond 3 standard errors.
    let n = paired.len() as f64;
    let mean = paired.iter().sum::<f64>() / n;
    let sd = (paired.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(
        mean > 3.0 * sd / n.sqrt(),
        "mean reduction {mean:e}, standard error {:e}",
        sd / n.sqrt()
    );
    assert!(smoothed_sq < filtered_sq);
}

/// A failed step returns its typed error and leaves the recorder as it was.
#[test]
fn failed_steps_leave_the_recorder_unchanged() {
    let prior = ManifoldGaussian::new(So2::from_angle_unchecked(1.0), Matrix1::new(0.1)).unwrap();
    let mut rts = RtsSmoother::new(prior);
    let bad_noise = ProcessFn::new(|x: &So2<f64>, (): &()| *x, |_, ()| Matrix1::new(f64::NAN));
    assert!(matches!(
        rts.propagate(&Ekf(&bad_noise), &()),
        Err(OperatorError::NonFinite { .. })
    ));
    assert!(rts.propagate(&Ukf::new(&bad_noise), &()).is_err());
    let bad_prediction = MeasurementFn::new(
        |_: &So2<f64>| Vector1::new(f64::NAN),
        |_| Matrix1::new(0.01),
    )
    .with_jacobian(|_: &So2<f64>| Matrix1::new(1.0));
    assert!(matches!(
        rts.condition(&Ekf(&bad_prediction), &Vector1::new(0.5)),
        Err(OperatorError::NonFinite { .. })
    ));
    let heading = MeasurementFn::new(
        |x: &So2<f64>| Vector1::new(x.angle()),
        |_| Matrix1::new(0.01),
    );
    assert!(matches!(
        rts.condition(&Ekf(&heading), &Vector1::new(f64::INFINITY)),
        Err(OperatorError::NonFinite { .. })
    ));
    assert_eq!(rts.filtered().len(), 1);
    assert_eq!(rts.current().mean().angle(), 1.0);
    assert_eq!(rts.current().covariance()[0], 0.1);
    // The smoother of a single epoch is its filtered density.
    let smoothed = rts.smooth().unwrap();
    assert_eq!(smoothed.len(), 1);
    assert_eq!(smoothed[0].mean().angle(), 1.0);
}

/// A random walk `x′ = x + w`, `z = x + n` with q = r = 1 and a diffuse prior of variance p₀,
/// measured at epochs 1 and 2: the smoothed variance of epoch 0 is `5 / (3 + 5/p₀)`. The
/// textbook backward sum `P_f + G (P_s′ − P_p) Gᵀ` cancels terms of size p₀: it returned 1.875
/// at p₀ = 1e15 and 32 at 1e17 as Ok, and from then on such steps were refused. Joseph's form
/// sums positive terms and gives 5/3 to rounding at every p₀ up to the densities' limit, with the
/// EKF's and the UKF's records alike, as the iterated smoother (its own square-root solve) does.
#[test]
fn a_diffuse_prior_is_smoothed_to_its_rounding() {
    use liebayes_operators::iterated_smoother::IteratedSmoother;
    // Analytic Jacobians: the EKF's numeric ones are off by about 1e-11.
    let walk = ProcessFn::new(
        |x: &Rn<f64, 1>, (): &()| *x,
        |_: &Rn<f64, 1>, (): &()| Matrix1::new(1.0),
    )
    .with_jacobian(|_: &Rn<f64, 1>, (): &()| Matrix1::identity());
    let sensor = MeasurementFn::new(
        |x: &Rn<f64, 1>| *x.coords(),
        |_: &Rn<f64, 1>| Matrix1::new(1.0),
    )
    .with_jacobian(|_: &Rn<f64, 1>| Matrix1::identity());
    for p0 in [1e10, 1e15, 1e17, 1e20, 1e50, 1e99] {
        // The information form of the three epochs: Λ = [[1/p₀ + 1, −1, 0], [−1, 3, −1],
        // [0, −1, 2]], η = (0, z₁, z₂); epoch 0's variance (Λ⁻¹)₀₀ and mean (2 z₁ + z₂) / det Λ.
        let det = 3.0 + 5.0 / p0;
        let (exact, exact_mean) = (5.0 / det, (2.0 * 0.5 - 0.25) / det);
        let prior =
            ManifoldGaussian::new(Rn::new(Vector1::new(0.0)).unwrap(), Matrix1::new(p0)).unwrap();
        let mut ekf = RtsSmoother::new(prior.clone());
        let mut ukf = RtsSmoother::new(prior.clone());
        let mut iterated = IteratedSmoother::<Rn<f64, 1>, (), 1, 1>::new(prior);
        for z in [0.5, -0.25] {
            ekf.propagate(&Ekf(&walk), &()).unwrap();
            ekf.condition(&Ekf(&sensor), &Vector1::new(z)).unwrap();
            ukf.propagate(&Ukf::new(&walk), &()).unwrap();
            ukf.condition(&Ukf::new(&sensor), &Vector1::new(z)).unwrap();
            iterated.propagate(&walk, &()).unwrap();
            iterated.condition(&sensor, &Vector1::new(z)).unwrap();
        }
        for (name, rts) in [("EKF", &ekf), ("UKF", &ukf)] {
            let smoothed = rts.smooth().unwrap();
            let variance = smoothed[0].covariance()[(0, 0)];
            assert!(
                (variance / exact - 1.0).abs() < 1e-12,
                "{name}, {p0:e}: {variance}"
            );
            let mean = smoothed[0].mean().coords()[0];
            assert!(
                (mean / exact_mean - 1.0).abs() < 1e-12,
                "{name}, {p0:e}: mean {mean}"
            );
        }
        let smoothed = iterated.smooth(&walk, &sensor).unwrap();
        let variance = smoothed.densities[0].covariance()[(0, 0)];
        assert!((variance / exact - 1.0).abs() < 1e-9, "{p0:e}: {variance}");
    }
}
