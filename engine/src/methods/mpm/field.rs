//! One grain's nodal field for a step (the multi-field method: every grain has its own nodes,
//! so two grains meet only through contact, Bardenhagen et al., Comput. Model. Eng. Sci. 2,
//! 509, 2001): the box of grid nodes its points reach, the nodal masses and velocities projected
//! from the points, and the grain's Newton system — residual and matrix — at the current
//! velocity iterate.
//!
//! Time integration is Moreau-Jean's θ-method (Jean, Comput. Methods Appl. Mech. Eng. 177,
//! 235, 1999), the one the sources' contact dynamics uses, on the nodal velocities `v` of the
//! step's end, `v0` those of its start:
//! `M (v − v0) = h [(1 − θ) f(0) + θ f(u)] + h M g + Hᵀ P`, with the nodal displacements
//! `u = h (θ v + (1 − θ) v0)`, `f` the internal forces, `P` the contact impulses. Newton on
//! `v` uses the matrix `M + (θh)² K`, `K = −∂f/∂u` (material and geometric stiffness from the
//! law's tangent). θ = ½ is the trapezoidal rule (no numerical damping: the vibrating bar
//! keeps its amplitude), θ = 1 backward Euler (damps the high frequencies contacts excite).
//! Being implicit, the step is not bound by the time a wave takes to cross a cell.
//!
//! Internal forces at the points' start-of-step positions (updated Lagrangian): with `F_n`
//! the point's deformation gradient at the step's start, `f_inc = I + Σ u_i ⊗ ∇N_i`,
//! `F = f_inc F_n`, `P` the first Piola-Kirchhoff stress at `F` and `g_i = F_nᵀ ∇N_i`:
//! `f_i = −Σ_p V0_p P_p g_i`, `K_(ia)(jc) = Σ_p V0_p A_aBcE g_iB g_jE`.

use super::banded::Banded;
use super::ghost;
use super::grid::{Grid, Stencil, V2};
use super::points::Points;
use crate::constitutive::{ConstitutiveLaw, History, Mat2};
use crate::math::{positive_part, Real};
use crate::methods::soft::augment::{self, Closed};

/// Why a field could not be formed or assembled: the point (index in [`Points`]) and what
/// happened to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PointFailure {
    /// The point left the grid.
    LeftGrid(usize),
    /// The point's deformation has `det F <= 0` (or its law is undefined there).
    Inverted(usize, Real),
}

pub use crate::methods::soft::Scheme;

/// One grain's nodal field (module documentation).
#[derive(Debug, Default)]
pub struct Field {
    /// First node of the box along x and y.
    pub i0: usize,
    /// First node of the box along y.
    pub j0: usize,
    /// Nodes of the box along x.
    pub wx: usize,
    /// Nodes of the box along y.
    pub wy: usize,
    /// Nodes numbered x fastest (the box is narrower along x) or y fastest.
    x_fast: bool,
    /// Nodal masses, kg/m (zero at nodes of the box no point reaches).
    pub mass: Vec<Real>,
    /// Nodal velocities at the step's start, m/s.
    pub v0: Vec<V2>,
    /// Nodal velocities of the current iterate, m/s.
    pub v: Vec<V2>,
    /// Internal forces at the step's start, N/m.
    force0: Vec<V2>,
    /// Each point's stencil at its start-of-step position.
    pub stencils: Vec<Stencil>,
    /// Each point's deformation gradient and history at the current iterate.
    pub f_new: Vec<Mat2>,
    /// Each point's history at the current iterate.
    pub history_new: Vec<History>,
    /// Newton residual `G(v)` per node, N·s/m.
    pub residual: Vec<V2>,
    /// The Newton matrix `M + (θh)² K`, factorised after [`Field::assemble`].
    pub matrix: Banded,
    /// The Newton matrix's entries before factorisation.
    assembled: Vec<Real>,
    /// The Newton correction of the current iteration, two entries a node, m/s.
    pub correction: Vec<Real>,
    /// Each point's flow at the last iterate: plastic (its history moved) or elastic.
    plastic: Vec<bool>,
    /// Points whose flow changed, elastic to plastic or back, between the last two iterates
    /// (at the step's first iterate: the points that flow).
    pub switches: usize,
    /// Its current matrix is not Newton's own: the diagonal was scaled, or the points'
    /// tangents replaced by their positive parts, to make it definite ([`Field::assemble`]).
    /// While any grain's is, the iterations converge linearly at best.
    pub damped: bool,
    /// The penalty along the closed contacts that made the current matrix definite
    /// ([`augment`]), N·s/m per m/s; zero when it was definite as it is.
    pub penalty: Real,
    /// The node triples of the ghost penalty ([`ghost`]), found at the step's start.
    pub ghost: Vec<[usize; 3]>,
    /// The ghost penalty's stiffness, Pa (the system's fraction times the law's P-wave
    /// modulus).
    pub ghost_stiffness: Real,
    /// The mass-weighted root mean square of the grain's last Newton correction, m/s.
    pub last_correction: Real,
    /// The grain's whole Newton correction of the previous iteration of the step (two entries
    /// a node, m/s; empty at the step's first), to tell a correction that turns back on it:
    /// `correction` moves here when the next iteration begins.
    pub previous: Vec<Real>,
}

