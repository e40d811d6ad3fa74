//! The four resampling schemes, normalising the weights as they are read, with a buffer kept between
//! calls.

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
/// weights need not be normalised: each is read as `(wᵢ / max w) / Σⱼ (wⱼ / max w)`, so that any
/// finite non-negative weights with a positive sum (1e300, f64::MAX, subnormals) give draws in
/// proportion to them. Two passes over the weights (the checks with the largest weight, the total)
/// precede the drawing pass; nothing is copied. Allocates its result (and, for the multinomial and
/// residual schemes, the sorted draws); [`ParticleSet::resample`](super::ParticleSet::resample)
/// reuses buffers instead.
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
    let weights = Weights::checked(weights)?;
    let mut indices = with_capacity(DRAWS, n)?;
    let mut work = Workspace::default();
    if matches!(scheme, Resampling::Multinomial | Resampling::Residual) {
        reserve(&mut work.sums, DRAWS, n)?;
    }
    resample_into(weights, n, scheme, rng, &mut work, &mut indices);
    Ok(indices)
}

/// Finite non-negative weights, not all zero, normalised as they are read:
/// `wᵢ = (rawᵢ / largest) / total` with `total = Σ rawᵢ / largest` in [1, len], so that no weight up
/// to f64::MAX overflows the total.
#[derive(Clone, Copy, Debug)]
pub(super) struct Weights<'a> {
    raw: &'a [f64],
    largest: f64,
    total: f64,
}

impl<'a> Weights<'a> {
    /// Weights that are already normalised (as a particle set keeps them), read as they are:
    /// dividing by 1 is exact.
    pub(super) fn normalised(raw: &'a [f64]) -> Self {
        Self {
            raw,
            largest: 1.0,
            total: 1.0,
        }
    }

    /// Checks the weights (and finds the largest) in one pass, then sums them in a second.
    ///
    /// # Errors
    /// As [`resample_indices`].
    fn checked(raw: &'a [f64]) -> Result<Self, OperatorError> {
        const WEIGHT: &str = "resampling weight";
        if raw.is_empty() {
            return Err(OperatorError::OutOfRange {
                what: "number of weights to resample from",
                value: 0.0,
                range: "at least 1",
            });
        }
        let (largest, valid) = raw.iter().fold((0.0_f64, true), |(largest, valid), &w| {
            (largest.max(w), valid & (0.0..=f64::MAX).contains(&w))
        });
        if !valid {
            // The first non-finite weight, else the first negative one.
            return Err(match raw.iter().find(|w| !w.is_finite()) {
                Some(&value) => OperatorError::NonFinite {
                    what: WEIGHT,
                    value,
                },
                None => OperatorError::OutOfRange {
                    what: WEIGHT,
                    value: raw.iter().copied().find(|w| *w < 0.0).unwrap_or_default(),
                    range: "[0, infinity)",
                },
            });
        }
        if largest == 0.0 {
            return Err(OperatorError::NonFinite {
                what: "total resampling weight (every weight is zero)",
                value: 0.0,
            });
        }
        let total = raw.iter().map(|w| w / largest).sum();
        Ok(Self {
            raw,
            largest,
            total,
        })
    }

    /// The normalised weights wᵢ, in index order.
    fn iter(self) -> impl DoubleEndedIterator<Item = f64> + ExactSizeIterator + 'a {
        self.raw.iter().map(move |w| w / self.largest / self.total)
    }
}

/// The buffer reused from one resampling to the next: the partial sums of the exponential spacings
/// of the multinomial (and residual) draws.
#[derive(Clone, Debug, Default)]
pub(super) struct Workspace {
    sums: Vec<f64>,
}

impl Workspace {
    /// The buffer for resampling n particles, allocated once, so that no resampling of a set of n
    /// particles allocates.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] when it cannot be allocated.
    pub(super) fn for_particles(what: &'static str, n: usize) -> Result<Self, OperatorError> {
        Ok(Self {
            sums: with_capacity(what, n)?,
        })
    }
}

