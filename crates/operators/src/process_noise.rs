//! Process noise from a continuous model: Van Loan's discretisation, the white-noise blocks of the
//! kinematic models, and the transport of a covariance between the body-frame and world-frame
//! error conventions.
//!
//! * [`van_loan`]: `ẋ = A x + G w`, `E[w(t) w(s)ᵀ] = Q_c δ(t − s)`, sampled every `dt`, is
//!   `x_{k+1} = Φ x_k + w_k` with `Φ = exp(A dt)` and
//!   `Q = ∫₀^dt exp(A s) G Q_c Gᵀ exp(A s)ᵀ ds`, both read off one matrix exponential
//!   (C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans. Automatic
//!   Control 23(3), 1978): `exp([[−A, G Q_c Gᵀ], [0, Aᵀ]] dt) = [[·, C₁₂], [0, C₂₂]]`,
//!   `Φ = C₂₂ᵀ`, `Q = Φ C₁₂`.
//! * [`continuous_white_noise`]: that integral in closed form for a chain of N integrators driven by
//!   white noise on its last derivative (N = 2: constant velocity, 3: constant acceleration):
//!   `Q_ij = q dt^(2N−1−i−j) / ((N−1−i)! (N−1−j)! (2N−1−i−j))`.
//! * [`piecewise_white_noise`]: the discrete models (Bar-Shalom, Li and Kirubarajan, "Estimation
//!   with Applications to Tracking and Navigation", 2001, § 6.3), `Q = Γ Γᵀ σ²`: for N = 2 a
//!   piecewise-constant acceleration over each step, `Γ = [dt²/2, dt]`; for N ≥ 3 a piecewise-constant
//!   increment of the highest derivative, `Γ = [dt^(N−1)/(N−1)!, …, dt²/2, dt, 1]`. These are
//!   filterpy's `Q_discrete_white_noise(dim=N, dt, var)`.
//! * [`per_axis`]: one block per axis of motion, in the order `[x, ẋ, y, ẏ, …]`.
//! * [`world_from_body`] and [`body_from_world`]: with `x exp(δ_b) = exp(δ_w) x`, `δ_w = Ad(x) δ_b`,
//!   so a covariance moves as `P_w = Ad(x) P_b Ad(x)ᵀ` and back with `Ad(x⁻¹)`; exact for every x
//!   (the map is linear), so a process noise given in the body frame serves a world-frame filter
//!   ([`Left`]) and a density changes convention without loss.

use crate::OperatorError;
use crate::error::all_finite;
use crate::numerics::{binary_split, scale_by_power_of_two, symmetric_part};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::{Left, LieGroup};
use nalgebra::{DMatrix, SMatrix};

/// A continuous model sampled at one step: `x_{k+1} = Φ x_k + w_k`, `w_k ~ N(0, Q)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Discretized<const N: usize> {
    /// Φ = exp(A dt).
    pub transition: SMatrix<f64, N, N>,
    /// Q, symmetric positive semi-definite.
    pub noise: SMatrix<f64, N, N>,
}

