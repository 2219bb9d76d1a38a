//! Candidate routes from the scene's geometry.
//!
//! A route is a path for the grippers, turned into per-step displacements (the controls). Routes
//! are built from two base paths — the initial guess and the straight path, which takes each
//! gripper to its particle's target (or, for a gripper without one, translates it by the
//! targets' mean displacement) — as *carry routes* where a base's rollout rests the cloth on a
//! collider (the grippers lifted on a half circle from the base's start to its end,
//! `super::carry`), and as detours around the obstacles in the way that a base path's rollout
//! runs into (the safety obstacles and the colliders no target lies on, `super::obstacles`):
//!
//! 1. simulate the base path and mark the steps where the cloth (and, under the continuous check,
//!    its straight motion from the step before) comes closer than `δ + clearance` to a safety
//!    obstacle (`clearance` = the task tolerance); consecutive marked steps form a *blocked
//!    segment*;
//! 2. for each segment and each of 8 directions perpendicular to the travel (over, under, left,
//!    right and the diagonals; "up" is against gravity), find the smallest offset `s` such that the
//!    cloth of every step of the segment, translated by `s·n`, keeps `δ + clearance` from every
//!    safety obstacle while the grippers stay on the free side of every collider plane: the
//!    cloth's extent, plus `δ`, taken over, beside or under the obstacle;
//! 3. a detour offsets the base path by `s·n` over the segment, ramping linearly from the
//!    previous keypoint (the start, or the previous segment) and back to the end.
//!
//! Where the task hangs the cloth over a collider (targets on it above the grippers' ends), the
//! drape route (`super::drape`) lifts the grippers over it and lowers them on the far side.
//! Seeded random perturbations (a via-point at a random step with a random perpendicular offset
//! up to the cloth's size) complete the set. Everything is deterministic.

use super::carry::carry_paths;
use super::drape::drape_paths;
use super::lay::lay_route;
use super::obstacles::in_the_way;
use autodiff::Tensor;
use cloth::sdf::{SignedDistance, Union};
use cloth::ControlsView;
use cloth::{Controls, Model};
use rand::{RngExt, SeedableRng};
use rand_xorshift::XorShiftRng;

/// A candidate start for the planner: controls and a label saying how they were built.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// How the route was built, e.g. `straight, over (0.85) at steps 3–5`.
    pub route: String,
    /// The controls (`T × 3K`).
    pub controls: Controls,
}

/// Gripper positions of a route: `paths[t][k]`, steps `0..=T`.
type Paths = Vec<Vec<[f64; 3]>>;

/// The 8 detour directions as (name, weight along up, weight along left).
const DIRECTIONS: [(&str, f64, f64); 8] = [
    ("over", 1.0, 0.0),
    ("under", -1.0, 0.0),
    ("left", 0.0, 1.0),
    ("right", 0.0, -1.0),
    ("over-left", 1.0, 1.0),
    ("over-right", 1.0, -1.0),
    ("under-left", -1.0, 1.0),
    ("under-right", -1.0, -1.0),
];

/// Offsets tried per detour direction: `s = h, 2h, …` up to this many steps.
const OFFSET_STEPS: usize = 400;

