//! A bounding-volume hierarchy over triangles for closest-triangle queries (`f64`).
//!
//! Built top-down by median split of the triangle centroids along the longest axis; queried
//! best-first with pruning by the box distance. Deterministic: a tie between triangles goes to
//! the smaller index.

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
        bvh.build(vertices, triangles, &centroids, 0, triangles.len());
        bvh
    }

    fn build(
        &mut self,
        vertices: &[[f64; 3]],
        triangles: &[[usize; 3]],
        centroids: &[[f64; 3]],
        start: usize,
        end: usize,
    ) -> usize {
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
            return id;
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
        let left = self.build(vertices, triangles, centroids, start, mid);
        let right = self.build(vertices, triangles, centroids, mid, end);
        self.nodes[id] = Node::Inner {
            bounds,
            children: [left, right],
        };
        id
    }

    /// The triangle nearest to `p` by `distance_squared(triangle, p)` and that squared distance;
    /// on a tie the smaller triangle index.
    pub fn nearest(
        &self,
        p: &Vector3<f64>,
        distance_squared: impl Fn(usize) -> f64,
    ) -> (usize, f64) {
        let mut best = (usize::MAX, f64::INFINITY);
        let mut stack = vec![(self.nodes[0].bounds().distance_squared(p), 0usize)];
        while let Some((lower, id)) = stack.pop() {
            if lower > best.1 {
                continue;
            }
            match &self.nodes[id] {
                Node::Leaf { start, end, .. } => {
                    for &t in &self.order[*start..*end] {
                        let d = distance_squared(t);
                        if d < best.1 || (d == best.1 && t < best.0) {
                            best = (t, d);
                        }
                    }
                }
                Node::Inner { children, .. } => {
                    let [a, b] = children.map(|c| (self.nodes[c].bounds().distance_squared(p), c));
                    // Push the farther child first, so the nearer one is visited first.
                    let (near, far) = if b.0 < a.0 { (b, a) } else { (a, b) };
                    stack.push(far);
                    stack.push(near);
                }
            }
        }
        best
    }
}
