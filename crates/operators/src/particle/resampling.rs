//! The four resampling schemes, normalising the weights as they are read, with a buffer kept between
//! calls.

use crate::OperatorError;
use crate::error::check_size;
use rand::{Rng, RngCore};
use rand_distr::{Distribution, Exp1, Gamma};

/// How to resample N particles from normalised weights wᵢ. All four are unbiased (each particle's
/// expected number of copies is N wᵢ); they differ in variance and cost:
///
/// * `Multinomial`: N independent draws; the highest variance. Drawn sorted, as exponential
///   spacings a block at a time (see [`Resampler::draw`]).
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

/// The indices of n draws from `weights` by `scheme`, in increasing order (empty for n = 0): the
/// one-off form of [`Resampler::draw`], which keeps its buffers for the next call. Allocates its
/// result (and, for the multinomial and residual schemes, one block of sorted draws and the sums of
/// the blocks).
///
/// # Errors
/// As [`Resampler::draw`].
pub fn resample_indices<R: Rng + ?Sized>(
    weights: &[f64],
    n: usize,
    scheme: Resampling,
    rng: &mut R,
) -> Result<Vec<usize>, OperatorError> {
    let mut resampler = Resampler::default();
    resampler.draw(weights, n, scheme, rng)?;
    Ok(resampler.indices)
}

/// Resampling that keeps its buffers from one call to the next: once it has drawn n indices by a
/// scheme, no later call for up to n draws allocates (a particle set keeps one for its own
/// resampling).
///
/// ```
/// use liebayes_operators::particle::{Resampler, Resampling};
/// use rand::SeedableRng;
///
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
/// let mut resampler = Resampler::with_capacity(4)?;
/// // Weights need not be normalised; a particle of weight zero is never drawn.
/// let indices = resampler.draw(&[1.0, 0.0, 3.0], 4, Resampling::Systematic, &mut rng)?;
/// assert_eq!(indices.len(), 4);
/// assert_eq!(indices.iter().filter(|&&i| i == 2).count(), 3);
/// # Ok::<(), liebayes_operators::OperatorError>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct Resampler {
    /// The drawn indices, with room for [`COPIES`] more.
    indices: Vec<usize>,
    /// The sum of each block's spacings, for the multinomial and residual schemes.
    block_sums: Vec<f64>,
    /// One block of their sorted points, followed by [`WINDOW`] infinities.
    block: Vec<f64>,
}

