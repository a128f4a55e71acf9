//! The force stage of DEM: the pairs of the neighbour list in parallel, by blocks of particles
//! (each block owns the records of its interacting pairs, see [`super::pair_state`]), then the
//! gather: each task evaluates the wall contacts of its own range of particles
//! ([`super::wall_contacts`]), sums their forces over all pair records, in block order, and gives
//! them the second half kick. No atomics: the result does not depend on the number of threads.

use rayon::prelude::*;

use super::integrate::{half_kick, Kin};
use super::pair_state::{PairBlock, PairExtra, PairForce, PairSprings};
use super::tasks::{LOOP_CHUNK, PARTICLE_BLOCK};
use super::wall_contacts::{evaluate_block, Grains, Owned, WallScene};
use super::Dem;
use crate::contact::batch::{BatchInput, BatchOutput, BatchSprings, LANES};
use crate::contact::{ContactOutput, ContactTable};
use crate::geometry::near_pairs::NearPair;
use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// What a force task owns: its block's pairs, the springs of the evaluation before, its near
/// pairs and reach (see `Dem::reach`).
type BlockState<'a> = (((&'a mut PairBlock, &'a mut PairSprings), &'a mut Vec<NearPair>), &'a mut (u32, u32));

/// Gather tasks per thread when there are several threads (each walks only the blocks that
/// reach its particles, so more tasks cost little).
const GATHER_TASKS_PER_THREAD: usize = 4;

/// What the contact laws of a pair need from the simulation.
struct PairScene<'a> {
    p: &'a Particles,
    kin: &'a [Kin],
    domain: &'a Domain,
    table: &'a ContactTable,
    dt: f64,
    with_extra: bool,
}

/// The touching pairs of a block waiting for their contact laws, a batch at a time, field by
/// field: the scan of the near pairs (short, branchy) fills it, then the batch is evaluated in
/// loops over its pairs — gathering the particles' velocities, then the geometry and kinematics,
/// then the law ([`crate::contact::PairLaw::compute_batch`], which the compiler turns into vector instructions
/// over several contacts). Each pair: its index `q` in the neighbour list, i and the image of j
/// (`image_y`: its period along y, for the Lees-Edwards velocity), their separation
/// `d = r_i - r_j'`, radii, and the springs carried from its last evaluation.
struct Batch {
    q: [u32; LANES],
    i: [u32; LANES],
    j: [u32; LANES],
    image_y: [i8; LANES],
    d: [[Real; LANES]; 3],
    r_i: [Real; LANES],
    r_j: [Real; LANES],
    extra: [PairExtra; LANES],
    /// The particles' velocities, gathered: relative velocity at mid-step and predicted, the
    /// spins and predicted spins of i and j, the masses.
    kin: Gathered,
    input: BatchInput,
    springs: BatchSprings,
    out: BatchOutput,
    len: usize,
}

thread_local! {
    /// The batch of the force stage's blocks run on this thread.
    static BATCH: std::cell::RefCell<Box<Batch>> = std::cell::RefCell::new(Box::new(Batch::new()));
}

/// The particles' kinematics of a batch's pairs, gathered into arrays.
struct Gathered {
    v_rel: [[Real; LANES]; 3],
    vp_rel: [[Real; LANES]; 3],
    w_i: [[Real; LANES]; 3],
    w_j: [[Real; LANES]; 3],
    wp_i: [[Real; LANES]; 3],
    wp_j: [[Real; LANES]; 3],
    m_i: [Real; LANES],
    m_j: [Real; LANES],
}

impl Batch {
    fn new() -> Self {
        let (z, z3) = ([0.0; LANES], [[0.0; LANES]; 3]);
        Self {
            q: [0; LANES],
            i: [0; LANES],
            j: [0; LANES],
            image_y: [0; LANES],
            d: z3,
            r_i: z,
            r_j: z,
            extra: [PairExtra::default(); LANES],
            kin: Gathered { v_rel: z3, vp_rel: z3, w_i: z3, w_j: z3, wp_i: z3, wp_j: z3, m_i: z, m_j: z },
            input: BatchInput::default(),
            springs: BatchSprings::default(),
            out: BatchOutput::default(),
            len: 0,
        }
    }

