//! The reverse pass of a [`Tape`]: vector–Jacobian products of a recorded segment for one or
//! several sets of seeds, node by node.

use super::rows::soft_min_weights;
use super::{bidx, Binary, Gradients, Op, Tape, Unary, Var};
use crate::rowfn::vjp_rows;
use crate::tensor::Tensor;

impl Tape {
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

    /// Several independent vector–Jacobian products in one backward pass: element `k` of the result
    /// is [`Tape::vjp`] of `seeds[k]`. Each Gauss–Seidel node pulls all of them back together
    /// ([`crate::DynRowFn::vjp_update_batch_seeds`]), so work a row's adjoint needs whatever the
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
                    // The update pulled back after the next one (each has its carry node) reads
                    // saved inputs written long ago by the forward: start loading them now.
                    if let Some(Op::UpdateRows { inputs, .. }) =
                        id.checked_sub(4).map(|k| &self.nodes[k].op)
                    {
                        prefetch(inputs);
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

/// Adds `g` into an adjoint slot, or fills an empty one.
fn accumulate(slot: &mut Option<Tensor>, g: Tensor) {
    match slot {
        Some(t) => t.add_assign(&g),
        None => *slot = Some(g),
    }
}

/// Values [`prefetch`] asks for at most (the hardware prefetcher follows longer streams).
const PREFETCH_VALUES: usize = 1024;

/// Asks the CPU to start loading the first [`PREFETCH_VALUES`] of `data` into its second-level
/// cache: a colour set's saved inputs are a short stream (a few cache lines per row block), too
/// short for the hardware prefetcher to ramp up, and the pull-back stalled on their first loads
/// (18% of its kernel's samples on one load at n = 10). Two updates ahead and into L2: one
/// ahead into L1 only moved the stall onto the prefetches. A hint only: no effect on values,
/// and none off x86-64.
#[inline]
fn prefetch(data: &[f64]) {
    #[cfg(target_arch = "x86_64")]
    for line in data[..data.len().min(PREFETCH_VALUES)].chunks(8) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T1};
        // SAFETY: a prefetch is a hint that never faults, and the pointer is in bounds.
        unsafe { _mm_prefetch::<_MM_HINT_T1>(line.as_ptr().cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = data;
}
