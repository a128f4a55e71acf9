//! One finite-element grain (or block): its mesh, lumped masses, nodal displacements and
//! velocities, the state of its elements, and its Newton system for a step.
//!
//! Time integration is the θ-method of contact dynamics on the nodal velocities, as for the
//! material point method ([`crate::methods::mpm::field`]): with `v0` the velocities at the
//! step's start and `v` at its end, the displacement over the step is
//! `Δu = h (θ v + (1 − θ) v0)` and the residual
//! `G(v) = M (v − v0) + h [(1 − θ) f(u) + θ f(u + Δu)] − h M g − Hᵀ P`,
//! `f` the internal forces ([`super::element`]), `P` the contact impulses. Newton on `v` uses
//! the matrix `M + (θh)² K`, `K = ∂f/∂u`, factorised by [`super::sparse`]. θ = ½ is the
//! trapezoidal rule (a linear grain keeps its energy), θ = 1 backward Euler.
//!
//! A prescribed velocity (a node held or driven) takes its value before the iterations; its row
//! and column of the matrix are the node's mass alone and its residual zero, so its correction
//! is zero.

use nalgebra::Vector2;

use super::element::{self, ElementFailure, Geometry, State};
use super::mesh::Mesh;
use super::sparse::{SparseError, SparseSpd};
use crate::constitutive::{ConstitutiveLaw, History, Mat2};
use crate::math::{positive_part, Real};
use crate::methods::soft::augment::{self, Closed};
use crate::methods::soft::Scheme;

type V2 = Vector2<Real>;

/// Why a body could not be built or stepped.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BodyFailure {
    /// An element of the mesh is degenerate or inverted at its reference positions.
    #[error("element {element} of the mesh is degenerate or inverted")]
    BadMesh {
        /// The element.
        element: usize,
    },
    /// An element is inverted at the iterate (`det F <= 0` at a Gauss point or its centre).
    #[error("element {element} is inverted (det F = {jacobian:.3e})")]
    Inverted {
        /// The element.
        element: usize,
        /// The smallest `det F` found.
        jacobian: Real,
    },
    /// The Newton matrix is not positive definite.
    #[error("the Newton matrix is not positive definite")]
    NotPositiveDefinite,
    /// Newton did not converge within its budget.
    #[error("Newton did not converge in {iterations} iterations (last correction {correction:.2e} relative)")]
    NewtonBudget {
        /// Iterations done.
        iterations: u32,
        /// The last correction, relative to its scale.
        correction: Real,
        /// The last matrix was made definite by positive parts ([`Body::damped`]).
        damped: bool,
    },
}

/// The nodal sums of the elements' internal forces `states` on `quads`, into `out` (N/m).
fn sum_forces(quads: &[[u32; 4]], states: &[State], nodes: usize, out: &mut Vec<V2>) {
    out.clear();
    out.resize(nodes, V2::zeros());
    for (q, s) in quads.iter().zip(states) {
        for a in 0..4 {
            out[q[a] as usize] += s.force[a];
        }
    }
}

/// Adds the correction `d` (two entries a node) to the nodal values `x`; returns the largest
/// nodal correction.
pub fn add_correction(x: &mut [V2], d: &[Real]) -> Real {
    let mut biggest: Real = 0.0;
    for (k, x) in x.iter_mut().enumerate() {
        let c = V2::new(d[2 * k], d[2 * k + 1]);
        *x += c;
        biggest = biggest.max(c.norm());
    }
    biggest
}