    /// Queues the pair `q` of i and the image `image` of j; evaluates the batch into `out` when
    /// it is full.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn push(
        &mut self,
        s: &PairScene<'_>,
        out: &mut PairBlock,
        (q, i, j, image): (u32, u32, u32, [i8; 3]),
        d: Vec3,
        radii: (Real, Real),
        xi: Vec3,
        extra: PairExtra,
    ) {
        let k = self.len;
        self.q[k] = q;
        self.i[k] = i;
        self.j[k] = j;
        self.image_y[k] = image[1];
        for a in 0..3 {
            self.d[a][k] = d[a];
            self.springs.xi[a][k] = xi[a];
        }
        (self.r_i[k], self.r_j[k]) = radii;
        if s.with_extra {
            self.extra[k] = extra;
        }
        self.len = k + 1;
        if self.len == LANES {
            self.flush(s, out);
        }
    }

    /// Evaluates the queued pairs, in order, into the block's lists.
    #[inline(never)]
    fn flush(&mut self, s: &PairScene<'_>, out: &mut PairBlock) {
        let n = self.len;
        if n == 0 {
            return;
        }
        let g = &mut self.kin;
        let p = s.p;
        for k in 0..n {
            let (i, j) = (self.i[k] as usize, self.j[k] as usize);
            let (a, b) = (&s.kin[i], &s.kin[j]);
            let (vi, vj, wi, wj) = (&p.vel[i], &p.vel[j], &p.omega[i], &p.omega[j]);
            let image = s.domain.image_velocity(self.image_y[k]);
            for c in 0..3 {
                g.v_rel[c][k] = vi[c] - vj[c];
                g.vp_rel[c][k] = a.vp[c] - b.vp[c];
                (g.w_i[c][k], g.w_j[c][k], g.wp_i[c][k], g.wp_j[c][k]) = (wi[c], wj[c], a.wp[c], b.wp[c]);
            }
            g.v_rel[0][k] -= image;
            g.vp_rel[0][k] -= image;
            (g.m_i[k], g.m_j[k]) = (p.mass[i], p.mass[j]);
        }
        contact_inputs(&self.d, (&self.r_i, &self.r_j), g, &mut self.input, n);
        // One law for the whole batch (a scene of one material): evaluated at once; otherwise,
        // or with rolling or bridges, pair by pair.
        let material = |k: usize| (s.p.material[self.i[k] as usize], s.p.material[self.j[k] as usize]);
        let first = material(0);
        let law = s.table.get(first.0 as usize, first.1 as usize);
        if !s.with_extra && law.batchable() && (1..n).all(|k| material(k) == first) {
            law.compute_batch(&self.input, &mut self.springs, &mut self.out, s.dt);
        } else {
            for k in 0..n {
                let (i, j) = (self.i[k] as usize, self.j[k] as usize);
                let input = self.input.contact(k, &g.w_i, &g.w_j, (self.r_i[k], self.r_j[k]));
                let law = s.table.get(s.p.material[i] as usize, s.p.material[j] as usize);
                let mut xi = Vec3::new(self.springs.xi[0][k], self.springs.xi[1][k], self.springs.xi[2][k]);
                let force = if s.with_extra {
                    let both_wet = s.p.wet[i] && s.p.wet[j];
                    let extra = &mut self.extra[k];
                    law.compute(&input, &mut xi, Some(&mut extra.roll), both_wet.then_some(&mut extra.bridge), s.dt)
                } else {
                    law.compute(&input, &mut xi, None, None, s.dt)
                };
                for c in 0..3 {
                    self.springs.xi[c][k] = xi[c];
                    (self.out.force[c][k], self.out.torque_i[c][k], self.out.torque_j[c][k]) =
                        (force.force[c], force.torque_i[c], force.torque_j[c]);
                }
            }
        }
        out.state.q.extend_from_slice(&self.q[..n]);
        if s.with_extra {
            out.state.extras.extend_from_slice(&self.extra[..n]);
        }
        for (c, f) in out.state.xi.iter_mut().zip(&self.springs.xi) {
            c.extend_from_slice(&f[..n]);
        }
        let o = &self.out;
        let v = |a: &[[Real; LANES]; 3], k: usize| Vec3::new(a[0][k], a[1][k], a[2][k]);
        out.forces.extend((0..n).map(|k| PairForce {
            i: self.i[k],
            j: self.j[k],
            out: ContactOutput { force: v(&o.force, k), torque_i: v(&o.torque_i, k), torque_j: v(&o.torque_j, k) },
        }));
        self.len = 0;
    }
}