impl Field {
    /// Number of nodes of the box.
    pub fn nodes(&self) -> usize {
        self.wx * self.wy
    }

    /// Local index of grid node `(i, j)` (in the box).
    #[inline(always)]
    pub fn local(&self, i: usize, j: usize) -> usize {
        if self.x_fast {
            (j - self.j0) * self.wx + (i - self.i0)
        } else {
            (i - self.i0) * self.wy + (j - self.j0)
        }
    }

    /// Grid node `(i, j)` of local node `k`.
    pub fn grid_node(&self, k: usize) -> (usize, usize) {
        if self.x_fast {
            (self.i0 + k % self.wx, self.j0 + k / self.wx)
        } else {
            (self.i0 + k / self.wy, self.j0 + k % self.wy)
        }
    }

    /// The local indices of the 3x3 nodes of stencil `s`, `[a][b]` for node `base + (a, b)`.
    #[inline(always)]
    pub fn stencil_nodes(&self, s: &Stencil) -> [[usize; 3]; 3] {
        let mut k = [[0; 3]; 3];
        for (a, row) in k.iter_mut().enumerate() {
            for (b, x) in row.iter_mut().enumerate() {
                *x = self.local(s.base[0] + a, s.base[1] + b);
            }
        }
        k
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let v2 = std::mem::size_of::<V2>();
        self.mass.capacity() * 8
            + (self.v0.capacity() + self.v.capacity() + self.force0.capacity() + self.residual.capacity()) * v2
            + self.stencils.capacity() * std::mem::size_of::<Stencil>()
            + self.f_new.capacity() * std::mem::size_of::<Mat2>()
            + self.history_new.capacity() * std::mem::size_of::<History>()
            + self.matrix.heap_bytes()
            + self.assembled.capacity() * std::mem::size_of::<Real>()
            + (self.correction.capacity() + self.previous.capacity()) * std::mem::size_of::<Real>()
            + self.plastic.capacity()
            + self.ghost.capacity() * std::mem::size_of::<[usize; 3]>()
    }