/// A meshed body (module documentation).
#[derive(Debug)]
pub struct Body {
    /// The mesh at the reference configuration.
    pub mesh: Mesh,
    /// Each element's reference geometry.
    pub geometry: Vec<Geometry>,
    /// The F-bar element (else the plain one).
    pub fbar: bool,
    /// Lumped nodal masses, kg/m.
    pub mass: Vec<Real>,
    /// Nodal displacements from the reference positions, m.
    pub u: Vec<V2>,
    /// Nodal velocities, m/s (during a step: the iterate).
    pub v: Vec<V2>,
    /// The elements' state at `u`.
    pub states: Vec<State>,
    /// Prescribed velocities of the step: `(unknown, value)`, the unknown `2 node + axis`, m/s.
    pub fixed: Vec<(usize, Real)>,
    /// Nodal velocities at the step's start, m/s.
    pub v0: Vec<V2>,
    /// Internal forces at the step's start, N/m.
    force0: Vec<V2>,
    /// The elements' state at the iterate.
    trial: Vec<State>,
    /// Newton residual at the iterate, two entries a node, N·s/m.
    pub residual: Vec<Real>,
    /// The Newton matrix (factorised after [`Body::iterate`] with `refresh`).
    pub matrix: SparseSpd,
    /// The factorised matrix is not Newton's own: the elements' stiffnesses were replaced by
    /// their positive parts to make it definite ([`Body::iterate`]); Newton then converges
    /// linearly at best.
    pub damped: bool,
    /// The penalty along the closed contacts that made the factorised matrix definite
    /// ([`augment`]), N·s/m per m/s; zero when the matrix was definite as it is.
    pub penalty: Real,
    /// The matrix's entries before a penalty was added ([`Body::iterate`]).
    saved: Vec<Real>,
    /// Where each element's 8×8 block goes in the matrix (`usize::MAX`: the upper triangle,
    /// added through its mirror).
    slots: Vec<[usize; 64]>,
    /// Scratch kept between iterations: the displacements at the iterate, the nodal forces.
    total: Vec<V2>,
    force: Vec<V2>,
}

impl Body {
    /// A body at rest of density `density` (kg/m³) on `mesh`.
    pub fn new(mesh: Mesh, density: Real, fbar: bool) -> Result<Self, BodyFailure> {
        let n = mesh.nodes.len();
        let mut geometry = Vec::with_capacity(mesh.quads.len());
        let mut mass = vec![0.0; n];
        for (e, q) in mesh.quads.iter().enumerate() {
            let x = q.map(|k| mesh.nodes[k as usize]);
            let geo = Geometry::new(&x).ok_or(BodyFailure::BadMesh { element: e })?;
            for a in 0..4 {
                mass[q[a] as usize] += density * geo.share[a];
            }
            geometry.push(geo);
        }
        let dof = |q: &[u32; 4], r: usize| 2 * q[r / 2] as usize + r % 2;
        let pairs = mesh.quads.iter().flat_map(|q| (0..64).map(move |rc| (dof(q, rc / 8), dof(q, rc % 8))));
        let matrix = SparseSpd::new(2 * n, pairs).map_err(|_| BodyFailure::BadMesh { element: 0 })?;
        let slots = mesh
            .quads
            .iter()
            .map(|q| {
                let mut s = [usize::MAX; 64];
                for (rc, slot) in s.iter_mut().enumerate() {
                    let (r, c) = (dof(q, rc / 8), dof(q, rc % 8));
                    if r >= c {
                        *slot = matrix.slot(r, c).unwrap_or(usize::MAX);
                    }
                }
                s
            })
            .collect();
        let rest = State { force: [V2::zeros(); 4], f: [Mat2::identity(); 4], history: [History::default(); 4] };
        let e = mesh.quads.len();
        Ok(Self {
            mesh,
            geometry,
            fbar,
            mass,
            u: vec![V2::zeros(); n],
            v: vec![V2::zeros(); n],
            states: vec![rest; e],
            fixed: Vec::new(),
            v0: vec![V2::zeros(); n],
            force0: vec![V2::zeros(); n],
            trial: vec![rest; e],
            residual: vec![0.0; 2 * n],
            matrix,
            damped: false,
            penalty: 0.0,
            saved: Vec::new(),
            slots,
            total: Vec::with_capacity(n),
            force: Vec::with_capacity(n),
        })
    }

    /// Nodes.
    pub fn nodes(&self) -> usize {
        self.mesh.nodes.len()
    }

    /// Current position of node `k`, m.
    pub fn position(&self, k: usize) -> V2 {
        self.mesh.nodes[k] + self.u[k]
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v2 = std::mem::size_of::<V2>();
        self.mesh.nodes.capacity() * v2
            + self.mesh.quads.capacity() * 16
            + self.mesh.boundary.capacity() * 4
            + self.geometry.capacity() * std::mem::size_of::<Geometry>()
            + (self.mass.capacity() + self.residual.capacity()) * 8
            + (self.u.capacity() + self.v.capacity() + self.v0.capacity() + self.force0.capacity()) * v2
            + (self.states.capacity() + self.trial.capacity()) * std::mem::size_of::<State>()
            + self.slots.capacity() * 64 * 8
            + (self.total.capacity() + self.force.capacity()) * v2
            + self.saved.capacity() * 8
            + self.matrix.heap_bytes()
    }