/// Proposes routes for `model`'s task at margin `delta` (see the module docs): detours of the
/// initial guess `initial` and of the straight path, and `random` seeded perturbations, at most
/// `limit` in all (detours first, by base path and then by the size of their offsets). With
/// `swept` (the continuous check) the motion between the steps counts as running into an
/// obstacle too.
pub fn propose(
    model: &Model,
    initial: &Controls,
    (delta, swept): (f64, bool),
    random: usize,
    seed: u64,
    limit: usize,
) -> Vec<Candidate> {
    let geometry = Geometry::new(model, delta, swept);
    let straight = geometry.straight_paths();
    // The initial guess and the straight path; one of them when they coincide (to rounding).
    let guess = paths_of(model, initial);
    let mut bases = vec![("initial guess", guess.clone())];
    if !same_paths(&guess, &straight) {
        bases.push(("straight", straight.clone()));
    }
    // The straight path itself, unless it is the initial guess (already planned first).
    let mut out = Vec::new();
    if bases.len() > 1 {
        out.push(Candidate {
            route: "straight".into(),
            controls: controls_of(&straight),
        });
    }
    // Per base path: its carry route where its rollout rests the cloth on a collider, and its
    // detours, ordered by rank (best direction per segment first); the lay route (from the
    // guess's rollout) first.
    let mut detours: Vec<Vec<Candidate>> = Vec::new();
    for (i, (name, base)) in bases.iter().enumerate() {
        let Ok(states) = model.simulate(&controls_of(base)) else {
            continue;
        };
        if i == 0 {
            out.extend(geometry.laid(&states, &std::cell::Cell::new(0)));
            out.extend(geometry.draped(&states));
        }
        out.extend(geometry.carried(name, base, &states));
        detours.push(geometry.detours(name, base, &states));
    }
    // Interleave the bases so both get candidates under the limit.
    let longest = detours.iter().map(Vec::len).max().unwrap_or(0);
    for rank in 0..longest {
        for list in &detours {
            if let Some(c) = list.get(rank) {
                out.push(c.clone());
            }
        }
    }
    // The same controls twice (e.g. the initial guess *is* the straight path) plan once.
    let mut unique: Vec<Candidate> = Vec::new();
    for c in out {
        if !unique
            .iter()
            .any(|u| u.controls.data() == c.controls.data())
        {
            unique.push(c);
        }
    }
    unique.truncate(limit.saturating_sub(random).max(1));
    unique.extend(geometry.random_routes(&straight, random, seed));
    unique
}

/// When the rollout `states` of the controls `initial` rests the cloth on a collider, the carry
/// routes (`super::carry`) of `initial` (`initial guess, carried`) and of the straight path
/// (`straight, carried`; its end is the grippers' targets), each once; none otherwise. The lay
/// route (`lay/`, `lay`) first, where the task has one. Also returns how many rollouts
/// building them took (the lay route's corrections for the cloth's lag).
pub fn carried(model: &Model, initial: &Controls, states: &[Tensor]) -> (Vec<Candidate>, usize) {
    let geometry = Geometry::new(model, 0.0, false);
    let rollouts = std::cell::Cell::new(0);
    let mut out: Vec<Candidate> = geometry.laid(states, &rollouts).into_iter().collect();
    out.extend(geometry.draped(states));
    let bases = [
        ("initial guess", paths_of(model, initial)),
        ("straight", geometry.straight_paths()),
    ];
    for (name, base) in &bases {
        if let Some(c) = geometry.carried(name, base, states) {
            let path = paths_of(model, &c.controls);
            if out
                .iter()
                .all(|o| !same_paths(&paths_of(model, &o.controls), &path))
            {
                out.push(c);
            }
        }
    }
    (out, rollouts.get())
}

/// What the proposals need to know about the scene.
struct Geometry<'a> {
    model: &'a Model,
    delta: f64,
    /// The motion between the steps counts too (the continuous check).
    swept: bool,
    clearance: f64,
    /// What the routes go around ([`in_the_way`]): the safety obstacles and the colliders no
    /// target lies on.
    avoid: Union,
    /// Unit vector against gravity (`+z` without gravity).
    world_up: [f64; 3],
    /// Unit "up" and "left", perpendicular to the travel direction.
    up: [f64; 3],
    left: [f64; 3],
    /// Largest offset tried.
    reach: f64,
    /// Offset increment.
    increment: f64,
    /// The cloth's size (largest rest extent).
    size: f64,
}

impl<'a> Geometry<'a> {
    fn new(model: &'a Model, delta: f64, swept: bool) -> Self {
        let displacement = mean_target_displacement(model);
        let gravity = model.gravity_step.unwrap_or([0.0, 0.0, -1.0]);
        let world_up = normalized(scale(gravity, -1.0)).unwrap_or([0.0, 0.0, 1.0]);
        let travel = normalized(displacement).unwrap_or_else(|| any_perpendicular(world_up));
        // Up without its travel component; if travel is vertical, any perpendicular.
        let up = normalized(sub(world_up, scale(travel, dot(world_up, travel))))
            .unwrap_or_else(|| any_perpendicular(travel));
        let left = cross(up, travel);
        let size = extent(&model.start);
        let avoid = in_the_way(model);
        let obstacles = obstacle_extent(&avoid);
        let clearance = model.task.tolerance;
        let increment = (0.5 * clearance).max(1e-3 * (size + obstacles).max(1e-9));
        let reach = 2.0 * (size + obstacles + delta + clearance);
        Geometry {
            model,
            delta,
            swept,
            clearance,
            avoid,
            world_up,
            up,
            left,
            reach: reach.min(increment * OFFSET_STEPS as f64),
            increment,
            size,
        }
    }