    /// Forms the field of the points `range` for a new step: stencils, box, nodal masses,
    /// velocities (momentum over mass), the internal forces at the start, and the triples of
    /// the ghost penalty of stiffness `ghost` times the law's P-wave modulus ([`ghost`]; none
    /// at 0). From rest (`rest`: a quasi-static load step): `v0` is zero, the points'
    /// velocities only Newton's first guess.
    pub fn begin(
        &mut self,
        grid: &Grid,
        pts: &Points,
        range: std::ops::Range<usize>,
        law: &dyn ConstitutiveLaw,
        ghost: Real,
        rest: bool,
    ) -> Result<(), PointFailure> {
        self.stencils.clear();
        let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
        for p in range.clone() {
            let s = grid.stencil(&pts.x[p]).ok_or(PointFailure::LeftGrid(p))?;
            for a in 0..2 {
                lo[a] = lo[a].min(s.base[a]);
                hi[a] = hi[a].max(s.base[a] + 2);
            }
            self.stencils.push(s);
        }
        if self.stencils.is_empty() {
            (lo, hi) = ([0, 0], [0, 0]);
        }
        self.i0 = lo[0];
        self.j0 = lo[1];
        self.wx = hi[0] + 1 - lo[0];
        self.wy = hi[1] + 1 - lo[1];
        self.x_fast = self.wx <= self.wy;
        let n = self.nodes();
        self.mass.clear();
        self.mass.resize(n, 0.0);
        for buf in [&mut self.v0, &mut self.v, &mut self.force0, &mut self.residual] {
            buf.clear();
            buf.resize(n, V2::zeros());
        }
        self.f_new.clear();
        self.history_new.clear();
        self.plastic.clear();
        self.correction.clear();
        for (k, p) in range.enumerate() {
            let s = self.stencils[k];
            let nodes = self.stencil_nodes(&s);
            let (m, fp) = (pts.mass[p], &pts.f[p]);
            let (stress, _) = law.first_piola(fp, &pts.history[p]).ok_or(PointFailure::Inverted(p, fp.determinant()))?;
            let vp = stress * (fp.transpose() * pts.vol0[p]);
            for a in 0..3 {
                for b in 0..3 {
                    let (w, grad) = (s.weight(a, b), s.gradient(a, b));
                    let i = nodes[a][b];
                    self.mass[i] += w * m;
                    self.v0[i] += pts.v[p] * (w * m);
                    self.force0[i] -= vp * grad;
                }
            }
            self.f_new.push(*fp);
            self.history_new.push(pts.history[p]);
            self.plastic.push(false);
        }
        for (v, &m) in self.v0.iter_mut().zip(&self.mass) {
            if m > 0.0 {
                *v /= m;
            }
        }
        self.v.copy_from_slice(&self.v0);
        if rest {
            self.v0.iter_mut().for_each(|v| *v = V2::zeros());
        }
        let mut triples = std::mem::take(&mut self.ghost);
        triples.clear();
        if ghost > 0.0 {
            ghost::find(self, &mut triples);
        }
        self.ghost = triples;
        self.ghost_stiffness = ghost * law.moduli().p_wave();
        Ok(())
    }

    /// The nodal displacement of the step at the current iterate, `h (θ v + (1 − θ) v0)`, m.
    #[inline(always)]
    pub fn displacement(&self, i: usize, sc: &Scheme) -> V2 {
        (self.v[i] * sc.theta + self.v0[i] * (1.0 - sc.theta)) * sc.dt
    }

    /// Assembles the residual and the matrix of the points `range` at the current iterate `v`
    /// and factorises the matrix; each point's `F` and history at the iterate are kept in
    /// `f_new`, `history_new`.
    ///
    /// Under compression the geometric stiffness is negative, and at long steps it can outweigh
    /// the mass term along a few modes (the linearised rotation of a grain squeezed between
    /// walls stretches it at second order, which its stress then favours): the matrix is then
    /// not positive definite. It is then made definite along the grain's `closed` contacts
    /// ([`augment`]: Newton's own on the modes those contacts hold, [`Field::penalty`]). Where
    /// no penalty does, it is factorised again with its diagonal scaled by `1 + ε`,
    /// ε = 1e-3, 1e-2, 0.1 and 1 (Levenberg–Marquardt's scaled damping): Newton's fixed point
    /// does not depend on the matrix, only its rate of convergence does. A scaled diagonal
    /// keeps that rate near Newton's at the nodes the grain barely reaches (a shift by a
    /// multiple of the mean stiffness swamps their small masses: measured on a block squeezed
    /// between walls, 20 iterations without converging instead of 4). Returns `Err(None)` if
    /// even the largest damping leaves it indefinite. (In the dense part of a compaction about
    /// one grain assembly in five needs ε = 1e-3.)
    ///
    /// Where even ε = 1 leaves it indefinite, the matrix is assembled again with each point's
    /// tangent replaced by its positive part ([`crate::math::positive_part`]), which makes
    /// `K` positive semidefinite and the matrix definite: a perfectly plastic grain
    /// (hardening 0) under high pressure has no material stiffness along its flow direction,
    /// and there the negative geometric stiffness outweighs the mass of the nodes it barely
    /// reaches at any step (measured: the 300-grain compaction with `H = 0` stopped at Φ 0.887
    /// on a matrix indefinite at a sixteenth of the step; with the positive part it goes on to
    /// Φ 0.915, where Newton runs over its budget).
    pub fn assemble(
        &mut self,
        pts: &Points,
        range: std::ops::Range<usize>,
        law: &dyn ConstitutiveLaw,
        sc: &Scheme,
        (closed, closed_count): (&[Closed], usize),
    ) -> Result<(), Option<PointFailure>> {
        self.assemble_matrix(pts, range.clone(), law, sc, false)?;
        self.damped = false;
        self.penalty = 0.0;
        if self.matrix.factorise().is_ok()
            || self.factorise_penalised(&closed[..closed_count])
            || (closed_count < closed.len() && self.factorise_penalised(closed))
        {
            return Ok(());
        }
        self.damped = true;
        if self.factorise_damped() {
            return Ok(());
        }
        self.assemble_matrix(pts, range, law, sc, true)?;
        if self.matrix.factorise().is_ok() || self.factorise_damped() {
            return Ok(());
        }
        Err(None)
    }

