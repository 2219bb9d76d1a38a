//! The reverse-mode tape: an arena of tensor-level nodes addressed by `Copy` [`Var`] handles.
//!
//! Ops are tensor-level (one node per op, never per scalar). [`Tape::update_rows`] records a whole
//! Gauss–Seidel colour-set projection as one node and, when its input has no other consumer, moves
//! the state buffer instead of copying it, so a solver sweep costs one saved input row per
//! constraint and nothing per particle.
//!
//! A tape can be [cleared](Tape::clear) and reused without reallocating, and any recorded segment
//! can be differentiated from an arbitrary upstream gradient with [`Tape::vjp`]: record one time
//! step, pull the gradient through it, clear, repeat (checkpointing).
//!
//! # Conventions at non-differentiable points
//! The same as the scalar algebra's ([`crate::real`]), so a tape op and the equivalent row
//! function written with [`crate::Real`] give the same gradient:
//! - [`Tape::sqrt`] at 0 and [`Tape::relu`] at 0: derivative 0;
//! - [`Tape::min`] / [`Tape::max`] on a tie: the whole gradient goes to the first argument `a`;
//! - [`Tape::row_min`] / [`Tape::row_max`] on a tie: to the first (lowest-index) extremal column;
//! - [`Tape::row_norm`] of a zero row: gradient 0 (finite). A tiny non-zero row (say of length
//!   1e-12) gets the exact unit-vector gradient; a row whose squared norm underflows (length below
//!   about 1.5e-154) counts as zero.

mod backward;
mod rows;

pub use rows::{soft_min_value, soft_min_weights};

use crate::index::RowIndex;
use crate::rowfn::{eval_rows, DynRowFn};
use crate::tensor::Tensor;
use crate::update::update_rows;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

static NEXT_EPOCH: AtomicU64 = AtomicU64::new(1);

fn new_epoch() -> u64 {
    NEXT_EPOCH.fetch_add(1, Ordering::Relaxed)
}

/// A handle to a value recorded on a [`Tape`]. Cheap to copy; valid until the tape is cleared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Var {
    id: u32,
    epoch: u64,
}

/// Elementwise binary operations (with broadcasting of size-1 dimensions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Binary {
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
}

/// Elementwise unary operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Unary {
    Neg,
    Square,
    Sqrt,
    Relu,
}

enum Op {
    Leaf,
    Gather {
        src: usize,
        index: Arc<RowIndex>,
    },
    ScatterAdd {
        src: usize,
        index: Arc<RowIndex>,
    },
    AssignRows {
        dst: usize,
        index: Arc<RowIndex>,
        src: usize,
    },
    Binary {
        kind: Binary,
        a: usize,
        b: usize,
    },
    Unary {
        kind: Unary,
        a: usize,
    },
    AddScalar {
        a: usize,
    },
    Scale {
        a: usize,
        c: f64,
    },
    Sum {
        a: usize,
    },
    RowSum {
        a: usize,
    },
    RowNorm {
        a: usize,
    },
    Dot {
        a: usize,
        b: usize,
    },
    RowArg {
        a: usize,
        arg: Vec<usize>,
    },
    SoftMin {
        a: usize,
        kappa: f64,
    },
    ConcatRows {
        parts: Vec<usize>,
    },
    ConcatCols {
        parts: Vec<usize>,
    },
    MapRows {
        f: Arc<dyn DynRowFn>,
        input: usize,
    },
    UpdateRows {
        f: Arc<dyn DynRowFn>,
        index: Arc<RowIndex>,
        state: usize,
        carry: usize,
        inputs: Vec<f64>,
    },
    /// The carried output of the `UpdateRows` node just before it.
    UpdateCarry,
}

struct Node {
    op: Op,
    value: Tensor,
    /// Set when an in-place update moved the value away.
    consumed: bool,
    /// Number of recorded ops that read this node.
    uses: u32,
    /// Shape of the value (kept when the value is moved away).
    shape: (usize, usize),
}

/// A reverse-mode recording of tensor operations.
pub struct Tape {
    nodes: Vec<Node>,
    epoch: u64,
    /// Spare buffers of the last cleared recording, by capacity (reused best-fit).
    pool: BTreeMap<usize, Vec<Vec<f64>>>,
}

impl Default for Tape {
    fn default() -> Self {
        Tape::new()
    }
}