    /// Kinetic energy, J/m.
    pub fn kinetic_energy(&self) -> Real {
        self.mass.iter().zip(&self.v).map(|(m, v)| 0.5 * m * v.norm_squared()).sum()
    }

    /// Energy stored in the elements at `u`, J/m.
    pub fn strain_energy(&self, law: &dyn ConstitutiveLaw) -> Real {
        self.geometry.iter().zip(&self.states).map(|(g, s)| element::stored_energy(g, s, law)).sum()
    }

    /// Total internal force on each node at `u` (the sum of the elements'), N/m.
    pub fn internal_forces(&self) -> Vec<V2> {
        let mut f = Vec::new();
        sum_forces(&self.mesh.quads, &self.states, self.nodes(), &mut f);
        f
    }

    /// The displacements the current iterate reaches at the step's end, into `total`.
    fn fill_total(&mut self, sc: &Scheme) {
        let mut total = std::mem::take(&mut self.total);
        total.clear();
        total.extend((0..self.nodes()).map(|k| self.u[k] + self.increment(k, sc)));
        self.total = total;
    }

    /// The elements' states at the displacements `total` (from the accepted histories) into
    /// `trial`, and — when `stiffness` is given — their stiffness times it added to the
    /// matrix (each element's replaced by its positive part when `positive`).
    fn evaluate(&mut self, law: &dyn ConstitutiveLaw, total: &[V2], stiffness: Option<Real>, positive: bool) -> Result<(), BodyFailure> {
        for (e, q) in self.mesh.quads.iter().enumerate() {
            let u = q.map(|k| total[k as usize]);
            let geo = &self.geometry[e];
            let h = &self.states[e].history;
            let fail = |ElementFailure::Inverted { jacobian }| BodyFailure::Inverted { element: e, jacobian };
            self.trial[e] = element::state(geo, &u, h, law, self.fbar).map_err(fail)?;
            if let Some(scale) = stiffness {
                let mut k = element::stiffness(geo, &u, h, law, self.fbar).map_err(fail)?;
                if positive {
                    let p = positive_part(&nalgebra::SMatrix::<Real, 8, 8>::from_fn(|i, j| k[i][j]));
                    k = std::array::from_fn(|i| std::array::from_fn(|j| p[(i, j)]));
                }
                for (rc, &slot) in self.slots[e].iter().enumerate() {
                    if slot != usize::MAX {
                        self.matrix.add_at(slot, scale * k[rc / 8][rc % 8]);
                    }
                }
            }
        }
        Ok(())
    }

    /// Starts a step: the velocities and internal forces at its start; from rest (`rest`: a
    /// quasi-static load step, the last step's velocities kept only as Newton's first guess).
    pub fn begin(&mut self, rest: bool) {
        if rest {
            self.v0.iter_mut().for_each(|v| *v = V2::zeros());
        } else {
            self.v0.clone_from(&self.v);
        }
        sum_forces(&self.mesh.quads, &self.states, self.nodes(), &mut self.force0);
        for &(d, value) in &self.fixed {
            self.v[d / 2][d % 2] = value;
        }
    }

    /// The displacement over the step of node `k` at the current iterate, m.
    pub fn increment(&self, k: usize, sc: &Scheme) -> V2 {
        (self.v[k] * sc.theta + self.v0[k] * (1.0 - sc.theta)) * sc.dt
    }

