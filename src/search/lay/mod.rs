//! Lay routes: a hanging cloth lifted over what is in its way and laid down onto its targets.
//!
//! A person who lays a hanging towel on a table lifts it until its lowest edge clears everything
//! on the way, carries it over, lets the free edge touch down first at the far side of where the
//! towel is to lie, and then draws the held edge back and down onto its place, so that the towel
//! unrolls flat instead of piling up. A *lay route* does that with the grippers' centroid, from
//! the scene's geometry and the rollout's physics only:
//!
//! * **hang** `h`: how far the cloth reaches below the grippers' centroid (along world up), the
//!   largest over the rollout of the initial guess (the cloth hanging from its grippers);
//! * **lay direction** `d`: the horizontal direction from the grippers' end centroid `c_e` to the
//!   mean of the targets of the particles not held (the *free* targets), and the **reach** `ℓ`,
//!   the farthest free target along `d`;
//! * **touch point** `c_e + ℓ d + (r + h) up`, `r` the free targets' mean height above `c_e`:
//!   where the centroid is when the free edge just touches down at the far side;
//! * **carry**: the centroid moves from its start to the touch point over a straight horizontal
//!   line, at the height of the *upper concave hull* (the taut string from above) of the start,
//!   the touch point and, at each point of the way, the *floor* the hanging cloth must stay above
//!   (the top of the obstacles below the grippers' span, plus a margin, in the caller's `floor`)
//!   raised by `h`: the shortest such path over the obstacles;
//! * **lay**: a straight line from the touch point to `c_e`, the held edge drawn back and down as
//!   the cloth unrolls from its free edge.
//!
//! Each gripper keeps its offset from the centroid, moving linearly from its start offset to its
//! end offset over the carry. Each part is cut into steps of equal largest gripper travel, the
//! steps shared between them so that the longest is shortest and the touch point is a step; a
//! route whose steps would exceed the scene's `task.limits.max_step` or leave its workspace is
//! not offered (it starts the planner far from feasible).
//!
//! * **lag**: a hanging cloth carried along trails behind its grippers (each step's solve moves
//!   it only part of the way to hanging straight), so its free edge reaches the touch step short
//!   of the far targets. [`lay_route`] measures that shortfall on the route's own rollout and
//!   moves the touch point forward by it (the `lead`), a few times, then probes either side.

use super::limits::{within_max_step, within_workspace};
use super::obstacles::in_the_way;
use autodiff::Tensor;
use cloth::sdf::{SignedDistance, Union};
use cloth::Model;
use nalgebra::Vector3;

type V = Vector3<f64>;

/// Gripper positions of a route: `paths[t][k]`, steps `0..=T`.
type Paths = Vec<Vec<[f64; 3]>>;

/// Points of the carry's horizontal travel at which the floor is measured (plus one).
const CARRY_SAMPLES: usize = 400;

/// Points per gap between neighbouring grippers at which the floor is measured (plus one).
const SPAN_SAMPLES: usize = 8;

/// Dense points of the whole route (plus one) before it is cut into steps.
const DENSE_SAMPLES: usize = 4000;

/// Most corrections of the touch point for the cloth's lag (one rollout each).
const LAG_CORRECTIONS: usize = 3;

/// A lag within this fraction of the task tolerance is left uncorrected.
const LAG_FRACTION: f64 = 0.25;

/// Leads tried beside the best corrected one, in task tolerances (one rollout each).
const LEAD_PROBES: [f64; 4] = [-1.0, -0.5, 0.5, 1.0];

/// What a lay route is built from (module docs). Heights are along `up`.
#[derive(Clone, Debug)]
pub struct LaySpec<'a> {
    /// Each gripper's start.
    pub starts: &'a [[f64; 3]],
    /// Each gripper's end (its particle's target, or the start moved with the targets).
    pub ends: &'a [[f64; 3]],
    /// Targets of the particles no gripper holds.
    pub free_targets: &'a [[f64; 3]],
    /// Unit vector against gravity.
    pub up: [f64; 3],
    /// How far the cloth reaches below the grippers' centroid.
    pub hang: f64,
    /// Number of steps `T`.
    pub horizon: usize,
    /// Largest gripper displacement per step, if the scene sets one.
    pub max_step: Option<f64>,
    /// How much farther along the lay direction than the farthest free target the touch point
    /// lies: the lag of the hanging cloth behind its grippers, measured on a rollout.
    pub lead: f64,
}