    /// Each gripper on a straight line to its particle's target when it has one, else
    /// translated by the targets' mean displacement, in `T` equal steps.
    fn straight_paths(&self) -> Paths {
        let model = self.model;
        let mean = mean_target_displacement(model);
        let start = gripper_starts(model);
        let targets = model.task.targets.as_slice();
        let travel: Vec<[f64; 3]> = model
            .controls
            .as_slice()
            .iter()
            .zip(&start)
            .map(|(&p, &s)| match targets.iter().position(|&q| q == p) {
                Some(i) => sub(
                    std::array::from_fn(|j| model.task.target_positions.get(i, j)),
                    s,
                ),
                None => mean,
            })
            .collect();
        let horizon = model.task.horizon;
        (0..=horizon)
            .map(|t| {
                let f = t as f64 / horizon as f64;
                start
                    .iter()
                    .zip(&travel)
                    .map(|(&p, &d)| add(p, scale(d, f)))
                    .collect()
            })
            .collect()
    }

    /// The carry route of `base` (called `name`) when its rollout `states` rests the cloth on a
    /// collider.
    fn carried(&self, name: &str, base: &Paths, states: &[Tensor]) -> Option<Candidate> {
        if !self.rests_on_colliders(states) {
            return None;
        }
        let carry = carry_paths(base, self.world_up, self.clearance)?;
        Some(Candidate {
            route: format!("{name}, carried"),
            controls: controls_of(&carry),
        })
    }

    /// The lay route (`lay/`) from the grippers' starts to the straight path's ends, with
    /// the hang measured on `states` (the initial guess's rollout), where the task has one;
    /// `rollouts` counts the rollouts it took.
    fn laid(&self, states: &[Tensor], rollouts: &std::cell::Cell<usize>) -> Option<Candidate> {
        let straight = self.straight_paths();
        let ends = straight.last()?;
        let rollout = |paths: &Paths| {
            rollouts.set(rollouts.get() + 1);
            self.model.simulate(&controls_of(paths)).ok()
        };
        let paths = lay_route(self.model, (&straight[0], ends), states, rollout)?;
        Some(Candidate {
            route: "lay".into(),
            controls: controls_of(&paths),
        })
    }

    /// The drape route ([`super::drape`]) from the grippers' starts to the straight path's ends,
    /// with the depth measured on `states` (the initial guess's rollout), where the task hangs
    /// the cloth over a collider.
    fn draped(&self, states: &[Tensor]) -> Option<Candidate> {
        let straight = self.straight_paths();
        let ends = straight.last()?;
        let paths = drape_paths(self.model, (&straight[0], ends), states, self.delta)?;
        Some(Candidate {
            route: "drape".into(),
            controls: controls_of(&paths),
        })
    }

    /// True when some particle of some state lies within the clearance (the task tolerance) of
    /// a collider: the cloth rests on, or slides along, something.
    fn rests_on_colliders(&self, states: &[Tensor]) -> bool {
        let colliders = &self.model.colliders;
        !colliders.is_empty()
            && states.iter().any(|x| {
                x.data().chunks_exact(3).any(|p| {
                    colliders.distance(&nalgebra::Vector3::new(p[0], p[1], p[2])) < self.clearance
                })
            })
    }