/// Gradients of one backward pass with respect to the leaves, indexed by [`Var`].
///
/// Adjoints of intermediate values are released during the pass, so only leaves are kept.
pub struct Gradients {
    epoch: u64,
    adj: Vec<Option<Tensor>>,
    shapes: Vec<(usize, usize)>,
}

impl Gradients {
    /// The gradient with respect to `v`, or `None` when no path led from the seeds to `v`.
    ///
    /// # Panics
    /// If `v` belongs to another tape or recording.
    pub fn get(&self, v: Var) -> Option<&Tensor> {
        assert_eq!(
            v.epoch, self.epoch,
            "Gradients::get: the Var belongs to another recording"
        );
        self.adj[v.id as usize].as_ref()
    }

    /// The gradient with respect to `v`, zeros when no path led to it.
    pub fn wrt(&self, v: Var) -> Tensor {
        match self.get(v) {
            Some(t) => t.clone(),
            None => {
                let (r, c) = self.shapes[v.id as usize];
                Tensor::zeros(r, c)
            }
        }
    }
}

/// Broadcast index: position in an operand of shape `(r, c)` for output element `(i, j)`.
#[inline]
fn bidx(shape: (usize, usize), i: usize, j: usize) -> usize {
    let r = if shape.0 == 1 { 0 } else { i };
    let c = if shape.1 == 1 { 0 } else { j };
    r * shape.1 + c
}

fn broadcast_shape(a: (usize, usize), b: (usize, usize), what: &str) -> (usize, usize) {
    let dim = |x: usize, y: usize| {
        if x == y || y == 1 {
            Some(x)
        } else if x == 1 {
            Some(y)
        } else {
            None
        }
    };
    match (dim(a.0, b.0), dim(a.1, b.1)) {
        (Some(r), Some(c)) => (r, c),
        _ => panic!("{what}: shapes {a:?} and {b:?} do not broadcast"),
    }
}

impl Tape {
    /// An empty tape.
    pub fn new() -> Self {
        Tape {
            nodes: Vec::new(),
            epoch: new_epoch(),
            pool: BTreeMap::new(),
        }
    }

    /// Drops every recorded node, keeping their buffers for reuse. Earlier `Var`s become invalid.
    ///
    /// Re-recording the same workload then draws every recorded value and saved input from these
    /// buffers (smallest that fits). Spare buffers the previous re-recording left unused are
    /// released here, so the tape never holds more than one recording's worth of memory; clearing
    /// an empty tape keeps its spare buffers.
    pub fn clear(&mut self) {
        let Tape { nodes, pool, .. } = self;
        if !nodes.is_empty() {
            pool.clear();
        }
        for node in nodes.drain(..) {
            recycle(pool, node.value.into_data());
            if let Op::UpdateRows { inputs, .. } = node.op {
                recycle(pool, inputs);
            }
        }
        self.epoch = new_epoch();
    }

    /// Number of recorded nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when nothing is recorded.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Bytes held by recorded values and saved inputs (capacity, not just length).
    pub fn memory_bytes(&self) -> usize {
        let f = std::mem::size_of::<f64>();
        self.nodes
            .iter()
            .map(|n| {
                let saved = match &n.op {
                    Op::UpdateRows { inputs, .. } => inputs.capacity(),
                    Op::RowArg { arg, .. } => arg.capacity(),
                    _ => 0,
                };
                std::mem::size_of::<Node>() + (n.value.len() + saved) * f
            })
            .sum()
    }

    /// Bytes the tape holds: recorded values and saved inputs as [`Tape::memory_bytes`], plus the
    /// spare buffers kept by [`Tape::clear`] and the node list's capacity.
    pub fn reserved_bytes(&self) -> usize {
        let f = std::mem::size_of::<f64>();
        let spare: usize = self
            .pool
            .iter()
            .map(|(&cap, bucket)| cap * bucket.len())
            .sum();
        let nodes = (self.nodes.capacity() - self.nodes.len()) * std::mem::size_of::<Node>();
        self.memory_bytes() + spare * f + nodes
    }

    /// A zeroed buffer of `len` values.
    fn alloc(&mut self, len: usize) -> Vec<f64> {
        let mut v = self.spare(len);
        v.resize(len, 0.0);
        v
    }

