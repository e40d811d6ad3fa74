//! [`ManifoldGaussian`]: a Gaussian in the tangent space at a point of any manifold (the "concentrated
//! Gaussian" of the Lie-group literature), the density the EKF and the UKF carry.

use crate::eigen::smallest_eigenvalue;
use crate::error::DensityError;
use crate::gaussian::{MAX_SCALE, largest_within_scale, whitened_squared_norm, within_scale};
use crate::traits::{Density, Entropy, Rotate};
use liebayes_manifolds::{Jacobian, LieGroup, Manifold, MeanSettings};
use nalgebra::{Cholesky, SMatrix, SVector};
use rand::Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// Two means are the same point for [`ManifoldGaussian::kl_divergence`] when their offset is below
/// 1e-6 standard deviations: squared Mahalanobis length at most 1e-12.
const SAME_MEAN_MAHALANOBIS_SQUARED: f64 = 1e-12;

/// Relative asymmetry accepted in P: `|P − Pᵀ| ≤ 1e-12 max|P|` (as for [`Gaussian`](crate::Gaussian)).
const SYMMETRY_TOLERANCE: f64 = 1e-12;

/// The distribution of `x = μ ⊞ δ`, `δ ~ N(0, P)`: a mean μ on a D-dimensional manifold X and a
/// covariance P in the tangent space at μ of X's own retraction `⊞`. The frame of the errors is the
/// type's: on a Lie group `G` itself `μ ⊞ δ = μ · exp(δ)` (body-frame errors), on
/// [`Left<G>`](liebayes_manifolds::Left) `μ ⊞ δ = exp(δ) · μ` (world-frame errors).
///
/// # Base measure
/// `log_pdf(x)` is the Gaussian log density of the tangent vector `δ = x ⊟ μ`: a density with respect
/// to the Lebesgue measure **in the tangent coordinates at μ** (exponential coordinates on a Lie
/// group). On Rⁿ that is the Lebesgue measure itself. On a curved space it differs from the density
/// against the Riemannian or Haar measure by the Jacobian of `δ ↦ μ ⊞ δ` (on SO(3),
/// `|det Jr(δ)|⁻¹ = θ² / (2(1 − cos θ))`, θ = |δ|, which is `1 + θ²/12 + …`), and the mass of δ
/// beyond the injectivity radius (past ±π on SO(2)) wraps onto points that `local` maps elsewhere.
/// Both effects vanish as P → 0: this is the usual concentrated-Gaussian approximation, exact on Rⁿ.
/// Conversions to and from the exact SO(3) families (Bingham, heat kernel) are named approximations.
///
/// # Moments
/// In the tangent coordinates at μ, `E[x ⊟ μ] = 0` and `E[(x ⊟ μ)(x ⊟ μ)ᵀ] = P` (exactly while the
/// support stays inside the injectivity radius, up to the wrapped mass otherwise): μ is the mean on the
/// manifold (the fixed point of `m ← m ⊞ E[x ⊟ m]`) and P the covariance about it.
///
/// # Construction
/// [`new`](Self::new) validates the mean (finite, with no limit on its size: a point of a general
/// manifold has no coordinates to bound, unlike [`Gaussian::new`](crate::Gaussian::new)'s mean,
/// which is at most [`MAX_SCALE`](crate::MAX_SCALE)) and P (finite, symmetric, positive definite,
/// with a representable inverse) and factors it once; [`cholesky_factor`](Self::cholesky_factor), `log_pdf`, `sample` and
/// [`mahalanobis_squared`](Self::mahalanobis_squared) reuse the factor and never invert. On Rⁿ (with a mean the Gaussian accepts) every
/// quantity equals the [`Gaussian`](crate::Gaussian)'s (the tests check it); the type keeps its own
/// factor rather than a `Gaussian` because the filters build one per step, and the checks above cost
/// less here than `Gaussian::new`'s general ones.
///
/// # Example
/// ```
/// use liebayes_densities::{Density, ManifoldGaussian};
/// use liebayes_manifolds::{Manifold, So2};
/// use nalgebra::{Matrix1, Vector1};
///
/// // A heading near +π with a standard deviation of 0.1 rad.
/// let g = ManifoldGaussian::new(So2::from_angle_unchecked(3.1), Matrix1::new(0.01)).unwrap();
/// // A point across the cut is 0.1 rad away in the tangent at the mean, one standard deviation.
/// let x = g.mean().retract(&Vector1::new(0.1));
/// assert!((g.mahalanobis_squared(&x) - 1.0).abs() < 1e-12);
/// assert!(g.log_pdf(&x) < g.log_pdf(g.mean()));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ManifoldGaussian<X, const D: usize> {
    mean: X,
    covariance: SMatrix<f64, D, D>,
    /// L, lower triangular, `P = L Lᵀ`.
    cholesky: SMatrix<f64, D, D>,
    /// `ln det P`.
    log_det: f64,
}