    /// Detours of `base` around the obstacles its rollout `states` runs into, best first.
    fn detours(&self, name: &str, base: &Paths, states: &[Tensor]) -> Vec<Candidate> {
        if self.avoid.is_empty() {
            return Vec::new();
        }
        let limit = self.delta + self.clearance;
        let blocked: Vec<usize> = (1..states.len())
            .filter(|&t| self.step_distance(states, t, [0.0; 3]) < limit)
            .collect();
        let segments = runs(&blocked);
        if segments.is_empty() {
            return Vec::new();
        }
        // Per segment: the clear directions, smallest offset first.
        let options: Vec<Vec<(usize, f64)>> = segments
            .iter()
            .map(|&(a, b)| {
                let mut found: Vec<(usize, f64)> = (0..DIRECTIONS.len())
                    .filter_map(|d| {
                        self.clear_offset(base, states, a, b, self.direction(d))
                            .map(|s| (d, s))
                    })
                    .collect();
                found.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
                found
            })
            .collect();
        let ranks = options.iter().map(Vec::len).max().unwrap_or(0);
        let mut out = Vec::new();
        for rank in 0..ranks {
            let choice: Vec<(usize, usize, [f64; 3], f64, &str)> = segments
                .iter()
                .zip(&options)
                .filter_map(|(&(a, b), opts)| {
                    let &(d, s) = opts.get(rank).or(opts.last())?;
                    Some((a, b, self.direction(d), s, DIRECTIONS[d].0))
                })
                .collect();
            if choice.is_empty() {
                continue;
            }
            let label = choice
                .iter()
                .map(|(a, b, _, s, dir)| {
                    let steps = if a == b {
                        format!("step {a}")
                    } else {
                        format!("steps {a}–{b}")
                    };
                    format!("{dir} ({s:.2}) at {steps}")
                })
                .collect::<Vec<_>>()
                .join("; ");
            let offsets: Vec<(usize, usize, [f64; 3])> = choice
                .iter()
                .map(|&(a, b, n, s, _)| (a, b, scale(n, s)))
                .collect();
            out.push(Candidate {
                route: format!("{name}, {label}"),
                controls: controls_of(&offset_paths(base, &offsets)),
            });
        }
        out
    }

    /// Unit vector of detour direction `d`.
    fn direction(&self, d: usize) -> [f64; 3] {
        let (_, u, l) = DIRECTIONS[d];
        normalized(add(scale(self.up, u), scale(self.left, l))).unwrap_or(self.up)
    }

    /// The smallest offset `s` along `n` for which the cloth of steps `a..=b`, translated by
    /// `s·n`, keeps `δ + clearance` from the safety obstacles, with the grippers on the free side
    /// of every collider plane; `None` within [`Geometry::reach`].
    fn clear_offset(
        &self,
        base: &Paths,
        states: &[Tensor],
        a: usize,
        b: usize,
        n: [f64; 3],
    ) -> Option<f64> {
        let limit = self.delta + self.clearance;
        let planes = &self.model.colliders.planes;
        let mut s = self.increment;
        while s <= self.reach {
            let shift = scale(n, s);
            let grippers_free = (a..=b).all(|t| {
                base[t].iter().all(|&g| {
                    let p = add(g, shift);
                    let v = nalgebra::Vector3::new(p[0], p[1], p[2]);
                    planes.iter().all(|pl| pl.distance(&v) >= 0.0)
                })
            });
            if grippers_free && (a..=b).all(|t| self.step_distance(states, t, shift) >= limit) {
                return Some(s);
            }
            s += self.increment;
        }
        None
    }

    /// The smallest signed distance to the safety obstacles of the cloth of step `t` translated
    /// by `shift` and, with [`Geometry::swept`], of its straight motion from step `t − 1`
    /// translated alike.
    fn step_distance(&self, states: &[Tensor], t: usize, shift: [f64; 3]) -> f64 {
        let safety = &self.avoid;
        let at = min_distance(safety, &states[t], shift);
        if !self.swept {
            return at;
        }
        let moved =
            |p: &[f64]| nalgebra::Vector3::new(p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]);
        states[t - 1]
            .data()
            .chunks_exact(3)
            .zip(states[t].data().chunks_exact(3))
            .map(|(a, b)| safety.min_along_segment(&moved(a), &moved(b)))
            .fold(at, f64::min)
    }

    /// `count` seeded perturbations of `base`: one via-point at a random interior step, offset
    /// perpendicular to the travel by up to the cloth's size.
    fn random_routes(&self, base: &Paths, count: usize, seed: u64) -> Vec<Candidate> {
        let horizon = self.model.task.horizon;
        let mut rng = XorShiftRng::seed_from_u64(seed);
        (0..count)
            .map(|i| {
                let t = if horizon > 1 {
                    rng.random_range(1..horizon)
                } else {
                    1
                };
                let angle = rng.random_range(0.0..std::f64::consts::TAU);
                let r = rng.random_range(0.0..=1.0) * self.size;
                let n = add(scale(self.up, angle.sin()), scale(self.left, angle.cos()));
                let offset = scale(n, r);
                Candidate {
                    route: format!("random {i}: via-point at step {t}, offset {r:.2}"),
                    controls: controls_of(&offset_paths(base, &[(t, t, offset)])),
                }
            })
            .collect()
    }
}