    /// An empty buffer with room for `len` values: the smallest spare one that fits, else new.
    fn spare(&mut self, len: usize) -> Vec<f64> {
        if len == 0 {
            return Vec::new();
        }
        let Some((&cap, bucket)) = self.pool.range_mut(len..).next() else {
            return Vec::with_capacity(len);
        };
        let v = bucket.pop().expect("pool buckets are never empty");
        if bucket.is_empty() {
            self.pool.remove(&cap);
        }
        v
    }

    /// A copy of node `id`'s value in a spare buffer.
    fn copy_value(&mut self, id: usize) -> Tensor {
        let (r, c) = self.nodes[id].value.shape();
        let mut v = self.spare(r * c);
        v.extend_from_slice(self.nodes[id].value.data());
        Tensor::new(r, c, v)
    }

    fn check(&self, v: Var) -> usize {
        assert_eq!(
            v.epoch, self.epoch,
            "Var from another tape, or recorded before Tape::clear"
        );
        let id = v.id as usize;
        assert!(
            !self.nodes[id].consumed,
            "Var was consumed by an in-place Tape::update_rows; use its result instead"
        );
        id
    }

    fn push(&mut self, op: Op, value: Tensor) -> Var {
        let id = self.nodes.len();
        for input in op_inputs(&op) {
            self.nodes[input].uses += 1;
        }
        let shape = value.shape();
        self.nodes.push(Node {
            op,
            value,
            consumed: false,
            uses: 0,
            shape,
        });
        Var {
            id: id as u32,
            epoch: self.epoch,
        }
    }

    /// The value of `v`.
    ///
    /// # Panics
    /// If `v` is from another recording, or was consumed by an in-place update.
    pub fn value(&self, v: Var) -> &Tensor {
        let id = self.check(v);
        &self.nodes[id].value
    }

    /// Shape of `v`.
    pub fn shape(&self, v: Var) -> (usize, usize) {
        self.value(v).shape()
    }

    /// Records an input. Gradients are available for every leaf.
    pub fn leaf(&mut self, value: Tensor) -> Var {
        self.push(Op::Leaf, value)
    }

    /// Rows of `src` gathered per batch row: output `index.rows() × (arity · src.cols)`.
    pub fn gather(&mut self, src: Var, index: &Arc<RowIndex>) -> Var {
        let s = self.check(src);
        let (n, c) = self.nodes[s].value.shape();
        assert!(
            index.bound() <= n,
            "gather: index {} out of range for {n} rows",
            index.bound().saturating_sub(1)
        );
        let mut out = self.alloc(index.rows() * index.arity() * c);
        let v = &self.nodes[s].value;
        for (k, &p) in index.as_slice().iter().enumerate() {
            out[k * c..(k + 1) * c].copy_from_slice(v.row(p));
        }
        let t = Tensor::new(index.rows(), index.arity() * c, out);
        self.push(
            Op::Gather {
                src: s,
                index: index.clone(),
            },
            t,
        )
    }

    /// Adds each batch row of `src` (`rows × (arity · c)`) into rows of an `n_rows × c` zero tensor.
    pub fn scatter_add(&mut self, src: Var, index: &Arc<RowIndex>, n_rows: usize) -> Var {
        let s = self.check(src);
        let (r, w) = self.nodes[s].value.shape();
        assert_eq!(
            r,
            index.rows(),
            "scatter_add: {r} source rows for {} index rows",
            index.rows()
        );
        assert!(
            w % index.arity() == 0,
            "scatter_add: width {w} is not a multiple of arity {}",
            index.arity()
        );
        assert!(
            index.bound() <= n_rows,
            "scatter_add: index out of range for {n_rows} rows"
        );
        let c = w / index.arity();
        let mut out = self.alloc(n_rows * c);
        let v = self.nodes[s].value.data();
        for (k, &p) in index.as_slice().iter().enumerate() {
            for j in 0..c {
                out[p * c + j] += v[k * c + j];
            }
        }
        self.push(
            Op::ScatterAdd {
                src: s,
                index: index.clone(),
            },
            Tensor::new(n_rows, c, out),
        )
    }

    /// `dst` with rows `index` (arity 1) replaced by the rows of `src`.
    pub fn assign_rows(&mut self, dst: Var, index: &Arc<RowIndex>, src: Var) -> Var {
        let (d, s) = (self.check(dst), self.check(src));
        assert_eq!(index.arity(), 1, "assign_rows: index must have arity 1");
        assert!(index.is_disjoint(), "assign_rows: index repeats a row");
        let (n, c) = self.nodes[d].value.shape();
        assert_eq!(
            self.nodes[s].value.shape(),
            (index.rows(), c),
            "assign_rows: source shape mismatch"
        );
        assert!(index.bound() <= n, "assign_rows: index out of range");
        let mut out = self.copy_value(d);
        for (k, &p) in index.as_slice().iter().enumerate() {
            out.row_mut(p).copy_from_slice(self.nodes[s].value.row(k));
        }
        self.push(
            Op::AssignRows {
                dst: d,
                index: index.clone(),
                src: s,
            },
            out,
        )
    }