    /// Factorises the assembled matrix with the penalty of the `closed` contacts
    /// ([`augment`]); whether one made it definite (its `ρ` then in [`Field::penalty`]).
    fn factorise_penalised(&mut self, closed: &[Closed]) -> bool {
        let matrix = &mut self.matrix;
        let first = augment::unknowns(closed).filter(|&d| d < matrix.len()).map(|d| matrix.get(d, d)).fold(0.0, Real::max);
        if first <= 0.0 {
            return false;
        }
        let assembled = &self.assembled;
        let found = augment::search(first, |rho| {
            matrix.restore(assembled);
            augment::penalty(
                closed,
                rho,
                |_| false,
                |r, c, v| {
                    if matrix.within(r, c) {
                        matrix.add_lower(r, c, v);
                    }
                },
            );
            matrix.factorise().is_ok()
        });
        self.penalty = found.unwrap_or(0.0);
        found.is_some()
    }

    /// Factorises the assembled matrix with its diagonal scaled by `1 + ε` for growing ε
    /// ([`Field::assemble`]); whether one of them is positive definite.
    fn factorise_damped(&mut self) -> bool {
        for damping in [1e-3, 1e-2, 1e-1, 1.0] {
            self.matrix.restore(&self.assembled);
            self.matrix.scale_diagonal(damping);
            if self.matrix.factorise().is_ok() {
                return true;
            }
        }
        false
    }

    /// The residual and the matrix of [`Field::assemble`], the matrix also kept unfactorised
    /// in `assembled` for the damped attempts; `positive`: each point's tangent replaced by
    /// its positive part. (The tests check the matrix against differences of the residual.)
    pub(super) fn assemble_matrix(
        &mut self,
        pts: &Points,
        range: std::ops::Range<usize>,
        law: &dyn ConstitutiveLaw,
        sc: &Scheme,
        positive: bool,
    ) -> Result<(), Option<PointFailure>> {
        let n = self.nodes();
        let fast = if self.x_fast { self.wx } else { self.wy };
        self.matrix.reset(2 * n, 4 * fast + 5);
        let hth = sc.dt * sc.theta;
        self.residual_start(sc);
        for i in 0..n {
            let m = self.mass[i];
            let d = if m > 0.0 { m } else { 1.0 };
            self.matrix.add_lower(2 * i, 2 * i, d);
            self.matrix.add_lower(2 * i + 1, 2 * i + 1, d);
        }
        let k2 = hth * hth;
        for (k, p) in range.enumerate() {
            let f = self.add_point(k, p, pts, law, sc)?;
            let mut tangent = law.tangent(&f, &pts.history[p]).ok_or(PointFailure::Inverted(p, f.determinant()))?;
            if positive {
                let a = positive_part(&nalgebra::Matrix4::from_fn(|i, j| tangent[i][j]));
                tangent = std::array::from_fn(|i| std::array::from_fn(|j| a[(i, j)]));
            }
            let s = self.stencils[k];
            let nodes = self.stencil_nodes(&s);
            let ft = pts.f[p].transpose();
            let mut g = [V2::zeros(); 9];
            let mut idx = [0usize; 9];
            for a in 0..3 {
                for b in 0..3 {
                    g[3 * a + b] = ft * s.gradient(a, b);
                    idx[3 * a + b] = nodes[a][b];
                }
            }
            let v0 = pts.vol0[p];
            // T[q][r][c][E] = Σ_B A[rB][cE] g_qB, then the block (q, q') is Σ_E T g_q'E.
            let mut t = [[[0.0; 4]; 2]; 9];
            for q in 0..9 {
                for r in 0..2 {
                    for ce in 0..4 {
                        t[q][r][ce] = tangent[2 * r][ce] * g[q].x + tangent[2 * r + 1][ce] * g[q].y;
                    }
                }
            }
            let w = k2 * v0;
            for q in 0..9 {
                for q2 in 0..9 {
                    let (i, j) = (idx[q], idx[q2]);
                    if j > i {
                        continue;
                    }
                    for r in 0..2 {
                        let di = 2 * i + r;
                        for c in 0..2 {
                            let dj = 2 * j + c;
                            if dj > di {
                                continue;
                            }
                            let kv = t[q][r][2 * c] * g[q2].x + t[q][r][2 * c + 1] * g[q2].y;
                            self.matrix.add_lower(di, dj, w * kv);
                        }
                    }
                }
            }
        }
        let matrix = &mut self.matrix;
        ghost::add_matrix(&self.ghost, self.ghost_stiffness, sc, |r, c, v| matrix.add_lower(r, c, v));
        self.matrix.save(&mut self.assembled);
        Ok(())
    }

