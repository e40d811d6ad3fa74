//! Small numerical pieces shared by the operators: log weights (particle set, grid) and the validated
//! Gaussian a filter step returns.

use crate::OperatorError;
use crate::error::with_capacity;
use liebayes_densities::{DensityError, ManifoldGaussian};
use liebayes_manifolds::Manifold;
use nalgebra::SMatrix;

/// What a step names when the Gaussian it produced is refused: the mean (a model returned a point
/// that is not finite) or the covariance (non-finite, not positive definite), each with what to check.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Produced {
    /// The step's mean, and which model produced it.
    pub(crate) mean: &'static str,
    /// The step's covariance, and what to check when it is refused.
    pub(crate) covariance: &'static str,
}

/// Runs a Kalman step `update(floor)` with its noise (an update's R, M × M, or a prediction's Q,
/// M = D) raised by `floor · I`: first with `floor = 0` (the exact step, whose result is returned
/// whenever it succeeds or fails for another reason), and, when rounding made its innovation
/// covariance S, its posterior or its predicted covariance lose positive definiteness
/// ([`OperatorError::NotPositiveDefinite`]), once more with `floor = 64 M ε scale()`, the scale the
/// size of what rounds: `max |Sᵢᵢ|` for an update (and, for a Jacobian H, at least
/// `|H|²_F max |Pᵢⱼ|`, the size of the Joseph form's terms), `max |P′ᵢᵢ|` for a prediction. A
/// noise R below that rounding is lost in S, and the posterior's variance along the measured
/// directions, of the order of R, is lost to the rounding of P; a prediction from a prior far
/// finer than a singular Q (a constant-velocity model's `Γ Γᵀ σ²` after a fix of variance 1e-18
/// of one step's noise) keeps
/// variances below the rounding of P′. The second try keeps them at least 64 M times that
/// rounding, dropping information finer than the arithmetic can hold (the result is slightly
/// wider than the exact one). If the second try fails too, the first error is returned (or the
/// second, when it is [`OperatorError::Linearisation`]).
pub(crate) fn above_rounding<T, const M: usize>(
    scale: impl FnOnce() -> f64,
    update: impl Fn(f64) -> Result<T, OperatorError>,
) -> Result<T, OperatorError> {
    match update(0.0) {
        Err(error @ OperatorError::NotPositiveDefinite { .. }) => {
            let floor = 64.0 * M as f64 * f64::EPSILON * scale();
            if floor > 0.0 && floor.is_finite() {
                // A raised step refused for its linearisation is refused for that, whatever
                // the exact step's rounding.
                update(floor).map_err(|second| match second {
                    OperatorError::Linearisation { .. } => second,
                    _ => error,
                })
            } else {
                Err(error)
            }
        }
        result => result,
    }
}

/// [`checked_gaussian`] of a filter step's covariance [raised to its rounding](raised_to_rounding)
/// when rounding left it singular: a prediction or a smoothed step, whose covariance is positive
/// semi-definite in exact arithmetic. Returns the density and the floor added (0 for the exact
/// step), which a step that records its noise adds to it.
pub(crate) fn checked_gaussian_above_rounding<X: Manifold<D, Scalar = f64>, const D: usize>(
    mean: &X,
    covariance: &SMatrix<f64, D, D>,
    what: Produced,
) -> Result<(ManifoldGaussian<X, D>, f64), OperatorError> {
    raised_to_rounding(
        covariance,
        |c| checked_gaussian(mean.clone(), c, what),
        ManifoldGaussian::cholesky_factor,
        what.covariance,
    )
}

