//! Rigid one-sided contact under Newton's method: an active-set projected Newton on the contact
//! rows, whose converged state is XPBD's rigid answer (compliance 0).
//!
//! A contact row is a rigid (compliance 0) inequality `C(pᵢ) ≥ 0` on one free particle — the
//! `collider` group, or a user constraint of that shape. Such a row has no finite energy, so it
//! is not a term of `Φ`: each step solves `min Φ(x)` subject to every contact row, whose KKT
//! conditions are XPBD's fixed point with compliance 0 (`M(x − x̃) = Σ ∇Cⱼ λⱼ`, `λ ≥ 0` on the
//! contact rows, `λ C = 0`).
//!
//! - *Feasibility by projection:* every trial state puts each penetrating particle back on the
//!   surface along `∇C` (`x ← x − C ∇C/|∇C|²`, exact for a Euclidean signed distance; repeated
//!   for a union), as XPBD's projection does.
//! - *Active set:* a particle on the surface (`C ≤ ε`, `ε` a few ulps of its coordinates) whose
//!   force `μ = ∇C·∇ᵢΦ/|∇C|²` pushes into the obstacle (`μ > 0`) is active; a particle the energy
//!   pulls away (`μ ≤ 0`) is free to leave.
//! - *Reduced Newton step:* with `P = I − n̂n̂ᵀ` on active particles (identity elsewhere), the
//!   step solves `K y = −P∇Φ`, `K = P (∇²Φ − Σ μ ∇²C) P + Σ m n̂n̂ᵀ`: Newton on the Lagrangian
//!   restricted to the contact surfaces' tangent planes, and the normal directions kept at the
//!   particle's mass so `K` is positive definite exactly when the reduced Hessian is. `K` has
//!   the pattern of `∇²Φ` (per-particle block transforms), so one symbolic analysis serves both.
//! - *Convergence:* the KKT residual `r = ∇Φ` with the normal component removed on active
//!   particles.
//!
//! The implicit gradient is that of the constrained minimizer: the active rows are equalities
//! there (strict complementarity), so the adjoint solve is `K y = P ā`, `z = P y`.

use super::assembly::Pattern;
use super::terms::ConstraintTerms;
use crate::model::Model;
use std::sync::Arc;

/// Projections per particle and trial state: one reaches an exact signed distance's surface;
/// a union of obstacles may need a few.
const MAX_PROJECTIONS: usize = 8;
/// A particle within this many ulps of its largest coordinate of a contact surface is on it.
const SURFACE_ULPS: f64 = 1024.0;

/// True for the constraint groups that are contact rows: rigid, one-sided, on one particle.
pub fn is_contact(terms: &dyn ConstraintTerms) -> bool {
    terms.compliance() == 0.0 && terms.inequality() && terms.arity() == 1
}

/// One contact row: its group and instance.
#[derive(Clone, Copy, Debug)]
struct Row {
    group: u32,
    instance: u32,
}

/// `C`, unit normal, `|∇C|` and `∇²C` of one contact row at a state.
struct RowGeometry {
    c: f64,
    normal: [f64; 3],
    grad_norm: f64,
    hessian: [f64; 9],
}

/// The contact rows of a model and their active set at the last state they saw.
#[derive(Clone)]
pub struct Contacts {
    groups: Vec<Arc<dyn ConstraintTerms>>,
    /// Per degree-of-freedom block (free particle): its contact row, if any.
    rows: Vec<Option<Row>>,
    /// Per degree-of-freedom block: the particle.
    particle: Vec<usize>,
    /// Per degree-of-freedom block: the particle's mass, the scale of the normal direction in `K`.
    mass: Vec<f64>,
    /// Per block: whether the particle is held on its contact surface.
    active: Vec<bool>,
    /// Per block: the active surface's unit normal.
    normal: Vec<[f64; 3]>,
    /// Per block: the contact force multiplier `μ` times `∇²C` (row-major), for the Lagrangian.
    curvature: Vec<[f64; 9]>,
    n_active: usize,
}

