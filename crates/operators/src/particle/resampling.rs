//! The four resampling schemes, on normalised weights, with buffers kept between calls.

use crate::OperatorError;
use crate::error::{check_size, reserve, with_capacity};
use rand::Rng;
use rand_distr::Exp1;

/// How to resample N particles from normalised weights wᵢ. All four are unbiased (each particle's
/// expected number of copies is N wᵢ); they differ in variance and cost:
///
/// * `Multinomial`: N independent draws; the highest variance.
/// * `Stratified`: one uniform draw in each of the N strata [k/N, (k+1)/N).
/// * `Systematic`: one uniform offset u, points (k + u)/N; each particle gets ⌊N wᵢ⌋ or ⌈N wᵢ⌉ copies.
/// * `Residual`: ⌊N wᵢ⌋ copies each, then the remainder multinomially from the residual weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Resampling {
    /// Independent draws.
    Multinomial,
    /// One draw per stratum.
    Stratified,
    /// One offset for all strata.
    Systematic,
    /// Deterministic floors, then multinomial on the residuals.
    Residual,
}

/// The indices of n draws from `weights` by `scheme`, in increasing order (empty for n = 0). The
/// weights need not be normalised: they are divided by their largest value and then by their sum
/// before anything is drawn, so that any finite non-negative weights with a positive sum (1e300,
/// subnormals) give draws in proportion to them. Allocates its result;
/// [`ParticleSet::resample`](super::ParticleSet::resample) reuses buffers instead.
///
/// # Errors
/// [`OperatorError::OutOfRange`] for no weights (with n > 0) or a negative weight,
/// [`OperatorError::NonFinite`] for a NaN or infinite weight or weights that are all zero,
/// [`OperatorError::TooLarge`] for n above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the result
/// cannot be allocated; all checked before anything is allocated.
pub fn resample_indices<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
) -> Result<Vec<usize>, OperatorError> {
    const DRAWS: &str = "number of resampled draws";
    check_size(DRAWS, n)?;
    if n == 0 {
        return Ok(Vec::new());
    }
    if weights.is_empty() {
        return Err(OperatorError::OutOfRange {
            what: "number of weights to resample from",
            value: 0.0,
            range: "at least 1",
        });
    }
    if let Some(&w) = weights.iter().find(|w| !w.is_finite()) {
        return Err(OperatorError::NonFinite {
            what: "resampling weight",
            value: w,
        });
    }
    if let Some(&w) = weights.iter().find(|w| **w < 0.0) {
        return Err(OperatorError::OutOfRange {
            what: "resampling weight",
            value: w,
            range: "[0, infinity)",
        });
    }
    let largest = weights.iter().copied().fold(0.0, f64::max);
    if largest == 0.0 {
        return Err(OperatorError::NonFinite {
            what: "total resampling weight (every weight is zero)",
            value: 0.0,
        });
    }
    let mut work = Workspace::default();
    reserve(
        &mut work.normalised,
        "number of weights to resample from",
        weights.len(),
    )?;
    work.normalised.extend(weights.iter().map(|w| w / largest));
    let total: f64 = work.normalised.iter().sum();
    for w in &mut work.normalised {
        *w /= total;
    }
    let mut indices = with_capacity(DRAWS, n)?;
    reserve(&mut work.points, DRAWS, n)?;
    reserve(
        &mut work.residual,
        "number of weights to resample from",
        weights.len(),
    )?;
    let normalised = std::mem::take(&mut work.normalised);
    resample_into(&normalised, n, scheme, rng, &mut work, &mut indices);
    Ok(indices)
}

/// Buffers reused from one resampling to the next.
#[derive(Clone, Debug, Default)]
pub(super) struct Workspace {
    points: Vec<f64>,
    residual: Vec<f64>,
    /// The weights of [`resample_indices`], normalised.
    normalised: Vec<f64>,
}

impl Workspace {
    /// The buffers for resampling n particles (the draws and the residuals), allocated once, so
    /// that no resampling of a set of n particles allocates.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] when they cannot be allocated.
    pub(super) fn for_particles(what: &'static str, n: usize) -> Result<Self, OperatorError> {
        Ok(Self {
            points: with_capacity(what, n)?,
            residual: with_capacity(what, n)?,
            normalised: Vec::new(),
        })
    }
}