impl Resampler {
    /// A resampler with room for n draws by any scheme, so that no call for up to n draws allocates.
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] for n above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the
    /// buffers cannot be allocated.
    pub fn with_capacity(n: usize) -> Result<Self, OperatorError> {
        check_size(DRAWS, n)?;
        let mut resampler = Self::default();
        resampler.reserve(n, true)?;
        Ok(resampler)
    }

    /// The indices of n draws from `weights` by `scheme`, in increasing order (empty for n = 0),
    /// valid until the next call. The weights need not be normalised: any finite non-negative
    /// weights with a positive sum (1e300, f64::MAX, subnormals) give draws in proportion to them.
    /// One pass checks the weights, finds the largest and sums them (a second sums them scaled by a
    /// power of two when that sum overflows or the weights are tiny), one more draws; nothing is
    /// copied and no scheme sorts: time linear in n and the number of weights.
    ///
    /// The random numbers: the systematic scheme takes one uniform from `rng`; the other schemes
    /// take one 64-bit seed from `rng` and draw from SplitMix64 started there (the stratified
    /// scheme finds the uniform of stratum k as SplitMix64's k-th output, by its index). The
    /// multinomial scheme, and the residual scheme's remainder, draw their sorted points by Rényi's
    /// representation, in blocks of 1024: each block's sum of exponential spacings is one
    /// Gamma draw, and the spacings inside it are fresh exponential draws scaled to that sum (the
    /// normalised spacings are independent of their sum), so only one block is held at a time.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for no weights (with n > 0) or a negative weight,
    /// [`OperatorError::NonFinite`] for a NaN or infinite weight or weights that are all zero,
    /// [`OperatorError::TooLarge`] for n above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the
    /// buffers cannot grow to n; all checked before anything is allocated or drawn.
    pub fn draw<R: Rng + ?Sized>(
        &mut self,
        weights: &[f64],
        n: usize,
        scheme: Resampling,
        rng: &mut R,
    ) -> Result<&[usize], OperatorError> {
        check_size(DRAWS, n)?;
        if n == 0 {
            self.indices.clear();
            return Ok(&self.indices);
        }
        let weights = Weights::checked(weights)?;
        self.reserve(
            n,
            matches!(scheme, Resampling::Multinomial | Resampling::Residual),
        )?;
        Ok(self.draw_checked(weights, n, scheme, rng))
    }

    /// The indices of the last draw.
    pub(super) fn indices(&self) -> &[usize] {
        &self.indices
    }

    /// n ≥ 1 draws from checked `weights` into the indices (the buffers must have room for n, or
    /// they grow). Each scheme counts, for particle i, how many of its sorted points lie below the
    /// cumulative weight `Cᵢ = w₀ + … + wᵢ` (summed in index order): that count is where particle
    /// i's copies end. The last particle of positive weight takes the points past the rounded total.
    pub(super) fn draw_checked<R: Rng + ?Sized>(
        &mut self,
        weights: Weights<'_>,
        n: usize,
        scheme: Resampling,
        rng: &mut R,
    ) -> &[usize] {
        let out = &mut self.indices;
        out.clear();
        let nf = n as f64;
        match scheme {
            Resampling::Multinomial => {
                let (mut points, total) =
                    SortedPoints::new(n, rng, &mut self.block_sums, &mut self.block);
                by_counts(weights, n, total, out, |c| points.below(c));
            }
            Resampling::Stratified => {
                let seed = rng.next_u64();
                by_counts(weights, n, nf, out, |c| {
                    // Point k = (k + Uₖ)/N of stratum k lies below Cᵢ iff k < ⌊N Cᵢ⌋, or k = ⌊N Cᵢ⌋ and
                    // Uₖ < N Cᵢ − ⌊N Cᵢ⌋.
                    let (k, whole) = floor_count(c.min(nf));
                    k + usize::from(k < n && SplitMix64::uniform_at(seed, k) < c - whole)
                });
            }
            Resampling::Systematic => {
                let u = rng.random::<f64>();
                by_counts(weights, n, nf, out, |c| {
                    // Points (k + u)/N below Cᵢ: k < N Cᵢ − u.
                    let x = (c - u).clamp(0.0, nf);
                    let (k, whole) = floor_count(x);
                    k + usize::from(whole < x)
                });
            }
            Resampling::Residual => {
                residual(weights, n, rng, &mut self.block_sums, &mut self.block, out);
            }
        }
        out
    }

    /// Room for n indices and, with `points`, the blocks of n sorted points (n below
    /// [`MAX_ELEMENTS`](crate::MAX_ELEMENTS), checked by the caller).
    fn reserve(&mut self, n: usize, points: bool) -> Result<(), OperatorError> {
        grow(&mut self.indices, n + COPIES)?;
        if points {
            grow(&mut self.block_sums, n.div_ceil(BLOCK))?;
            grow(&mut self.block, BLOCK + WINDOW)?;
        }
        Ok(())
    }
}

/// What `resample_indices` calls its draws in errors.
const DRAWS: &str = "number of resampled draws";

/// Below this largest weight, or when the plain sum overflows, the weights are summed and read
/// scaled by a power of two (so that `N / total` stays finite).
const TINY: f64 = 1e-270;

/// Finite non-negative weights, not all zero, read as `wᵢ = rawᵢ · scale / total` with
/// `total = Σ rawᵢ · scale`: `scale` is 1 unless the weights are tiny (below [`TINY`]) or their sum
/// overflows, when it is a power of two (exact scaling) that brings the largest weight near 1.
#[derive(Clone, Copy, Debug)]
pub(super) struct Weights<'a> {
    raw: &'a [f64],
    scale: f64,
    total: f64,
}

impl<'a> Weights<'a> {
    /// Weights that are already normalised (as a particle set keeps them), read as they are.
    pub(super) fn normalised(raw: &'a [f64]) -> Self {
        Self {
            raw,
            scale: 1.0,
            total: 1.0,
        }
    }