/// n draws from `weights` into `out` (cleared first), with the workspace's buffer (which must have
/// room for n for the multinomial and residual schemes, or it grows). One pass over the weights
/// draws and merges, normalising each weight as it is read; the stratified and systematic points
/// are generated in that pass, the multinomial ones (exponential spacings) need their total first
/// and are stored.
pub(super) fn resample_into<R: Rng + ?Sized>(
    weights: Weights<'_>,
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
    let unfixed = |w| (w, 0);
    let last = || last_positive(weights.iter());
    match scheme {
        Resampling::Multinomial => {
            let total = exponential_sums(n, rng, &mut work.sums);
            let points = work.sums.iter().map(|s| s / total);
            select(weights, unfixed, last(), points, n, out);
        }
        Resampling::Stratified => {
            let points = (0..n).map(|k| (k as f64 + rng.random::<f64>()) / nf);
            select(weights, unfixed, last(), points, n, out);
        }
        Resampling::Systematic => systematic(weights, n, rng.random::<f64>(), out),
        Resampling::Residual => residual(weights, n, rng, &mut work.sums, out),
    }
}

/// Copies of its index each particle writes without looking at its count (the systematic scheme's
/// counts are ⌊N wᵢ⌋ or ⌈N wᵢ⌉, so a particle rarely has more).
const COPIES: usize = 4;

/// The systematic points `(k + u)/N` counted instead of merged: the points below the cumulative
/// weight `Cᵢ` are the k with `k < N Cᵢ − u`, so particle i's copies fill `out[sᵢ₋₁, sᵢ)` with
/// `sᵢ = ⌈N Cᵢ − u⌉` clamped to [0, N]. Each particle writes [`COPIES`] copies at `sᵢ₋₁` whatever its
/// count (a particle without copies is overwritten by the next one, which starts at the same place;
/// the copies past a particle's end by the particles after it), and only a particle with more copies
/// writes the rest: one pass over the weights without a data-dependent branch per particle (but
/// within [`COPIES`] of the end, where the copies would not fit). The last particle of positive
/// weight takes the points past the rounded total.
fn systematic(weights: Weights<'_>, n: usize, u: f64, out: &mut Vec<usize>) {
    let nf = n as f64;
    let last = last_positive(weights.iter());
    out.clear();
    out.resize(n, 0);
    let mut cumulative = 0.0;
    let mut start = 0;
    for (i, w) in weights.iter().enumerate().take(last + 1) {
        cumulative += w;
        // In [0, N] before the cast: exact.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let end = (nf * cumulative - u).ceil().clamp(0.0, nf) as usize;
        if start + COPIES <= n {
            out[start..start + COPIES].fill(i);
            if end > start + COPIES {
                out[start + COPIES..end].fill(i);
            }
        } else {
            // The last few draws: no room for the unconditional copies.
            out[start..end].fill(i);
        }
        start = end;
    }
    out[start..].fill(last);
}

/// ⌊N wᵢ⌋ copies of each particle (at most N in all: the bound absorbs the rounding of N wᵢ), and
/// the remaining R = N − Σ ⌊N wᵢ⌋ draws multinomially from the residuals `rᵢ = N wᵢ − ⌊N wᵢ⌋`,
/// normalised by their sum: one pass for the floors and that sum, one to draw and merge in index
/// order; time linear in N and the number of particles.
fn residual<R: Rng + ?Sized>(
    weights: Weights<'_>,
    n: usize,
    rng: &mut R,
    sums: &mut Vec<f64>,
    out: &mut Vec<usize>,
) {
    let nf = n as f64;
    // With normalised weights ⌊N wᵢ⌋ ≤ N wᵢ, so the floors sum to at most N up to rounding.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let floor = |w: f64| (nf * w).floor() as usize;
    let residual = |w: f64| nf * w - (nf * w).floor();
    let (floors, total) = weights.iter().fold((0_usize, 0.0), |(floors, total), w| {
        (floors.saturating_add(floor(w)), total + residual(w))
    });
    let rest = n.saturating_sub(floors);
    // The R draws as sorted points in [0, 1], and the particle that takes the points past the
    // rounded total of the residuals.
    let (points_total, last) = if rest == 0 {
        sums.clear();
        (1.0, 0)
    } else if total > 0.0 {
        let points_total = exponential_sums(rest, rng, sums);
        (
            points_total,
            last_positive(weights.iter().map(|w| residual(w) / total)),
        )
    } else {
        // Every N wᵢ was an integer up to rounding: the floors fell short of N only by that
        // rounding, and the heaviest particle takes the rest (every point goes past the residuals'
        // total, zero).
        sums.clear();
        sums.resize(rest, 0.0);
        let heaviest = weights
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(0, |(i, _)| i);
        (1.0, heaviest)
    };
    let divisor = if total > 0.0 { total } else { 1.0 };
    select(
        weights,
        |w| (residual(w) / divisor, floor(w)),
        last,
        sums.iter().map(|s| s / points_total),
        n,
        out,
    );
}