/// `build(P + floor I)` for a covariance P that is positive semi-definite in exact arithmetic (a
/// prediction `F P Fᵀ + Q`, a smoothed step): first with `floor = 0`, and once more with the
/// floor of [`above_rounding`] (scaled from `max |Pᵢᵢ|`) when rounding left P not positive
/// definite ([`OperatorError::NotPositiveDefinite`] from `build`) or its Cholesky `factor` (the
/// built density's own) shows it [singular to rounding](singular_to_rounding), refused as not
/// positive definite naming `what`. Returns the result and the floor added.
pub(crate) fn raised_to_rounding<T, const D: usize>(
    covariance: &SMatrix<f64, D, D>,
    build: impl Fn(&SMatrix<f64, D, D>) -> Result<T, OperatorError>,
    factor: impl Fn(&T) -> &SMatrix<f64, D, D>,
    what: &'static str,
) -> Result<(T, f64), OperatorError> {
    above_rounding::<_, D>(
        || covariance.diagonal().amax(),
        |floor| {
            let raised = covariance + SMatrix::<f64, D, D>::identity() * floor;
            let built = build(&raised)?;
            if floor == 0.0 && singular_to_rounding(factor(&built), &raised) {
                return Err(OperatorError::NotPositiveDefinite { what });
            }
            Ok((built, floor))
        },
    )
}

/// Whether a covariance P with Cholesky factor L is singular to rounding: some pivot
/// `Lᵢᵢ² < D ε Pᵢᵢ`, the i-th variable fixed by the ones before it to within the rounding of its
/// own variance. The test is free of units (the pivots of the correlation matrix): a state that
/// mixes metres and radians passes it unless its variables are that correlated.
pub(crate) fn singular_to_rounding<const D: usize>(
    factor: &SMatrix<f64, D, D>,
    covariance: &SMatrix<f64, D, D>,
) -> bool {
    let tolerance = D as f64 * f64::EPSILON;
    (0..D).any(|i| factor[(i, i)] * factor[(i, i)] < tolerance * covariance[(i, i)])
}

/// The statistical linearisation `F̂ = Cᵀ P⁻¹` of a cross-covariance `C = Cov(δ, y)` for
/// `δ ~ N(0, P)`, by two triangular solves with the Cholesky factor L of `P = L Lᵀ` (a density's
/// factor: a positive diagonal), never an inverse. For a model linear in δ, `y = F δ`, it is F.
pub(crate) fn slope<const D: usize, const M: usize>(
    factor: &SMatrix<f64, D, D>,
    cross: &SMatrix<f64, D, M>,
) -> SMatrix<f64, M, D> {
    factor
        .tr_solve_lower_triangular_unchecked(&factor.solve_lower_triangular_unchecked(cross))
        .transpose()
}

/// `P⁻¹ B` for `P = L Lᵀ` from its Cholesky factor L (a positive diagonal): a forward solve with
/// L, then a backward one with `Lᵀ` formed once. Solving with the factor's transpose in place
/// (nalgebra's `Cholesky::solve`) takes a dot product along each of L's rows, strided in its
/// column-major storage: alone, at 11 × 11 with 11 right-hand sides, 1.04 µs against 0.68 µs
/// here. The smoother's backward step uses it for its gain (a fixed-lag step with a lag of 50
/// about a fifth faster); in the Kalman updates, whose innovation covariances are a few rows,
/// it measured no faster.
pub(crate) fn cholesky_solve<const D: usize, const C: usize>(
    factor: &SMatrix<f64, D, D>,
    b: &SMatrix<f64, D, C>,
) -> SMatrix<f64, D, C> {
    factor
        .transpose()
        .solve_upper_triangular_unchecked(&factor.solve_lower_triangular_unchecked(b))
}

/// The scale [`above_rounding`] raises a linearised update's noise by: `max |Sᵢᵢ|` of
/// `S = H P Hᵀ + R`, and at least `|H|²_F max |Pᵢⱼ|`, the size of the Joseph form's terms.
pub(crate) fn rounding_scale<const D: usize, const M: usize>(
    h: &SMatrix<f64, M, D>,
    p: &SMatrix<f64, D, D>,
    r: &SMatrix<f64, M, M>,
) -> f64 {
    (h * p * h.transpose() + r)
        .diagonal()
        .amax()
        .max(h.norm_squared() * p.amax())
}