    /// Checks the weights, finds the largest and sums them in one pass (four sums side by side);
    /// sums them again scaled when the plain sum overflows or the weights are tiny.
    ///
    /// # Errors
    /// As [`resample_indices`].
    fn checked(raw: &'a [f64]) -> Result<Self, OperatorError> {
        const WEIGHT: &str = "resampling weight";
        const LANES: usize = 4;
        if raw.is_empty() {
            return Err(OperatorError::OutOfRange {
                what: "number of weights to resample from",
                value: 0.0,
                range: "at least 1",
            });
        }
        let (mut largest, mut sum, mut valid) = ([0.0_f64; LANES], [0.0_f64; LANES], true);
        let chunks = raw.chunks_exact(LANES);
        let tail = chunks.remainder();
        for chunk in chunks {
            for ((l, s), &w) in largest.iter_mut().zip(&mut sum).zip(chunk) {
                *l = l.max(w);
                *s += w;
                valid &= (0.0..=f64::MAX).contains(&w);
            }
        }
        for (l, (s, &w)) in largest.iter_mut().zip(sum.iter_mut().zip(tail)) {
            *l = l.max(w);
            *s += w;
            valid &= (0.0..=f64::MAX).contains(&w);
        }
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
        let largest = largest.into_iter().fold(0.0, f64::max);
        if largest == 0.0 {
            return Err(OperatorError::NonFinite {
                what: "total resampling weight (every weight is zero)",
                value: 0.0,
            });
        }
        let total: f64 = sum.into_iter().sum();
        if total.is_finite() && largest >= TINY {
            return Ok(Self {
                raw,
                scale: 1.0,
                total,
            });
        }
        // Powers of two: scaling by them is exact (but for weights that underflow, below 2⁻¹⁰⁷⁴
        // of the largest). The largest weight becomes at most 2⁴²⁴ or at least 2⁻⁴⁷⁴.
        let scale = if largest < TINY {
            2f64.powi(600)
        } else {
            2f64.powi(-600)
        };
        let total = raw.iter().map(|w| w * scale).sum();
        Ok(Self { raw, scale, total })
    }

    /// `factor / total`, finite for factors up to 2⁵⁰⁰ (the total is at least [`TINY`], or 2⁻⁴⁷⁴
    /// when scaled), for [`Weights::scaled`].
    fn per(self, factor: f64) -> f64 {
        factor / self.total
    }

    /// A raw weight's normalised weight times `factor`, with `per = self.per(factor)`. Two products:
    /// `scale · per` alone can overflow (subnormal weights have a total near 2⁻¹⁰⁷⁴).
    fn scaled(self, raw: f64, per: f64) -> f64 {
        raw * self.scale * per
    }

    /// The index of the last particle whose `positive` holds (0 if none).
    fn last(self, positive: impl Fn(f64) -> bool) -> usize {
        self.raw.iter().rposition(|&w| positive(w)).unwrap_or(0)
    }
}

/// Sorted points are stored followed by this many infinite ones, so that a window of this many
/// points from any point up to the last is in the buffer.
const WINDOW: usize = 4;

/// Makes room for `capacity` elements in an emptied `buffer` (nothing to do when it has it).
///
/// # Errors
/// [`OperatorError::TooLarge`] when it cannot be allocated.
fn grow<T>(buffer: &mut Vec<T>, capacity: usize) -> Result<(), OperatorError> {
    buffer.clear();
    buffer
        .try_reserve_exact(capacity)
        .map_err(|_| OperatorError::TooLarge {
            what: DRAWS,
            value: capacity,
            max: crate::MAX_ELEMENTS,
        })
}

/// ⌊x⌋ of a count x in [0, 2⁵³], as an index and as a float. The casts truncate, which is the floor
/// there, and go through i64, whose conversions are single instructions on x86-64 (a call to `floor`
/// would be a library call on the baseline target, and usize conversions take several steps).
#[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
fn floor_count(x: f64) -> (usize, f64) {
    let k = x as i64;
    (k as usize, k as f64)
}

/// Copies of its index each particle writes without looking at its count (a particle rarely has
/// more: the systematic scheme gives ⌊N wᵢ⌋ or ⌈N wᵢ⌉ copies, the others about N wᵢ on average).
const COPIES: usize = 4;

/// Appends copies of particle i to `out` until it holds `end`. It appends [`COPIES`] copies whatever
/// the count and then shortens or lengthens `out` to `end`, so that the common counts (zero to
/// [`COPIES`]) take no data-dependent branch, and each slot of `out` is written once or twice, never
/// cleared first. `out` has room for [`COPIES`] more than the draws, so nothing is reallocated.
#[inline]
fn push_copies(out: &mut Vec<usize>, end: usize, i: usize) {
    out.extend_from_slice(&[i; COPIES]);
    if end > out.len() {
        out.resize(end, i);
    } else {
        out.truncate(end);
    }
}