/// n draws from normalised, finite, non-negative `weights` (at least one, not all zero) into `out`
/// (cleared first), with the workspace's buffers.
pub(super) fn resample_into<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
    work: &mut Workspace,
    out: &mut Vec<usize>,
) {
    out.clear();
    if n == 0 {
        return;
    }
    let nf = n as f64;
    let points = &mut work.points;
    points.clear();
    match scheme {
        Resampling::Multinomial => {
            sorted_uniforms(n, rng, points);
            select(weights, points, out);
        }
        Resampling::Stratified => {
            points.extend((0..n).map(|k| (k as f64 + rng.random::<f64>()) / nf));
            select(weights, points, out);
        }
        Resampling::Systematic => {
            let u = rng.random::<f64>();
            points.extend((0..n).map(|k| (k as f64 + u) / nf));
            select(weights, points, out);
        }
        Resampling::Residual => residual(weights, n, rng, work, out),
    }
}

/// ⌊N wᵢ⌋ copies of each particle (at most N in all: the bound absorbs the rounding of N wᵢ), then
/// the remaining draws multinomially from the residuals `N wᵢ − ⌊N wᵢ⌋`, merged in index order: in
/// time linear in N and the number of particles.
fn residual<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    rng: &mut R,
    work: &mut Workspace,
    out: &mut Vec<usize>,
) {
    let nf = n as f64;
    // With normalised weights ⌊N wᵢ⌋ ≤ N wᵢ, so the floors sum to at most N up to rounding.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let floor = |w: f64| (nf * w).floor() as usize;
    let floors = weights
        .iter()
        .fold(0_usize, |sum, &w| sum.saturating_add(floor(w)));
    let rest = n.saturating_sub(floors);
    let residual = &mut work.residual;
    residual.clear();
    residual.extend(weights.iter().map(|w| nf * w - (nf * w).floor()));
    let total: f64 = residual.iter().sum();
    // The residual draws, in index order (as f64, exact below 2⁵³, in the points buffer).
    let points = &mut work.points;
    points.clear();
    if rest > 0 {
        if total > 0.0 {
            for r in residual.iter_mut() {
                *r /= total;
            }
            sorted_uniforms(rest, rng, points);
            select(residual, points, out);
        } else {
            // Every N wᵢ was an integer up to rounding: the floors fell short of N only by that
            // rounding, and the heaviest particle takes the rest.
            let heaviest = weights
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map_or(0, |(i, _)| i);
            out.extend(std::iter::repeat_n(heaviest, rest));
        }
        points.clear();
        #[allow(clippy::cast_precision_loss)]
        points.extend(out.iter().map(|&i| i as f64));
        out.clear();
    }
    let mut drawn = points.iter().peekable();
    for (i, &w) in weights.iter().enumerate() {
        let copies = floor(w).min(n - out.len());
        out.extend(std::iter::repeat_n(i, copies));
        #[allow(clippy::cast_precision_loss)]
        while drawn.next_if(|&&d| d == i as f64).is_some() {
            out.push(i);
        }
    }
}

/// n sorted uniform draws on [0, 1] into `points` (cleared first) in time linear in n, by
/// exponential spacings (Rényi's representation): with E₁, …, Eₙ₊₁ independent Exp(1) and Sₖ
/// their partial sums, `(S₁, …, Sₙ) / Sₙ₊₁` is distributed as the order statistics of n uniform
/// draws.
fn sorted_uniforms<R: Rng + ?Sized>(n: usize, rng: &mut R, points: &mut Vec<f64>) {
    points.clear();
    let mut sum = 0.0;
    points.extend((0..n).map(|_| {
        sum += rng.sample::<f64, _>(Exp1);
        sum
    }));
    let total = sum + rng.sample::<f64, _>(Exp1);
    for p in points.iter_mut() {
        *p /= total;
    }
}

/// For sorted points in [0, 1], appends the index whose cumulative-weight interval holds each point;
/// a point past the rounded total goes to the last particle of positive weight, never to a trailing
/// particle of weight zero.
fn select(weights: &[f64], sorted_points: &[f64], out: &mut Vec<usize>) {
    let last = weights.iter().rposition(|w| *w > 0.0).unwrap_or(0);
    let mut cumulative = weights[0];
    let mut i = 0;
    for &p in sorted_points {
        while p >= cumulative && i < last {
            i += 1;
            cumulative += weights[i];
        }
        out.push(i);
    }
}