/// The relative asymmetry a covariance may have: `max |M − Mᵀ| ≤ 1e-12 max |M|` (rounding, not a
/// different matrix).
pub(crate) const SYMMETRY_TOLERANCE: f64 = 1e-12;

/// `M / max |Mᵢⱼ|` and that largest entry, `None` for a zero matrix: a product with the
/// reciprocal, or a quotient when the reciprocal overflows (a largest entry below 2⁻¹⁰²²).
fn unit_scaled<const N: usize>(m: &SMatrix<f64, N, N>) -> Option<(SMatrix<f64, N, N>, f64)> {
    let scale = m.amax();
    if scale == 0.0 {
        return None;
    }
    let inverse = scale.recip();
    let scaled = if inverse.is_finite() {
        m * inverse
    } else {
        m / scale
    };
    Some((scaled, scale))
}

/// Checks that a finite matrix is symmetric to [`SYMMETRY_TOLERANCE`]: Cholesky factorisations
/// read one triangle only, so an asymmetric matrix would be taken for another without a word.
///
/// # Errors
/// [`OperatorError::OutOfRange`] naming `what`, with the largest `|M − Mᵀ|`.
pub(crate) fn check_symmetric<const N: usize>(
    what: &'static str,
    m: &SMatrix<f64, N, N>,
) -> Result<(), OperatorError> {
    match unit_scaled(m) {
        Some((scaled, scale)) => check_unit_symmetric(what, &scaled, scale),
        None => Ok(()),
    }
}

/// [`check_symmetric`] of `scaled = M / scale` (entries at most 1 in magnitude), one triangle
/// against the other.
fn check_unit_symmetric<const N: usize>(
    what: &'static str,
    scaled: &SMatrix<f64, N, N>,
    scale: f64,
) -> Result<(), OperatorError> {
    let mut asymmetry = 0.0_f64;
    for j in 1..N {
        for i in 0..j {
            asymmetry = asymmetry.max((scaled[(i, j)] - scaled[(j, i)]).abs());
        }
    }
    if asymmetry > SYMMETRY_TOLERANCE {
        return Err(OperatorError::OutOfRange {
            what,
            value: asymmetry * scale,
            range: "symmetric matrices (the value shown is max |A - A^T|)",
        });
    }
    Ok(())
}

/// A model's noise matrix (its Q or R) checked finite and symmetric before a step adds it to
/// computed products: those are symmetrised to undo their rounding, which would otherwise take an
/// asymmetric Q for its symmetric part without a word. It must also have no negative variance and
/// no negative 2 × 2 principal minor, `q_ii q_jj ≥ q_ij²` (beyond a rounding of 1e-12 of the
/// largest entry squared): conditions every positive semi-definite matrix meets, checked in
/// O(N²) per step, which refuse the usual indefinite noise (a time step of the wrong sign, a
/// correlation above 1) that would otherwise shrink the covariance it is added to.
///
/// # Errors
/// [`OperatorError::NonFinite`], [`OperatorError::OutOfRange`] (from [`check_symmetric`]) or
/// [`OperatorError::NotPositiveDefinite`] (a negative variance or minor) naming `what`.
pub(crate) fn model_noise<const N: usize>(
    what: &'static str,
    noise: SMatrix<f64, N, N>,
) -> Result<SMatrix<f64, N, N>, OperatorError> {
    crate::error::all_finite(what, noise.iter())?;
    // Scaled first, so that the products of entries near f64::MAX do not overflow.
    if let Some((s, scale)) = unit_scaled(&noise) {
        check_unit_symmetric(what, &s, scale)?;
        let indefinite = (0..N).any(|j| {
            s[(j, j)] < 0.0
                || (0..j)
                    .any(|i| s[(i, i)] * s[(j, j)] - s[(i, j)] * s[(i, j)] < -SYMMETRY_TOLERANCE)
        });
        if indefinite {
            return Err(OperatorError::NotPositiveDefinite { what });
        }
    }
    Ok(noise)
}