/// `base` with each `(a, b, o)` offset `o` applied over steps `a..=b`, ramping linearly between
/// keypoints: 0 at step 0, the segments' offsets, and 0 at step `T` — a route always ends where
/// its base path ends (a segment reaching `T` holds its offset until `T − 1`).
fn offset_paths(base: &Paths, segments: &[(usize, usize, [f64; 3])]) -> Paths {
    let horizon = base.len() - 1;
    let last = horizon.saturating_sub(1).max(1);
    let mut keys: Vec<(usize, [f64; 3])> = vec![(0, [0.0; 3])];
    for &(a, b, o) in segments {
        let a = a.clamp(1, last);
        keys.push((a, o));
        keys.push((b.clamp(a, last), o));
    }
    keys.push((horizon, [0.0; 3]));
    let offset_at = |t: usize| -> [f64; 3] {
        for w in keys.windows(2) {
            let ((t0, o0), (t1, o1)) = (w[0], w[1]);
            if t >= t0 && t <= t1 {
                if t1 == t0 {
                    return o1;
                }
                let f = (t - t0) as f64 / (t1 - t0) as f64;
                return add(scale(o0, 1.0 - f), scale(o1, f));
            }
        }
        [0.0; 3]
    };
    base.iter()
        .enumerate()
        .map(|(t, row)| {
            let o = offset_at(t);
            row.iter().map(|&p| add(p, o)).collect()
        })
        .collect()
}

/// True when two gripper paths agree to 1e-9 of their largest coordinate.
fn same_paths(a: &Paths, b: &Paths) -> bool {
    let points = || a.iter().chain(b).flatten().flatten();
    let scale = points().fold(0.0, |m: f64, v| m.max(v.abs()));
    a.len() == b.len()
        && a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(p, q)| p.iter().zip(q).all(|(x, y)| (x - y).abs() <= 1e-9 * scale))
}

/// Maximal runs of consecutive step numbers, as `(first, last)`.
fn runs(steps: &[usize]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &t in steps {
        match out.last_mut() {
            Some((_, last)) if *last + 1 == t => *last = t,
            _ => out.push((t, t)),
        }
    }
    out
}

/// The smallest signed distance of the particles of `x`, translated by `shift`, to `sdf`.
fn min_distance(sdf: &cloth::sdf::Union, x: &Tensor, shift: [f64; 3]) -> f64 {
    x.data()
        .chunks_exact(3)
        .map(|p| {
            sdf.distance(&nalgebra::Vector3::new(
                p[0] + shift[0],
                p[1] + shift[1],
                p[2] + shift[2],
            ))
        })
        .fold(f64::INFINITY, f64::min)
}

/// Gripper positions along `controls` (rest positions plus the running sum of displacements).
pub fn paths_of(model: &Model, controls: &Controls) -> Paths {
    let per_gripper: Vec<Vec<[f64; 3]>> = gripper_starts(model)
        .into_iter()
        .enumerate()
        .map(|(k, start)| controls.gripper_path(k, start))
        .collect();
    (0..=controls.n_steps())
        .map(|t| per_gripper.iter().map(|path| path[t]).collect())
        .collect()
}

/// Controls (per-step displacements) of gripper paths.
fn controls_of(paths: &Paths) -> Controls {
    let steps: Vec<Vec<[f64; 3]>> = paths
        .windows(2)
        .map(|w| w[1].iter().zip(&w[0]).map(|(&b, &a)| sub(b, a)).collect())
        .collect();
    cloth::controls_from_steps(&steps)
        .unwrap_or_else(|| Tensor::zeros(0, 3 * paths.first().map_or(0, Vec::len)))
}

fn gripper_starts(model: &Model) -> Vec<[f64; 3]> {
    model
        .controls
        .as_slice()
        .iter()
        .map(|&p| std::array::from_fn(|j| model.start.get(p, j)))
        .collect()
}

