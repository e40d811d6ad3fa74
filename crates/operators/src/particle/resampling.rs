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
    let mut indices = resampler.indices;
    indices.truncate(n);
    Ok(indices)
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
    /// The drawn indices in the first `drawn` slots, with room for [`COPIES`] more (the slots
    /// past them hold what earlier draws left: each draw writes every slot it returns).
    indices: Vec<usize>,
    drawn: usize,
    /// Where each block of sorted points ends, for the multinomial and residual schemes.
    block_ends: Vec<f64>,
    /// Two blocks of those points, one for each run of the count, each followed by [`WINDOW`]
    /// infinities.
    blocks: Vec<f64>,
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
    /// The random numbers: the systematic scheme takes one uniform from `rng`; the stratified
    /// scheme takes one 64-bit seed and finds the uniform of stratum k as wyrand's k-th output
    /// from there, by its index. The multinomial scheme, and the residual scheme's remainder, take
    /// two seeds and draw their sorted points by Rényi's representation, in blocks of 1024: each
    /// block's sum of exponential spacings is one Gamma draw (wyrand from the first seed), and the
    /// spacings inside it are fresh exponential draws scaled to that sum (the normalised spacings
    /// are independent of their sum), from wyrand started at the block's own output of the second
    /// seed. Only two blocks are held at a time: from 2048 particles on, the count runs in two
    /// interleaved halves, each reading its own block, so that neither waits on its last count.
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
            self.drawn = 0;
            return Ok(&[]);
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
        &self.indices[..self.drawn]
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
        let out = &mut self.indices[..];
        let nf = n as f64;
        match scheme {
            Resampling::Multinomial => {
                let (points, total) = SortedPoints::new(n, rng, &mut self.block_ends);
                let per = weights.per(total);
                let last = weights.last(|w| w > 0.0);
                let drawn = count_draws(
                    &weights.raw[..=last],
                    last,
                    n,
                    &points,
                    &mut self.blocks,
                    out,
                    |raw| (0, weights.scaled(raw, per)),
                );
                out[drawn..n].fill(last);
            }
            Resampling::Stratified => {
                let seed = rng.next_u64();
                by_counts(weights, n, out, |c| {
                    // Point k = (k + Uₖ)/N of stratum k lies below Cᵢ iff k < ⌊N Cᵢ⌋, or k = ⌊N Cᵢ⌋ and
                    // Uₖ < N Cᵢ − ⌊N Cᵢ⌋.
                    let (k, whole) = floor_count(c.min(nf));
                    k + usize::from(k < n && WyRand::uniform_at(seed, k) < c - whole)
                });
            }
            Resampling::Systematic => {
                let u = rng.random::<f64>();
                by_counts(weights, n, out, |c| {
                    // Points (k + u)/N below Cᵢ: k < N Cᵢ − u.
                    let x = (c - u).clamp(0.0, nf);
                    let (k, whole) = floor_count(x);
                    k + usize::from(whole < x)
                });
            }
            Resampling::Residual => {
                residual(weights, n, rng, &mut self.block_ends, &mut self.blocks, out);
            }
        }
        self.drawn = n;
        &self.indices[..n]
    }

    /// Room for n indices and, with `points`, the blocks of n sorted points (n below
    /// [`MAX_ELEMENTS`](crate::MAX_ELEMENTS), checked by the caller).
    fn reserve(&mut self, n: usize, points: bool) -> Result<(), OperatorError> {
        grow(&mut self.indices, n + COPIES, 0)?;
        if points {
            // The ends are rewritten by each draw: room is all they need.
            let ends = n.div_ceil(BLOCK);
            if self.block_ends.capacity() < ends {
                self.block_ends.clear();
                reserve_exact(&mut self.block_ends, ends)?;
            }
            grow(&mut self.blocks, RUNS * (BLOCK + WINDOW), f64::INFINITY)?;
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

    /// Checks the weights, finds the largest and sums them in one pass (eight sums side by side);
    /// sums them again scaled when the plain sum overflows or the weights are tiny.
    ///
    /// The pass keeps no per-weight flag: a NaN or infinite weight makes the sum non-finite and a
    /// negative one makes the smallest negative, and only then are the weights read again for the
    /// first bad one (the sum may have only overflowed). So the pass is three vector operations a
    /// weight, fast enough to run at the speed of memory.
    ///
    /// # Errors
    /// As [`resample_indices`].
    fn checked(raw: &'a [f64]) -> Result<Self, OperatorError> {
        const WEIGHT: &str = "resampling weight";
        const LANES: usize = 8;
        if raw.is_empty() {
            return Err(OperatorError::OutOfRange {
                what: "number of weights to resample from",
                value: 0.0,
                range: "at least 1",
            });
        }
        let (mut largest, mut smallest, mut sum) =
            ([0.0_f64; LANES], [0.0_f64; LANES], [0.0; LANES]);
        let chunks = raw.chunks_exact(LANES);
        let tail = chunks.remainder();
        // Comparisons, not `f64::max` and `min`, whose care for NaN the sum already takes.
        let mut read = |lanes: &[f64]| {
            for (((l, m), s), &w) in largest
                .iter_mut()
                .zip(&mut smallest)
                .zip(&mut sum)
                .zip(lanes)
            {
                *l = if w > *l { w } else { *l };
                *m = if w < *m { w } else { *m };
                *s += w;
            }
        };
        for chunk in chunks {
            read(chunk);
        }
        read(tail);
        let total: f64 = sum.into_iter().sum();
        let smallest = smallest.into_iter().fold(0.0, f64::min);
        if !(total.is_finite() && smallest >= 0.0) {
            // The first non-finite weight, else the first negative one; else the sum overflowed.
            if let Some(&value) = raw.iter().find(|w| !w.is_finite()) {
                return Err(OperatorError::NonFinite {
                    what: WEIGHT,
                    value,
                });
            }
            if let Some(&value) = raw.iter().find(|w| **w < 0.0) {
                return Err(OperatorError::OutOfRange {
                    what: WEIGHT,
                    value,
                    range: "[0, infinity)",
                });
            }
        }
        let largest = largest.into_iter().fold(0.0, f64::max);
        if largest == 0.0 {
            return Err(OperatorError::NonFinite {
                what: "total resampling weight (every weight is zero)",
                value: 0.0,
            });
        }
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

/// Lengthens `buffer` to at least `len` elements, the new ones `fill` (nothing to do when it is
/// that long: what it holds is kept, to be overwritten).
///
/// # Errors
/// [`OperatorError::TooLarge`] when it cannot be allocated.
fn grow<T: Clone>(buffer: &mut Vec<T>, len: usize, fill: T) -> Result<(), OperatorError> {
    if buffer.len() >= len {
        return Ok(());
    }
    // Reserved fallibly first, so that a size the allocator refuses is an error, not an abort.
    reserve_exact(buffer, len - buffer.len())?;
    if buffer.is_empty() {
        // A fresh `vec!` of zeros takes memory the system has zeroed, its pages untouched until
        // the draws write them; `resize` would write every slot first (0.1 s at 1e8 draws).
        *buffer = Vec::new();
        *buffer = vec![fill; len];
    } else {
        buffer.resize(len, fill);
    }
    Ok(())
}

/// Room for `additional` more elements in `buffer`.
///
/// # Errors
/// [`OperatorError::TooLarge`] when it cannot be allocated.
fn reserve_exact<T>(buffer: &mut Vec<T>, additional: usize) -> Result<(), OperatorError> {
    buffer
        .try_reserve_exact(additional)
        .map_err(|_| OperatorError::TooLarge {
            what: DRAWS,
            value: buffer.len().saturating_add(additional),
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

/// Writes particle i's copies into `out[pos..end]` (`out` has [`COPIES`] slots past `pos`): it
/// writes that many whatever the count and then any more (the next particle overwrites what is
/// past `end`), so that the common counts (zero to [`COPIES`]) take no data-dependent branch and
/// no slot is cleared first.
#[inline]
fn write_copies(out: &mut [usize], pos: usize, end: usize, i: usize) {
    out[pos..pos + COPIES].copy_from_slice(&[i; COPIES]);
    if end > pos + COPIES {
        out[pos + COPIES..end].fill(i);
    }
}

/// Weights are summed this many at a time before their counts are taken. The sums alone are a
/// short loop that the processor runs far ahead of the counting, so that the reads of the next
/// weights from memory overlap it: at 1e8 particles the systematic scheme takes 4.3 ns a
/// particle where one loop of both took 6.5 ns (32 to 256 measured alike; 1024 and up slower).
const CHUNK: usize = 64;

/// The draws of the stratified and systematic schemes: particle i's copies end where `end(Cᵢ)`
/// says, `Cᵢ` the cumulative weight in units of N; the last particle of positive weight takes
/// every draw left, up to n. One pass over the weights up to that particle, [`CHUNK`] at a time.
/// `end` must not decrease; `out` holds n + [`COPIES`] slots.
// Measured: inlined into `draw_checked`, it made the residual scheme's loop there 28 % slower.
#[inline(never)]
fn by_counts(weights: Weights<'_>, n: usize, out: &mut [usize], end: impl Fn(f64) -> usize) {
    let last = weights.last(|w| w > 0.0);
    let per = weights.per(n as f64);
    let (mut cumulative, mut pos) = (0.0, 0);
    let mut sums = [0.0; CHUNK];
    for (c, chunk) in weights.raw[..last].chunks(CHUNK).enumerate() {
        for (sum, &raw) in sums.iter_mut().zip(chunk) {
            cumulative += weights.scaled(raw, per);
            *sum = cumulative;
        }
        for (j, &sum) in sums[..chunk.len()].iter().enumerate() {
            let stop = end(sum).min(n);
            write_copies(out, pos, stop, c * CHUNK + j);
            pos = stop;
        }
    }
    out[pos..n].fill(last);
}

/// wyrand (Wang Yi, the generator of the wyhash family): a 64-bit counter advanced by a fixed
/// odd increment, each output the 128-bit product of the counter and the counter xor a second
/// constant, its halves xored; so its k-th output can also be found directly by index. A small
/// fast generator (one multiplication an output) for the schemes' many draws, started from a
/// draw of the caller's generator.
#[derive(Clone, Copy, Debug)]
struct WyRand(u64);

impl WyRand {
    const INCREMENT: u64 = 0xa076_1d64_78bd_642f;
    const MIX: u64 = 0xe703_7ed1_a0b4_28db;

    /// The generator's k-th output (k = 0 first) from `seed`, the top 53 bits as a uniform in
    /// [0, 1).
    fn uniform_at(seed: u64, k: usize) -> f64 {
        (Self::output_at(seed, k) >> 11) as f64 * (f64::EPSILON / 2.0)
    }

    /// The generator's k-th output (k = 0 first) from `seed`.
    fn output_at(seed: u64, k: usize) -> u64 {
        Self::mix(seed.wrapping_add((k as u64).wrapping_add(1).wrapping_mul(Self::INCREMENT)))
    }

    /// The output of counter value z.
    #[allow(clippy::cast_possible_truncation)]
    fn mix(z: u64) -> u64 {
        let t = u128::from(z) * u128::from(z ^ Self::MIX);
        (t as u64) ^ ((t >> 64) as u64)
    }
}

impl RngCore for WyRand {
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
/// counted), so that N points take N/[`BLOCK`] stored block ends instead of N stored points.
const BLOCK: usize = 1024;

/// The count's runs over the particles, stepped in turn, each with its own block of points: a
/// run's next count starts from where its last one ended, a chain of dependent loads and
/// comparisons, and two chains side by side take 0.72 s for 1e8 multinomial draws where one
/// took 0.89 s.
const RUNS: usize = 2;

/// Below this many weighted particles the count is one run: two runs draw the block where they
/// meet twice and add a pass over the first run's weights.
const SPLIT: usize = 2 * BLOCK;

/// n sorted points, drawn a block at a time from the partial sums `Sₖ = E₁ + … + Eₖ` of n
/// independent Exp(1) draws: by Rényi's representation `(S₁, …, Sₙ) / Sₙ₊₁` is distributed as the
/// order statistics of n uniform draws on [0, 1], sorted in time linear in n. The blocks' sums
/// are drawn first (one Gamma draw each; their total plus one more exponential is `Sₙ₊₁`); a
/// block's points are its [`BLOCK`] exponential spacings scaled to its sum (the normalised
/// spacings are independent of their sum), drawn from its own generator (wyrand started at the
/// block's output of a second seed), so that any block can be drawn on its own and
/// drawn again the same.
struct SortedPoints<'a> {
    /// Where each block ends: `S` at its last point.
    ends: &'a [f64],
    /// The blocks' generators' seed.
    seed: u64,
    n: usize,
}

impl<'a> SortedPoints<'a> {
    /// n sorted points from two seeds drawn from `rng`, their block ends in `ends` (which must
    /// have room for n / [`BLOCK`] of them, or it grows), and their scale `Sₙ₊₁`.
    fn new<R: Rng + ?Sized>(n: usize, rng: &mut R, ends: &'a mut Vec<f64>) -> (Self, f64) {
        let mut sums = WyRand(rng.next_u64());
        let seed = rng.next_u64();
        ends.clear();
        let mut total = 0.0;
        for start in (0..n).step_by(BLOCK) {
            // A block of k spacings sums to a Gamma(k, 1) draw (a shape of at least 1 is always
            // valid: the mean in its place is never taken).
            let size = (BLOCK.min(n - start)) as f64;
            total += Gamma::new(size, 1.0).map_or(size, |g| g.sample(&mut sums));
            ends.push(total);
        }
        total += sums.sample::<f64, _>(Exp1);
        (Self { ends, seed, n }, total)
    }

    /// Block b's points into `block[..size]` (the rest of `block`, [`WINDOW`] or more slots, is
    /// left infinite), and their number `size`. The partial sums run in four interleaved chains
    /// (a group of four spacings is summed off the chain, and the running total steps a group at a
    /// time); the points are scaled to the block's span and its last is the block's end exactly,
    /// so that the points increase across blocks too.
    fn draw(&self, b: usize, block: &mut [f64]) -> usize {
        let size = BLOCK.min(self.n - b * BLOCK);
        let (start, end) = (if b == 0 { 0.0 } else { self.ends[b - 1] }, self.ends[b]);
        let mut rng = WyRand(WyRand::output_at(self.seed, b));
        let points = &mut block[..size];
        for point in points.iter_mut() {
            *point = rng.sample(Exp1);
        }
        let mut total = 0.0;
        let mut groups = points.chunks_exact_mut(4);
        for group in &mut groups {
            let partial = [
                group[0],
                group[0] + group[1],
                group[0] + group[1] + group[2],
                group[0] + group[1] + group[2] + group[3],
            ];
            for (point, p) in group.iter_mut().zip(partial) {
                *point = total + p;
            }
            total += partial[3];
        }
        for point in groups.into_remainder() {
            total += *point;
            *point = total;
        }
        let scale = if total > 0.0 {
            (end - start) / total
        } else {
            0.0
        };
        for point in points.iter_mut() {
            *point = (start + *point * scale).min(end);
        }
        points[size - 1] = end;
        block[size..].fill(f64::INFINITY);
        size
    }
}

/// A reader of [`SortedPoints`] in increasing order, one block at a time in its own buffer: it
/// counts the points below thresholds that do not decrease from call to call.
struct Cursor<'a, 'b> {
    points: &'b SortedPoints<'a>,
    /// The current block's points, then [`WINDOW`] or more infinities.
    block: &'b mut [f64],
    /// The current block, its number of points, and its first point not yet counted.
    index: usize,
    size: usize,
    next: usize,
}

impl<'a, 'b> Cursor<'a, 'b> {
    /// A cursor at the block where `threshold` falls (the first for 0), with the points below it
    /// counted: [`Cursor::rank`] is their number.
    fn at(points: &'b SortedPoints<'a>, block: &'b mut [f64], threshold: f64) -> Self {
        let index = points
            .ends
            .partition_point(|&end| end < threshold)
            .min(points.ends.len().saturating_sub(1));
        let size = if points.ends.is_empty() {
            block.fill(f64::INFINITY);
            0
        } else {
            points.draw(index, block)
        };
        let mut cursor = Self {
            points,
            block,
            index,
            size,
            next: 0,
        };
        cursor.below(threshold);
        cursor
    }

    /// The number of points counted.
    fn rank(&self) -> usize {
        self.index * BLOCK + self.next
    }

    /// The number of points below `threshold`.
    #[inline]
    fn below(&mut self, threshold: f64) -> usize {
        self.next = points_below(self.block, self.next, threshold);
        if self.next == self.size {
            self.below_in_next_blocks(threshold);
        }
        self.rank()
    }

    /// Draws blocks and counts on while every point of the current one is below `threshold` (at
    /// most once per block).
    #[inline(never)]
    fn below_in_next_blocks(&mut self, threshold: f64) {
        while self.next == self.size && self.index + 1 < self.points.ends.len() {
            self.index += 1;
            self.size = self.points.draw(self.index, self.block);
            self.next = points_below(self.block, 0, threshold);
        }
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

/// One run of the count: particles in index order, each taking its floor of copies and the
/// points between its cumulative weight and the one before it, the cumulative weight held at or
/// below `limit` (where the next run starts).
struct Run<'a, 'b> {
    cursor: Cursor<'a, 'b>,
    cumulative: f64,
    limit: f64,
    /// The points counted, the next slot of the output, and the slot its draws must end by.
    rank: usize,
    pos: usize,
    end: usize,
}

impl Run<'_, '_> {
    /// Particle i's copies: `floor` of them, and the points up to its cumulative weight after
    /// adding `weight`.
    // Measured: left to the compiler, the step and `take` are calls per particle and the
    // multinomial scheme takes 0.86 s instead of 0.73 s for 1e8 draws.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn step(&mut self, out: &mut [usize], i: usize, (floor, weight): (usize, f64)) {
        self.cumulative += weight;
        // Not `f64::min`, whose care for NaN (none here) costs instructions in the hot loop.
        let threshold = if self.cumulative < self.limit {
            self.cumulative
        } else {
            self.limit
        };
        self.take(out, i, floor, threshold);
    }

    /// Particle i's copies when it is the run's last: `floor` of them, and every point below the
    /// run's limit.
    fn finish(&mut self, out: &mut [usize], i: usize, (floor, _): (usize, f64)) {
        self.take(out, i, floor, self.limit);
    }

    /// Writes `floor` copies of particle i and one for each point up to `threshold`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn take(&mut self, out: &mut [usize], i: usize, floor: usize, threshold: f64) {
        let rank = self.cursor.below(threshold);
        let stop = (self.pos + floor + (rank - self.rank)).min(self.end);
        write_copies(out, self.pos, stop, i);
        self.pos = stop;
        self.rank = rank;
    }
}

/// Counts at most n draws of `weights` against `points` into `out` (room for n + [`COPIES`]):
/// particle i takes `split(wᵢ).0` copies and the points between the cumulative sums of
/// `split(wⱼ).1` before it and up to it; particle `last` (the last whose second part is positive:
/// those after it take only their floors) takes every point past its predecessor's sum. Returns
/// the slot past the last draw.
///
/// With [`SPLIT`] or more particles before `last`, two runs share the work: the first takes the
/// particles before m = last / 2 and the points below their total c₀ (summed first, four sums
/// side by side), the second starts at c₀ with the rest; they step in turn, and the counts are
/// those of one run with the first run's sums held at or below c₀.
fn count_draws(
    weights: &[f64],
    last: usize,
    n: usize,
    points: &SortedPoints<'_>,
    blocks: &mut [f64],
    out: &mut [usize],
    split: impl Fn(f64) -> (usize, f64),
) -> usize {
    let (first_block, second_block) = blocks.split_at_mut(BLOCK + WINDOW);
    let run = |block, threshold, floors: usize, limit, end: usize| {
        let cursor = Cursor::at(points, block, threshold);
        let rank = cursor.rank();
        Run {
            cursor,
            cumulative: threshold,
            limit,
            rank,
            pos: floors.saturating_add(rank).min(end),
            end,
        }
    };
    // The first run's particles (none when there is one run), and where the second starts.
    let m = if last < SPLIT { 0 } else { last / 2 };
    let (floors, c0) = sum_split(&weights[..m], &split);
    let mut second = run(second_block, c0, floors, f64::INFINITY, n);
    let start = second.pos;
    // The second run's first particles, until its draws fill [`COPIES`] slots: the first run's
    // last particles may write copies into those slots, so they are kept aside and put back.
    let mut i = m;
    while i < last && second.pos < start + COPIES {
        second.step(out, i, split(weights[i]));
        i += 1;
    }
    let mut kept = [0; COPIES];
    kept.copy_from_slice(&out[start..start + COPIES]);
    if m > 0 {
        let mut first = run(first_block, 0.0, 0, c0, start);
        let paired = (m - 1).min(last - i);
        for (j, (&a, &b)) in weights[..paired].iter().zip(&weights[i..]).enumerate() {
            first.step(out, j, split(a));
            second.step(out, i + j, split(b));
        }
        for (j, &a) in weights[..m - 1].iter().enumerate().skip(paired) {
            first.step(out, j, split(a));
        }
        first.finish(out, m - 1, split(weights[m - 1]));
        i += paired;
    }
    out[start..start + COPIES].copy_from_slice(&kept);
    for (j, &w) in weights[..last].iter().enumerate().skip(i) {
        second.step(out, j, split(w));
    }
    second.finish(out, last, split(weights[last]));
    for (j, &w) in weights.iter().enumerate().skip(last + 1) {
        second.step(out, j, split(w));
    }
    second.pos
}

/// The sums of `split(w).0` and `split(w).1` over `weights`, the second in four sums side by
/// side.
fn sum_split(weights: &[f64], split: impl Fn(f64) -> (usize, f64)) -> (usize, f64) {
    const LANES: usize = 4;
    let (mut floors, mut sums) = (0_usize, [0.0; LANES]);
    let chunks = weights.chunks_exact(LANES);
    let tail = chunks.remainder();
    for chunk in chunks {
        for (sum, &w) in sums.iter_mut().zip(chunk) {
            let (floor, part) = split(w);
            floors = floors.saturating_add(floor);
            *sum += part;
        }
    }
    for &w in tail {
        let (floor, part) = split(w);
        floors = floors.saturating_add(floor);
        sums[0] += part;
    }
    (floors, sums.into_iter().sum())
}

/// ⌊N wᵢ⌋ copies of each particle (at most N in all: the bound absorbs the rounding of N wᵢ), and
/// the remaining R = N − Σ ⌊N wᵢ⌋ draws multinomially from the residuals `rᵢ = N wᵢ − ⌊N wᵢ⌋`: one
/// pass for the floors and the residuals' total, one to count each particle's draws; time linear in
/// N and the number of particles.
fn residual<R: Rng + ?Sized>(
    weights: Weights<'_>,
    n: usize,
    rng: &mut R,
    ends: &mut Vec<f64>,
    blocks: &mut [f64],
    out: &mut [usize],
) {
    let per = weights.per(n as f64);
    // (⌊N wᵢ⌋, N wᵢ − ⌊N wᵢ⌋). With normalised weights ⌊N wᵢ⌋ ≤ N wᵢ ≤ N (up to rounding): the
    // cast is exact.
    let split = |w: f64| {
        let x = weights.scaled(w, per);
        let (floor, whole) = floor_count(x);
        (floor, x - whole)
    };
    let (floors, total) = sum_split(weights.raw, split);
    let rest = n.saturating_sub(floors);
    let (points, points_total) = SortedPoints::new(rest, rng, ends);
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
    let drawn = count_draws(weights.raw, last, n, &points, blocks, out, |w| {
        let (floor, residual) = split(w);
        (floor, residual * factor)
    });
    out[drawn..n].fill(last);
}
