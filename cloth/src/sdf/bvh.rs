//! A bounding-volume hierarchy over triangles for closest-triangle queries (`f64`).
//!
//! Built top-down by median split of the triangle centroids along the longest axis; queried
//! depth first, nearer child first, with pruning by the box distance, optionally bounded
//! ([`Bvh::nearest_within`]). Deterministic: a tie between triangles goes to the smaller index.

use nalgebra::Vector3;

/// Triangles per leaf at most.
const LEAF: usize = 4;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Aabb {
    min: [f64; 3],
    max: [f64; 3],
}

impl Aabb {
    fn empty() -> Aabb {
        Aabb {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        }
    }

    fn grow(&mut self, p: &[f64; 3]) {
        for (k, &x) in p.iter().enumerate() {
            self.min[k] = self.min[k].min(x);
            self.max[k] = self.max[k].max(x);
        }
    }

    /// Squared distance from `p` to the box (0 inside).
    fn distance_squared(&self, p: &Vector3<f64>) -> f64 {
        (0..3)
            .map(|k| {
                let d = (self.min[k] - p[k]).max(p[k] - self.max[k]).max(0.0);
                d * d
            })
            .sum()
    }
}

/// A node: a box and either two children or a range of the sorted triangle order.
#[derive(Clone, Debug, PartialEq)]
enum Node {
    Inner {
        bounds: Aabb,
        children: [usize; 2],
    },
    Leaf {
        bounds: Aabb,
        start: usize,
        end: usize,
    },
}

impl Node {
    fn bounds(&self) -> &Aabb {
        match self {
            Node::Inner { bounds, .. } | Node::Leaf { bounds, .. } => bounds,
        }
    }
}

/// A BVH over a triangle list.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<usize>,
}