/// Whether a matrix is diagonal: every entry off the diagonal exactly zero (a diagonal noise's
/// factor is the square roots of its variances, and it bounds a weighted sum term by term).
pub(crate) fn is_diagonal<const N: usize>(m: &SMatrix<f64, N, N>) -> bool {
    (0..N).all(|i| (0..N).all(|j| i == j || m[(i, j)] == 0.0))
}

/// `(M + Mᵀ)/2`, computed as `M/2 + Mᵀ/2` so that entries near the largest finite value do not
/// overflow.
pub(crate) fn symmetric_part<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    m * 0.5 + m.transpose() * 0.5
}

/// The Gaussian a filter step returns: the mean checked with [`Manifold::is_finite`], P symmetrised as
/// `(P + Pᵀ)/2` (by [`symmetric_part`]) and validated by the density's constructor (finite, positive definite, with a
/// representable inverse).
///
/// # Errors
/// [`OperatorError::NonFinitePoint`] for a mean that is not finite, [`OperatorError::NonFinite`] for a
/// covariance entry that is not, [`OperatorError::OutOfRange`] for a positive definite covariance
/// beyond the density's limits (an entry above 1e100, or `tr P⁻¹` above 1e100: too concentrated),
/// [`OperatorError::NotPositiveDefinite`] otherwise.
#[inline]
pub(crate) fn checked_gaussian<X: Manifold<D, Scalar = f64>, const D: usize>(
    mean: X,
    covariance: &SMatrix<f64, D, D>,
    what: Produced,
) -> Result<ManifoldGaussian<X, D>, OperatorError> {
    if !mean.is_finite() {
        return Err(OperatorError::NonFinitePoint { what: what.mean });
    }
    ManifoldGaussian::new(mean, symmetric_part(covariance)).map_err(|e| match e {
        DensityError::NonFinite { value, .. } => OperatorError::NonFinite {
            what: what.covariance,
            value,
        },
        // The density's limits name their own quantity (its largest entry, its inverse's
        // trace); only a failed factorisation means "not positive definite".
        DensityError::OutOfRange { what, value, range }
            if !range.starts_with("positive definite") =>
        {
            OperatorError::OutOfRange { what, value, range }
        }
        _ => OperatorError::NotPositiveDefinite {
            what: what.covariance,
        },
    })
}

/// The terms per chunk of the weights' sums. Serial and parallel steps add the same chunks in the
/// same order, so they agree bit for bit.
const SUM_CHUNK: usize = 4096;

/// How the passes over the weights run: on this thread, or (feature `rayon`) split over the
/// thread pool in chunks of [`SUM_CHUNK`], with the same result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Passes {
    /// On this thread.
    Serial,
    /// On rayon's pool.
    #[cfg(feature = "rayon")]
    Parallel,
}

/// `(Σ eᵢ, Σ eᵢ²)` with `eᵢ = exp(lᵢ − m)` over one chunk: the normaliser and, from the same
/// exponentials, the effective sample size.
fn scaled_chunk_sums(chunk: &[f64], max: f64) -> (f64, f64) {
    chunk.iter().fold((0.0, 0.0), |(s, q), l| {
        let e = (l - max).exp();
        (s + e, q + e * e)
    })
}

/// Adds two chunks' sums.
fn add_sums(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 + b.0, a.1 + b.1)
}

impl Passes {
    /// The first NaN or +∞ (in index order).
    fn first_invalid(self, values: &[f64]) -> Option<f64> {
        let invalid = |v: &f64| v.is_nan() || *v == f64::INFINITY;
        match self {
            Passes::Serial => values.iter().copied().find(invalid),
            #[cfg(feature = "rayon")]
            Passes::Parallel => {
                use rayon::prelude::*;
                values.par_iter().copied().find_first(invalid)
            }
        }
    }