/// A lay route: the grippers' positions and the step at the touch point.
#[derive(Clone, Debug)]
pub struct Lay {
    /// `paths[t][k]`, steps `0..=T`.
    pub paths: Paths,
    /// The step at which the grippers' centroid is at the touch point.
    pub touch: usize,
}

/// The lay direction and reach of free targets `free` from the grippers' end centroid `ce`
/// (module docs): the unit horizontal direction to their mean, and the farthest along it.
/// `None` when their mean is not off `ce` horizontally.
pub fn lay_direction(ce: V, free: &[V], up: V) -> Option<(V, f64)> {
    if free.is_empty() {
        return None;
    }
    let mean = free.iter().sum::<V>() / free.len() as f64 - ce;
    let d = (mean - up * mean.dot(&up)).try_normalize(1e-9)?;
    let reach = free.iter().map(|p| (p - ce).dot(&d)).fold(0.0, f64::max);
    Some((d, reach))
}

/// The lay route of `spec` (module docs), from `starts` to `ends` exactly. `floor(q)` is the
/// height the cloth's lowest point must stay above at the horizontal position of `q` (`None`:
/// nothing there). `None` when there is no free target off the grippers' ends horizontally, no
/// travel, or a step would exceed `max_step`.
pub fn lay_paths(spec: &LaySpec<'_>, floor: impl Fn(V) -> Option<f64>) -> Option<Lay> {
    let k = spec.starts.len();
    if k == 0 || spec.ends.len() != k || spec.horizon < 2 || spec.free_targets.is_empty() {
        return None;
    }
    let up = V::from(spec.up).try_normalize(1e-12)?;
    let height = |p: &V| p.dot(&up);
    let flat = |p: V| p - up * p.dot(&up);
    let starts: Vec<V> = spec.starts.iter().map(|&p| V::from(p)).collect();
    let ends: Vec<V> = spec.ends.iter().map(|&p| V::from(p)).collect();
    let free: Vec<V> = spec.free_targets.iter().map(|&p| V::from(p)).collect();
    let mean = |ps: &[V]| ps.iter().sum::<V>() / ps.len() as f64;
    let (cs, ce) = (mean(&starts), mean(&ends));
    let (d, reach) = lay_direction(ce, &free, up)?;
    let rise = free.iter().map(|p| height(&(p - ce))).sum::<f64>() / free.len() as f64;
    let touch = ce + d * (reach + spec.lead).max(0.0) + up * (rise + spec.hang);
    // The carry: horizontal travel from the start to the touch point.
    let across = flat(touch - cs);
    let width = across.norm();
    let along = across.try_normalize(1e-12).unwrap_or_else(V::zeros);
    let offset = |g: usize, phi: f64| (starts[g] - cs) * (1.0 - phi) + (ends[g] - ce) * phi;
    let mut points = vec![(0.0, height(&cs))];
    for i in 0..=CARRY_SAMPLES {
        let phi = i as f64 / CARRY_SAMPLES as f64;
        let centre = cs + along * (width * phi);
        let grippers: Vec<V> = (0..k).map(|g| centre + offset(g, phi)).collect();
        let span = span_points(&grippers);
        if let Some(z) = span.into_iter().filter_map(&floor).reduce(f64::max) {
            points.push((width * phi, z + spec.hang));
        }
    }
    points.push((width, height(&touch)));
    let hull = upper_hull(&points);
    // The centroid's polyline with each vertex's phase of the offsets; the lay after it.
    let base = flat(cs);
    let carry: Vec<(V, f64)> = hull
        .iter()
        .map(|&(w, z)| {
            let phi = if width > 0.0 { w / width } else { 1.0 };
            (base + along * w + up * z, phi)
        })
        .collect();
    let place = |c: V, phi: f64| -> Vec<V> { (0..k).map(|g| c + offset(g, phi)).collect() };
    let carry = dense_route(&carry, place);
    let lay = dense_route(&[(touch, 1.0), (ce, 1.0)], place);
    // The steps shared between the parts, at least one each, so that the longest step is the
    // shortest it can be; the touch point is a step: the free edge lands there before the lay.
    let (a, b) = (travel(&carry), travel(&lay));
    if a + b < 1e-12 {
        return None;
    }
    let longest = |n: usize| (a / n as f64).max(b / (spec.horizon - n) as f64);
    let n = (1..spec.horizon)
        .min_by(|&x, &y| longest(x).total_cmp(&longest(y)))
        .unwrap_or(1);
    let mut paths = cut_into_steps(&carry, n);
    paths.pop();
    paths.extend(cut_into_steps(&lay, spec.horizon - n));
    paths[0] = spec.starts.to_vec();
    paths[spec.horizon] = spec.ends.to_vec();
    within_max_step(&paths, spec.max_step).then_some(Lay { paths, touch: n })
}