impl Bvh {
    /// Builds the hierarchy over `triangles` of `vertices` (at least one triangle).
    pub fn new(vertices: &[[f64; 3]], triangles: &[[usize; 3]]) -> Bvh {
        let centroids: Vec<[f64; 3]> = triangles
            .iter()
            .map(|t| std::array::from_fn(|k| t.iter().map(|&v| vertices[v][k]).sum::<f64>() / 3.0))
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::new(),
            order: (0..triangles.len()).collect(),
        };
        let (_, depth) = bvh.build_node(vertices, triangles, &centroids, 0, triangles.len());
        assert!(
            depth < STACK,
            "Bvh::new: a tree of depth {depth} does not fit the query stack"
        );
        bvh
    }

    /// Builds the subtree over `order[start..end]`: its node id and depth (a leaf has depth 1).
    fn build_node(
        &mut self,
        vertices: &[[f64; 3]],
        triangles: &[[usize; 3]],
        centroids: &[[f64; 3]],
        start: usize,
        end: usize,
    ) -> (usize, usize) {
        let mut bounds = Aabb::empty();
        let mut spread = Aabb::empty();
        for &t in &self.order[start..end] {
            for &v in &triangles[t] {
                bounds.grow(&vertices[v]);
            }
            spread.grow(&centroids[t]);
        }
        let id = self.nodes.len();
        if end - start <= LEAF {
            self.nodes.push(Node::Leaf { bounds, start, end });
            return (id, 1);
        }
        self.nodes.push(Node::Leaf { bounds, start, end });
        let axis = (0..3)
            .max_by(|&a, &b| {
                (spread.max[a] - spread.min[a]).total_cmp(&(spread.max[b] - spread.min[b]))
            })
            .unwrap_or(0);
        let mid = (start + end) / 2;
        self.order[start..end].sort_by(|&a, &b| {
            centroids[a][axis]
                .total_cmp(&centroids[b][axis])
                .then(a.cmp(&b))
        });
        let (left, left_depth) = self.build_node(vertices, triangles, centroids, start, mid);
        let (right, right_depth) = self.build_node(vertices, triangles, centroids, mid, end);
        self.nodes[id] = Node::Inner {
            bounds,
            children: [left, right],
        };
        (id, 1 + left_depth.max(right_depth))
    }

    /// True when `p` is in the root's bounding box (its boundary included).
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        self.nodes[0].bounds().distance_squared(p) == 0.0
    }

    /// The triangle nearest to `p` by `distance_squared(triangle, p)` and that squared distance;
    /// on a tie the smaller triangle index.
    #[cfg(any(test, feature = "internals"))]
    pub fn nearest(
        &self,
        p: &Vector3<f64>,
        distance_squared: impl Fn(usize) -> f64,
    ) -> (usize, f64) {
        self.nearest_within(p, f64::INFINITY, distance_squared)
            .expect("an unbounded query finds a triangle")
    }

    /// [`Bvh::nearest`] bounded by `bound_squared`: `Ok` with the nearest triangle and its
    /// squared distance when that is at most `bound_squared` (then the same answer as
    /// [`Bvh::nearest`]); otherwise `Err` with a lower bound, above `bound_squared`, of every
    /// triangle's squared distance (the smallest box distance of the subtrees it skipped and
    /// triangle distance of the leaves it read).
    pub fn nearest_within(
        &self,
        p: &Vector3<f64>,
        bound_squared: f64,
        distance_squared: impl Fn(usize) -> f64,
    ) -> Result<(usize, f64), f64> {
        self.nearest_by(
            bound_squared,
            |min, max| {
                Aabb {
                    min: *min,
                    max: *max,
                }
                .distance_squared(p)
            },
            distance_squared,
        )
    }

    /// The triangle with the smallest `measure(triangle)` (the smaller index on a tie), given a
    /// lower bound `box_lower(min, max)` of the measure of every triangle in a box: `Ok` with it
    /// and its measure when that is at most `bound`; otherwise `Err` with a lower bound, above
    /// `bound`, of every triangle's measure (the smallest box bound of the subtrees it skipped
    /// and measure of the leaves it read). A point's squared distance is one such measure
    /// ([`Bvh::nearest_within`]); a segment's is another.
    ///
    /// Depth first, nearer child first; a subtree is skipped as soon as its box bound exceeds
    /// the best measure so far (or the bound). No allocation: the stack is an array, as deep
    /// as the tree.
    pub fn nearest_by(
        &self,
        bound: f64,
        box_lower: impl Fn(&[f64; 3], &[f64; 3]) -> f64,
        measure: impl Fn(usize) -> f64,
    ) -> Result<(usize, f64), f64> {
        let lower = |id: usize| {
            let b = self.nodes[id].bounds();
            box_lower(&b.min, &b.max)
        };
        // `best.0 == usize::MAX` until a triangle within the bound is found; `best.1` is the
        // pruning radius.
        let mut best = (usize::MAX, bound);
        let mut beyond = f64::INFINITY;
        let mut stack = Stack::default();
        stack.push_within((lower(0), 0), best.1, &mut beyond);
        while let Some((low, id)) = stack.pop() {
            if low > best.1 {
                beyond = beyond.min(low);
                continue;
            }
            match &self.nodes[id] {
                Node::Leaf { start, end, .. } => {
                    for &t in &self.order[*start..*end] {
                        let d = measure(t);
                        if d < best.1 || (d == best.1 && t < best.0) {
                            best = (t, d);
                        } else {
                            beyond = beyond.min(d);
                        }
                    }
                }
                Node::Inner { children, .. } => {
                    let [a, b] = children.map(|c| (lower(c), c));
                    // Push the farther child first, so the nearer one is visited first.
                    let (near, far) = if b.0 < a.0 { (b, a) } else { (a, b) };
                    stack.push_within(far, best.1, &mut beyond);
                    stack.push_within(near, best.1, &mut beyond);
                }
            }
        }
        if best.0 == usize::MAX {
            Err(beyond)
        } else {
            Ok(best)
        }
    }
}

/// Entries a query's stack holds at most: one more than the tree's depth, which a median split
/// keeps at `log₂(triangles / LEAF) + 1` (checked in [`Bvh::new`]).
const STACK: usize = 64;

/// A query's stack of `(squared box distance, node)`, on the call stack.
struct Stack {
    entries: [(f64, usize); STACK],
    len: usize,
}

impl Default for Stack {
    fn default() -> Stack {
        Stack {
            entries: [(0.0, 0); STACK],
            len: 0,
        }
    }
}

impl Stack {
    /// Pushes `entry` when its box is within `radius`; otherwise lowers `beyond` to its distance.
    #[inline(always)]
    fn push_within(&mut self, entry: (f64, usize), radius: f64, beyond: &mut f64) {
        if entry.0 > radius {
            *beyond = beyond.min(entry.0);
        } else {
            self.entries[self.len] = entry;
            self.len += 1;
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(f64, usize)> {
        self.len = self.len.checked_sub(1)?;
        Some(self.entries[self.len])
    }
}