/// `ln det P = 2 ln Π Lᵢᵢ` from the Cholesky factor L of P (one logarithm while the product stays
/// a normal number, the sum of logarithms otherwise).
pub(crate) fn log_det<const D: usize>(l: &SMatrix<f64, D, D>) -> f64 {
    let product: f64 = l.diagonal().iter().product();
    if product.is_normal() {
        2.0 * product.ln()
    } else {
        2.0 * l.diagonal().iter().map(|d| d.ln()).sum::<f64>()
    }
}

/// `None` when `tr P⁻¹ = ‖L⁻¹‖²_F ≤ limit` (L the Cholesky factor of P), else `Some(tr P⁻¹)`.
///
/// First a bound in O(D²): the comparison matrix M(L) (|Lᵢᵢ| on the diagonal, −|Lᵢⱼ| below) has
/// a non-negative inverse with `|L⁻¹| ≤ M(L)⁻¹` entrywise, so `‖L⁻¹‖_F ≤ 1ᵀ M(L)⁻¹ 1 = Σ yᵢ` with
/// `M(L) y = 1` solved by forward substitution (sums of non-negative terms: no cancellation). Only
/// when that bound exceeds the limit is the trace computed, column by column of L⁻¹ (O(D³)).
pub(crate) fn inverse_trace_above<const D: usize>(
    l: &SMatrix<f64, D, D>,
    limit: f64,
) -> Option<f64> {
    let mut y = [0.0; D];
    for i in 0..D {
        let below: f64 = (0..i).map(|k| l[(i, k)].abs() * y[k]).sum();
        y[i] = (1.0 + below) / l[(i, i)].abs();
    }
    let bound: f64 = y.iter().sum();
    // A margin for the bound's own rounding (relative D eps at most).
    if bound * bound <= limit * (1.0 - 1e-12) {
        return None;
    }
    let trace = inverse_trace(l);
    (trace.is_nan() || trace > limit).then_some(trace)
}