/// The draws of the multinomial, stratified and systematic schemes: particle i's copies end where
/// `end(Cᵢ)` says, `Cᵢ` the cumulative weight in units of `factor` (the points' total); the last
/// particle of positive weight takes every draw left, up to n. One pass over the weights up to that
/// particle. `end` must not decrease.
fn by_counts(
    weights: Weights<'_>,
    n: usize,
    factor: f64,
    out: &mut Vec<usize>,
    mut end: impl FnMut(f64) -> usize,
) {
    let last = weights.last(|w| w > 0.0);
    let per = weights.per(factor);
    let mut cumulative = 0.0;
    for (i, &raw) in weights.raw[..last].iter().enumerate() {
        cumulative += weights.scaled(raw, per);
        let stop = end(cumulative).clamp(out.len(), n);
        push_copies(out, stop, i);
    }
    out.resize(n, last);
}

/// SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators", 2014):
/// a 64-bit counter advanced by the golden-ratio increment and mixed, so that its k-th output can
/// also be found directly by index. A small fast generator for the schemes' many draws, started
/// from one draw of the caller's generator.
#[derive(Clone, Copy, Debug)]
struct SplitMix64(u64);

impl SplitMix64 {
    const INCREMENT: u64 = 0x9e37_79b9_7f4a_7c15;

    /// The generator's k-th output (k = 0 first) from `seed`, the top 53 bits as a uniform in
    /// [0, 1).
    fn uniform_at(seed: u64, k: usize) -> f64 {
        let state = seed.wrapping_add((k as u64).wrapping_add(1).wrapping_mul(Self::INCREMENT));
        (Self::mix(state) >> 11) as f64 * (f64::EPSILON / 2.0)
    }

    fn mix(mut z: u64) -> u64 {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

impl RngCore for SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(Self::INCREMENT);
        Self::mix(self.0)
    }

    #[allow(clippy::cast_possible_truncation)]
    fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    fn fill_bytes(&mut self, dst: &mut [u8]) {
        for chunk in dst.chunks_mut(8) {
            let bytes = self.next_u64().to_le_bytes();
            chunk.copy_from_slice(&bytes[..chunk.len()]);
        }
    }
}

/// Sorted points are drawn this many at a time (8 KiB, held in the first-level cache while it is
/// counted), so that N points take N/[`BLOCK`] stored sums instead of N stored points.
const BLOCK: usize = 1024;

/// The partial sums `Sₖ = E₁ + … + Eₖ` of n independent Exp(1) draws, read in increasing order, and
/// `Sₙ₊₁`: by Rényi's representation `(S₁, …, Sₙ) / Sₙ₊₁` is distributed as the order statistics of
/// n uniform draws on [0, 1], sorted in time linear in n. Drawn a block at a time: the sums of the
/// blocks first (one Gamma draw each, their total plus one more exponential is `Sₙ₊₁`), then each
/// block's spacings when the count reaches it, as [`BLOCK`] exponential draws scaled to the block's
/// sum.
struct SortedPoints<'a> {
    rng: SplitMix64,
    /// Each block's sum.
    sums: &'a [f64],
    /// The current block's points, then [`WINDOW`] infinities.
    block: &'a mut Vec<f64>,
    /// The blocks drawn so far.
    blocks: usize,
    /// The points before the current block, and their last (the sum of the blocks so far).
    before: usize,
    start: f64,
    /// The points left to draw, and the current block's first point not yet counted.
    left: usize,
    next: usize,
}

impl<'a> SortedPoints<'a> {
    /// n sorted points from a seed drawn from `rng`, in the buffers (which must have room for
    /// n / [`BLOCK`] sums and a block, or they grow), and their scale `Sₙ₊₁`.
    fn new<R: Rng + ?Sized>(
        n: usize,
        rng: &mut R,
        sums: &'a mut Vec<f64>,
        block: &'a mut Vec<f64>,
    ) -> (Self, f64) {
        let mut rng = SplitMix64(rng.next_u64());
        sums.clear();
        let mut total = 0.0;
        for start in (0..n).step_by(BLOCK) {
            // A block of k spacings sums to a Gamma(k, 1) draw (a shape of at least 1 is always
            // valid: the mean in its place is never taken).
            let size = (BLOCK.min(n - start)) as f64;
            let sum = Gamma::new(size, 1.0).map_or(size, |g| g.sample(&mut rng));
            sums.push(sum);
            total += sum;
        }
        total += rng.sample::<f64, _>(Exp1);
        block.clear();
        block.extend([f64::INFINITY; WINDOW]);
        let points = Self {
            rng,
            sums,
            block,
            blocks: 0,
            before: 0,
            start: 0.0,
            left: n,
            next: 0,
        };
        (points, total)
    }