    /// Assembles only the residual at the current iterate `v` (with `f_new`, `history_new`),
    /// keeping the matrix factorised at an earlier iterate of the step: a modified Newton
    /// iteration, whose fixed point is the same (module documentation of
    /// [`super::system`]).
    pub fn assemble_residual(
        &mut self,
        pts: &Points,
        range: std::ops::Range<usize>,
        law: &dyn ConstitutiveLaw,
        sc: &Scheme,
    ) -> Result<(), PointFailure> {
        self.residual_start(sc);
        for (k, p) in range.enumerate() {
            self.add_point(k, p, pts, law, sc)?;
        }
        Ok(())
    }

    /// The residual's nodal part: inertia, gravity and the start-of-step internal forces.
    fn residual_start(&mut self, sc: &Scheme) {
        for i in 0..self.nodes() {
            let m = self.mass[i];
            self.residual[i] = (self.v[i] - self.v0[i] - sc.gravity * sc.dt) * m - self.force0[i] * (sc.dt * (1.0 - sc.theta));
        }
        let (v, v0) = (&self.v, &self.v0);
        let displacement = |k: usize| (v[k] * sc.theta + v0[k] * (1.0 - sc.theta)) * sc.dt;
        ghost::add_residual(&self.ghost, self.ghost_stiffness, sc, displacement, &mut self.residual);
    }

    /// Point `p` (the `k`-th of the grain) at the current iterate: keeps its `F` and history
    /// in `f_new`, `history_new`, adds its internal force to the residual, and returns `F`.
    fn add_point(&mut self, k: usize, p: usize, pts: &Points, law: &dyn ConstitutiveLaw, sc: &Scheme) -> Result<Mat2, PointFailure> {
        let s = self.stencils[k];
        let nodes = self.stencil_nodes(&s);
        let fp = pts.f[p];
        let mut inc = Mat2::identity();
        for a in 0..3 {
            for b in 0..3 {
                inc += self.displacement(nodes[a][b], sc) * s.gradient(a, b).transpose();
            }
        }
        let f = inc * fp;
        let (stress, hist) = law.first_piola(&f, &pts.history[p]).ok_or(PointFailure::Inverted(p, f.determinant()))?;
        self.f_new[k] = f;
        self.history_new[k] = hist;
        let ps = stress * fp.transpose() * (sc.dt * sc.theta * pts.vol0[p]);
        for a in 0..3 {
            for b in 0..3 {
                self.residual[nodes[a][b]] += ps * s.gradient(a, b);
            }
        }
        Ok(f)
    }

    /// Counts the points `range` whose flow changed since the last iterate (into
    /// [`Field::switches`]): plastic where the iterate's history moved from the step's start.
    pub fn count_switches(&mut self, pts: &Points, range: std::ops::Range<usize>) {
        self.switches = 0;
        for (k, p) in range.enumerate() {
            let plastic = self.history_new[k].alpha > pts.history[p].alpha;
            if plastic != self.plastic[k] {
                self.plastic[k] = plastic;
                self.switches += 1;
            }
        }
    }

    /// Solves the factorised Newton matrix for `rhs` (two entries a node) in place.
    pub fn solve(&self, rhs: &mut [Real]) {
        self.matrix.solve(rhs);
    }
}