/// The geometry and kinematics of the first `n` pairs of a batch for their contact laws:
/// normal, overlap, levers, the contact point's relative velocity at mid-step (which advances
/// the springs) and predicted at the end of the step from the last accelerations (which the
/// dashpots use), effective radius and mass, mean spin about the normal. Every lane is computed
/// (a loop of fixed length becomes vector instructions, four lanes a time with AVX2).
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn contact_inputs(d: &[[Real; LANES]; 3], (r_i, r_j): (&[Real; LANES], &[Real; LANES]), g: &Gathered, input: &mut BatchInput, n: usize) {
    input.len = n;
    for k in 0..LANES {
        let (dx, dy, dz) = (d[0][k], d[1][k], d[2][k]);
        let dist = (dx * dx + dy * dy + dz * dz).sqrt();
        let inv = 1.0 / dist;
        let (n0, n1, n2) = (dx * inv, dy * inv, dz * inv);
        let (ri, rj) = (r_i[k], r_j[k]);
        let delta = ri + rj - dist;
        let (a_i, a_j) = (ri - 0.5 * delta, rj - 0.5 * delta);
        // (w_i a_i + w_j a_j) × n, and the same with the predicted spins.
        let cross = |wi: &[[Real; LANES]; 3], wj: &[[Real; LANES]; 3]| {
            let (u0, u1, u2) = (wi[0][k] * a_i + wj[0][k] * a_j, wi[1][k] * a_i + wj[1][k] * a_j, wi[2][k] * a_i + wj[2][k] * a_j);
            (u1 * n2 - u2 * n1, u2 * n0 - u0 * n2, u0 * n1 - u1 * n0)
        };
        let (c0, c1, c2) = cross(&g.w_i, &g.w_j);
        let (p0, p1, p2) = cross(&g.wp_i, &g.wp_j);
        input.n[0][k] = n0;
        input.n[1][k] = n1;
        input.n[2][k] = n2;
        input.delta[k] = delta;
        input.a_i[k] = a_i;
        input.a_j[k] = a_j;
        input.v_c[0][k] = g.v_rel[0][k] - c0;
        input.v_c[1][k] = g.v_rel[1][k] - c1;
        input.v_c[2][k] = g.v_rel[2][k] - c2;
        input.v_damp[0][k] = g.vp_rel[0][k] - p0;
        input.v_damp[1][k] = g.vp_rel[1][k] - p1;
        input.v_damp[2][k] = g.vp_rel[2][k] - p2;
        let (s0, s1, s2) = (g.w_i[0][k] + g.w_j[0][k], g.w_i[1][k] + g.w_j[1][k], g.w_i[2][k] + g.w_j[2][k]);
        input.spin_n[k] = 0.5 * (s0 * n0 + s1 * n1 + s2 * n2);
        input.r_eff[k] = ri * rj / (ri + rj);
        input.m_eff[k] = g.m_i[k] * g.m_j[k] / (g.m_i[k] + g.m_j[k]);
    }
}

impl Dem {
    /// Computes every force and torque of the current configuration; with `kick`, also gives
    /// the particles the second half kick of the step with them.
    pub(crate) fn compute_forces(&mut self, kick: bool) {
        self.pair_forces();
        self.wall_forces_and_gather(kick);
    }

    /// The part of [`Dem::compute_forces`] after the pair forces: the gather with the wall
    /// contacts (with `kick`, the second half kick), then the walls' reactions.
    pub(crate) fn wall_forces_and_gather(&mut self, kick: bool) {
        self.gather(kick);
        // New forces (and, with the kick, velocities): the packed predictions are out of date
        // until the next drift writes them.
        self.kin_current = false;
        if self.wall_slots() > 0 {
            self.wall_reactions();
        }
        if !self.w.glued.is_empty() {
            self.glued_loads();
        }
    }