    /// The number of points below `threshold`; thresholds must not decrease from call to call.
    #[inline]
    fn below(&mut self, threshold: f64) -> usize {
        self.next = points_below(self.block, self.next, threshold);
        if self.next + WINDOW == self.block.len() && self.left > 0 {
            self.below_in_next_blocks(threshold);
        }
        self.before + self.next
    }

    /// Draws blocks and counts on while every point of the current one is below `threshold` (at
    /// most once per block).
    #[inline(never)]
    fn below_in_next_blocks(&mut self, threshold: f64) {
        for _ in 0..self.sums.len() {
            self.before += self.block.len() - WINDOW;
            self.draw_block();
            self.next = points_below(self.block, 0, threshold);
            if self.next + WINDOW < self.block.len() || self.left == 0 {
                break;
            }
        }
    }

    /// The next block's points: its exponential spacings' partial sums scaled to the block's sum
    /// (the last point is the block's end exactly, so the points increase across blocks too).
    fn draw_block(&mut self) {
        let size = BLOCK.min(self.left);
        let (start, sum) = (self.start, self.sums[self.blocks]);
        let end = start + sum;
        let mut partial = 0.0;
        self.block.clear();
        self.block.extend((0..size).map(|_| {
            partial += self.rng.sample::<f64, _>(Exp1);
            partial
        }));
        let scale = if partial > 0.0 { sum / partial } else { 0.0 };
        for point in self.block.iter_mut() {
            *point = (start + *point * scale).min(end);
        }
        if let Some(last) = self.block.last_mut() {
            *last = end;
        }
        self.block.extend([f64::INFINITY; WINDOW]);
        self.blocks += 1;
        self.start = end;
        self.left -= size;
        self.next = 0;
    }
}

/// The index past the sorted points from `from` on that lie below `threshold`: the points are read
/// [`WINDOW`] at a time and counted, so that the loop goes round again only for a particle with
/// [`WINDOW`] or more draws (the buffer's infinite padding ends it).
#[inline]
fn points_below(points: &[f64], from: usize, threshold: f64) -> usize {
    let mut next = from;
    while let Some(window) = points.get(next..next + WINDOW) {
        let below = window.iter().filter(|&&p| p < threshold).count();
        next += below;
        if below < WINDOW {
            break;
        }
    }
    next
}

/// ⌊N wᵢ⌋ copies of each particle (at most N in all: the bound absorbs the rounding of N wᵢ), and
/// the remaining R = N − Σ ⌊N wᵢ⌋ draws multinomially from the residuals `rᵢ = N wᵢ − ⌊N wᵢ⌋`: one
/// pass for the floors and the residuals' total, one to count each particle's draws; time linear in
/// N and the number of particles.
fn residual<R: Rng + ?Sized>(
    weights: Weights<'_>,
    n: usize,
    rng: &mut R,
    sums: &mut Vec<f64>,
    block: &mut Vec<f64>,
    out: &mut Vec<usize>,
) {
    let per = weights.per(n as f64);
    // (⌊N wᵢ⌋, N wᵢ − ⌊N wᵢ⌋). With normalised weights ⌊N wᵢ⌋ ≤ N wᵢ ≤ N (up to rounding): the
    // cast is exact.
    let split = |w: f64| {
        let x = weights.scaled(w, per);
        let (floor, whole) = floor_count(x);
        (floor, x - whole)
    };
    let (floors, total) = weights
        .raw
        .iter()
        .fold((0_usize, 0.0), |(floors, total), &w| {
            let (floor, residual) = split(w);
            (floors.saturating_add(floor), total + residual)
        });
    let rest = n.saturating_sub(floors);
    let (mut points, points_total) = SortedPoints::new(rest, rng, sums, block);
    // The particle that takes the points past the rounded total of the residuals: the last with a
    // positive residual, or, when every N wᵢ was an integer up to rounding (the floors fell short of
    // N only by that rounding), the heaviest.
    let last = if total > 0.0 {
        weights.last(|w| split(w).1 > 0.0)
    } else {
        weights
            .raw
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(i, _)| i)
    };
    let factor = if total > 0.0 {
        points_total / total
    } else {
        0.0
    };
    let (mut cumulative, mut next) = (0.0, 0);
    for (i, &w) in weights.raw.iter().enumerate() {
        let (floor, residual) = split(w);
        cumulative += residual * factor;
        let before = next;
        next = if i == last {
            rest
        } else {
            points.below(cumulative)
        };
        let stop = (out.len().saturating_add(floor) + (next - before)).min(n);
        push_copies(out, stop, i);
    }
    out.resize(n, last);
}
