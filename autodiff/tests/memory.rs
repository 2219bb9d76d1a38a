//! Memory control: a cleared tape re-records the same workload in the buffers it already holds
//! (no growth, across many clear cycles), and `update_rows` moves the state buffer along a chain
//! instead of copying it.
//!
//! A counting global allocator (per thread, so concurrently running tests do not disturb each
//! other) measures what `Tape::memory_bytes` does not see: the spare buffers a cleared tape keeps.

use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tape, Tensor, Var};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Arc;

struct Counting;

thread_local! {
    /// Bytes allocated minus bytes freed by this thread.
    static LIVE: Cell<isize> = const { Cell::new(0) };
    /// Bytes allocated by this thread.
    static ALLOCATED: Cell<usize> = const { Cell::new(0) };
}

fn count(add: usize, sub: usize) {
    // `try_with`: the thread-locals may already be gone while a thread shuts down.
    let _ = LIVE.try_with(|l| l.set(l.get() + add as isize - sub as isize));
    let _ = ALLOCATED.try_with(|a| a.set(a.get() + add));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size(), 0);
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size(), 0);
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count(0, layout.size());
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size, layout.size());
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn live() -> isize {
    LIVE.with(|l| l.get())
}

fn allocated() -> usize {
    ALLOCATED.with(|a| a.get())
}

/// XPBD distance projection with a carried multiplier: `[xᵢ, xⱼ, λ] → [xᵢ', xⱼ', λ']`.
struct Distance;

impl RowFn for Distance {
    fn n_in(&self) -> usize {
        7
    }
    fn n_out(&self) -> usize {
        7
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let dl = (-(len - 1.0) - x[6] * 0.01) / 2.01;
        for k in 0..3 {
            out[k] = x[k] + d[k] / len * dl;
            out[3 + k] = x[3 + k] - d[k] / len * dl;
        }
        out[6] = x[6] + dl;
    }
}

/// `R^6 → R^1`: a pair's length.
struct Length;

impl RowFn for Length {
    fn n_in(&self) -> usize {
        6
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        let d = [x[0] - x[3], x[1] - x[4], x[2] - x[5]];
        out[0] = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    }
}

const N: usize = 40;

struct Workload {
    dist: Arc<dyn DynRowFn>,
    length: Arc<dyn DynRowFn>,
    set_a: Arc<RowIndex>,
    set_b: Arc<RowIndex>,
    x0: Tensor,
}

