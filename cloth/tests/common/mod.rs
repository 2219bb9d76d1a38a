//! Helpers shared by the integration tests: small scenes, a tiny deterministic RNG, finite
//! differences and the comparison used throughout.

#![allow(dead_code)]

use autodiff::{Real, Tensor};
use cloth::constraint::{norm, Constraint};
use cloth::nalgebra::Vector3;
use cloth::scene::{
    Bending, BendingModel, BoxSpec, CapsuleSpec, ContactModel, ContactSpec, InitialControls,
    MeshSpec, Obstacle, ObstacleRole, PlaneSpec, SphereSetSpec, Stiffness, Target,
};
use cloth::sdf::{Cuboid, MeshSdf};
use cloth::{Model, Scene};

/// xorshift64*: deterministic pseudo-random numbers without an RNG crate.
pub struct XorShift(u64);

impl XorShift {
    pub fn new(seed: u64) -> Self {
        XorShift(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    /// Uniform in `[0, 1)`.
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[a, b)`.
    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next_f64()
    }
    /// A vector uniform in `[-1, 1]^n`.
    pub fn direction(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.uniform(-1.0, 1.0)).collect()
    }
}

/// Which bending model a small scene uses.
#[derive(Clone, Copy, Debug)]
pub enum BendKind {
    None,
    Distance(f64),
    Dihedral(f64),
    Isometric(f64),
}

/// A small hanging cloth (`rows × cols`, side 1, in the plane `y = −1.5`, top at `z = 2`),
/// gripped at its two top corners, `T = horizon`, with the bottom row as targets.
pub fn small_scene(
    rows: usize,
    cols: usize,
    horizon: usize,
    iterations: usize,
    stretch: f64,
    bending: BendKind,
) -> Scene {
    let mut s = Scene::builtin("swing").unwrap();
    s.name = format!("small{rows}x{cols}");
    s.cloth.rows = rows;
    s.cloth.cols = cols;
    s.physics.iterations = iterations;
    s.task.horizon = horizon;
    s.material.stretch = if stretch.is_infinite() {
        Stiffness::Infinite
    } else {
        Stiffness::Finite(stretch)
    };
    s.material.bending = match bending {
        BendKind::None => None,
        BendKind::Distance(k) => Some(Bending {
            model: BendingModel::Distance,
            stiffness: Stiffness::Finite(k),
        }),
        BendKind::Dihedral(k) => Some(Bending {
            model: BendingModel::Dihedral,
            stiffness: Stiffness::Finite(k),
        }),
        BendKind::Isometric(k) => Some(Bending {
            model: BendingModel::Isometric,
            stiffness: Stiffness::Finite(k),
        }),
    };
    s.controls = vec![[0, 0].into(), [0, cols - 1].into()];
    s.task.targets = (0..cols)
        .map(|c| Target {
            particle: [rows - 1, c].into(),
            position: [-0.5 + c as f64 / (cols - 1) as f64, 1.0, 1.5],
        })
        .collect();
    s.task.initial_controls = InitialControls::Zeros;
    s.validate().unwrap();
    s
}

/// A sphere-set obstacle.
pub fn spheres(centers: Vec<[f64; 3]>, radii: Vec<f64>, role: ObstacleRole) -> Obstacle {
    Obstacle::Spheres(SphereSetSpec {
        centers,
        radii,
        role,
        friction: None,
    })
}

/// A plane obstacle.
pub fn plane(point: [f64; 3], normal: [f64; 3], role: ObstacleRole) -> Obstacle {
    Obstacle::Plane(PlaneSpec {
        point,
        normal,
        role,
        friction: None,
    })
}

/// Controls from a flat list of values (`horizon × 3·n_controls`).
pub fn controls_from(model: &Model, values: &[f64]) -> Tensor {
    Tensor::new(
        model.task.horizon,
        3 * model.n_controls(),
        values[..model.task.horizon * 3 * model.n_controls()].to_vec(),
    )
}

/// `u + s·d`.
pub fn shifted(u: &Tensor, d: &[f64], s: f64) -> Tensor {
    let mut v = u.clone();
    for (x, di) in v.data_mut().iter_mut().zip(d) {
        *x += s * di;
    }
    v
}

/// `⟨a, b⟩`.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Central difference of `f` at `u` along `d` with step `h`.
pub fn central(f: &dyn Fn(&Tensor) -> f64, u: &Tensor, d: &[f64], h: f64) -> f64 {
    (f(&shifted(u, d, h)) - f(&shifted(u, d, -h))) / (2.0 * h)
}

/// The derivative at 0 of the piecewise-smooth `f` by the fourth-order central stencil at
/// `step`, or `Err(disagreement)` where the stencils at `step/10`, `step` and `2·step` differ by
/// more than `rel` relative: a kink (a row switching on, a contact pair changing) within the
/// stencil. Two scales are not enough: a kink between `step/10` and `step` bends the stencils
/// at `step` and `2·step` alike (measured on a self-contact fold: both 1.3e-6 off, while central
/// differences at 1e-8 were within 4.4e-9 of the exact derivative).
pub fn smooth_derivative(f: impl Fn(f64) -> f64, step: f64, rel: f64) -> Result<f64, f64> {
    let fd = |e: f64| (8.0 * (f(e) - f(-e)) - (f(2.0 * e) - f(-2.0 * e))) / (12.0 * e);
    let (fd0, fd1, fd2) = (fd(0.1 * step), fd(step), fd(2.0 * step));
    let disagreement = (fd1 - fd2).abs().max((fd1 - fd0).abs()) / fd1.abs().max(1e-12);
    if disagreement <= rel {
        Ok(fd1)
    } else {
        Err(disagreement)
    }
}

/// `|a − b| / (max(|a|, |b|) + floor/rel)`: the relative error with an absolute floor, scaled so
/// that `rel_err(..) ≤ rel` means `|a − b| ≤ rel·max(|a|, |b|) + floor`.
pub fn within(a: f64, b: f64, rel: f64, floor: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + floor
}

/// The excess of `|a − b|` over `rel·max(|a|,|b|) + floor`, as a ratio (≤ 1 passes).
pub fn ratio(a: f64, b: f64, rel: f64, floor: f64) -> f64 {
    (a - b).abs() / (rel * a.abs().max(b.abs()) + floor)
}

/// True when the two tensors are equal bit for bit.
pub fn bitwise_eq(a: &Tensor, b: &Tensor) -> bool {
    a.shape() == b.shape()
        && a.data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Replays [`Model::simulate`] step by step with the same kernel ([`autodiff::update::update_rows`])
/// and records, for every projection of a row of the group named `watch`, whether it was active
/// (`c(x) < 0`, with `c` the caller's function of the row's first particle) and the smallest `|c|`
/// seen. Returns the states (which must equal `simulate`'s bit for bit), the activity pattern and
/// the margin.
pub fn replay_watching(
    model: &Model,
    controls: &Tensor,
    watch: &str,
    c: &dyn Fn(&[f64]) -> f64,
) -> (Vec<Tensor>, Vec<bool>, f64) {
    use autodiff::update::update_rows;
    let mut states = vec![model.start.clone()];
    let mut pattern = Vec::new();
    let mut margin = f64::INFINITY;
    let sets: Vec<(&str, &cloth::ProjectionSet)> = model
        .groups
        .iter()
        .flat_map(|g| g.sets.iter().map(move |s| (g.name.as_str(), s)))
        .collect();
    for t in 0..model.task.horizon {
        let mut x = model.begin_step(&states[t], &model.step_controls(controls, t));
        let mut lambdas = model.initial_carries(&states[t]);
        for _ in 0..model.iterations {
            for ((name, set), lambda) in sets.iter().zip(lambdas.iter_mut()) {
                if *name == watch {
                    for k in 0..set.index.rows() {
                        let v = c(x.row(set.index.row(k)[0]));
                        pattern.push(v < 0.0);
                        margin = margin.min(v.abs());
                    }
                }
                update_rows(set.projection.as_ref(), &set.index, &mut x, lambda, None);
            }
        }
        states.push(x);
    }
    (states, pattern, margin)
}

/// `dL/dU` and `dC/dU` of `model` at `u` (safety margin `delta`) against central differences with
/// step `h` along a random direction drawn from `seed`: within `1e-5·|g|·|d| + 1e-9`.
pub fn check_gradients_along_a_direction(
    model: &Model,
    u: &Tensor,
    seed: u64,
    delta: f64,
    h: f64,
) -> Result<(), proptest::test_runner::TestCaseError> {
    let e = model.evaluate(u, delta, true).unwrap();
    let mut rng = XorShift::new(seed);
    let d = rng.direction(u.data().len());
    let l = |v: &Tensor| model.evaluate(v, delta, false).unwrap().metrics.l;
    let c = |v: &Tensor| model.evaluate(v, delta, false).unwrap().metrics.c;
    let norm2 = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    for (name, f, g) in [
        ("dL/dU", &l as &dyn Fn(&Tensor) -> f64, e.grad_l.unwrap()),
        ("dC/dU", &c as &dyn Fn(&Tensor) -> f64, e.grad_c.unwrap()),
    ] {
        let fd = central(f, u, &d, h);
        let an = dot(g.data(), &d);
        let scale = norm2(g.data()) * norm2(&d);
        proptest::prop_assert!(
            (fd - an).abs() <= 1e-5 * scale + 1e-9,
            "{name}: analytic {an:e}, central difference {fd:e} (scale {scale:e})"
        );
    }
    Ok(())
}

/// `model.evaluate(u, 0, true)` in a rayon pool of `threads` threads, with checkpoint budget
/// `budget` (determinism tests compare these bit for bit).
pub fn evaluate_in_pool(
    model: &Model,
    u: &Tensor,
    threads: usize,
    budget: usize,
) -> cloth::Evaluation {
    let mut m = model.clone();
    m.checkpoint_budget = budget;
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| m.evaluate(u, 0.0, true).unwrap())
}

/// Asserts that every state of the Newton rollout `states` of controls `u` is a minimizer of its
/// step's `Φ` (the exact Hessian is positive definite there).
pub fn assert_minimizers(model: &Model, states: &[Tensor], u: &Tensor) {
    let mut system = cloth::internals::NewtonSystem::new(model).unwrap();
    for t in 1..states.len() {
        let xt = model.begin_step(&states[t - 1], &model.step_controls(u, t - 1));
        assert!(
            system.factorize_exact(states[t].data(), xt.data()),
            "step {t} is not a minimizer"
        );
    }
}

/// An obstacle of each kind (`plane`, `sphere`, `capsule`, `box`, else a mesh cube) 0.02 behind
/// the hanging cloth of the contact tests (+y; the plane is the floor z = 0).
pub fn behind(kind: &str, role: ObstacleRole) -> Obstacle {
    let (y, z) = (-1.18, 1.4);
    match kind {
        "plane" => plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], role),
        "sphere" => spheres(vec![[0.05, y, z]], vec![0.3], role),
        "capsule" => Obstacle::Capsule(CapsuleSpec {
            a: [-0.7, y, z],
            b: [0.7, y, z - 0.1],
            radius: 0.3,
            role,
            friction: None,
        }),
        "box" => Obstacle::Box(BoxSpec {
            center: [0.0, y, 1.3],
            half_extents: [0.6, 0.3, 0.3],
            rotation: None,
            role,
            friction: None,
        }),
        _ => {
            let (v, t) = Cuboid::new([0.0, y, 1.3], [0.6, 0.3, 0.3], None).surface_triangles();
            Obstacle::Mesh(MeshSpec {
                file: "cube.obj".into(),
                role,
                friction: None,
                surface: Some(MeshSdf::new(v, t)),
            })
        }
    }
}

/// `physics.contact` naming `model` with every setting at its default.
pub fn contact_model(model: ContactModel) -> Option<ContactSpec> {
    Some(ContactSpec {
        model,
        d_hat: None,
        stiffness: None,
        friction_epsilon: None,
    })
}

/// `drop`'s grippers lowered to the ground and dragged (docs/performance.md, "Contact under
/// Newton"): the cloth lands on the collider, so contact rows are active.
pub fn lowered_and_dragged(model: &Model) -> Tensor {
    let mut u = model.zero_controls();
    for t in 0..model.task.horizon {
        for k in 0..model.n_controls() {
            let row = u.row_mut(t);
            row[3 * k] = 0.01 * (1 - k % 2) as f64;
            row[3 * k + 1] = 0.05;
            row[3 * k + 2] = -0.15;
        }
    }
    u
}

/// A user's constraint type as the tests write one (after `examples/custom_constraint.rs`):
/// triangle-area preservation `C = ½|(p₁ − p₀) × (p₂ − p₀)| − A⁰`.
pub struct TriangleArea {
    /// `A⁰` of each instance.
    pub rest: Vec<f64>,
}

impl TriangleArea {
    /// `½|(p₁ − p₀) × (p₂ − p₀)|`.
    pub fn area<R: Real>(p: &[Vector3<R>]) -> R {
        norm(&(p[1] - p[0]).cross(&(p[2] - p[0]))) * 0.5
    }
}

impl Constraint for TriangleArea {
    const ARITY: usize = 3;
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        Self::area(p) - self.rest[instance]
    }
}