/// The partial sums `Sₖ = E₁ + … + Eₖ` of n independent Exp(1) draws into `sums` (cleared first),
/// and `Sₙ₊₁`: by Rényi's representation `(S₁, …, Sₙ) / Sₙ₊₁` is distributed as the order statistics
/// of n uniform draws on [0, 1], sorted in time linear in n.
fn exponential_sums<R: Rng + ?Sized>(n: usize, rng: &mut R, sums: &mut Vec<f64>) -> f64 {
    sums.clear();
    let mut sum = 0.0;
    sums.extend((0..n).map(|_| {
        sum += rng.sample::<f64, _>(Exp1);
        sum
    }));
    sum + rng.sample::<f64, _>(Exp1)
}

/// The index of the last positive weight (0 if none).
fn last_positive(mut weights: impl DoubleEndedIterator<Item = f64> + ExactSizeIterator) -> usize {
    weights.rposition(|w| w > 0.0).unwrap_or(0)
}

/// Weights normalised, accumulated and merged this many at a time (on the stack): the divisions of a
/// block run side by side, and the merge reads finished cumulative sums.
const BLOCK: usize = 256;

/// Merges sorted points in [0, 1] with the cumulative weights `Cᵢ = w₀ + … + wᵢ` (summed in index
/// order) of `(wᵢ, fixedᵢ) = split(weightᵢ)`, appending for each particle i its `fixedᵢ` copies
/// (capped so that `out` holds at most `draws`), then one copy per point p < Cᵢ not taken before;
/// particle `last` takes every point left, so that a point past the rounded total goes to the last
/// particle of positive weight, never to a trailing particle of weight zero.
fn select(
    weights: Weights<'_>,
    split: impl Fn(f64) -> (f64, usize),
    last: usize,
    points: impl Iterator<Item = f64>,
    draws: usize,
    out: &mut Vec<usize>,
) {
    let mut points = Blocks::new(points);
    let mut cumulative = [0.0; BLOCK];
    let mut fixed = [0; BLOCK];
    let mut sum = 0.0;
    for (b, raw) in weights.raw.chunks(BLOCK).enumerate() {
        let (cumulative, fixed) = (&mut cumulative[..raw.len()], &mut fixed[..raw.len()]);
        for ((c, f), w) in cumulative.iter_mut().zip(fixed.iter_mut()).zip(raw) {
            (*c, *f) = split(w / weights.largest / weights.total);
        }
        for c in cumulative.iter_mut() {
            sum += *c;
            *c = sum;
        }
        for ((i, &c), &f) in (b * BLOCK..).zip(cumulative.iter()).zip(fixed.iter()) {
            out.extend(std::iter::repeat_n(i, f.min(draws - out.len())));
            while points.next_if(|p| p < c || i == last) {
                out.push(i);
            }
        }
    }
}

/// Points drawn a block at a time (the draws of a block run side by side, and the merge reads
/// finished values).
struct Blocks<I> {
    source: I,
    block: [f64; BLOCK],
    len: usize,
    next: usize,
}

impl<I: Iterator<Item = f64>> Blocks<I> {
    fn new(source: I) -> Self {
        Self {
            source,
            block: [0.0; BLOCK],
            len: 0,
            next: 0,
        }
    }

    /// Takes the next point if there is one and `take` holds for it.
    fn next_if(&mut self, take: impl Fn(f64) -> bool) -> bool {
        if self.next == self.len {
            self.len = self
                .block
                .iter_mut()
                .zip(&mut self.source)
                .map(|(slot, p)| *slot = p)
                .count();
            self.next = 0;
        }
        let taken = self.next < self.len && take(self.block[self.next]);
        self.next += usize::from(taken);
        taken
    }
}