/// `tr P⁻¹ = ‖L⁻¹‖²_F`, with the columns of L⁻¹ by forward substitution.
fn inverse_trace<const D: usize>(l: &SMatrix<f64, D, D>) -> f64 {
    let mut trace = 0.0;
    for j in 0..D {
        // Column j of L⁻¹, x = L⁻¹ eⱼ, a column of L at a time: once xₖ is known, Lᵢₖ xₖ is taken
        // off every later row.
        let mut x = [0.0; D];
        x[j] = 1.0;
        for k in j..D {
            let xk = x[k] / l[(k, k)];
            trace += xk * xk;
            for (xi, lik) in x[k + 1..].iter_mut().zip(&l.column(k).as_slice()[k + 1..]) {
                *xi -= lik * xk;
            }
        }
    }
    trace
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> ManifoldGaussian<X, D> {
    /// The distribution `μ ⊞ N(0, P)`: any finite mean μ (its size is not limited; see the type
    /// docs), and P as below.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for a mean with a NaN or infinite coordinate
    /// ([`Manifold::is_finite`]) and for NaN or infinite entries of P, [`DensityError::OutOfRange`]
    /// for a P that is not symmetric (to 1e-12 relative) or not positive definite (its Cholesky factorisation
    /// fails), and for an entry of P or the trace `tr P⁻¹ = ‖L⁻¹‖²_F` above
    /// [`MAX_SCALE`](crate::MAX_SCALE) = 1e100, the limit of every Gaussian (beyond it samples,
    /// the entropy, Mahalanobis distances and divergences overflow).
    pub fn new(mean: X, covariance: SMatrix<f64, D, D>) -> Result<Self, DensityError> {
        const WHAT: &str = "tangent covariance P";
        if !mean.is_finite() {
            return Err(DensityError::NonFinite {
                what: "mean (a coordinate of the point on the manifold)",
                value: f64::NAN,
            });
        }
        // The largest magnitude, four running maxima side by side (one chain of comparisons over
        // every entry is slower), and a sum of `v · 0`, NaN exactly when an entry is not finite.
        let (mut largest, mut poison) = ([0.0_f64; 4], [0.0_f64; 4]);
        let mut take = |lane: usize, v: f64| {
            poison[lane] += v * 0.0;
            largest[lane] = if v.abs() > largest[lane] {
                v.abs()
            } else {
                largest[lane]
            };
        };
        let entries = covariance.as_slice().chunks_exact(4);
        for (lane, &v) in entries.remainder().iter().enumerate() {
            take(lane, v);
        }
        for chunk in entries {
            for (lane, &v) in chunk.iter().enumerate() {
                take(lane, v);
            }
        }
        if poison.iter().any(|p| p.is_nan()) {
            if let Some(&value) = covariance.iter().find(|v| !v.is_finite()) {
                return Err(DensityError::NonFinite { what: WHAT, value });
            }
        }
        let scale = largest[0].max(largest[1]).max(largest[2].max(largest[3]));
        largest_within_scale(WHAT, scale)?;
        let mut asymmetry = 0.0_f64;
        for j in 1..D {
            for i in 0..j {
                asymmetry = asymmetry.max((covariance[(i, j)] - covariance[(j, i)]).abs());
            }
        }
        if asymmetry > SYMMETRY_TOLERANCE * scale {
            return Err(DensityError::OutOfRange {
                what: WHAT,
                value: asymmetry,
                range: "symmetric matrices (|P - P^T| <= 1e-12 max|P|); symmetrise it with \
                        (P + P^T)/2",
            });
        }
        let covariance = if asymmetry > 0.0 {
            (covariance + covariance.transpose()) * 0.5
        } else {
            covariance
        };
        let Some(factor) = Cholesky::new(covariance) else {
            return Err(DensityError::OutOfRange {
                what: WHAT,
                // The smallest eigenvalue for the message (a dynamic copy: the error path only).
                value: smallest_eigenvalue(D, covariance.as_slice()),
                range: "positive definite matrices (the value shown is the smallest eigenvalue)",
            });
        };
        let cholesky = factor.unpack();
        if let Some(inverse_trace) = inverse_trace_above(&cholesky, MAX_SCALE) {
            return Err(DensityError::OutOfRange {
                what: "trace of the inverse tangent covariance P^-1",
                value: inverse_trace,
                range: "at most 1e100: the covariance's eigenvalues must be above about 1e-100",
            });
        }
        Ok(Self {
            mean,
            covariance,
            log_det: log_det(&cholesky),
            cholesky,
        })
    }

    /// The moment fit to weighted samples on the manifold: the mean μ is the weighted mean, the point
    /// where the weighted tangent residuals `μ ⊟ xᵢ` average to zero
    /// ([`weighted_mean`](liebayes_manifolds::weighted_mean) from the first sample), and
    /// `P = Σ wᵢ (μ ⊟ xᵢ)(μ ⊟ xᵢ)ᵀ / Σ wᵢ`. It is the maximum-likelihood fit of `μ ⊞ N(0, P)` as
    /// the spread goes to zero, and an approximation for wide ones (residuals beyond the injectivity
    /// radius, e.g. rotations more than π apart, are wrapped by `local`).
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] for no samples, a length that differs from the weights' or a
    /// negative weight; the mean's errors ([`DensityError::Manifold`]: non-finite or degenerate
    /// weights, no convergence); [`new`](Self::new)'s errors for the fitted P (fewer distinct samples
    /// than the dimension needs give a P that is not positive definite).
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::ManifoldGaussian;
    /// use liebayes_manifolds::{LieGroup, Manifold, So3};
    /// use nalgebra::{Matrix3, Vector3};
    /// let mean = So3::exp(&Vector3::new(0.3, -0.2, 1.0));
    /// let steps = [Vector3::x(), -Vector3::x(), Vector3::y(), -Vector3::y(), Vector3::z(), -Vector3::z()];
    /// let samples: Vec<So3<f64>> = steps.iter().map(|d| mean.retract(&(d * 0.01))).collect();
    /// let fit = ManifoldGaussian::<So3<f64>, 3>::fit(&samples, &[1.0; 6])?;
    /// assert!(fit.mean().local(&mean).norm() < 1e-12);
    /// assert!((fit.covariance() - Matrix3::identity() * (1e-4 / 3.0)).norm() < 1e-12);
    /// # Ok::<(), liebayes_densities::DensityError>(())
    /// ```
    pub fn fit(samples: &[X], weights: &[f64]) -> Result<Self, DensityError> {
        let (Some(first), true) = (samples.first(), samples.len() == weights.len()) else {
            return Err(DensityError::OutOfRange {
                what: "number of samples to fit (the weights must have one per sample)",
                value: samples.len() as f64,
                range: "at least 1, as many as the weights",
            });
        };
        if let Some(&w) = weights.iter().find(|w| **w < 0.0) {
            return Err(DensityError::OutOfRange {
                what: "weight of a sample to fit",
                value: w,
                range: "[0, infinity)",
            });
        }
        let pairs = samples.iter().zip(weights.iter().copied());
        let mean =
            liebayes_manifolds::weighted_mean(first, pairs.clone(), MeanSettings::default())?;
        let total: f64 = weights.iter().sum();
        // Each residual scaled by √(w / total) before its outer product: a sample of weight 0 adds
        // exactly nothing, however far (r rᵀ alone overflows beyond 1e154, and ∞ · 0 is NaN).
        let covariance = pairs.fold(SMatrix::<f64, D, D>::zeros(), |p, (x, w)| {
            let s = mean.local(x) * (w / total).sqrt();
            p + s * s.transpose()
        });
        Self::new(mean, covariance)
    }

    /// μ, the mean on the manifold.
    pub fn mean(&self) -> &X {
        &self.mean
    }

    /// P, the covariance of `δ = x ⊟ μ` in the tangent space at μ.
    pub fn covariance(&self) -> &SMatrix<f64, D, D> {
        &self.covariance
    }

    /// The lower Cholesky factor L with `P = L Lᵀ` (computed once, at construction).
    pub fn cholesky_factor(&self) -> &SMatrix<f64, D, D> {
        &self.cholesky
    }

    /// `ln det P`.
    pub fn log_determinant(&self) -> f64 {
        self.log_det
    }

    /// `δᵀ P⁻¹ δ` of a tangent vector at μ, by one triangular solve (+∞ where it overflows).
    fn tangent_mahalanobis_squared(&self, delta: &SVector<f64, D>) -> f64 {
        // The factor of a successful Cholesky decomposition has a positive diagonal.
        whitened_squared_norm(&self.cholesky, delta)
    }

    /// The squared Mahalanobis distance `(x ⊟ μ)ᵀ P⁻¹ (x ⊟ μ)` of a point, by one triangular solve:
    /// the NEES of an estimate μ against a true state x (χ² with D degrees of freedom when x is a draw
    /// of this density and the support stays inside the injectivity radius).
    pub fn mahalanobis_squared(&self, x: &X) -> f64 {
        self.tangent_mahalanobis_squared(&self.mean.local(x))
    }

    /// The first-order covariance `J P Jᵀ` of `f(x)` for a map with right Jacobian J at the mean
    /// (`f(μ ⊞ δ) = f(μ) ⊞ (J δ + O(|δ|²))`). Unlike [`propagate_linearized`](Self::propagate_linearized)
    /// it accepts rank-deficient results: rotating a point p cannot move it along p, so the covariance
    /// of R p is singular.
    ///
    /// The result is `J P Jᵀ` as rounded in f64, symmetrised: positive semi-definite to rounding,
    /// not exactly. Where it is singular or nearly so, its smallest eigenvalues may come out
    /// slightly negative, down to about `−E ε max|cᵢⱼ|` (ε = 2.2e-16); [`new`](Self::new) refuses
    /// such a matrix, so add the positive definite covariance it is combined with first, as
    /// [`compose`](Self::compose) does.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for a Jacobian with a NaN or infinite entry,
    /// [`DensityError::OutOfRange`] when an entry of `J P Jᵀ` exceeds
    /// [`MAX_SCALE`](crate::MAX_SCALE) = 1e100 (or overflows), the limit of every Gaussian.
    pub fn propagated_covariance<const E: usize>(
        &self,
        jacobian: &Jacobian<f64, E, D>,
    ) -> Result<SMatrix<f64, E, E>, DensityError> {
        if let Some(&value) = jacobian.iter().find(|v| !v.is_finite()) {
            return Err(DensityError::NonFinite {
                what: "Jacobian J of the propagation",
                value,
            });
        }
        let c = self.sandwich(jacobian);
        if c.iter().any(|v| v.is_nan()) {
            return Err(DensityError::OutOfRange {
                what: "propagated covariance J P J^T",
                value: f64::INFINITY,
                range: "entries of at most 1e100 (its products overflow)",
            });
        }
        within_scale("propagated covariance J P J^T", &c)?;
        Ok(c)
    }

    /// `J P Jᵀ`, symmetrised.
    fn sandwich<const E: usize>(&self, jacobian: &Jacobian<f64, E, D>) -> SMatrix<f64, E, E> {
        let c = jacobian * self.covariance() * jacobian.transpose();
        (c + c.transpose()) * 0.5
    }

    /// **First-order propagation** through a map `y = f(x)` into another manifold Y, given the image
    /// of the mean f(μ) and the right Jacobian `J = ∂[f(μ ⊞ δ) ⊟ f(μ)]/∂δ` at δ = 0:
    /// `y ~ f(μ) ⊞ N(0, J P Jᵀ)`. Exact for maps that are affine in the tangent coordinates (group
    /// translations, the adjoint, linear maps of Rⁿ); for others the error is of order P² times the
    /// second derivative of f.
    ///
    /// # Errors
    /// As [`propagated_covariance`](Self::propagated_covariance), and as [`new`](Self::new) when
    /// `J P Jᵀ` is not positive definite (J rank-deficient): a degenerate Gaussian is refused, not
    /// repaired.
    pub fn propagate_linearized<Y: Manifold<E, Scalar = f64>, const E: usize>(
        &self,
        image_of_mean: Y,
        jacobian: &Jacobian<f64, E, D>,
    ) -> Result<ManifoldGaussian<Y, E>, DensityError> {
        ManifoldGaussian::new(image_of_mean, self.propagated_covariance(jacobian)?)
    }

    /// `KL(self ‖ other) = ½ (tr(P_q⁻¹ P_p) − D + ln det P_q − ln det P_p)` for two Gaussians with
    /// the same mean point. Both are then images of their tangent Gaussians under the same map
    /// `δ ↦ μ ⊞ δ`, so the value is exact wherever that map is injective on the support (up to the
    /// wrapped mass, see the type docs; exact on Rⁿ).
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] when the means differ, that is when `μ_p ⊟ μ_q` is longer than
    /// 1e-6 of q's standard deviations (squared Mahalanobis length above 1e-12): the two densities then
    /// live in different tangent coordinates and no exact closed form exists. Below that the offset's
    /// term `½ (μ_p ⊟ μ_q)ᵀ P_q⁻¹ (μ_p ⊟ μ_q)` is included, as on Rⁿ.
    pub fn kl_divergence(&self, other: &Self) -> Result<f64, DensityError> {
        let offset = other.mahalanobis_squared(&self.mean);
        if offset.is_nan() || offset > SAME_MEAN_MAHALANOBIS_SQUARED {
            return Err(DensityError::OutOfRange {
                what: "squared Mahalanobis distance between the two means",
                value: offset,
                range: "[0, 1e-12]: the closed-form KL needs a common mean point",
            });
        }
        // tr(P_q⁻¹ P_p) = ‖L_q⁻¹ L_p‖²_F.
        let trace = other
            .cholesky
            .solve_lower_triangular_unchecked(&self.cholesky)
            .norm_squared();
        Ok(0.5 * (trace + offset - D as f64 + other.log_det - self.log_det))
    }
}

