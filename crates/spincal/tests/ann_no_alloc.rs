//! The LM epoch allocates nothing: after a warm-up run, a run of 30 epochs makes exactly as many
//! heap allocations as a run of 3 (the per-run report histories, reserved up front). Only the
//! training thread's allocations are counted: the test harness's other threads may allocate at
//! any time (once, a lazy set-up elsewhere made this test fail when the count was global).

mod common;

use std::alloc::{GlobalAlloc, Layout as AllocLayout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::synthetic::turntable_pair;
use spincal::correctors::ann::{AnnProblem, Dataset, LmSettings, LmWorkspace};
use spincal::correctors::corrector::Axis;
use spincal::correctors::division::DivisionMode;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Set on the thread whose allocations are counted (const-initialised: reading it allocates
    /// nothing).
    static COUNTED: Cell<bool> = const { Cell::new(false) };
}

fn note_allocation() {
    if COUNTED.try_with(Cell::get).unwrap_or(false) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: AllocLayout) -> *mut u8 {
        note_allocation();
        System.alloc(layout)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: AllocLayout) {
        System.dealloc(ptr, layout)
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: AllocLayout, new_size: usize) -> *mut u8 {
        note_allocation();
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn epochs_do_not_allocate() {
    let (measured, reference) = turntable_pair(2000, 8);
    let problem = AnnProblem::new(
        &measured,
        &reference,
        &[Axis::X, Axis::Y],
        2,
        DivisionMode::Contiguous,
    )
    .unwrap();
    let layout = problem.layout(&[10, 6]).unwrap();
    let start = problem.initial_weights(&layout, 1, 0);
    let mut workspace = LmWorkspace::new(&layout, 100);
    let no_validation = Dataset::default();
    let mut count = |epochs: usize| {
        let settings = LmSettings {
            max_epochs: epochs,
            min_relative_decrease: 0.0,
            min_gradient: 0.0,
            ..LmSettings::default()
        };
        let mut weights = start.clone();
        let before = ALLOCATIONS.load(Ordering::Relaxed);
        COUNTED.set(true);
        let report = workspace.train(&mut weights, &problem.train, &no_validation, &settings);
        COUNTED.set(false);
        let made = ALLOCATIONS.load(Ordering::Relaxed) - before;
        assert_eq!(report.epochs, epochs, "{:?}", report.stop);
        made
    };
    // The first run pays one-time set-up (room for the kept trial pass, sized to the training
    // set); after that only the two report histories are allocated.
    count(1);
    let short = count(3);
    let long = count(30);
    assert_eq!(
        short, long,
        "allocations grow with epochs: {short} for 3 epochs, {long} for 30"
    );
    assert!(
        short <= 2,
        "{short} allocations per run (expected only the two histories)"
    );
}