/// Points along the polyline through the grippers in order (each gap cut in [`SPAN_SAMPLES`]):
/// the span the cloth hangs from; the one gripper alone.
fn span_points(grippers: &[V]) -> Vec<V> {
    if grippers.len() == 1 {
        return grippers.to_vec();
    }
    grippers
        .windows(2)
        .flat_map(|w| {
            (0..=SPAN_SAMPLES).map(move |m| w[0] + (w[1] - w[0]) * (m as f64 / SPAN_SAMPLES as f64))
        })
        .collect()
}

/// The upper concave hull of `points` (sorted by their first coordinate), from the first point
/// to the last, both kept: the shortest path from the first to the last on or above every point.
fn upper_hull(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for &p in points {
        // Pop while the last vertex lies on or below the line from the one before it to `p`
        // (the first point is never popped, and every point is pushed).
        while hull.len() >= 2 {
            let (o, a) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            let cross = (a.0 - o.0) * (p.1 - o.1) - (a.1 - o.1) * (p.0 - o.0);
            // Above the same abscissa: only the higher point counts.
            let below = if p.0 > a.0 { cross >= 0.0 } else { p.1 >= a.1 };
            if below {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(p);
    }
    hull
}

/// The gripper positions at [`DENSE_SAMPLES`] + 1 points equally spaced along the centroid's
/// polyline `vertices` (each with its offsets' phase, interpolated linearly between vertices),
/// `grippers(c, phase)` placing them.
fn dense_route(vertices: &[(V, f64)], grippers: impl Fn(V, f64) -> Vec<V>) -> Vec<Vec<V>> {
    let lengths: Vec<f64> = vertices
        .windows(2)
        .map(|w| (w[1].0 - w[0].0).norm())
        .collect();
    let total: f64 = lengths.iter().sum();
    let mut out = Vec::with_capacity(DENSE_SAMPLES + 1);
    let (mut seg, mut before) = (0, 0.0);
    for i in 0..=DENSE_SAMPLES {
        let s = total * i as f64 / DENSE_SAMPLES as f64;
        while seg + 1 < lengths.len() && before + lengths[seg] < s {
            before += lengths[seg];
            seg += 1;
        }
        let f = if lengths.get(seg).copied().unwrap_or(0.0) > 0.0 {
            ((s - before) / lengths[seg]).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let (a, b) = (vertices[seg], vertices[(seg + 1).min(vertices.len() - 1)]);
        out.push(grippers(a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f));
    }
    out
}

/// The cumulative largest gripper travel along `dense`, point by point.
fn cumulative(dense: &[Vec<V>]) -> Vec<f64> {
    let mut cost = vec![0.0];
    for w in dense.windows(2) {
        let step = w[0]
            .iter()
            .zip(&w[1])
            .map(|(a, b)| (b - a).norm())
            .fold(0.0, f64::max);
        cost.push(cost.last().copied().unwrap_or(0.0) + step);
    }
    cost
}

/// The largest gripper travel along `dense` (the sum over its pieces).
fn travel(dense: &[Vec<V>]) -> f64 {
    cumulative(dense).last().copied().unwrap_or(0.0)
}

/// `dense` cut into `steps` steps of equal largest gripper travel (`steps + 1` points, from its
/// first point to its last).
fn cut_into_steps(dense: &[Vec<V>], steps: usize) -> Paths {
    let cost = cumulative(dense);
    let total = cost.last().copied().unwrap_or(0.0);
    let point = |p: V| [p.x, p.y, p.z];
    let mut j = 0;
    (0..=steps)
        .map(|t| {
            if t == steps || dense.len() < 2 {
                return dense[if t == 0 { 0 } else { dense.len() - 1 }]
                    .iter()
                    .map(|&p| point(p))
                    .collect();
            }
            let goal = total * t as f64 / steps as f64;
            while j + 2 < cost.len() && cost[j + 1] < goal {
                j += 1;
            }
            let gap = cost[j + 1] - cost[j];
            let f = if gap > 0.0 {
                (goal - cost[j]) / gap
            } else {
                0.0
            };
            dense[j]
                .iter()
                .zip(&dense[j + 1])
                .map(|(a, b)| point(a + (b - a) * f))
                .collect()
        })
        .collect()
}

/// The highest point at or below height `hi` (along the unit `up`) on the vertical line through
/// `q` where `sdf` is within `margin`, searched down to height `lo` by sphere tracing; `None`
/// when there is none above `lo`.
pub fn surface_top(sdf: &Union, q: V, up: V, margin: f64, (lo, hi): (f64, f64)) -> Option<f64> {
    let base = q - up * q.dot(&up);
    let gap = |z: f64| sdf.distance(&(base + up * z)) - margin;
    let (mut z, mut above) = (hi, None);
    for _ in 0..10_000 {
        let d = gap(z);
        if d <= 1e-4 {
            let Some(mut out) = above.filter(|_| d < -1e-4) else {
                return Some(z);
            };
            // Stepped inside (the least step is 1 mm): bisect back to the surface.
            let mut within = z;
            for _ in 0..40 {
                let mid = 0.5 * (within + out);
                if gap(mid) <= 0.0 {
                    within = mid;
                } else {
                    out = mid;
                }
            }
            return Some(out);
        }
        above = Some(z);
        z -= d.max(1e-3);
        if z < lo {
            return None;
        }
    }
    None
}

/// The lay route of `model`'s task (module docs) from the grippers' `starts` to their `ends`,
/// with the hang measured on `states` (the initial guess's rollout) and the lag on the route's
/// own rollouts (`rollout(paths)`: states `0..=T`). A hanging cloth carried along lags behind its
/// grippers, so its free edge is short of the far targets at the touch step: the touch point
/// moves farther by that shortfall (of the *leading* free particles, whose targets lie within
/// the tolerance of the farthest along the lay direction) and the route is built again, up to
/// [`LAG_CORRECTIONS`] times or until the shortfall is within [`LAG_FRACTION`] of the tolerance;
/// then, unless the best so far lands every target within the tolerance, the leads
/// [`LEAD_PROBES`] tolerances beside it are tried (the landing switches between equilibria within
/// centimetres). Of these, the route whose rollout ends with the smallest largest target error is
/// returned.
/// `None` unless the targets lie flat (their heights within the task tolerance), some free
/// target lies on a collider, the cloth hangs more than the tolerance below its grippers, and the
/// route keeps the limits.
pub fn lay_route(
    model: &Model,
    (starts, ends): (&[[f64; 3]], &[[f64; 3]]),
    states: &[Tensor],
    rollout: impl Fn(&Paths) -> Option<Vec<Tensor>>,
) -> Option<Paths> {
    let tolerance = model.task.tolerance;
    let gravity = model.gravity_step.unwrap_or([0.0, 0.0, -1.0]);
    let up = (-V::from(gravity)).try_normalize(1e-12)?;
    let held = model.controls.as_slice();
    let targets: Vec<(usize, V)> = model
        .task
        .targets
        .as_slice()
        .iter()
        .enumerate()
        .map(|(i, &p)| (p, V::from_fn(|j, _| model.task.target_positions.get(i, j))))
        .collect();
    let heights = targets.iter().map(|(_, p)| p.dot(&up));
    let spread = heights.clone().fold(f64::MIN, f64::max) - heights.fold(f64::MAX, f64::min);
    let free: Vec<(usize, V)> = targets
        .iter()
        .filter(|(p, _)| !held.contains(p))
        .copied()
        .collect();
    let on_collider = free
        .iter()
        .any(|(_, q)| model.colliders.distance(q).abs() <= tolerance);
    let hang = hang(states, held, up);
    if targets.is_empty() || spread > tolerance || !on_collider || hang <= tolerance {
        return None;
    }
    let free_points: Vec<[f64; 3]> = free.iter().map(|(_, q)| [q.x, q.y, q.z]).collect();
    let spec = LaySpec {
        starts,
        ends,
        free_targets: &free_points,
        up: [up.x, up.y, up.z],
        hang,
        horizon: model.task.horizon,
        max_step: model.task.limits.max_step,
        lead: 0.0,
    };
    // What the hanging cloth stays above: the obstacles in the way by the margin δ + tolerance,
    // and every collider (the table it is laid on too) by nothing.
    let way = in_the_way(model);
    let margin = model.task.delta + tolerance;
    let all = starts.iter().chain(ends).map(|&p| V::from(p).dot(&up));
    let lowest = all.clone().fold(f64::MAX, f64::min);
    let range = (
        lowest - hang - margin - 1e-2,
        all.fold(f64::MIN, f64::max) + 2.0 * hang + margin,
    );
    let floor = |q: V| {
        let a = surface_top(&way, q, up, margin, range);
        let b = surface_top(&model.colliders, q, up, 0.0, range);
        a.into_iter().chain(b).reduce(f64::max)
    };
    let inside = |lay: &Lay| within_workspace(&lay.paths, model.task.limits.workspace.as_ref());
    // The lag: how far the leading free particles are short of their targets along the lay
    // direction at the touch step; the touch point moves by it, a few times, and the route whose
    // rollout ends nearest the targets (by its largest error) is kept.
    let ce = ends.iter().map(|&p| V::from(p)).sum::<V>() / ends.len() as f64;
    let (d, reach) = lay_direction(ce, &free.iter().map(|f| f.1).collect::<Vec<_>>(), up)?;
    let leading: Vec<&(usize, V)> = free
        .iter()
        .filter(|(_, q)| (q - ce).dot(&d) >= reach - tolerance)
        .collect();
    let at = |x: &Tensor, p: usize| V::from_fn(|j, _| x.get(p, j));
    // One route per lead: its paths, its rollout's largest target error (infinite when it cannot
    // be simulated) and the leading particles' shortfall at its touch step.
    let attempt = |lead: f64| -> Option<(Paths, f64, Option<f64>)> {
        let lay = lay_paths(
            &LaySpec {
                lead,
                ..spec.clone()
            },
            floor,
        )
        .filter(inside)?;
        let Some(states) = rollout(&lay.paths) else {
            return Some((lay.paths, f64::INFINITY, None));
        };
        let last = states.last()?;
        let error = targets
            .iter()
            .map(|&(p, q)| (at(last, p) - q).norm())
            .fold(0.0, f64::max);
        let x = states.get(lay.touch)?;
        let short = leading
            .iter()
            .map(|&&(p, q)| (q - at(x, p)).dot(&d))
            .sum::<f64>()
            / leading.len() as f64;
        Some((lay.paths, error, Some(short)))
    };
    // (error, lead, paths) of the best route so far.
    let mut best: Option<(f64, f64, Paths)> = None;
    let keep = |best: &mut Option<(f64, f64, Paths)>, lead: f64, paths: Paths, error: f64| {
        if best.as_ref().is_none_or(|b| error < b.0) {
            *best = Some((error, lead, paths));
        }
    };
    let mut lead = 0.0;
    for _ in 0..=LAG_CORRECTIONS {
        let Some((paths, error, short)) = attempt(lead) else {
            break;
        };
        keep(&mut best, lead, paths, error);
        match short {
            Some(short) if short.abs() > LAG_FRACTION * tolerance => lead += short,
            _ => break,
        }
    }
    // The landing switches between equilibria within centimetres of the touch point: unless the
    // best route already lands within the tolerance, probe either side of its lead.
    let centre = best.as_ref().filter(|b| b.0 > tolerance).map(|b| b.1);
    for offset in centre.map_or(&[][..], |_| &LEAD_PROBES[..]) {
        let lead = centre.unwrap_or(0.0) + offset * tolerance;
        if let Some((paths, error, _)) = attempt(lead) {
            keep(&mut best, lead, paths, error);
        }
    }
    best.map(|b| b.2)
}

/// The largest depth, along `up`, of any particle below the centroid of the `held` particles,
/// over `states`.
fn hang(states: &[Tensor], held: &[usize], up: V) -> f64 {
    let all: Vec<usize> = (0..states.first().map_or(0, Tensor::rows)).collect();
    depth_below(states, held, &all, up)
}

/// The largest depth, along `up`, of the `particles` below the centroid of the `held` ones,
/// over `states` (0 without held particles).
pub(super) fn depth_below(states: &[Tensor], held: &[usize], particles: &[usize], up: V) -> f64 {
    let point = |x: &Tensor, i: usize| V::from_fn(|j, _| x.get(i, j));
    states
        .iter()
        .filter(|_| !held.is_empty())
        .map(|x| {
            let c = held.iter().map(|&i| point(x, i)).sum::<V>() / held.len() as f64;
            particles
                .iter()
                .map(|&i| (c - point(x, i)).dot(&up))
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests;