impl<G: LieGroup<D, Scalar = f64>, const D: usize> ManifoldGaussian<G, D> {
    /// The distribution of `a · b` for independent `a ~ self` and `b ~ other`, to first order:
    /// mean `μ_a μ_b`, covariance `Ad(μ_b⁻¹) P_a Ad(μ_b⁻¹)ᵀ + P_b` (from `j_compose_self = Ad(b⁻¹)`
    /// and `j_compose_other = I`). The error is of order P² (the second-order terms of the
    /// Baker-Campbell-Hausdorff series).
    ///
    /// # Errors
    /// As [`propagated_covariance`](Self::propagated_covariance) and [`new`](Self::new) (only when
    /// the covariance exceeds the limit of every Gaussian).
    pub fn compose(&self, other: &Self) -> Result<Self, DensityError> {
        let ja = self.mean.j_compose_self(&other.mean);
        let covariance = self.propagated_covariance(&ja)? + other.covariance();
        Self::new(self.mean.compose(&other.mean), covariance)
    }
}

/// A lower-triangular L′ with `L′ L′ᵀ = A Aᵀ` (an LQ factorisation `A = L′ Q`), by Givens rotations
/// of the columns, with a non-negative diagonal: exact orthogonal steps that cannot fail.
fn lower_factor<const D: usize>(mut a: SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    for i in 0..D {
        for j in (i + 1)..D {
            let (x, y) = (a[(i, i)], a[(i, j)]);
            if y == 0.0 {
                continue;
            }
            let r = x.hypot(y);
            let (c, s) = (x / r, y / r);
            for k in i..D {
                let (p, q) = (a[(k, i)], a[(k, j)]);
                a[(k, i)] = c * p + s * q;
                a[(k, j)] = c * q - s * p;
            }
            a[(i, j)] = 0.0;
        }
        if a[(i, i)] < 0.0 {
            for k in i..D {
                a[(k, i)] = -a[(k, i)];
            }
        }
    }
    a
}

