//! The cloth geometry a scene derives: its mesh, rest positions, control and target particle
//! indices, target positions, tolerance and initial controls — what [`crate::Model::from_scene`]
//! compiles from.

use crate::mesh::{ClothMesh, GridMesh};
use crate::scene::{InitialControls, Obstacle, ParticleRef, Scene};
use crate::sdf::{Capsule, Cuboid, Plane, SignedDistance, SphereSet, Surface, Union};

impl Scene {
    /// The cloth's topology: the grid's (`cloth.rows × cloth.cols`, `GridMesh::topology` in
    /// `cloth/src/mesh.rs`) or the triangles of `cloth.mesh` ([`ClothMesh::from_triangles`]). A
    /// mesh cloth whose file has not been read ([`Scene::load_files`]) has no particles.
    pub fn mesh(&self) -> ClothMesh {
        if self.cloth.is_mesh() {
            match &self.cloth.mesh_data {
                Some(m) => ClothMesh::from_triangles(m.vertices.len(), m.triangles.clone()),
                None => ClothMesh::from_triangles(0, Vec::new()),
            }
        } else {
            GridMesh::new(self.cloth.rows, self.cloth.cols).topology()
        }
    }

    /// Number of particles: `cloth.rows × cloth.cols`, or the mesh cloth's vertex count.
    pub fn n_particles(&self) -> usize {
        if self.cloth.is_mesh() {
            self.cloth
                .mesh_data
                .as_ref()
                .map_or(0, |m| m.vertices.len())
        } else {
            self.cloth.rows * self.cloth.cols
        }
    }

    /// Rest positions in particle-index order. A grid's particle `p = r·cols + c` rests at
    /// `top_left + right·(c/max(cols−1,1)) + down·(r/max(rows−1,1))`, summed left to right; a mesh
    /// cloth's vertices rest where the file puts them.
    pub fn rest_positions(&self) -> Vec<[f64; 3]> {
        let c = &self.cloth;
        if c.is_mesh() {
            return c
                .mesh_data
                .as_ref()
                .map_or_else(Vec::new, |m| m.vertices.clone());
        }
        let col_den = c.cols.saturating_sub(1).max(1) as f64;
        let row_den = c.rows.saturating_sub(1).max(1) as f64;
        let mut out = Vec::with_capacity(self.n_particles());
        for r in 0..c.rows {
            let s = r as f64 / row_den;
            for col in 0..c.cols {
                let t = col as f64 / col_den;
                out.push(std::array::from_fn(|k| {
                    c.top_left[k] + c.right[k] * t + c.down[k] * s
                }));
            }
        }
        out
    }