    /// Evaluates the residual at the current iterate and — when `refresh` — assembles and
    /// factorises the matrix (module documentation).
    ///
    /// Under compression the elements' geometric stiffness is negative, and over a long step it
    /// can outweigh the mass along a few modes of a squeezed grain: the matrix is then not
    /// positive definite. It is then made definite along the grain's `closed` contacts
    /// ([`augment`]: Newton's own on the modes those contacts hold, [`Body::penalty`]); where
    /// no penalty does, it is assembled again with each element's stiffness replaced by its
    /// positive part ([`crate::math::positive_part`], [`Body::damped`]), which makes it
    /// definite but converges only linearly. Newton's fixed point does not depend on the
    /// matrix, only its rate.
    pub fn iterate(
        &mut self,
        law: &dyn ConstitutiveLaw,
        sc: &Scheme,
        refresh: bool,
        (closed, closed_count): (&[Closed], usize),
    ) -> Result<(), BodyFailure> {
        self.fill_total(sc);
        if !refresh {
            return self.assemble(law, sc, None);
        }
        self.assemble(law, sc, Some(false))?;
        self.damped = false;
        self.penalty = 0.0;
        match self.matrix.factorise() {
            Ok(()) => return Ok(()),
            Err(SparseError::NotPositiveDefinite) => {}
            Err(SparseError::Pattern(_)) => return Err(BodyFailure::NotPositiveDefinite),
        }
        if self.factorise_penalised(&closed[..closed_count]) || (closed_count < closed.len() && self.factorise_penalised(closed)) {
            return Ok(());
        }
        self.assemble(law, sc, Some(true))?;
        self.damped = true;
        self.matrix.factorise().map_err(|_| BodyFailure::NotPositiveDefinite)
    }

    /// Factorises the assembled matrix with the penalty of the `closed` contacts ([`augment`]);
    /// whether one made it definite (its `ρ` then in [`Body::penalty`]).
    fn factorise_penalised(&mut self, closed: &[Closed]) -> bool {
        let fixed = &self.fixed;
        let held = |d: usize| fixed.iter().any(|&(f, _)| f == d);
        let matrix = &mut self.matrix;
        let first = augment::unknowns(closed).filter(|&d| !held(d)).map(|d| matrix.get(d, d)).fold(0.0, Real::max);
        if first <= 0.0 {
            return false;
        }
        let saved = &mut self.saved;
        matrix.save(saved);
        let found = augment::search(first, |rho| {
            matrix.restore(saved);
            augment::penalty(closed, rho, held, |r, c, v| {
                if let Some(slot) = matrix.slot(r, c) {
                    matrix.add_at(slot, v);
                }
            });
            matrix.factorise().is_ok()
        });
        self.penalty = found.unwrap_or(0.0);
        found.is_some()
    }

    /// The residual at the displacements in `total` and — when `matrix` says whether with the
    /// elements' positive parts — the unfactorised matrix.
    fn assemble(&mut self, law: &dyn ConstitutiveLaw, sc: &Scheme, matrix: Option<bool>) -> Result<(), BodyFailure> {
        let refresh = matrix.is_some();
        if refresh {
            self.matrix.clear();
        }
        let c = sc.theta * sc.dt;
        let total = std::mem::take(&mut self.total);
        let evaluated = self.evaluate(law, &total, refresh.then_some(c * c), matrix.unwrap_or(false));
        self.total = total;
        evaluated?;
        sum_forces(&self.mesh.quads, &self.trial, self.nodes(), &mut self.force);
        let f = &self.force;
        for k in 0..self.nodes() {
            let m = self.mass[k];
            let g = (self.v[k] - self.v0[k]) * m + (self.force0[k] * (1.0 - sc.theta) + f[k] * sc.theta - sc.gravity * m) * sc.dt;
            self.residual[2 * k] = g.x;
            self.residual[2 * k + 1] = g.y;
            if refresh {
                for i in 0..2 {
                    if let Some(s) = self.matrix.slot(2 * k + i, 2 * k + i) {
                        self.matrix.add_at(s, m);
                    }
                }
            }
        }
        for &(d, _) in &self.fixed {
            self.residual[d] = 0.0;
            if refresh {
                self.matrix.isolate(d, self.mass[d / 2]);
            }
        }
        Ok(())
    }

    /// Evaluates the elements at the displacements the converged iterate reaches (nothing moves
    /// yet: [`Body::commit`] does).
    pub fn settle(&mut self, law: &dyn ConstitutiveLaw, sc: &Scheme) -> Result<(), BodyFailure> {
        self.fill_total(sc);
        let total = std::mem::take(&mut self.total);
        let evaluated = self.evaluate(law, &total, None, false);
        self.total = total;
        evaluated
    }