/// The largest difference accepted between `ln det` of a transported covariance's Givens factor
/// and that of the Cholesky factor of the covariance as rounded and stored: 1e-3, a determinant
/// described to 0.1 % (rounding leaves about `D ε cond(P)`, 1e-6 at a condition number of 1e11).
const DETERMINANT_AGREEMENT: f64 = 1e-3;

impl<G: LieGroup<D, Scalar = f64>, const D: usize> Rotate<G> for ManifoldGaussian<G, D> {
    /// Left translation, exact: `g (μ ⊞ δ) = (g μ) ⊞ J δ` with `J = j_compose_other(g, μ)`, so the
    /// mean is `g μ` and the covariance `J P Jᵀ`. For the right perturbation `x · exp(δ)` J is the
    /// identity and P is kept as it is. With world-frame errors (`Left<G>`) J = Ad(g): the factor
    /// of `J P Jᵀ` is `J L` made lower-triangular by Givens rotations (orthogonal steps, which keep
    /// its determinant to rounding however ill-conditioned P is), and the stored covariance is
    /// `J P Jᵀ` as rounded, symmetrised. The result passes the checks of
    /// [`new`](ManifoldGaussian::new) on that stored covariance: finite, entries and `tr P⁻¹`
    /// within 1e100, positive definite (its Cholesky factorisation exists), and it describes the
    /// same density as the factor (the two factors' `ln det` agree to 1e-3), so that what `new`,
    /// the serde reader or [`compose`](ManifoldGaussian::compose) build from
    /// [`covariance`](ManifoldGaussian::covariance) is this density. Where Ad(g) is so
    /// ill-conditioned that rounding decides the smallest eigenvalues of `J P Jᵀ` (a translation of
    /// 1e30 with P = I: exact eigenvalues 1e-60 beside 1e60, which no f64 matrix holds), the
    /// rounded matrix is singular, indefinite or of another determinant, and the result is an
    /// error.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] when `J P Jᵀ` leaves the range
    /// of [`new`](ManifoldGaussian::new) (a translation near overflow makes Ad(g) huge), or once
    /// rounded is not positive definite or not the transported density's covariance.
    fn rotated(&self, g: &G) -> Result<Self, DensityError> {
        const WHAT: &str = "covariance of the translated Gaussian, Ad(g) P Ad(g)^T";
        let j = g.j_compose_other(&self.mean);
        let mean = g.compose(&self.mean);
        if j == SMatrix::<f64, D, D>::identity() {
            return Ok(Self {
                mean,
                ..self.clone()
            });
        }
        let covariance = self.sandwich(&j);
        if let Some(&value) = covariance.iter().find(|v| !v.is_finite()) {
            return Err(DensityError::NonFinite { what: WHAT, value });
        }
        within_scale(WHAT, &covariance)?;
        let cholesky = lower_factor(j * self.cholesky);
        if let Some(inverse_trace) = inverse_trace_above(&cholesky, MAX_SCALE) {
            return Err(DensityError::OutOfRange {
                what: "trace of the inverse of the translated covariance Ad(g) P Ad(g)^T",
                value: inverse_trace,
                range: "at most 1e100: the covariance's eigenvalues must be above about 1e-100",
            });
        }
        let transported = log_det(&cholesky);
        let Some(own) = Cholesky::new(covariance) else {
            return Err(DensityError::OutOfRange {
                what: WHAT,
                value: smallest_eigenvalue(D, covariance.as_slice()),
                range: "positive definite matrices once rounded (the value shown is the smallest \
                        eigenvalue): Ad(g) is too ill-conditioned for f64",
            });
        };
        let disagreement = (log_det(&own.unpack()) - transported).abs();
        if disagreement > DETERMINANT_AGREEMENT {
            return Err(DensityError::OutOfRange {
                what: "ln det of the rounded covariance Ad(g) P Ad(g)^T against its transported \
                       factor's",
                value: disagreement,
                range: "[0, 1e-3]: Ad(g) is too ill-conditioned for f64 (rounding decides the \
                        covariance's smallest eigenvalues)",
            });
        }
        Ok(Self {
            mean,
            covariance,
            cholesky,
            log_det: transported,
        })
    }