    /// Length of the cloth's longest side. A grid: the larger of `|right|` (when `cols > 1`) and
    /// `|down|` (when `rows > 1`). A mesh cloth: the largest extent of its rest vertices' bounding
    /// box. 0 for a single particle.
    pub fn longest_side(&self) -> f64 {
        let c = &self.cloth;
        if c.is_mesh() {
            let rest = self.rest_positions();
            return (0..3)
                .map(|k| {
                    let (lo, hi) = rest
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                            (lo.min(p[k]), hi.max(p[k]))
                        });
                    if hi >= lo {
                        hi - lo
                    } else {
                        0.0
                    }
                })
                .fold(0.0, f64::max);
        }
        let len = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let right = if c.cols > 1 { len(&c.right) } else { 0.0 };
        let down = if c.rows > 1 { len(&c.down) } else { 0.0 };
        right.max(down)
    }

    /// Default of `task.tolerance`: 10% of [`Scene::longest_side`] (1e-3 for a cloth of one
    /// particle, which has no side to measure).
    pub fn default_tolerance(&self) -> f64 {
        let side = self.longest_side();
        if side > 0.0 {
            0.1 * side
        } else {
            1e-3
        }
    }

    /// The task's target tolerance: `task.tolerance`, or [`Scene::default_tolerance`].
    pub fn tolerance(&self) -> f64 {
        self.task
            .tolerance
            .unwrap_or_else(|| self.default_tolerance())
    }

    /// The particle index a validated scene's reference names: `r·cols + c` for a grid's
    /// `[r, c]`, the vertex index itself on a mesh cloth.
    pub fn particle_index(&self, particle: ParticleRef) -> usize {
        match particle {
            ParticleRef::Grid([r, c]) => r * self.cloth.cols + c,
            ParticleRef::Vertex(v) => v,
        }
    }

    /// Particle indices of the control particles, in control order.
    pub fn control_indices(&self) -> Vec<usize> {
        self.controls
            .iter()
            .map(|&p| self.particle_index(p))
            .collect()
    }

    /// Particle indices of the targets, in target order: `task.targets`, or every vertex of
    /// `task.target_mesh`.
    pub fn target_indices(&self) -> Vec<usize> {
        match &self.task.target_mesh_data {
            Some(vertices) => (0..vertices.len()).collect(),
            None => self
                .task
                .targets
                .iter()
                .map(|t| self.particle_index(t.particle))
                .collect(),
        }
    }

    /// Target positions, in target order.
    pub fn target_positions(&self) -> Vec<[f64; 3]> {
        match &self.task.target_mesh_data {
            Some(vertices) => vertices.clone(),
            None => self.task.targets.iter().map(|t| t.position).collect(),
        }
    }

    /// The initial control guess as a `horizon × controls` array (`[t][k]` = displacement of control `k`
    /// during step `t + 1`). The shape is exact for a validated scene.
    pub fn initial_controls_array(&self) -> Vec<Vec<[f64; 3]>> {
        let (h, m) = (self.task.horizon, self.controls.len());
        match &self.task.initial_controls {
            InitialControls::Zeros => vec![vec![[0.0; 3]; m]; h],
            InitialControls::Constant(v) => vec![v.clone(); h],
            InitialControls::Explicit(steps) => steps.clone(),
        }
    }

    /// The initial control guess as a controls tensor (`horizon × 3·controls`, see
    /// [`crate::Controls`]).
    pub fn initial_controls(&self) -> autodiff::Tensor {
        let u = self.initial_controls_array();
        let values = u.iter().flatten().flatten().copied().collect();
        autodiff::Tensor::new(u.len(), 3 * self.controls.len(), values)
    }
}

impl Obstacle {
    /// The obstacle's runtime signed distance field, as a one-obstacle [`Union`]. A mesh obstacle
    /// whose file has not been read ([`Scene::load_files`]) gives an empty union.
    pub fn field(&self) -> Union {
        let mut u = Union::default();
        match self {
            Obstacle::Spheres(s) => u.spheres.push(SphereSet {
                centers: s.centers.clone(),
                radii: s.radii.clone(),
            }),
            Obstacle::Plane(p) => u.planes.push(Plane {
                point: p.point,
                normal: p.normalized(),
            }),
            Obstacle::Capsule(c) => u.capsules.push(Capsule {
                a: c.a,
                b: c.b,
                radius: c.radius,
            }),
            Obstacle::Box(b) => u
                .boxes
                .push(Cuboid::new(b.center, b.half_extents, b.rotation)),
            Obstacle::Mesh(m) => u.meshes.extend(m.surface.clone()),
        }
        u
    }

    /// The signed distance of `p` to the obstacle.
    pub fn signed_distance(&self, p: [f64; 3]) -> f64 {
        self.field().distance(&nalgebra::Vector3::from(p))
    }

    /// A closed tessellation of a bounded obstacle (capsule, box, mesh, each sphere of a sphere
    /// set) for figures; `None` for a plane.
    pub fn surface_triangles(&self) -> Option<Surface> {
        let merge = |parts: Vec<Surface>| {
            let mut out: Surface = (Vec::new(), Vec::new());
            for (v, t) in parts {
                let offset = out.0.len();
                out.0.extend(v);
                out.1.extend(t.iter().map(|tri| tri.map(|i| i + offset)));
            }
            out
        };
        match self {
            Obstacle::Spheres(s) => Some(merge(
                s.centers
                    .iter()
                    .zip(&s.radii)
                    .map(|(&c, &r)| crate::sdf::sphere_surface(c, r))
                    .collect(),
            )),
            Obstacle::Plane(_) => None,
            Obstacle::Capsule(c) => Some(
                Capsule {
                    a: c.a,
                    b: c.b,
                    radius: c.radius,
                }
                .surface_triangles(),
            ),
            Obstacle::Box(b) => {
                Some(Cuboid::new(b.center, b.half_extents, b.rotation).surface_triangles())
            }
            Obstacle::Mesh(m) => m.surface.as_ref().map(|s| s.surface_triangles()),
        }
    }
}