    fn binary(&mut self, kind: Binary, a: Var, b: Var) -> Var {
        let (ia, ib) = (self.check(a), self.check(b));
        let (sa, sb) = (self.nodes[ia].value.shape(), self.nodes[ib].value.shape());
        let (r, c) = broadcast_shape(sa, sb, "elementwise op");
        let mut out = self.alloc(r * c);
        let (va, vb) = (self.nodes[ia].value.data(), self.nodes[ib].value.data());
        for i in 0..r {
            for j in 0..c {
                let (x, y) = (va[bidx(sa, i, j)], vb[bidx(sb, i, j)]);
                out[i * c + j] = match kind {
                    Binary::Add => x + y,
                    Binary::Sub => x - y,
                    Binary::Mul => x * y,
                    Binary::Div => x / y,
                    Binary::Min => {
                        if y < x {
                            y
                        } else {
                            x
                        }
                    }
                    Binary::Max => {
                        if y > x {
                            y
                        } else {
                            x
                        }
                    }
                };
            }
        }
        self.push(Op::Binary { kind, a: ia, b: ib }, Tensor::new(r, c, out))
    }

    /// `a + b`, broadcasting size-1 dimensions (scalars, rows, columns).
    pub fn add(&mut self, a: Var, b: Var) -> Var {
        self.binary(Binary::Add, a, b)
    }
    /// `a − b`, broadcasting.
    pub fn sub(&mut self, a: Var, b: Var) -> Var {
        self.binary(Binary::Sub, a, b)
    }
    /// `a ⊙ b`, broadcasting.
    pub fn mul(&mut self, a: Var, b: Var) -> Var {
        self.binary(Binary::Mul, a, b)
    }
    /// `a ⊘ b`, broadcasting.
    pub fn div(&mut self, a: Var, b: Var) -> Var {
        self.binary(Binary::Div, a, b)
    }
    /// Elementwise minimum, broadcasting; a tie passes the gradient to `a`.
    pub fn min(&mut self, a: Var, b: Var) -> Var {
        self.binary(Binary::Min, a, b)
    }
    /// Elementwise maximum, broadcasting; a tie passes the gradient to `a`.
    pub fn max(&mut self, a: Var, b: Var) -> Var {
        self.binary(Binary::Max, a, b)
    }

    fn unary(&mut self, kind: Unary, a: Var) -> Var {
        let ia = self.check(a);
        let (r, c) = self.nodes[ia].value.shape();
        let mut out = self.alloc(r * c);
        for (o, &x) in out.iter_mut().zip(self.nodes[ia].value.data()) {
            *o = match kind {
                Unary::Neg => -x,
                Unary::Square => x * x,
                Unary::Sqrt => x.sqrt(),
                Unary::Relu => {
                    if x > 0.0 {
                        x
                    } else {
                        0.0
                    }
                }
            };
        }
        self.push(Op::Unary { kind, a: ia }, Tensor::new(r, c, out))
    }

    /// `−a`.
    pub fn neg(&mut self, a: Var) -> Var {
        self.unary(Unary::Neg, a)
    }
    /// `a²` elementwise.
    pub fn square(&mut self, a: Var) -> Var {
        self.unary(Unary::Square, a)
    }
    /// `√a` elementwise; derivative 0 at 0 (the crate's convention).
    pub fn sqrt(&mut self, a: Var) -> Var {
        self.unary(Unary::Sqrt, a)
    }
    /// `max(a, 0)` elementwise; derivative 0 at 0.
    pub fn relu(&mut self, a: Var) -> Var {
        self.unary(Unary::Relu, a)
    }

    /// `a + c` for a constant `c`.
    pub fn add_scalar(&mut self, a: Var, c: f64) -> Var {
        let ia = self.check(a);
        let (r, cols) = self.nodes[ia].value.shape();
        let mut out = self.alloc(r * cols);
        for (o, &x) in out.iter_mut().zip(self.nodes[ia].value.data()) {
            *o = x + c;
        }
        self.push(Op::AddScalar { a: ia }, Tensor::new(r, cols, out))
    }