    /// The largest value (exact in any order; the values are checked not NaN).
    fn max(self, values: &[f64]) -> f64 {
        match self {
            Passes::Serial => values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            #[cfg(feature = "rayon")]
            Passes::Parallel => {
                use rayon::prelude::*;
                values
                    .par_iter()
                    .copied()
                    .reduce(|| f64::NEG_INFINITY, f64::max)
            }
        }
    }

    /// [`scaled_chunk_sums`] over the chunks of [`SUM_CHUNK`] values, the chunks' sums added in
    /// order (`partials`: scratch with room for one pair per chunk, so nothing is allocated).
    fn scaled_sums(self, values: &[f64], max: f64, partials: &mut Vec<(f64, f64)>) -> (f64, f64) {
        match self {
            Passes::Serial => {
                let _ = partials;
                values
                    .chunks(SUM_CHUNK)
                    .map(|c| scaled_chunk_sums(c, max))
                    .fold((0.0, 0.0), add_sums)
            }
            #[cfg(feature = "rayon")]
            Passes::Parallel => {
                use rayon::prelude::*;
                values
                    .par_chunks(SUM_CHUNK)
                    .map(|c| scaled_chunk_sums(c, max))
                    .collect_into_vec(partials);
                partials.iter().copied().fold((0.0, 0.0), add_sums)
            }
        }
    }

    /// `lᵢ ← pᵢ` normalised by `sum`.
    fn write(self, values: &mut [f64], pending: &[f64], sum: LogSum) {
        match self {
            Passes::Serial => {
                for (l, p) in values.iter_mut().zip(pending) {
                    *l = sum.normalised(*p);
                }
            }
            #[cfg(feature = "rayon")]
            Passes::Parallel => {
                use rayon::prelude::*;
                values
                    .par_iter_mut()
                    .zip(pending.par_iter())
                    .for_each(|(l, p)| *l = sum.normalised(*p));
            }
        }
    }

    /// `pᵢ ← lᵢ + (pᵢ − offset)`.
    fn add(self, pending: &mut [f64], values: &[f64], offset: f64) {
        match self {
            Passes::Serial => {
                for (p, l) in pending.iter_mut().zip(values) {
                    *p = l + (*p - offset);
                }
            }
            #[cfg(feature = "rayon")]
            Passes::Parallel => {
                use rayon::prelude::*;
                pending
                    .par_iter_mut()
                    .zip(values.par_iter())
                    .for_each(|(p, l)| *p = l + (*p - offset));
            }
        }
    }
}

/// `ln Σ exp(lᵢ)` split as `m + ln s` with m the largest term and `s = Σ exp(lᵢ − m)` in [1, n], so
/// that nothing overflows or underflows and the relative values `lᵢ − m` are kept whatever the size
/// of m: normalising `lᵢ` to `(lᵢ − m) − ln s` is exact to rounding even at offsets of −1e300, where
/// `lᵢ − (m + ln s)` would lose `ln s` to m's rounding. `None` for no terms or all terms −∞.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LogSum {
    max: f64,
    log_scaled_sum: f64,
    /// `1 / Σ wᵢ² = s² / Σ eᵢ²` of the normalised terms `wᵢ = eᵢ / s`.
    effective_size: f64,
}

impl LogSum {
    fn of(values: &[f64], passes: Passes, partials: &mut Vec<(f64, f64)>) -> Option<Self> {
        let max = passes.max(values);
        if max == f64::NEG_INFINITY {
            return None;
        }
        let (scaled, squares) = passes.scaled_sums(values, max, partials);
        Some(Self {
            max,
            log_scaled_sum: scaled.ln(),
            // s ≥ 1 and Σ eᵢ² ≥ 1 (the largest term is 1): finite.
            effective_size: scaled * scaled / squares,
        })
    }