impl Workload {
    fn new() -> Self {
        Workload {
            dist: Arc::new(Distance),
            length: Arc::new(Length),
            set_a: Arc::new(RowIndex::new(2, (0..N).collect())),
            set_b: Arc::new(RowIndex::new(2, (1..N - 1).collect())),
            x0: Tensor::new(
                N,
                3,
                (0..N * 3)
                    .map(|k| {
                        if k % 3 == 0 {
                            1.2 * (k / 3) as f64
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            ),
        }
    }

    /// Records one "time step" touching most op kinds; returns the loss.
    fn record(&self, t: &mut Tape) -> Var {
        let x = t.leaf(self.x0.clone());
        let la0 = t.leaf(Tensor::zeros(N / 2, 1));
        let lb0 = t.leaf(Tensor::zeros(N / 2 - 1, 1));
        let v = t.scale(x, 1.0);
        let (mut s, mut la, mut lb) = (v, la0, lb0);
        for _ in 0..8 {
            (s, la) = t.update_rows(&self.dist, &self.set_a, s, la);
            (s, lb) = t.update_rows(&self.dist, &self.set_b, s, lb);
        }
        let pairs = t.gather(s, &self.set_a);
        let len = t.map_rows(&self.length, pairs);
        let back = t.scatter_add(pairs, &self.set_a, N);
        let both = t.concat_cols(&[back, s]);
        let stacked = t.concat_rows(&[la, la]);
        let sq = t.square(both);
        let m = t.row_max(sq);
        let lm = t.sum(m);
        let ll = t.dot(len, len);
        let lc = t.sum(stacked);
        let a = t.add(lm, ll);
        let b = t.add(a, lc);
        let chosen = Arc::new(RowIndex::single(vec![0, 3]));
        let two = t.gather(s, &chosen);
        let moved = t.assign_rows(s, &chosen, two);
        let lmv = t.sum(moved);
        t.add(b, lmv)
    }
}

#[test]
fn clear_and_rerecord_does_not_grow_memory_bytes() {
    let w = Workload::new();
    let mut t = Tape::new();
    let loss = w.record(&mut t);
    let (bytes, nodes, value) = (t.memory_bytes(), t.len(), t.value(loss).item());
    for cycle in 1..6 {
        t.clear();
        assert!(t.is_empty());
        assert_eq!(t.memory_bytes(), 0);
        let loss = w.record(&mut t);
        assert_eq!(t.len(), nodes);
        assert_eq!(t.value(loss).item(), value);
        assert_eq!(t.memory_bytes(), bytes, "cycle {cycle}");
    }
}

/// Regression: `Tape::clear` kept every buffer of the cleared recording (the user's leaves,
/// copies of leaves, concatenations) in its spare pool, but a re-recording drew from it only for
/// some of them, so the pool grew by a recording's worth of leftovers at every clear; and spare
/// buffers were reused last-in first-out whatever their size, so a re-recording reallocated.
#[test]
fn clear_cycles_reuse_buffers_without_growth() {
    let w = Workload::new();
    let mut t = Tape::new();
    // (Sized up front: their own growth would count as live heap.)
    let mut live_after = Vec::with_capacity(8);
    let mut alloc_during = Vec::with_capacity(8);
    for _ in 0..8 {
        t.clear();
        let a0 = allocated();
        let loss = w.record(&mut t);
        let _ = t.backward(loss);
        alloc_during.push(allocated() - a0);
        live_after.push(live());
    }
    // After a warm-up cycle, the heap held by the tape is the same at every cycle.
    for k in 2..live_after.len() {
        assert_eq!(
            live_after[k], live_after[1],
            "live heap grew at cycle {k}: {live_after:?}"
        );
    }
    // And a steady-state recording allocates far less than the tape holds: the recorded values
    // and saved inputs come from the spare buffers (what remains is the leaves' own data, the
    // backward pass's adjoints and small bookkeeping).
    let record_only = {
        t.clear();
        let a0 = allocated();
        let _ = w.record(&mut t);
        allocated() - a0
    };
    let held = t.memory_bytes();
    assert!(
        record_only * 8 < held,
        "a re-recording allocated {record_only} B for a tape holding {held} B \
         (allocations per cycle incl. backward: {alloc_during:?})"
    );
}

#[test]
#[should_panic(expected = "consumed")]
fn update_rows_moves_the_state_old_var_panics() {
    let w = Workload::new();
    let mut t = Tape::new();
    let x = t.leaf(w.x0.clone());
    let s0 = t.scale(x, 1.0);
    let la = t.leaf(Tensor::zeros(N / 2, 1));
    let (s1, _) = t.update_rows(&w.dist, &w.set_a, s0, la);
    let _ = t.value(s1);
    // s0 had no other reader: its buffer now belongs to s1.
    let _ = t.value(s0);
}

#[test]
#[should_panic(expected = "consumed")]
fn update_rows_moves_the_carry_old_var_panics() {
    let w = Workload::new();
    let mut t = Tape::new();
    let x = t.leaf(w.x0.clone());
    let la = t.leaf(Tensor::zeros(N / 2, 1));
    let (s1, la1) = t.update_rows(&w.dist, &w.set_a, x, la);
    let (_, _) = t.update_rows(&w.dist, &w.set_a, s1, la1);
    let _ = t.value(la1);
}

#[test]
fn update_rows_chain_moves_and_copies_only_when_needed() {
    let w = Workload::new();
    let mut t = Tape::new();
    let x = t.leaf(w.x0.clone());
    let la = t.leaf(Tensor::zeros(N / 2, 1));
    // A leaf is never moved.
    let (s1, la1) = t.update_rows(&w.dist, &w.set_a, x, la);
    assert_eq!(t.value(x), &w.x0);
    assert_eq!(t.value(la).shape(), (N / 2, 1));
    // A state with another reader is copied, and stays readable.
    let norm = t.row_norm(s1);
    let (s2, la2) = t.update_rows(&w.dist, &w.set_a, s1, la1);
    let _ = (t.value(s1), t.value(norm));
    // Further along the chain, each update adds its saved inputs and two nodes — no state copy.
    let mut bytes = vec![t.memory_bytes()];
    let (mut s, mut l) = (s2, la2);
    for _ in 0..5 {
        (s, l) = t.update_rows(&w.dist, &w.set_a, s, l);
        bytes.push(t.memory_bytes());
    }
    let steps: Vec<usize> = bytes.windows(2).map(|b| b[1] - b[0]).collect();
    assert!(steps.iter().all(|&d| d == steps[0]), "{steps:?}");
    let inputs = w.set_a.rows() * 7 * std::mem::size_of::<f64>();
    let state = N * 3 * std::mem::size_of::<f64>();
    assert!(
        steps[0] >= inputs && steps[0] < inputs + state,
        "{} per update",
        steps[0]
    );
    // Only the chain's last state and carry are readable.
    let _ = (t.value(s), t.value(l));
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| t.value(s2).len()));
    assert!(caught.is_err());
}