    /// Ends the step after [`Body::settle`]: the displacements move on and the elements' states
    /// are those at the new displacements.
    pub fn commit(&mut self, sc: &Scheme) {
        for k in 0..self.nodes() {
            let d = self.increment(k, sc);
            self.u[k] += d;
        }
        std::mem::swap(&mut self.states, &mut self.trial);
    }

    /// Puts the body where a saved state left it: nodal displacements `u` (m) and velocities
    /// `v` (m/s), one a node, and each element's Gauss points' histories (`history`, four an
    /// element in their order; `None`: at rest). The elements' states are evaluated again at
    /// `u` from those histories: a plastic point on its yield surface stays there, so the
    /// stresses are the saving run's to round-off.
    pub fn restore(&mut self, law: &dyn ConstitutiveLaw, u: &[V2], v: &[V2], history: Option<&[History]>) -> Result<(), BodyFailure> {
        self.u.copy_from_slice(u);
        self.v.copy_from_slice(v);
        if let Some(h) = history {
            for (s, h) in self.states.iter_mut().zip(h.chunks_exact(4)) {
                s.history.copy_from_slice(h);
            }
        }
        let total = self.u.clone();
        self.evaluate(law, &total, None, false)?;
        std::mem::swap(&mut self.states, &mut self.trial);
        Ok(())
    }

    /// A step of `sc.dt` without contact: Newton on the velocities to a correction below
    /// `tolerance` times the velocity scale (the largest nodal speed, at least `floor`), at most
    /// `max_newton` iterations; returns the iterations.
    pub fn step_free(
        &mut self,
        law: &dyn ConstitutiveLaw,
        sc: &Scheme,
        tolerance: Real,
        max_newton: u32,
        floor: Real,
    ) -> Result<u32, BodyFailure> {
        self.begin(false);
        let mut last = Real::INFINITY;
        for it in 1..=max_newton {
            self.iterate(law, sc, true, (&[], 0))?;
            let mut dv: Vec<Real> = self.residual.iter().map(|r| -r).collect();
            self.matrix.solve(&mut dv);
            let scale = self.v.iter().map(|v| v.norm()).fold(floor, Real::max);
            last = add_correction(&mut self.v, &dv) / scale;
            if last <= tolerance {
                self.settle(law, sc)?;
                self.commit(sc);
                return Ok(it);
            }
        }
        Err(BodyFailure::NewtonBudget { iterations: max_newton, correction: last, damped: self.damped })
    }

    /// Static equilibrium under the nodal loads `load` (N/m) with the displacements
    /// `prescribed` (`(unknown, value)`, m): Newton on `f(u) = load` to a correction below
    /// `tolerance` times the largest displacement; returns the iterations.
    pub fn solve_static(
        &mut self,
        law: &dyn ConstitutiveLaw,
        load: &[V2],
        prescribed: &[(usize, Real)],
        tolerance: Real,
        max_newton: u32,
    ) -> Result<u32, BodyFailure> {
        for &(d, value) in prescribed {
            self.u[d / 2][d % 2] = value;
        }
        let mut last = Real::INFINITY;
        for it in 1..=max_newton {
            self.matrix.clear();
            let total = self.u.clone();
            self.evaluate(law, &total, Some(1.0), false)?;
            sum_forces(&self.mesh.quads, &self.trial, self.nodes(), &mut self.force);
            let mut r: Vec<Real> = load.iter().zip(&self.force).flat_map(|(l, f)| [l.x - f.x, l.y - f.y]).collect();
            for &(d, _) in prescribed {
                r[d] = 0.0;
                self.matrix.isolate(d, 1.0);
            }
            self.matrix.factorise().map_err(|_| BodyFailure::NotPositiveDefinite)?;
            self.matrix.solve(&mut r);
            let scale = self.u.iter().map(|u| u.norm()).fold(Real::MIN_POSITIVE, Real::max);
            last = add_correction(&mut self.u, &r) / scale;
            if last <= tolerance {
                let total = self.u.clone();
                self.evaluate(law, &total, None, false)?;
                std::mem::swap(&mut self.states, &mut self.trial);
                return Ok(it);
            }
        }
        Err(BodyFailure::NewtonBudget { iterations: max_newton, correction: last, damped: false })
    }
}