    /// `ln Σ exp(lᵢ)` (rounded: m absorbs ln s when |m| ≫ 1).
    fn total(self) -> f64 {
        self.max + self.log_scaled_sum
    }

    /// `lᵢ − ln Σ exp(lⱼ)`, from the relative value first.
    fn normalised(self, l: f64) -> f64 {
        (l - self.max) - self.log_scaled_sum
    }
}

/// Normalised log weights (`Σ exp(lᵢ) = 1`) with a buffer of pending values, so that a Bayes step
/// computes every log-likelihood first and changes the weights only once all are valid: a failed step
/// leaves the weights as they were, and no step allocates.
#[derive(Clone, Debug)]
pub(crate) struct LogWeights {
    values: Vec<f64>,
    pending: Vec<f64>,
    /// One pair per chunk of [`SUM_CHUNK`] weights: the parallel passes' partial sums.
    partials: Vec<(f64, f64)>,
    /// `1 / Σ exp(2 lᵢ)`, kept with the weights: a propagation asks for it at every step, and the
    /// weights change only at a Bayes step or a reset.
    effective_size: f64,
}

impl LogWeights {
    /// n equal weights, `what` naming the count in an error.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the buffers
    /// cannot be allocated.
    pub(crate) fn uniform(what: &'static str, n: usize) -> Result<Self, OperatorError> {
        let mut values = with_capacity(what, n)?;
        values.resize(n, -(n as f64).ln());
        Ok(Self {
            values,
            pending: with_capacity(what, n)?,
            partials: {
                let mut partials = Vec::new();
                partials
                    .try_reserve_exact(n.div_ceil(SUM_CHUNK))
                    .map_err(|_| OperatorError::TooLarge {
                        what,
                        value: n,
                        max: crate::MAX_ELEMENTS,
                    })?;
                partials
            },
            effective_size: n as f64,
        })
    }

    /// The normalised log weights.
    pub(crate) fn values(&self) -> &[f64] {
        &self.values
    }

    /// The effective sample size `1 / Σ wᵢ²` of the weights, in [1, N].
    pub(crate) fn effective_size(&self) -> f64 {
        self.effective_size
    }

    /// The pending buffer, to be filled with one value per weight before [`Self::add_pending`] or
    /// [`Self::replace_with_pending`] (also usable as scratch space in between).
    pub(crate) fn pending(&mut self) -> &mut Vec<f64> {
        &mut self.pending
    }

    /// The linear weights `wᵢ = exp(lᵢ)`, computed into the pending buffer (for resampling).
    pub(crate) fn linear(&mut self) -> &[f64] {
        self.pending.clear();
        self.pending.extend(self.values.iter().map(|l| l.exp()));
        &self.pending
    }

    /// Resets to n equal weights.
    pub(crate) fn reset_uniform(&mut self) {
        let n = self.values.len();
        self.values.fill(-(n as f64).ln());
        self.effective_size = n as f64;
    }

    /// Bayes: `lᵢ += pendingᵢ`, then normalisation, with `passes` (the same result serial or
    /// parallel). Returns `ln Σ wᵢ exp(pendingᵢ)` (the log evidence, the weights being normalised
    /// before the step).
    ///
    /// The log-likelihoods' largest value M is taken out before they are added to the weights,
    /// `lᵢ ← lᵢ + (pendingᵢ − M)`, and added back only to the evidence: offsets such as −1e300, where
    /// `lᵢ + pendingᵢ` would round every weight's own value away, leave the posterior weights exact.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a pending value is NaN or +∞, when every updated weight is
    /// zero, or when the log evidence is below −f64::MAX (−∞ in f64); the weights are then unchanged.
    pub(crate) fn add_pending(
        &mut self,
        what: &'static str,
        passes: Passes,
    ) -> Result<f64, OperatorError> {
        check(what, &self.pending, passes)?;
        let offset = passes.max(&self.pending);
        if offset == f64::NEG_INFINITY {
            return Err(every_weight_zero());
        }
        passes.add(&mut self.pending, &self.values, offset);
        let sum =
            LogSum::of(&self.pending, passes, &mut self.partials).ok_or_else(every_weight_zero)?;
        let evidence = offset + sum.total();
        if evidence == f64::NEG_INFINITY {
            return Err(OperatorError::NonFinite {
                what: "log evidence ln sum w_i exp(l_i) (below -1.8e308: the data are too unlikely \
                       under every weighted point for f64)",
                value: evidence,
            });
        }
        self.write(sum, passes);
        Ok(evidence)
    }

