//! Shards partition the runs; run generators depend only on the seed and the run index.

use liebayes_experiments::{Shard, run_rngs};
use proptest::prelude::*;
use rand::Rng;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn shards_partition_the_runs(runs in prop_oneof![0..1000_u64, Just(u64::MAX)], count in 1..40_u64) {
        let mut next = 0;
        for k in 1..=count {
            let range = Shard::new(k, count).unwrap().runs(runs);
            prop_assert_eq!(range.start, next);
            let size = range.end - range.start;
            prop_assert!(size == runs / count || size == runs / count + 1);
            next = range.end;
        }
        prop_assert_eq!(next, runs);
    }
}

#[test]
fn shards_parse_and_refuse_what_is_not_k_of_n() {
    assert_eq!("3/8".parse::<Shard>().unwrap(), Shard::new(3, 8).unwrap());
    assert_eq!(Shard::new(3, 8).unwrap().to_string(), "3/8");
    assert_eq!(Shard::WHOLE.runs(10), 0..10);
    for bad in [
        "0/4",
        "5/4",
        "4",
        "a/b",
        "1/0",
        "/",
        "-1/4",
        "1/18446744073709551616",
        "",
    ] {
        let error = bad.parse::<Shard>().unwrap_err();
        assert!(error.to_string().contains("K/N"), "{bad}: {error}");
    }
}

#[test]
fn a_runs_randomness_depends_on_the_seed_and_its_index_only() {
    let draw = |seed, run| run_rngs(seed, run).0.random::<u64>();
    assert_eq!(draw(7, 3), draw(7, 3));
    assert_ne!(draw(7, 3), draw(7, 4));
    assert_ne!(draw(7, 3), draw(8, 3));
    // Streams do not overlap at their starts: the first draws of 1000 runs are distinct.
    let mut firsts: Vec<u64> = (0..1000).map(|run| draw(1, run)).collect();
    firsts.sort_unstable();
    firsts.dedup();
    assert_eq!(firsts.len(), 1000);
}