impl Contacts {
    /// The contact rows of `model` over `pattern`'s degrees of freedom (rows on control
    /// particles are ignored: those particles are held). The caller has checked that no particle
    /// has two contact rows ([`super::check_supported`]).
    pub fn new(model: &Model, pattern: &Pattern) -> Contacts {
        let n_blocks = pattern.n_dof / 3;
        let mut rows = vec![None; n_blocks];
        let mut particle = vec![0; n_blocks];
        let mut mass = vec![0.0; n_blocks];
        for (p, &w) in model.inv_mass.iter().enumerate() {
            if let Some(d) = pattern.dof(p) {
                particle[d / 3] = p;
                mass[d / 3] = 1.0 / w;
            }
        }
        let groups: Vec<Arc<dyn ConstraintTerms>> = model
            .groups
            .iter()
            .map(|g| g.terms.clone())
            .filter(|t| is_contact(t.as_ref()))
            .collect();
        for (gi, terms) in groups.iter().enumerate() {
            for k in 0..terms.count() {
                if let Some(d) = pattern.dof(terms.particles(k)[0]) {
                    rows[d / 3] = Some(Row {
                        group: gi as u32,
                        instance: k as u32,
                    });
                }
            }
        }
        Contacts {
            groups,
            active: vec![false; n_blocks],
            normal: vec![[0.0; 3]; n_blocks],
            curvature: vec![[0.0; 9]; n_blocks],
            rows,
            particle,
            mass,
            n_active: 0,
        }
    }

    /// True when the model has contact rows.
    pub fn any(&self) -> bool {
        !self.groups.is_empty()
    }

    /// Number of particles held on a contact surface at the last [`Contacts::activate`].
    #[cfg(any(test, feature = "internals"))]
    pub fn n_active(&self) -> usize {
        self.n_active
    }

    /// Per free particle (degree-of-freedom block): whether it is held on its contact surface at
    /// the last [`Contacts::activate`].
    pub fn active_set(&self) -> &[bool] {
        &self.active
    }

    /// The geometry of block `b`'s row at the full state `x`.
    fn geometry(&self, b: usize, row: Row, x: &[f64]) -> RowGeometry {
        let terms = self.groups[row.group as usize].as_ref();
        let p = self.particle[b];
        let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
        let c = terms.second_order(row.instance as usize, &x[3 * p..3 * p + 3], &mut g, &mut h);
        let grad_norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        let normal = if grad_norm > 0.0 {
            g.map(|v| v / grad_norm)
        } else {
            [0.0; 3]
        };
        RowGeometry {
            c,
            normal,
            grad_norm,
            hessian: h,
        }
    }

    /// Moves every penetrating particle of the full state `x` back onto its contact surface
    /// along `∇C` (a particle where `∇C = 0`, the centre of a sphere, cannot be moved and stays).
    pub fn project(&self, x: &mut [f64]) {
        for (b, row) in self.rows.iter().enumerate() {
            let Some(row) = *row else { continue };
            let terms = self.groups[row.group as usize].as_ref();
            let p = self.particle[b];
            for _ in 0..MAX_PROJECTIONS {
                let xp = &mut x[3 * p..3 * p + 3];
                let c = terms.value(row.instance as usize, xp);
                if c >= 0.0 {
                    break;
                }
                let geo = self.geometry(b, row, x);
                if geo.grad_norm == 0.0 {
                    break;
                }
                let s = geo.c / geo.grad_norm;
                for k in 0..3 {
                    x[3 * p + k] -= s * geo.normal[k];
                }
            }
        }
    }