    /// The pending values, normalised, become the weights.
    ///
    /// # Errors
    /// As [`Self::add_pending`].
    pub(crate) fn replace_with_pending(&mut self, what: &'static str) -> Result<(), OperatorError> {
        check(what, &self.pending, Passes::Serial)?;
        let sum = LogSum::of(&self.pending, Passes::Serial, &mut self.partials)
            .ok_or_else(every_weight_zero)?;
        self.write(sum, Passes::Serial);
        Ok(())
    }

    /// The pending values, normalised by their log sum, become the weights.
    fn write(&mut self, sum: LogSum, passes: Passes) {
        passes.write(&mut self.values, &self.pending, sum);
        self.effective_size = sum.effective_size.min(self.values.len() as f64);
    }
}

/// The error of a step after which no weight is left.
fn every_weight_zero() -> OperatorError {
    OperatorError::NonFinite {
        what: "total weight (every weight would be zero)",
        value: f64::NEG_INFINITY,
    }
}

/// Refuses NaN and +∞ (−∞, a zero weight, is allowed), naming the first.
fn check(what: &'static str, values: &[f64], passes: Passes) -> Result<(), OperatorError> {
    match passes.first_invalid(values) {
        Some(value) => Err(OperatorError::NonFinite { what, value }),
        None => Ok(()),
    }
}

