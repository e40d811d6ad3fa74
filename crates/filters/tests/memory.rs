//! A study keeps per-run results as running statistics: its memory does not grow with the number of
//! runs. A tracking global allocator records the peak of live heap bytes during a study of the exact
//! filter at 128 and at 4096 runs; the two peaks must agree (the per-epoch statistics, one run's
//! scores and a few block summaries in flight), where keeping every run's epochs would take 32 times
//! as much. The 10⁶-run figure, measured on the binary, is in docs/scaling.md.
#![allow(unsafe_code)] // implementing GlobalAlloc is unsafe by definition; this wrapper only counts.

use liebayes_experiments::{Shard, Study};
use liebayes_filters::azimuth::{AzimuthScenario, Config, Method, Motion};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Tracking;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let live = LIVE.fetch_add(layout.size(), Ordering::SeqCst) + layout.size();
        PEAK.fetch_max(live, Ordering::SeqCst);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Tracking = Tracking;

/// The peak of live heap bytes above the level at the start, while a study of `runs` runs goes.
fn peak_of_study(runs: u64) -> usize {
    let config = Config {
        steps: 200,
        ..Config::default()
    };
    let scenario = AzimuthScenario::new(Motion::Circle, config).unwrap();
    let study = Study::new("exact", runs, 9, Shard::WHOLE).unwrap();
    let base = LIVE.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let summary = Method::Exact.study(&scenario, &study, &|_| {}).unwrap();
    assert_eq!(summary.run_count(), runs);
    assert!(summary.failures().is_empty());
    PEAK.load(Ordering::SeqCst) - base
}

/// One test, so that no other test's thread allocates while the peak is read.
#[test]
fn a_study_runs_in_constant_memory() {
    let small = peak_of_study(512);
    let large = peak_of_study(8192);
    eprintln!("peak heap of a study: {small} bytes at 512 runs, {large} bytes at 8192 runs");
    assert!(
        large <= small + small / 2,
        "the study's memory grew with its runs: {small} bytes at 512 runs, {large} at 8192"
    );
}