    /// `c · a` for a constant `c`.
    pub fn scale(&mut self, a: Var, c: f64) -> Var {
        let ia = self.check(a);
        let (r, cols) = self.nodes[ia].value.shape();
        let mut out = self.alloc(r * cols);
        for (o, &x) in out.iter_mut().zip(self.nodes[ia].value.data()) {
            *o = c * x;
        }
        self.push(Op::Scale { a: ia, c }, Tensor::new(r, cols, out))
    }

    /// The batched local-function op: `f` applied to every row of `input` (`rows × f.n_in()`),
    /// giving `rows × f.n_out()`, in parallel for large batches. One node; its vector–Jacobian
    /// product comes from `f` itself ([`crate::RowFn::vjp`]).
    pub fn map_rows(&mut self, f: &Arc<dyn DynRowFn>, input: Var) -> Var {
        let ia = self.check(input);
        let (r, c) = self.nodes[ia].value.shape();
        assert_eq!(
            c,
            f.n_in(),
            "map_rows: input has {c} columns, the function takes {}",
            f.n_in()
        );
        let mut out = self.alloc(r * f.n_out());
        eval_rows(f.as_ref(), self.nodes[ia].value.data(), &mut out);
        self.push(
            Op::MapRows {
                f: f.clone(),
                input: ia,
            },
            Tensor::new(r, f.n_out(), out),
        )
    }

    /// One Gauss–Seidel colour-set projection, recorded as one node.
    ///
    /// For every batch row `k`, the state rows `index.row(k)` and carry row `k` are replaced by
    /// `f(state rows, carry row)` (see [`crate::update::update_rows`]). Returns the new state and the
    /// new carry. When `state` (or `carry`) is not a leaf and nothing else has read it, its buffer
    /// is moved rather than copied and the old `Var` becomes unusable.
    pub fn update_rows(
        &mut self,
        f: &Arc<dyn DynRowFn>,
        index: &Arc<RowIndex>,
        state: Var,
        carry: Var,
    ) -> (Var, Var) {
        let (is, ic) = (self.check(state), self.check(carry));
        let mut st = self.take_or_copy(is);
        let mut ca = self.take_or_copy(ic);
        let mut inputs = self.spare(index.rows() * f.n_in());
        update_rows(f.as_ref(), index, &mut st, &mut ca, Some(&mut inputs));
        let op = Op::UpdateRows {
            f: f.clone(),
            index: index.clone(),
            state: is,
            carry: ic,
            inputs,
        };
        let new_state = self.push(op, st);
        let new_carry = self.push(Op::UpdateCarry, ca);
        (new_state, new_carry)
    }

    fn take_or_copy(&mut self, id: usize) -> Tensor {
        let node = &mut self.nodes[id];
        if node.uses == 0 && !matches!(node.op, Op::Leaf) {
            node.consumed = true;
            std::mem::take(&mut node.value)
        } else {
            self.copy_value(id)
        }
    }
}

/// Files a cleared node's buffer among the spare ones (buffers without capacity are dropped).
fn recycle(pool: &mut BTreeMap<usize, Vec<Vec<f64>>>, mut buf: Vec<f64>) {
    if buf.capacity() > 0 {
        buf.clear();
        pool.entry(buf.capacity()).or_default().push(buf);
    }
}

fn op_inputs(op: &Op) -> Vec<usize> {
    match op {
        Op::Leaf => vec![],
        Op::Gather { src, .. } | Op::ScatterAdd { src, .. } => vec![*src],
        Op::AssignRows { dst, src, .. } => vec![*dst, *src],
        Op::Binary { a, b, .. } | Op::Dot { a, b } => vec![*a, *b],
        Op::Unary { a, .. }
        | Op::AddScalar { a }
        | Op::Scale { a, .. }
        | Op::Sum { a }
        | Op::RowSum { a }
        | Op::RowNorm { a }
        | Op::RowArg { a, .. }
        | Op::SoftMin { a, .. } => vec![*a],
        Op::ConcatRows { parts } | Op::ConcatCols { parts } => parts.clone(),
        Op::MapRows { input, .. } => vec![*input],
        Op::UpdateRows { state, carry, .. } => vec![*state, *carry],
        Op::UpdateCarry => vec![],
    }
}