    /// The pair forces: the near scan (or the filtering of the Verlet list into near pairs)
    /// and the contact law of every touching pair, one task per block of particles.
    pub(crate) fn pair_forces(&mut self) {
        if !self.kin_current {
            self.pack_kinematics();
        }
        let p = &self.w.p;
        let nl = &self.nl;
        let domain = &self.w.domain;
        let scene = PairScene { p, kin: &self.kin, domain, table: &self.table, dt: self.dt, with_extra: self.needs_extra };
        // Positions and radii packed together: one load per neighbour in the loops below.
        let pos = &self.w.p.pos;
        if !self.xr_current {
            let radius = &self.w.p.radius;
            self.xr.par_chunks_mut(LOOP_CHUNK).zip(pos.par_chunks(LOOP_CHUNK)).zip(radius.par_chunks(LOOP_CHUNK)).for_each(
                |((v, x), r)| {
                    for ((v, x), r) in v.iter_mut().zip(x).zip(r) {
                        *v = [x.x, x.y, x.z, *r];
                    }
                },
            );
            self.xr_current = true;
        }
        let xr = &self.xr;
        // A pair that interacted last time and is not touching now keeps interacting only if a
        // capillary bridge holds it (bridges form on contact, so only such pairs can hold one);
        // otherwise it is dropped, which forgets its springs.
        let untouched = |previous: &PairSprings, k: usize, batch: &mut Batch, current: &mut PairBlock| {
            if let Some(&extra) = previous.extras.get(k).filter(|e| e.bridge) {
                let (q, xi) = (previous.q[k], previous.xi(k));
                let (d, _) = nl.separation(q as usize, pos, domain);
                let (i, j) = (nl.pi[q as usize], nl.pair[q as usize].j);
                let image = nl.pair[q as usize].image;
                let radii = (p.radius[i as usize], p.radius[j as usize]);
                batch.push(&scene, current, (q, i, j, image), d, radii, xi, extra);
            }
        };
        // A touching pair picks up its record from the last evaluation by a merge walk (both are
        // in pair order) and joins the batch of pairs waiting for their laws; records before it
        // that are not touching any more go through `untouched`. The new records come out in
        // pair order.
        #[allow(clippy::too_many_arguments)]
        let touch = |previous: &PairSprings,
                     cursor: &mut usize,
                     batch: &mut Batch,
                     current: &mut PairBlock,
                     q: u32,
                     i: u32,
                     j: u32,
                     image,
                     d,
                     radii| {
            while previous.q.get(*cursor).is_some_and(|&o| o < q) {
                untouched(previous, *cursor, batch, current);
                *cursor += 1;
            }
            let (xi, extra) = match previous.q.get(*cursor) {
                Some(&old) if old == q => {
                    let extra = previous.extras.get(*cursor).copied().unwrap_or_default();
                    let xi = previous.xi(*cursor);
                    *cursor += 1;
                    (xi, extra)
                }
                _ => (Vec3::zeros(), PairExtra::default()),
            };
            batch.push(&scene, current, (q, i, j, image), d, radii, xi, extra);
        };
        // Separation of i and the image of j, squared distance, and the two radii.
        let separation = |i: usize, j: usize, image: [i8; 3]| {
            let ([xi, yi, zi, ri], [xj, yj, zj, rj]) = (xr[i], xr[j]);
            let (mut dx, mut dy, mut dz) = (xi - xj, yi - yj, zi - zj);
            if image != [0, 0, 0] {
                let sh = domain.image_shift(image);
                dx -= sh.x;
                dy -= sh.y;
                dz -= sh.z;
            }
            (Vec3::new(dx, dy, dz), dx * dx + dy * dy + dz * dz, (ri, rj))
        };
        // One task per block of particles: its pairs form one contiguous range of the list. The
        // scans find the touching pairs and do little else, so that they stay in registers (most
        // scanned pairs do not touch). When the near level is stale, the block scans its whole
        // range of the Verlet list and refills its near pairs on the way; otherwise it scans
        // only its near pairs.
        let refilter = self.near.is_stale(domain);
        let gap = self.near.gap;
        let kernel = |(b, (((current, previous), near), reach)): (usize, BlockState<'_>)| {
            std::mem::swap(&mut current.state, previous);
            current.state.clear();
            current.forces.clear();
            let previous = &*previous;
            let mut cursor = 0;
            // Each thread keeps one batch (20 KB) for all the blocks it takes: zeroing a new one
            // for each block cost a sparse gas more than its contacts.
            BATCH.with_borrow_mut(|batch| {
                batch.len = 0;
                if refilter {
                    near.clear();
                    let i0 = b * PARTICLE_BLOCK;
                    let i1 = (i0 + PARTICLE_BLOCK).min(nl.start.len() - 1);
                    for i in i0..i1 {
                        let (s, e) = (nl.start[i] as usize, nl.start[i + 1] as usize);
                        for (off, pr) in nl.pair[s..e].iter().enumerate() {
                            let (d, d2, radii) = separation(i, pr.j as usize, pr.image);
                            let reach = radii.0 + radii.1;
                            let far = reach + gap;
                            if d2 < far * far {
                                let q = (s + off) as u32;
                                near.push(NearPair { q, i: i as u32, j: pr.j, image: pr.image });
                                if d2 < reach * reach {
                                    touch(previous, &mut cursor, batch, current, q, i as u32, pr.j, pr.image, d, radii);
                                }
                            }
                        }
                    }
                } else {
                    for np in near.iter() {
                        let (d, d2, radii) = separation(np.i as usize, np.j as usize, np.image);
                        let reach = radii.0 + radii.1;
                        if d2 < reach * reach {
                            touch(previous, &mut cursor, batch, current, np.q, np.i, np.j, np.image, d, radii);
                        }
                    }
                }
                for k in cursor..previous.len() {
                    untouched(previous, k, batch, current);
                }
                batch.flush(&scene, current);
            });
            *reach = current.forces.iter().fold((u32::MAX, 0), |(lo, hi), c| (lo.min(c.j), hi.max(c.j)));
        };
        // One block per task (no sequential runs of blocks that an idle thread could not take).
        self.pairs
            .par_iter_mut()
            .zip(self.previous_springs.par_iter_mut())
            .zip(self.near.blocks.par_iter_mut())
            .zip(self.reach.par_iter_mut())
            .with_max_len(1)
            .enumerate()
            .for_each(kernel);
        if refilter {
            self.near.filtered(&self.w.domain);
        }
        if !self.bonds.is_empty() {
            self.bond_forces();
        }
    }