    /// `g x`.
    fn act(g: &G, x: &G) -> G {
        g.compose(x)
    }
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> rand::distr::Distribution<X>
    for ManifoldGaussian<X, D>
{
    /// One draw, by [`Density::sample`].
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> X {
        Density::sample(self, rng)
    }
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> Density for ManifoldGaussian<X, D> {
    type Point = X;

    /// `−½ (D ln 2π + ln det P + δᵀ P⁻¹ δ)` with `δ = x ⊟ μ`, against the Lebesgue measure in the
    /// tangent coordinates at μ (see the type docs).
    fn log_pdf(&self, x: &X) -> f64 {
        -0.5 * self.mahalanobis_squared(x) - self.log_normalizer()
    }

    /// `½ (D ln 2π + ln det P)`.
    fn log_normalizer(&self) -> f64 {
        0.5 * (D as f64 * (2.0 * PI).ln() + self.log_det)
    }

    /// `μ ⊞ L z`, z standard normal in Rᴰ.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> X {
        let z = SVector::<f64, D>::from_fn(|_, _| rng.sample(StandardNormal));
        self.mean.retract(&(self.cholesky * z))
    }

    /// μ.
    fn mode(&self) -> Option<X> {
        Some(self.mean.clone())
    }
}

impl<X: Manifold<D, Scalar = f64>, const D: usize> Entropy for ManifoldGaussian<X, D> {
    /// `½ (D (1 + ln 2π) + ln det P)`, against the same base measure as `log_pdf`.
    fn entropy(&self) -> f64 {
        0.5 * (D as f64 * (1.0 + (2.0 * PI).ln()) + self.log_det)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix5;

    /// Lower-triangular factors with positive diagonals spread over `spread` decades and
    /// off-diagonal entries up to `coupling` times the diagonal (deterministic xorshift draws).
    fn factors(spread: f64, coupling: f64) -> Vec<Matrix5<f64>> {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..200)
            .map(|_| {
                Matrix5::from_fn(|i, j| {
                    let d = 10f64.powf(spread * (uniform() - 0.5));
                    match i.cmp(&j) {
                        std::cmp::Ordering::Equal => d,
                        std::cmp::Ordering::Greater => coupling * d * (2.0 * uniform() - 1.0),
                        std::cmp::Ordering::Less => 0.0,
                    }
                })
            })
            .collect()
    }

