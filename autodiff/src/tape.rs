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

use crate::index::RowIndex;
use crate::rowfn::{eval_rows, vjp_rows, DynRowFn};
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
    /// released here, so the tape never holds more than one recording's worth of memory.
    pub fn clear(&mut self) {
        let Tape { nodes, pool, .. } = self;
        pool.clear();
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

    /// Sum of all elements (`1 × 1`), in row-major order.
    pub fn sum(&mut self, a: Var) -> Var {
        let ia = self.check(a);
        let s = self.nodes[ia].value.data().iter().sum::<f64>();
        let mut out = self.alloc(1);
        out[0] = s;
        self.push(Op::Sum { a: ia }, Tensor::new(1, 1, out))
    }

    /// Sum of each row (`rows × 1`).
    pub fn row_sum(&mut self, a: Var) -> Var {
        let ia = self.check(a);
        let r = self.nodes[ia].value.rows();
        let mut out = self.alloc(r);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.nodes[ia].value.row(i).iter().sum();
        }
        self.push(Op::RowSum { a: ia }, Tensor::vector(out))
    }

    /// Euclidean norm of each row (`rows × 1`); a zero row has gradient 0.
    pub fn row_norm(&mut self, a: Var) -> Var {
        let ia = self.check(a);
        let r = self.nodes[ia].value.rows();
        let mut out = self.alloc(r);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.nodes[ia]
                .value
                .row(i)
                .iter()
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt();
        }
        self.push(Op::RowNorm { a: ia }, Tensor::vector(out))
    }

    /// `Σ aᵢ bᵢ` over same-shaped tensors (`1 × 1`).
    pub fn dot(&mut self, a: Var, b: Var) -> Var {
        let (ia, ib) = (self.check(a), self.check(b));
        assert_eq!(
            self.nodes[ia].value.shape(),
            self.nodes[ib].value.shape(),
            "dot: shape mismatch"
        );
        let s = self.nodes[ia]
            .value
            .data()
            .iter()
            .zip(self.nodes[ib].value.data())
            .map(|(x, y)| x * y)
            .sum::<f64>();
        let mut out = self.alloc(1);
        out[0] = s;
        self.push(Op::Dot { a: ia, b: ib }, Tensor::new(1, 1, out))
    }

    fn row_arg(&mut self, a: Var, better: fn(f64, f64) -> bool) -> Var {
        let ia = self.check(a);
        let (r, c) = self.nodes[ia].value.shape();
        assert!(c > 0, "row min/max of a tensor with no column");
        let mut out = self.alloc(r);
        let mut arg = Vec::with_capacity(r);
        for (i, o) in out.iter_mut().enumerate() {
            let row = self.nodes[ia].value.row(i);
            let mut best = 0;
            for j in 1..c {
                if better(row[j], row[best]) {
                    best = j;
                }
            }
            arg.push(best);
            *o = row[best];
        }
        self.push(Op::RowArg { a: ia, arg }, Tensor::vector(out))
    }

    /// Minimum of each row (`rows × 1`); on a tie the first minimal column gets the gradient.
    pub fn row_min(&mut self, a: Var) -> Var {
        self.row_arg(a, |x, best| x < best)
    }

    /// Maximum of each row (`rows × 1`); on a tie the first maximal column gets the gradient.
    pub fn row_max(&mut self, a: Var) -> Var {
        self.row_arg(a, |x, best| x > best)
    }

    /// Smooth minimum of all elements, `−(1/κ) log Σᵢ exp(−κ aᵢ)` (`1 × 1`), computed stably.
    ///
    /// It never exceeds the true minimum and lies within `ln(count)/κ` of it; its gradient is the
    /// softmax weights `exp(−κ(aᵢ − result))`, summing to 1.
    ///
    /// # Panics
    /// If `a` is empty or `kappa` is not positive and finite.
    pub fn soft_min(&mut self, a: Var, kappa: f64) -> Var {
        let ia = self.check(a);
        assert!(
            kappa > 0.0 && kappa.is_finite(),
            "soft_min: kappa must be positive and finite"
        );
        let v = self.nodes[ia].value.data();
        assert!(!v.is_empty(), "soft_min of an empty tensor");
        let s = soft_min_value(v, kappa);
        self.push(Op::SoftMin { a: ia, kappa }, Tensor::scalar(s))
    }

    /// Stacks tensors with equal column counts on top of each other.
    pub fn concat_rows(&mut self, parts: &[Var]) -> Var {
        let ids: Vec<usize> = parts.iter().map(|&p| self.check(p)).collect();
        assert!(!ids.is_empty(), "concat_rows: nothing to concatenate");
        let c = self.nodes[ids[0]].value.cols();
        let total = ids.iter().map(|&i| self.nodes[i].value.len()).sum();
        let mut out = self.spare(total);
        let mut rows = 0;
        for &i in &ids {
            let v = &self.nodes[i].value;
            assert_eq!(v.cols(), c, "concat_rows: column counts differ");
            out.extend_from_slice(v.data());
            rows += v.rows();
        }
        self.push(Op::ConcatRows { parts: ids }, Tensor::new(rows, c, out))
    }

    /// Places tensors with equal row counts side by side.
    pub fn concat_cols(&mut self, parts: &[Var]) -> Var {
        let ids: Vec<usize> = parts.iter().map(|&p| self.check(p)).collect();
        assert!(!ids.is_empty(), "concat_cols: nothing to concatenate");
        let r = self.nodes[ids[0]].value.rows();
        let c: usize = ids.iter().map(|&i| self.nodes[i].value.cols()).sum();
        let mut out = self.spare(r * c);
        for row in 0..r {
            for &i in &ids {
                let v = &self.nodes[i].value;
                assert_eq!(v.rows(), r, "concat_cols: row counts differ");
                out.extend_from_slice(v.row(row));
            }
        }
        self.push(Op::ConcatCols { parts: ids }, Tensor::new(r, c, out))
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

    /// Gradient of the `1 × 1` output `y` with respect to every recorded value.
    ///
    /// # Panics
    /// If `y` is not `1 × 1`.
    pub fn backward(&self, y: Var) -> Gradients {
        let id = self.check(y);
        assert_eq!(
            self.nodes[id].value.shape(),
            (1, 1),
            "backward: the output must be 1 × 1; use Tape::vjp"
        );
        self.vjp(&[(y, Tensor::scalar(1.0))])
    }

    /// Vector–Jacobian product of the recorded segment: the gradient of `Σ ⟨seedᵢ, outputᵢ⟩` with
    /// respect to every recorded value.
    ///
    /// # Panics
    /// If a seed's shape differs from its output's.
    pub fn vjp(&self, seeds: &[(Var, Tensor)]) -> Gradients {
        let mut g = self.vjp_many(&[seeds]);
        g.pop()
            .expect("one set of seeds gives one set of gradients")
    }

    /// Several independent vector–Jacobian products in one backward pass: element `k` of the
    /// result is [`Tape::vjp`] of `seeds[k]`. Each Gauss–Seidel node pulls all of them back
    /// together ([`DynRowFn::vjp_update_batch_seeds`]), so work a row's adjoint needs whatever the
    /// seed (its constraint's value and gradient) is done once.
    ///
    /// # Panics
    /// If a seed's shape differs from its output's.
    pub fn vjp_many<S: AsRef<[(Var, Tensor)]>>(&self, seeds: &[S]) -> Vec<Gradients> {
        let n = self.nodes.len();
        let mut adjs: Vec<Vec<Option<Tensor>>> = seeds
            .iter()
            .map(|_| (0..n).map(|_| None).collect())
            .collect();
        let mut first = 0;
        for (adj, seeds) in adjs.iter_mut().zip(seeds) {
            for (v, seed) in seeds.as_ref() {
                assert_eq!(v.epoch, self.epoch, "vjp: seed Var from another recording");
                let id = v.id as usize;
                let shape = self.nodes[id].shape;
                assert_eq!(
                    seed.shape(),
                    shape,
                    "vjp: seed shape differs from its output's"
                );
                accumulate(&mut adj[id], seed.clone());
                first = first.max(id + 1);
            }
        }
        let shapes: Vec<(usize, usize)> = self.nodes.iter().map(|node| node.shape).collect();
        // Reused by every update node (no allocation per node).
        let (mut active, mut state_adj, mut carry_adj) = (Vec::new(), Vec::new(), Vec::new());
        for id in (0..first).rev() {
            match &self.nodes[id].op {
                // The carry's adjoint waits in its slot for the update node just before it.
                Op::UpdateCarry => {}
                Op::UpdateRows {
                    f,
                    index,
                    state,
                    carry,
                    inputs,
                } => {
                    active.clear();
                    active.extend(
                        (0..adjs.len())
                            .filter(|&k| adjs[k][id].is_some() || adjs[k][id + 1].is_some()),
                    );
                    if active.is_empty() {
                        continue;
                    }
                    let zeros = |(r, c): (usize, usize)| Tensor::zeros(r, c);
                    state_adj.clear();
                    state_adj.extend(
                        active
                            .iter()
                            .map(|&k| adjs[k][id].take().unwrap_or_else(|| zeros(shapes[id]))),
                    );
                    carry_adj.clear();
                    carry_adj.extend(active.iter().map(|&k| {
                        adjs[k][id + 1]
                            .take()
                            .unwrap_or_else(|| zeros(shapes[id + 1]))
                    }));
                    // Untouched state rows pass through; touched rows and the carry take the VJP.
                    f.vjp_update_batch_seeds(index, inputs, &mut state_adj, &mut carry_adj);
                    for ((&k, g), gc) in active
                        .iter()
                        .zip(state_adj.drain(..))
                        .zip(carry_adj.drain(..))
                    {
                        accumulate(&mut adjs[k][*state], g);
                        accumulate(&mut adjs[k][*carry], gc);
                    }
                }
                _ => {
                    for adj in adjs.iter_mut() {
                        if let Some(g) = adj[id].take() {
                            self.backward_node(id, g, adj, &shapes);
                        }
                    }
                }
            }
        }
        adjs.into_iter()
            .map(|adj| Gradients {
                epoch: self.epoch,
                adj,
                shapes: shapes.clone(),
            })
            .collect()
    }

    /// Pushes the adjoint `g` of node `id` to its inputs.
    fn backward_node(
        &self,
        id: usize,
        mut g: Tensor,
        adj: &mut [Option<Tensor>],
        shapes: &[(usize, usize)],
    ) {
        let val = |i: usize| &self.nodes[i].value;
        match &self.nodes[id].op {
            Op::Leaf => adj[id] = Some(g),
            Op::Gather { src, index } => {
                let (n, c) = shapes[*src];
                let mut out = Tensor::zeros(n, c);
                for (k, &p) in index.as_slice().iter().enumerate() {
                    for j in 0..c {
                        out.data_mut()[p * c + j] += g.data()[k * c + j];
                    }
                }
                accumulate(&mut adj[*src], out);
            }
            Op::ScatterAdd { src, index } => {
                let c = g.cols();
                let mut out = Tensor::zeros(index.rows(), index.arity() * c);
                for (k, &p) in index.as_slice().iter().enumerate() {
                    out.data_mut()[k * c..(k + 1) * c].copy_from_slice(g.row(p));
                }
                accumulate(&mut adj[*src], out);
            }
            Op::AssignRows { dst, index, src } => {
                let mut gs = Tensor::zeros(index.rows(), g.cols());
                for (k, &p) in index.as_slice().iter().enumerate() {
                    gs.row_mut(k).copy_from_slice(g.row(p));
                    g.row_mut(p).fill(0.0);
                }
                accumulate(&mut adj[*src], gs);
                accumulate(&mut adj[*dst], g);
            }
            Op::Binary { kind, a, b } => {
                let (sa, sb) = (shapes[*a], shapes[*b]);
                let (va, vb) = (val(*a).data(), val(*b).data());
                let (r, c) = g.shape();
                let mut ga = Tensor::zeros(sa.0, sa.1);
                let mut gb = Tensor::zeros(sb.0, sb.1);
                for i in 0..r {
                    for j in 0..c {
                        let (ka, kb) = (bidx(sa, i, j), bidx(sb, i, j));
                        let (x, y, gij) = (va[ka], vb[kb], g.data()[i * c + j]);
                        let (da, db) = match kind {
                            Binary::Add => (gij, gij),
                            Binary::Sub => (gij, -gij),
                            Binary::Mul => (gij * y, gij * x),
                            Binary::Div => (gij / y, -gij * x / (y * y)),
                            Binary::Min => {
                                if y < x {
                                    (0.0, gij)
                                } else {
                                    (gij, 0.0)
                                }
                            }
                            Binary::Max => {
                                if y > x {
                                    (0.0, gij)
                                } else {
                                    (gij, 0.0)
                                }
                            }
                        };
                        ga.data_mut()[ka] += da;
                        gb.data_mut()[kb] += db;
                    }
                }
                accumulate(&mut adj[*a], ga);
                accumulate(&mut adj[*b], gb);
            }
            Op::Unary { kind, a } => {
                for (gi, &x) in g.data_mut().iter_mut().zip(val(*a).data()) {
                    *gi *= match kind {
                        Unary::Neg => -1.0,
                        Unary::Square => 2.0 * x,
                        Unary::Sqrt => {
                            if x > 0.0 {
                                0.5 / x.sqrt()
                            } else {
                                0.0
                            }
                        }
                        Unary::Relu => {
                            if x > 0.0 {
                                1.0
                            } else {
                                0.0
                            }
                        }
                    };
                }
                accumulate(&mut adj[*a], g);
            }
            Op::AddScalar { a } => accumulate(&mut adj[*a], g),
            Op::Scale { a, c } => {
                g.data_mut().iter_mut().for_each(|x| *x *= c);
                accumulate(&mut adj[*a], g);
            }
            Op::Sum { a } => {
                let (r, c) = shapes[*a];
                accumulate(&mut adj[*a], Tensor::new(r, c, vec![g.item(); r * c]));
            }
            Op::RowSum { a } => {
                let (r, c) = shapes[*a];
                let data = (0..r)
                    .flat_map(|i| std::iter::repeat_n(g.data()[i], c))
                    .collect();
                accumulate(&mut adj[*a], Tensor::new(r, c, data));
            }
            Op::RowNorm { a } => {
                let x = val(*a);
                let mut out = Tensor::zeros(x.rows(), x.cols());
                for i in 0..x.rows() {
                    let row = x.row(i);
                    let nrm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
                    if nrm > 0.0 {
                        let s = g.data()[i] / nrm;
                        for (o, &v) in out.row_mut(i).iter_mut().zip(row) {
                            *o = s * v;
                        }
                    }
                }
                accumulate(&mut adj[*a], out);
            }
            Op::Dot { a, b } => {
                let s = g.item();
                let ga = Tensor::new(
                    shapes[*a].0,
                    shapes[*a].1,
                    val(*b).data().iter().map(|y| s * y).collect(),
                );
                let gb = Tensor::new(
                    shapes[*b].0,
                    shapes[*b].1,
                    val(*a).data().iter().map(|x| s * x).collect(),
                );
                accumulate(&mut adj[*a], ga);
                accumulate(&mut adj[*b], gb);
            }
            Op::RowArg { a, arg } => {
                let (r, c) = shapes[*a];
                let mut out = Tensor::zeros(r, c);
                for (i, &j) in arg.iter().enumerate() {
                    out.data_mut()[i * c + j] = g.data()[i];
                }
                accumulate(&mut adj[*a], out);
            }
            Op::SoftMin { a, kappa } => {
                let x = val(*a);
                let mut w = soft_min_weights(x.data(), *kappa);
                w.iter_mut().for_each(|wi| *wi *= g.item());
                accumulate(&mut adj[*a], Tensor::new(x.rows(), x.cols(), w));
            }
            Op::ConcatRows { parts } => {
                let mut offset = 0;
                for &p in parts {
                    let (r, c) = shapes[p];
                    let part = g.data()[offset..offset + r * c].to_vec();
                    offset += r * c;
                    accumulate(&mut adj[p], Tensor::new(r, c, part));
                }
            }
            Op::ConcatCols { parts } => {
                let mut col = 0;
                for &p in parts {
                    let (r, c) = shapes[p];
                    let mut part = Vec::with_capacity(r * c);
                    for i in 0..r {
                        part.extend_from_slice(&g.row(i)[col..col + c]);
                    }
                    col += c;
                    accumulate(&mut adj[p], Tensor::new(r, c, part));
                }
            }
            Op::MapRows { f, input } => {
                let x = val(*input);
                let mut gi = Tensor::zeros(x.rows(), x.cols());
                vjp_rows(f.as_ref(), x.data(), g.data(), gi.data_mut());
                accumulate(&mut adj[*input], gi);
            }
            Op::UpdateRows { .. } => unreachable!("update nodes are pulled back by vjp_many"),
            Op::UpdateCarry => unreachable!("carry adjoints are consumed by their update node"),
        }
    }
}