    /// Sums the forces on each particle: gravity, walls, then every interacting pair in block
    /// order. Each task owns a range of whole blocks of particles: it first evaluates their wall
    /// contacts (with the forces of the last evaluation, which it is about to overwrite), then
    /// walks the records of the blocks that can reach its particles (its own blocks, and those
    /// whose second particles fall in the range, see `Dem::reach`), adding only to its own
    /// particles: each particle receives its terms in the same order whatever the number of
    /// threads and tasks, so the result does not depend on them, and no step is serial. With
    /// several threads the particles go in several tasks per thread, so that a thread that joins
    /// late takes fewer. With `kick`, the task then gives its particles the second half kick.
    fn gather(&mut self, kick: bool) {
        let g = self.w.gravity;
        let field = self.w.field;
        let slots = self.wall_slots();
        let scene = WallScene {
            walls: &self.w.walls,
            drum: self.w.drum.as_ref(),
            glued_to: &self.w.glued_to,
            table: &self.wall_table,
            wall_material: self.wall_material,
            dt: self.dt,
        };
        let p = &mut self.w.p;
        let (pairs, reach, bonds) = (&self.pairs, &self.reach, &self.bonds.blocks);
        debug_assert!(
            pairs.iter().zip(reach).all(|(list, &(lo, hi))| list.forces.iter().all(|c| (lo..=hi).contains(&c.j))),
            "a block's reach must cover its records (written by pair_forces)"
        );
        let (h, alpha) = (0.5 * self.dt, self.params.local_damping);
        let n = p.len();
        let threads = rayon::current_num_threads().max(1);
        let tasks = if threads == 1 { 1 } else { GATHER_TASKS_PER_THREAD * threads };
        let span = n.div_ceil(tasks).next_multiple_of(PARTICLE_BLOCK).max(PARTICLE_BLOCK);
        let blocks = span / PARTICLE_BLOCK;
        // What the tasks write (forces, torques, and the velocities they kick), and what every
        // task reads.
        let grains = Grains {
            pos: &p.pos,
            radius: &p.radius,
            mass: &p.mass,
            inv_mass: &p.inv_mass,
            inv_inertia: &p.inv_inertia,
            material: &p.material,
        };
        let w = &mut self.wall_contacts;
        // As many chunks of blocks as of particles (`span` is a whole number of blocks).
        debug_assert_eq!(w.records.len(), n.div_ceil(PARTICLE_BLOCK));
        debug_assert_eq!(w.block_force.len(), w.records.len() * slots.max(1));
        let walls_per_task = (
            w.records.par_chunks_mut(blocks),
            w.previous.par_chunks_mut(blocks),
            w.candidates.par_chunks(blocks),
            w.block_force.par_chunks_mut(blocks * slots.max(1)),
            w.block_drum_torque.par_chunks_mut(blocks),
        );
        let ranges = p
            .force
            .par_chunks_mut(span)
            .zip(p.torque.par_chunks_mut(span))
            .zip(p.vel.par_chunks_mut(span))
            .zip(p.omega.par_chunks_mut(span))
            .zip(walls_per_task.0.zip(walls_per_task.1).zip(walls_per_task.2).zip(walls_per_task.3.zip(walls_per_task.4)))
            .with_max_len(1);
        ranges.enumerate().for_each(|(c, ((((fs, ts), vs), ws), (((records, previous), candidates), (block_force, drum_torque))))| {
            let base = c * span;
            let owned = base..base + fs.len();
            // The wall contacts of the task's blocks, with the forces of the last evaluation and
            // the velocities the pairs saw.
            if slots > 0 {
                let owner = Owned { base, vel: vs, omega: ws, force: fs, torque: ts };
                let lists = records.iter_mut().zip(previous.iter_mut()).zip(candidates).zip(block_force.chunks_mut(slots)).zip(drum_torque);
                for ((((records, previous), candidates), block_force), drum_torque) in lists {
                    evaluate_block(&scene, &grains, &owner, candidates, records, previous, block_force, drum_torque);
                }
            }
            let (mass, pos) = (&grains.mass[owned.clone()], &grains.pos[owned.clone()]);
            // Gravity, then walls, then pairs.
            if g == Vec3::zeros() {
                fs.fill(Vec3::zeros());
            } else {
                for (f, m) in fs.iter_mut().zip(mass) {
                    *f = g * *m;
                }
            }
            // The centripetal field that gathers a granule.
            if let Some((centre, a)) = field {
                for ((f, m), x) in fs.iter_mut().zip(mass).zip(pos) {
                    let d = centre - x;
                    let r = d.norm();
                    if r > 0.0 {
                        *f += d * (a * m / r);
                    }
                }
            }
            ts.fill(Vec3::zeros());
            for c in records.iter().flatten() {
                fs[c.i as usize - base] += c.force;
                ts[c.i as usize - base] += c.torque;
            }
            // A block holds the pairs of its own particles i, whose partners j lie in its reach.
            let (lo, hi) = (owned.start as u32, owned.end as u32);
            let reaches = |b: usize| {
                let own = (b * PARTICLE_BLOCK) as u32..((b + 1) * PARTICLE_BLOCK) as u32;
                let (jlo, jhi) = reach[b];
                (own.start < hi && own.end > lo) || (jlo < hi && jhi >= lo)
            };
            let mut add = |list: &[PairForce]| {
                for c in list {
                    let (i, j) = (c.i as usize, c.j as usize);
                    if owned.contains(&i) {
                        fs[i - base] += c.out.force;
                        ts[i - base] += c.out.torque_i;
                    }
                    if owned.contains(&j) {
                        fs[j - base] -= c.out.force;
                        ts[j - base] += c.out.torque_j;
                    }
                }
            };
            // Each block's contacts, then its bonds' attraction ([`super::bonds`]).
            for (b, list) in pairs.iter().enumerate().filter(|&(b, _)| reaches(b)) {
                add(&list.forces);
                if let Some(bonded) = bonds.get(b) {
                    add(&bonded.forces);
                }
            }
            if kick {
                let (im, ii) = (&grains.inv_mass[owned.clone()], &grains.inv_inertia[owned]);
                for ((((v, w), f), t), (im, ii)) in vs.iter_mut().zip(ws.iter_mut()).zip(fs.iter()).zip(ts.iter()).zip(im.iter().zip(ii)) {
                    half_kick(v, w, f, t, h * im, h * ii, alpha);
                }
            }
        });
    }

    /// The walls' and the drum's reactions: what the particles' wall contacts push on them,
    /// summed block by block in order.
    fn wall_reactions(&mut self) {
        let (on_walls, drum_torque) = self.wall_contacts.reactions();
        for (wall, f) in self.w.walls.iter_mut().zip(&on_walls) {
            wall.force = *f;
        }
        if let Some(d) = self.w.drum.as_mut() {
            d.force = on_walls[self.w.walls.len()];
            d.torque = drum_torque;
        }
    }
}