    /// The decision `tr P⁻¹ ≤ limit` (fast bound or exact trace) against ‖L⁻¹‖²_F from nalgebra's
    /// triangular solve, with limits just above and just below the trace: well-conditioned,
    /// strongly coupled (the bound loose by orders of magnitude) and widely spread factors.
    #[test]
    fn the_inverse_trace_decision_matches_the_exact_trace() {
        let (mut checked, mut refusals) = (0, 0);
        for (spread, coupling) in [(0.0, 0.3), (2.0, 30.0), (40.0, 1.0), (90.0, 3.0)] {
            for l in factors(spread, coupling) {
                let exact = l
                    .solve_lower_triangular(&Matrix5::identity())
                    .expect("a non-singular factor")
                    .norm_squared();
                if !exact.is_finite() {
                    continue;
                }
                checked += 1;
                // At the densities' limit most factors take the O(D²) bound.
                let refused = inverse_trace_above(&l, MAX_SCALE).is_some();
                assert_eq!(refused, exact > MAX_SCALE, "{l}: trace {exact:e}");
                refusals += usize::from(refused);
                assert_eq!(inverse_trace_above(&l, exact * (1.0 + 1e-9)), None, "{l}");
                let above = inverse_trace_above(&l, exact * (1.0 - 1e-9));
                let value = above.unwrap_or_else(|| panic!("{l}: trace {exact:e} not reported"));
                assert!(
                    (value / exact - 1.0).abs() < 1e-10,
                    "{value:e} against {exact:e}"
                );
            }
        }
        assert!(checked > 700, "only {checked} factors with a finite trace");
        assert!(refusals > 10, "only {refusals} traces above the limit");
    }
}
