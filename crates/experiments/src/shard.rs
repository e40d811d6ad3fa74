//! Studies split across machines: shard K of N runs a contiguous range of the run indices, and every
//! run draws its randomness from its own stream, so a shard's runs are exactly those of the full
//! study.

use crate::ExperimentError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::ops::Range;
use std::str::FromStr;

/// Shard `index` of `count` (1-based, as written on a command line: `--shard 3/8`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shard {
    index: u64,
    count: u64,
}

impl Shard {
    /// The whole study as one shard, 1/1.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Shard `index` of `count`.
    ///
    /// # Errors
    /// [`ExperimentError::BadShard`] unless `1 ≤ index ≤ count`.
    pub fn new(index: u64, count: u64) -> Result<Self, ExperimentError> {
        if index == 0 || index > count {
            return Err(ExperimentError::BadShard(format!("{index}/{count}")));
        }
        Ok(Self { index, count })
    }

    /// K, from 1.
    pub fn index(&self) -> u64 {
        self.index
    }

    /// N.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The run indices of this shard in a study of `runs` runs: `[⌊(K−1) runs / N⌋, ⌊K runs / N⌋)`.
    /// The N shards partition `[0, runs)` into contiguous ranges whose sizes differ by at most one.
    ///
    /// # Example
    /// ```
    /// use liebayes_experiments::Shard;
    /// // Ten runs over three machines: 3, 3 and 4 runs, contiguous.
    /// let parts: Vec<_> = (1..=3).map(|k| Shard::new(k, 3).unwrap().runs(10)).collect();
    /// assert_eq!(parts, vec![0..3, 3..6, 6..10]);
    /// assert!(Shard::new(0, 3).is_err());
    /// ```
    pub fn runs(&self, runs: u64) -> Range<u64> {
        let bound = |k: u64| {
            u64::try_from(u128::from(k) * u128::from(runs) / u128::from(self.count)).unwrap_or(runs)
        };
        bound(self.index - 1)..bound(self.index)
    }
}

impl FromStr for Shard {
    type Err = ExperimentError;

    /// `"K/N"`, for example `"3/8"`.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || ExperimentError::BadShard(text.to_owned());
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let parse = |s: &str| s.trim().parse::<u64>().map_err(|_| bad());
        Shard::new(parse(k)?, parse(n)?).map_err(|_| bad())
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The two random number generators of run `run` of a study seeded with `seed`: ChaCha8 keyed by
/// the seed, on stream `2·run` for the simulation and `2·run + 1` for the filter's own randomness
/// (2⁶⁴ independent streams of 2⁶⁸ bytes each). A run's randomness depends on the seed and its
/// index only, not on which shard, thread or order ran it, and the filter's draws do not depend on
/// how many the simulation took.
pub fn run_rngs(seed: u64, run: u64) -> (ChaCha8Rng, ChaCha8Rng) {
    let stream = |s: u64| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(s);
        rng
    };
    // run < 2^40 in a study; wrapping keeps any u64 well defined.
    (
        stream(run.wrapping_mul(2)),
        stream(run.wrapping_mul(2).wrapping_add(1)),
    )
}