/// `−(1/κ) log Σ exp(−κ xᵢ)`, shifted by the minimum so no exponential overflows: the value of
/// [`Tape::soft_min`].
pub fn soft_min_value(x: &[f64], kappa: f64) -> f64 {
    let m = x.iter().copied().fold(f64::INFINITY, f64::min);
    let sum: f64 = x.iter().map(|&xi| (-kappa * (xi - m)).exp()).sum();
    m - sum.ln() / kappa
}

/// The gradient of [`soft_min_value`]: the softmax weights `exp(−κ(xᵢ − s))`, summing to 1.
pub fn soft_min_weights(x: &[f64], kappa: f64) -> Vec<f64> {
    let s = soft_min_value(x, kappa);
    x.iter().map(|&xi| (-kappa * (xi - s)).exp()).collect()
}

/// Files a cleared node's buffer among the spare ones (buffers without capacity are dropped).
fn recycle(pool: &mut BTreeMap<usize, Vec<Vec<f64>>>, mut buf: Vec<f64>) {
    if buf.capacity() > 0 {
        buf.clear();
        pool.entry(buf.capacity()).or_default().push(buf);
    }
}

/// Adds `g` into an adjoint slot, or fills an empty one.
fn accumulate(slot: &mut Option<Tensor>, g: Tensor) {
    match slot {
        Some(t) => t.add_assign(&g),
        None => *slot = Some(g),
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