/// Van Loan's discretisation of `ẋ = A x + G w`, `w` white with spectral density `Q_c` (L × L,
/// symmetric positive semi-definite), over a step `dt ≥ 0` (see the module docs for the formula).
///
/// Range: any finite A, G, Q_c and dt whose Van Loan exponential is representable: it holds
/// `exp(−A dt)` beside `exp(A dt)`, so a stable drift over a long step (A = −I, dt = 1e9, whose Φ
/// and Q are finite) overflows too. The matrix exponential (nalgebra's Padé approximant with
/// scaling and squaring) is accurate to a few ulp times `‖A dt‖` for a normal A (a rotation
/// `[[0, 1], [−1, 0]]` over dt = 4.9e9: Φ within 2e-7 of the rotation and orthogonal to 3e-7), so a
/// stiff A with a large dt loses digits before it overflows; a defective A loses far more, its
/// squarings amplifying rounding like `(1 + √ε)^(‖A dt‖)` (the nilpotent `[[1, 1], [−1, −1]]` over
/// dt = 1e6: Φ 5 % from `I + A dt`). It allocates one 2N × 2N matrix: call it once per distinct
/// dt, not per step.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite entry or an exponential that overflows (take
/// shorter steps), [`OperatorError::OutOfRange`] for a negative dt or a generator beyond its
/// bound, [`OperatorError::NotPositiveDefinite`] for a Q_c that is not symmetric positive
/// semi-definite.
///
/// # Example
/// A constant-velocity model with white acceleration noise of density q: Van Loan gives the closed
/// form of [`continuous_white_noise`].
/// ```
/// use liebayes_operators::process_noise::{continuous_white_noise, van_loan};
/// use nalgebra::{Matrix1, Matrix2, Vector2};
///
/// let (q, dt) = (0.3, 0.1);
/// let a = Matrix2::new(0.0, 1.0, 0.0, 0.0);
/// let model = van_loan(&a, &Vector2::new(0.0, 1.0), &Matrix1::new(q), dt)?;
/// assert!((model.transition - Matrix2::new(1.0, dt, 0.0, 1.0)).amax() < 1e-15);
/// assert!((model.noise - continuous_white_noise::<2>(dt, q)?).amax() < 1e-15);
/// # Ok::<(), liebayes_operators::OperatorError>(())
/// ```
pub fn van_loan<const N: usize, const L: usize>(
    drift: &SMatrix<f64, N, N>,
    noise_gain: &SMatrix<f64, N, L>,
    spectral_density: &SMatrix<f64, L, L>,
    dt: f64,
) -> Result<Discretized<N>, OperatorError> {
    const {
        assert!(L >= 1, "the noise has at least one component");
    };
    all_finite("drift matrix A", drift.iter())?;
    all_finite("noise gain G", noise_gain.iter())?;
    check_step(dt)?;
    check_semi_definite(
        spectral_density,
        "spectral density Q_c (give a symmetric positive semi-definite matrix)",
    )?;
    let diffusion = noise_gain * spectral_density * noise_gain.transpose();
    all_finite(
        "G Q_c G^T (the noise gain or the spectral density overflows)",
        diffusion.iter(),
    )?;
    let mut generator = DMatrix::<f64>::zeros(2 * N, 2 * N);
    generator.view_mut((0, 0), (N, N)).copy_from(&(-drift * dt));
    generator
        .view_mut((0, N), (N, N))
        .copy_from(&(diffusion * dt));
    generator
        .view_mut((N, N), (N, N))
        .copy_from(&(drift.transpose() * dt));
    all_finite(
        "A dt or G Q_c G^T dt (the step is too large for the model)",
        generator.iter(),
    )?;
    let norm = generator
        .column_iter()
        .map(|column| column.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    if norm > MAX_GENERATOR_NORM {
        return Err(OperatorError::OutOfRange {
            what: "one-norm of Van Loan's generator [[-A dt, G Q_c G^T dt], [0, A^T dt]]",
            value: norm,
            range: "[0, 1e10]: the matrix exponential is out of range (take shorter steps)",
        });
    }
    let exponential = generator.exp();
    let transition = exponential.fixed_view::<N, N>(N, N).transpose();
    let noise = symmetric_part(&(transition * exponential.fixed_view::<N, N>(0, N)));
    all_finite(
        "the discretised model Phi and Q (the exponential of Van Loan's generator, which holds \
         exp(A dt) and exp(-A dt), overflows: take shorter steps)",
        transition.iter().chain(noise.iter()),
    )?;
    Ok(Discretized { transition, noise })
}

/// The largest one-norm of Van Loan's generator [`van_loan`] exponentiates. The exponential squares
/// about log₂(‖G‖₁ / 5.4) times (31 at this bound). Its scaling estimates a one-norm of |G|²⁷,
/// at most ‖G‖₁²⁷: beyond about 2.6e11 that can overflow (a nilpotent drift with a long step,
/// whose own powers vanish), and the count of squarings with it, so that the call would not
/// return. At this bound ‖G‖₁²⁷ is 1e270.
const MAX_GENERATOR_NORM: f64 = 1e10;

/// The process noise of a chain of N integrators (position, velocity, …) driven by white noise of
/// spectral density q on its last derivative, over a step dt: the closed form of [`van_loan`],
/// `Q_ij = q dt^(2N−1−i−j) / ((N−1−i)! (N−1−j)! (2N−1−i−j))`, state order `[x, ẋ, ẍ, …]`. N = 2 is
/// the constant-velocity model `q [[dt³/3, dt²/2], [dt²/2, dt]]`, N = 3 the constant-acceleration one.
/// Range: N ≥ 1 (a compile-time check), any finite q ≥ 0 and dt ≥ 0 whose powers neither overflow
/// nor underflow into a matrix that is not positive semi-definite (entries below 2.2e-308 keep only
/// part of their precision).
///
/// # Errors
/// [`OperatorError::NonFinite`] or [`OperatorError::OutOfRange`] for a q or dt that is not a finite
/// number ≥ 0, [`OperatorError::NonFinite`] for a result that overflows,
/// [`OperatorError::NotPositiveDefinite`] for one whose entries underflow (below the smallest
/// normal number) so far that their rounding makes Q indefinite.
pub fn continuous_white_noise<const N: usize>(
    dt: f64,
    spectral_density: f64,
) -> Result<SMatrix<f64, N, N>, OperatorError> {
    const {
        assert!(N >= 1, "an integrator chain has at least one state");
    };
    check_step(dt)?;
    check_variance(spectral_density, "spectral density q")?;
    let q = SMatrix::<f64, N, N>::from_fn(|i, j| {
        let power = 2 * N - 1 - i - j;
        times_power(spectral_density, dt, power)
            / (factorial(N - 1 - i) * factorial(N - 1 - j) * power as f64)
    });
    all_finite("continuous white-noise Q (q dt^(2N-1) overflows)", q.iter())?;
    check_underflow(
        &q,
        spectral_density > 0.0 && dt > 0.0,
        "continuous white-noise Q (q dt^(2N-1) underflows: take a larger q or dt)",
    )?;
    Ok(q)
}

/// The discrete white-noise process noise of an N-state kinematic block (filterpy's
/// `Q_discrete_white_noise`): `Q = Γ Γᵀ σ²` with `Γ = [dt²/2, dt]` for N = 2 (a piecewise-constant
/// acceleration of variance σ² over each step) and `Γ = [dt^(N−1)/(N−1)!, …, dt, 1]` for N ≥ 3 (a
/// piecewise-constant increment of the highest derivative per step). State order `[x, ẋ, ẍ, …]`.
/// Range: N ≥ 2 (a compile-time check), any finite variance ≥ 0 and dt ≥ 0 whose powers neither
/// overflow nor underflow (as [`continuous_white_noise`]).
///
/// # Errors
/// As [`continuous_white_noise`].
///
/// # Example
/// ```
/// use liebayes_operators::process_noise::piecewise_white_noise;
/// use nalgebra::Matrix2;
///
/// let q = piecewise_white_noise::<2>(0.5, 2.0)?;
/// // σ² [[dt⁴/4, dt³/2], [dt³/2, dt²]]
/// assert_eq!(q, Matrix2::new(0.03125, 0.125, 0.125, 0.5));
/// # Ok::<(), liebayes_operators::OperatorError>(())
/// ```
pub fn piecewise_white_noise<const N: usize>(
    dt: f64,
    variance: f64,
) -> Result<SMatrix<f64, N, N>, OperatorError> {
    const {
        assert!(
            N >= 2,
            "a kinematic block has at least a position and a velocity"
        );
    };
    check_step(dt)?;
    check_variance(variance, "noise variance sigma^2")?;
    // Γ_i = dt^p / p!, p = N − i for N = 2 (the noise is one derivative beyond the state), N − 1 − i
    // otherwise (the noise drives the highest state).
    let beyond = usize::from(N == 2);
    let gamma = nalgebra::SVector::<f64, N>::from_fn(|i, _| {
        let power = N - 1 - i + beyond;
        integer_power(dt, power) / factorial(power)
    });
    let q = gamma * gamma.transpose() * variance;
    all_finite(
        "discrete white-noise Q (dt^(N-1) sigma overflows)",
        q.iter(),
    )?;
    check_underflow(
        &q,
        variance > 0.0 && dt > 0.0,
        "discrete white-noise Q (dt^N sigma^2 underflows: take a larger sigma or dt)",
    )?;
    Ok(q)
}

/// Checks a white-noise block whose exact entries are all positive (`positive`: q > 0 and dt > 0)
/// when one of them underflowed to zero or into the subnormal range, where each entry keeps only
/// part of its relative precision: the rounded matrix must still be positive semi-definite.
fn check_underflow<const N: usize>(
    q: &SMatrix<f64, N, N>,
    positive: bool,
    what: &'static str,
) -> Result<(), OperatorError> {
    if positive && q.iter().any(|v| *v < f64::MIN_POSITIVE) {
        check_semi_definite(q, what)?;
    }
    Ok(())
}

/// The block-diagonal process noise of several independent axes, each with the block `block` of B
/// states: T = B × axes states in the order `[x, ẋ, y, ẏ, …]` (axis by axis). T must be a multiple
/// of B (a compile-time check).
///
/// # Example
/// A constant-velocity model in the plane, state `[x, ẋ, y, ẏ]`:
/// ```
/// use liebayes_operators::process_noise::{per_axis, piecewise_white_noise};
/// use nalgebra::Matrix4;
///
/// let q: Matrix4<f64> = per_axis(&piecewise_white_noise::<2>(0.1, 1.0)?);
/// assert_eq!(q.fixed_view::<2, 2>(2, 2), q.fixed_view::<2, 2>(0, 0));
/// assert_eq!(q[(0, 2)], 0.0);
/// # Ok::<(), liebayes_operators::OperatorError>(())
/// ```
pub fn per_axis<const B: usize, const T: usize>(block: &SMatrix<f64, B, B>) -> SMatrix<f64, T, T> {
    const {
        assert!(
            B > 0 && T % B == 0,
            "T must be a whole number of B-state blocks"
        );
    };
    SMatrix::<f64, T, T>::from_fn(|i, j| {
        if i / B == j / B {
            block[(i % B, j % B)]
        } else {
            0.0
        }
    })
}

/// `Ad(x) P Ad(x)ᵀ`: a covariance of body-frame errors (`x exp(δ)`, the crate's convention) as one
/// of world-frame errors (`exp(δ) x`, [`Left`]) at the same point. Exact (the map of the errors is
/// linear); any x and any symmetric positive semi-definite P (a process noise may be singular)
/// whose product is representable.
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite entry of P or a result that overflows (a pose
/// whose translation is near overflow makes Ad(x) huge); [`OperatorError::NotPositiveDefinite`]
/// for a P that is not symmetric positive semi-definite (to 1e-12 of its largest entry).
pub fn world_from_body<G, const D: usize>(
    x: &G,
    body: &SMatrix<f64, D, D>,
) -> Result<SMatrix<f64, D, D>, OperatorError>
where
    G: LieGroup<D, Scalar = f64>,
{
    check_semi_definite(
        body,
        "covariance P to transport (give a symmetric positive semi-definite matrix)",
    )?;
    let ad = x.adjoint();
    let moved = symmetric_part(&(ad * body * ad.transpose()));
    all_finite(
        "transported covariance Ad P Ad^T (the pose's translation is too large)",
        moved.iter(),
    )?;
    Ok(moved)
}

/// `Ad(x⁻¹) P Ad(x⁻¹)ᵀ`: a covariance of world-frame errors as one of body-frame errors at the same
/// point, the inverse of [`world_from_body`].
///
/// # Errors
/// As [`world_from_body`].
pub fn body_from_world<G, const D: usize>(
    x: &G,
    world: &SMatrix<f64, D, D>,
) -> Result<SMatrix<f64, D, D>, OperatorError>
where
    G: LieGroup<D, Scalar = f64>,
{
    world_from_body(&x.inverse(), world)
}

/// The same density with world-frame errors: `N(x, P)` with `x exp(δ)` becomes `N(x, Ad(x) P Ad(x)ᵀ)`
/// with `exp(δ) x` ([`Left`]), the same distribution of points.
///
/// # Errors
/// [`OperatorError::NonFinite`] or [`OperatorError::Density`] when the transported covariance is
/// not representable (an adjoint with entries near overflow).
pub fn to_world_frame<G, const D: usize>(
    density: &ManifoldGaussian<G, D>,
) -> Result<ManifoldGaussian<Left<G>, D>, OperatorError>
where
    G: LieGroup<D, Scalar = f64>,
{
    let x = density.mean();
    Ok(ManifoldGaussian::new(
        Left::new(x.clone()),
        world_from_body(x, density.covariance())?,
    )?)
}

/// The same density with body-frame errors, the inverse of [`to_world_frame`].
///
/// # Errors
/// As [`to_world_frame`].
pub fn to_body_frame<G, const D: usize>(
    density: &ManifoldGaussian<Left<G>, D>,
) -> Result<ManifoldGaussian<G, D>, OperatorError>
where
    G: LieGroup<D, Scalar = f64>,
{
    let x = density.mean().inner();
    Ok(ManifoldGaussian::new(
        x.clone(),
        body_from_world(x, density.covariance())?,
    )?)
}

/// Checks a time step: finite and ≥ 0.
fn check_step(dt: f64) -> Result<(), OperatorError> {
    all_finite("time step dt", [dt].iter())?;
    if dt < 0.0 {
        return Err(OperatorError::OutOfRange {
            what: "time step dt",
            value: dt,
            range: "[0, inf)",
        });
    }
    Ok(())
}

/// Checks a variance or a spectral density: finite and ≥ 0.
fn check_variance(value: f64, what: &'static str) -> Result<(), OperatorError> {
    all_finite(what, [value].iter())?;
    if value < 0.0 {
        return Err(OperatorError::OutOfRange {
            what,
            value,
            range: "[0, inf)",
        });
    }
    Ok(())
}

/// Checks that a matrix is finite, symmetric and positive semi-definite (relative tolerance 1e-12 of
/// its largest entry; the eigenvalues of the matrix scaled by that entry, so that subnormal and huge
/// matrices are read as precisely as others, with a bounded iteration).
fn check_semi_definite<const L: usize>(
    m: &SMatrix<f64, L, L>,
    what: &'static str,
) -> Result<(), OperatorError> {
    all_finite(what, m.iter())?;
    let scale = m.amax();
    if scale == 0.0 {
        return Ok(());
    }
    let scaled = m / scale;
    let smallest = nalgebra::SymmetricEigen::try_new(
        DMatrix::from_iterator(L, L, scaled.iter().copied()),
        f64::EPSILON,
        1000,
    )
    .map_or(f64::NAN, |e| e.eigenvalues.min());
    if (scaled - scaled.transpose()).amax() > 1e-12 || smallest.is_nan() || smallest < -1e-12 {
        return Err(OperatorError::NotPositiveDefinite { what });
    }
    Ok(())
}

/// `t^n` by repeated multiplication (exact for the small n of these blocks).
fn integer_power(t: f64, n: usize) -> f64 {
    (0..n).fold(1.0, |acc, _| acc * t)
}

/// `q tⁿ` for q, t ≥ 0 without an intermediate under- or overflow: the powers are taken of the
/// mantissas in [½, 1) and the binary exponents applied once, at the end, so that a product that
/// f64 holds is found even where tⁿ alone is not (q = 1e300, t = 1e-120, n = 3).
fn times_power(q: f64, t: f64, n: usize) -> f64 {
    if q == 0.0 || (t == 0.0 && n > 0) {
        return 0.0;
    }
    let ((q_mantissa, q_exponent), (t_mantissa, t_exponent)) = (binary_split(q), binary_split(t));
    // n ≤ 2N − 1 is a small count: the exponent sum stays far inside i64.
    #[allow(clippy::cast_possible_wrap)]
    let exponent = q_exponent + t_exponent * n as i64;
    scale_by_power_of_two(q_mantissa * integer_power(t_mantissa, n), exponent)
}

/// `n!` as a float (n ≤ 170 is finite).
fn factorial(n: usize) -> f64 {
    (1..=n).fold(1.0, |acc, k| acc * k as f64)
}