/// Mean over targets of (target position − the particle's rest position).
fn mean_target_displacement(model: &Model) -> [f64; 3] {
    let targets = model.task.targets.as_slice();
    let n = targets.len().max(1) as f64;
    let mut d = [0.0; 3];
    for (i, &p) in targets.iter().enumerate() {
        for (j, dj) in d.iter_mut().enumerate() {
            *dj += (model.task.target_positions.get(i, j) - model.start.get(p, j)) / n;
        }
    }
    d
}

/// Largest side of the axis-aligned box around `x`'s points.
fn extent(x: &Tensor) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in x.data().chunks_exact(3) {
        for j in 0..3 {
            lo[j] = lo[j].min(p[j]);
            hi[j] = hi[j].max(p[j]);
        }
    }
    (0..3).map(|j| hi[j] - lo[j]).fold(0.0, f64::max)
}

/// Largest side of the box around the spheres, capsules and boxes of `obstacles` (planes are
/// unbounded and meshes are left out: they add nothing).
fn obstacle_extent(obstacles: &Union) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut cover = |c: [f64; 3], r: [f64; 3]| {
        for j in 0..3 {
            lo[j] = lo[j].min(c[j] - r[j]);
            hi[j] = hi[j].max(c[j] + r[j]);
        }
    };
    for set in &obstacles.spheres {
        for (&c, &r) in set.centers.iter().zip(&set.radii) {
            cover(c, [r; 3]);
        }
    }
    for c in &obstacles.capsules {
        cover(c.a, [c.radius; 3]);
        cover(c.b, [c.radius; 3]);
    }
    for b in &obstacles.boxes {
        // The box's bounding sphere's box: rotation-free and never too small.
        let r = dot(b.half_extents, b.half_extents).sqrt();
        cover(b.center, [r; 3]);
    }
    (0..3).map(|j| hi[j] - lo[j]).fold(0.0, f64::max)
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a/|a|`, or `None` for a (nearly) zero vector.
fn normalized(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n > 1e-12).then(|| scale(a, 1.0 / n))
}

/// A unit vector perpendicular to the unit vector `a`.
fn any_perpendicular(a: [f64; 3]) -> [f64; 3] {
    let axis = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    normalized(cross(a, axis)).unwrap_or([0.0, 0.0, 1.0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_split_at_gaps() {
        assert_eq!(runs(&[1, 2, 3, 6, 7, 9]), vec![(1, 3), (6, 7), (9, 9)]);
        assert!(runs(&[]).is_empty());
    }

    #[test]
    fn offsets_ramp_between_keypoints_and_return_to_the_base_at_the_end() {
        let base: Paths = (0..=4).map(|t| vec![[t as f64, 0.0, 0.0]]).collect();
        let out = offset_paths(&base, &[(2, 2, [0.0, 0.0, 1.0])]);
        let z: Vec<f64> = out.iter().map(|r| r[0][2]).collect();
        assert_eq!(z, vec![0.0, 0.5, 1.0, 0.5, 0.0]);
        // A segment that reaches the last step holds its offset until T − 1 and ends on the base.
        let out = offset_paths(&base, &[(3, 4, [0.0, 2.0, 0.0])]);
        assert_eq!(out[3][0][1], 2.0);
        assert_eq!(out[4][0], base[4][0]);
    }

    #[test]
    fn controls_and_paths_are_inverse() {
        let paths: Paths = vec![
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
            vec![[0.5, 1.0, 0.0], [1.5, 1.0, 0.0]],
            vec![[0.5, 2.0, 3.0], [1.0, 2.0, 0.0]],
        ];
        let u = controls_of(&paths);
        assert_eq!(u.shape(), (2, 6));
        assert_eq!(u.row(1), &[0.0, 1.0, 3.0, -0.5, 1.0, 0.0]);
    }

    #[test]
    fn directions_are_perpendicular_to_the_travel() {
        let up = normalized([0.3, 0.0, 1.0]).unwrap();
        let travel = [1.0, 0.0, 0.0];
        let up = normalized(sub(up, scale(travel, dot(up, travel)))).unwrap();
        let left = cross(up, travel);
        assert!(dot(left, travel).abs() < 1e-15 && dot(left, up).abs() < 1e-15);
        assert!((dot(left, left) - 1.0).abs() < 1e-15);
    }
}