    /// The active set at the full state `x` with `∇Φ(x)` in `grad` (degree-of-freedom order):
    /// particles on their surface pushed into it.
    pub fn activate(&mut self, x: &[f64], grad: &[f64]) {
        self.n_active = 0;
        for b in 0..self.rows.len() {
            self.active[b] = false;
            let Some(row) = self.rows[b] else { continue };
            let geo = self.geometry(b, row, x);
            let p = self.particle[b];
            let scale = x[3 * p..3 * p + 3]
                .iter()
                .fold(1.0f64, |m, v| m.max(v.abs()));
            if geo.grad_norm == 0.0 || geo.c > SURFACE_ULPS * f64::EPSILON * scale {
                continue;
            }
            let g = &grad[3 * b..3 * b + 3];
            let force = (0..3).map(|k| geo.normal[k] * g[k]).sum::<f64>();
            if force <= 0.0 {
                continue;
            }
            // μ = ∇C·∇ᵢΦ / |∇C|², the multiplier of the Lagrangian Φ − Σ μ C.
            let mu = force / geo.grad_norm;
            self.active[b] = true;
            self.normal[b] = geo.normal;
            self.curvature[b] = geo.hessian.map(|h| mu * h);
            self.n_active += 1;
        }
    }

    /// Removes the normal component on active particles of `v` (degree-of-freedom order): `P v`.
    pub fn project_tangent(&self, v: &mut [f64]) {
        if self.n_active == 0 {
            return;
        }
        for (b, vb) in v.chunks_exact_mut(3).enumerate() {
            if self.active[b] {
                let n = &self.normal[b];
                let d = n[0] * vb[0] + n[1] * vb[1] + n[2] * vb[2];
                for k in 0..3 {
                    vb[k] -= d * n[k];
                }
            }
        }
    }

    /// The KKT residual norm `‖P ∇Φ‖` for `∇Φ` in `grad` at the last [`Contacts::activate`].
    pub fn residual_norm(&self, grad: &[f64]) -> f64 {
        let mut sum = 0.0;
        for (b, g) in grad.chunks_exact(3).enumerate() {
            if self.active[b] {
                let n = &self.normal[b];
                let d = n[0] * g[0] + n[1] * g[1] + n[2] * g[2];
                sum += (0..3).map(|k| (g[k] - d * n[k]).powi(2)).sum::<f64>();
            } else {
                sum += g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
            }
        }
        sum.sqrt()
    }

    /// Turns the Hessian of `Φ` in `values` (`pattern`'s lower triangle) into
    /// `K = P (H − Σ μ ∇²C) P + Σ m n̂n̂ᵀ` for the current active set; without `curvature` the
    /// `μ ∇²C` terms are left out (the positive definite fallback, with a projected `H`).
    pub fn reduce(&self, pattern: &Pattern, values: &mut [f64], curvature: bool) {
        if self.n_active == 0 {
            return;
        }
        for (a, b, idx) in pattern.blocks() {
            let (pa, pb) = (self.active[a], self.active[b]);
            if !pa && !pb {
                continue;
            }
            let mut m = [0.0; 9];
            for (mv, &i) in m.iter_mut().zip(idx) {
                *mv = values[i as usize];
            }
            if a == b && curvature {
                for (mv, h) in m.iter_mut().zip(&self.curvature[a]) {
                    *mv -= h;
                }
            }
            if pa {
                // m ← (I − n nᵀ) m.
                let n = &self.normal[a];
                for j in 0..3 {
                    let d = n[0] * m[j] + n[1] * m[3 + j] + n[2] * m[6 + j];
                    for i in 0..3 {
                        m[3 * i + j] -= n[i] * d;
                    }
                }
            }
            if pb {
                // m ← m (I − n nᵀ).
                let n = &self.normal[b];
                for i in 0..3 {
                    let d = m[3 * i] * n[0] + m[3 * i + 1] * n[1] + m[3 * i + 2] * n[2];
                    for j in 0..3 {
                        m[3 * i + j] -= d * n[j];
                    }
                }
            }
            if a == b {
                let (n, s) = (&self.normal[a], self.mass[a]);
                for i in 0..3 {
                    for j in 0..3 {
                        m[3 * i + j] += s * n[i] * n[j];
                    }
                }
            }
            for (k, (&i, &mv)) in idx.iter().zip(&m).enumerate() {
                // A diagonal block stores its lower triangle only.
                if a != b || k / 3 >= k % 3 {
                    values[i as usize] = mv;
                }
            }
        }
    }
}