/// `(m, e)` with `x = m 2ᵉ`, m in [½, 1), for a finite x > 0 (subnormals included).
pub(crate) fn binary_split(x: f64) -> (f64, i64) {
    const TWO_54: f64 = 18_014_398_509_481_984.0;
    let (x, shift) = if x < f64::MIN_POSITIVE {
        (x * TWO_54, 54)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    // The biased exponent field, at most 2046 for a finite x: it fits i64.
    #[allow(clippy::cast_possible_wrap)]
    let field = ((bits >> 52) & 0x7ff) as i64;
    let mantissa = f64::from_bits((bits & ((1 << 52) - 1)) | (1022 << 52));
    (mantissa, field - 1022 - shift)
}

/// `x 2ᵏ`, by factors of at most 2¹⁰⁰⁰ so that none overflows or underflows on its own: ±∞ or 0
/// only where the result does.
pub(crate) fn scale_by_power_of_two(mut x: f64, mut k: i64) -> f64 {
    let power = |k: i64| {
        // 1023 + k in [23, 2023] for k in [−1000, 1000]: a normal power of two.
        #[allow(clippy::cast_sign_loss)]
        f64::from_bits(((1023 + k) as u64) << 52)
    };
    while k > 1000 && x.is_finite() && x != 0.0 {
        x *= power(1000);
        k -= 1000;
    }
    while k < -1000 && x != 0.0 {
        x *= power(-1000);
        k += 1000;
    }
    x * power(k.clamp(-1000, 1000))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the direct sums for moderate values, and relative values kept at offsets of ±1e300.
    #[test]
    fn log_sums_keep_the_relative_values() {
        let values = [-1.0, 0.5, -3.0];
        let sum = LogSum::of(&values, Passes::Serial, &mut Vec::new()).unwrap();
        let direct: f64 = values.iter().map(|l: &f64| l.exp()).sum();
        assert!((sum.total() - direct.ln()).abs() < 1e-15);
        for offset in [-1e300, -1e15, 1e300] {
            let shifted = values.map(|l| l + offset);
            let sum = LogSum::of(&shifted, Passes::Serial, &mut Vec::new()).unwrap();
            // The shifted values are exact multiples of their ulp; their differences are not, so
            // compare with the normalisation of the differences the shift left.
            let relative = shifted.map(|l| l - shifted[1]);
            let reference = LogSum::of(&relative, Passes::Serial, &mut Vec::new()).unwrap();
            for (s, r) in shifted.iter().zip(&relative) {
                assert_eq!(sum.normalised(*s), reference.normalised(*r), "{offset}");
            }
            let total: f64 = shifted.iter().map(|l| sum.normalised(*l).exp()).sum();
            assert!((total - 1.0).abs() < 1e-15, "{offset}: {total}");
        }
        assert_eq!(
            LogSum::of(&[f64::NEG_INFINITY; 2], Passes::Serial, &mut Vec::new()),
            None
        );
        assert_eq!(LogSum::of(&[], Passes::Serial, &mut Vec::new()), None);
    }

    /// Two particles with log-likelihoods −1e300 keep their prior weights 0.9 and 0.1.
    #[test]
    fn huge_negative_likelihoods_keep_the_prior_weights() {
        let mut w = LogWeights::uniform("test weights", 2).unwrap();
        w.pending().extend([0.9_f64.ln(), 0.1_f64.ln()]);
        w.replace_with_pending("test").unwrap();
        w.pending().clear();
        w.pending().extend([-1e300, -1e300]);
        let evidence = w.add_pending("test", Passes::Serial).unwrap();
        assert_eq!(evidence, -1e300);
        assert!((w.values()[0].exp() - 0.9).abs() < 1e-15);
        assert!((w.values()[1].exp() - 0.1).abs() < 1e-15);
    }

    /// The noise checks at every scale, through both routes of the scaling (a product with the
    /// reciprocal, and a quotient where the reciprocal overflows, below 2⁻¹⁰²²): a covariance is
    /// kept as it is, a relative asymmetry of 1e-9 is refused with its size, a correlation above
    /// 1 and a negative variance are refused.
    #[test]
    fn model_noise_is_checked_at_every_scale() {
        let psd = SMatrix::<f64, 2, 2>::new(1.0, 0.5, 0.5, 0.75);
        let scales = [
            5e-324, 1e-320, 1e-310, 2.3e-308, 1e-100, 1.0, 1e100, 8.9e307,
        ];
        for scale in scales {
            let noise = psd * scale;
            assert_eq!(model_noise("Q", noise), Ok(noise), "{scale:e}");
            if scale >= 1e-300 {
                let mut asymmetric = noise;
                asymmetric[(0, 1)] *= 1.0 + 2e-9;
                match model_noise("Q", asymmetric) {
                    Err(OperatorError::OutOfRange { value, .. }) => {
                        let relative = value / (1e-9 * scale) - 1.0;
                        assert!(relative.abs() < 1e-6, "{scale:e}: {value:e}");
                    }
                    other => panic!("{scale:e}: {other:?}"),
                }
            }
            if scale < 1e-320 {
                // The smallest subnormal resolves neither 1.1 nor −0.5 of itself.
                continue;
            }
            let correlated = SMatrix::<f64, 2, 2>::new(1.0, 1.1, 1.1, 1.0) * scale;
            let negative = SMatrix::<f64, 2, 2>::new(1.0, 0.0, 0.0, -0.5) * scale;
            for indefinite in [correlated, negative] {
                assert_eq!(
                    model_noise("Q", indefinite),
                    Err(OperatorError::NotPositiveDefinite { what: "Q" }),
                    "{scale:e}"
                );
            }
        }
        let zero = SMatrix::<f64, 2, 2>::zeros();
        assert_eq!(model_noise("Q", zero), Ok(zero));
    }
}
