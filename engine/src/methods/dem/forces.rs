//! The force stage of DEM: the pairs of the neighbour list in parallel, by blocks of particles
//! (each block owns the records of its interacting pairs, see [`super::pair_state`]), then the
//! gather: each task evaluates the wall contacts of its own range of particles
//! ([`super::wall_contacts`]), sums their forces over all pair records, in block order, and gives
//! them the second half kick. No atomics: the result does not depend on the number of threads.

use rayon::prelude::*;

use super::pair_state::{PairContact, PairExtra};
use super::wall_contacts::{evaluate_block, Grains, Owned, WallScene};
use super::{half_kick, Dem};
use crate::contact::{ContactInput, ContactOutput, ContactTable};
use crate::geometry::near_pairs::NearPair;
use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// What a force task owns: its block's records (current and previous evaluation), near pairs
/// and reach (see `Dem::reach`).
type BlockState<'a> = (((&'a mut Vec<PairContact>, &'a mut Vec<PairContact>), &'a mut Vec<NearPair>), &'a mut (u32, u32));

/// Particles per task in the simple per-particle loops (plain slice loops inside each task).
pub(crate) const LOOP_CHUNK: usize = 2048;

/// Particles per force task: their pairs form one contiguous block of the neighbour list.
pub(crate) const PARTICLE_BLOCK: usize = 256;

/// Gather tasks per thread when there are several threads (each walks only the blocks that
/// reach its particles, so more tasks cost little).
const GATHER_TASKS_PER_THREAD: usize = 4;

/// Force and torques of one interacting pair (i, j'), where j' is the image `img` of j and
/// `d = r_i - r_j'`; advances the springs `xi` and `extra` carried by the pair's record.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn pair_contact(
    p: &Particles,
    domain: &Domain,
    table: &ContactTable,
    dt: f64,
    with_extra: bool,
    (i, j): (usize, usize),
    (ri, rj): (Real, Real),
    xi: &mut Vec3,
    extra: &mut PairExtra,
    img: [i8; 3],
    d: Vec3,
) -> ContactOutput {
    let h = 0.5 * dt;
    let dist = d.norm();
    let n = d / dist;
    let delta = ri + rj - dist;
    let (a_i, a_j) = (ri - 0.5 * delta, rj - 0.5 * delta);
    let (wi, wj) = (p.omega[i], p.omega[j]);
    let mut v_rel = p.vel[i] - p.vel[j];
    v_rel.x -= domain.image_velocity(img[1]);
    let v_c = v_rel - (wi * a_i + wj * a_j).cross(&n);
    // End-of-step prediction from the previous accelerations.
    let dv = p.force[i] * (h * p.inv_mass[i]) - p.force[j] * (h * p.inv_mass[j]);
    let (alpha_i, alpha_j) = (p.torque[i] * (h * p.inv_inertia[i]), p.torque[j] * (h * p.inv_inertia[j]));
    let v_damp = v_c + dv - (alpha_i * a_i + alpha_j * a_j).cross(&n);
    let (mi, mj) = (p.mass[i], p.mass[j]);
    let input = ContactInput {
        n,
        delta,
        r_i: ri,
        r_j: rj,
        r_eff: ri * rj / (ri + rj),
        m_eff: mi * mj / (mi + mj),
        a_i,
        a_j,
        v_c,
        v_damp,
        w_rel: wi - wj,
        spin_n: 0.5 * (wi + wj).dot(&n),
    };
    let law = table.get(p.material[i] as usize, p.material[j] as usize);
    if with_extra {
        let both_wet = p.wet[i] && p.wet[j];
        let PairExtra { roll, bridge } = extra;
        law.compute(&input, xi, Some(roll), both_wet.then_some(bridge), dt)
    } else {
        law.compute(&input, xi, None, None, dt)
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
        if self.wall_slots() > 0 {
            self.wall_reactions();
        }
        if !self.glued.is_empty() {
            self.glued_loads();
        }
    }

    /// The pair forces: the near scan (or the filtering of the Verlet list into near pairs)
    /// and the contact law of every touching pair, one task per block of particles.
    pub(crate) fn pair_forces(&mut self) {
        let p = &self.p;
        let nl = &self.nl;
        let domain = &self.domain;
        let table = &self.table;
        let dt = self.dt;
        let with_extra = self.needs_extra;
        // Positions and radii packed together: one load per neighbour in the loops below.
        let pos = &self.p.pos;
        if !self.xr_current {
            let radius = &self.p.radius;
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
        let untouched = |c: &PairContact, current: &mut Vec<PairContact>| {
            if c.extra.bridge {
                let (d, _) = nl.separation(c.q as usize, pos, domain);
                let image = nl.pair[c.q as usize].image;
                let (mut xi, mut extra) = (c.xi, c.extra);
                let (i, j) = (c.i as usize, c.j as usize);
                let out = pair_contact(p, domain, table, dt, with_extra, (i, j), (p.radius[i], p.radius[j]), &mut xi, &mut extra, image, d);
                current.push(PairContact { xi, extra, out, ..*c });
            }
        };
        // A touching pair picks up its record from the last evaluation by a merge walk (both are
        // in pair order) and goes to `pair_contact`, out of line; records before it that are not
        // touching any more go through `untouched`. The new records come out in pair order.
        #[allow(clippy::too_many_arguments)]
        let touch =
            |previous: &[PairContact], cursor: &mut usize, current: &mut Vec<PairContact>, q: u32, i: u32, j: u32, image, d, radii| {
                while let Some(old) = previous.get(*cursor).filter(|o| o.q < q) {
                    untouched(old, current);
                    *cursor += 1;
                }
                // Only the springs are carried over: the record is written once, whole.
                let (mut xi, mut extra) = match previous.get(*cursor) {
                    Some(old) if old.q == q => {
                        *cursor += 1;
                        (old.xi, old.extra)
                    }
                    _ => (Vec3::zeros(), PairExtra::default()),
                };
                let out = pair_contact(p, domain, table, dt, with_extra, (i as usize, j as usize), radii, &mut xi, &mut extra, image, d);
                current.push(PairContact { q, i, j, xi, extra, out });
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
            std::mem::swap(current, previous);
            current.clear();
            let mut cursor = 0;
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
                                touch(previous, &mut cursor, current, q, i as u32, pr.j, pr.image, d, radii);
                            }
                        }
                    }
                }
            } else {
                for np in near.iter() {
                    let (d, d2, radii) = separation(np.i as usize, np.j as usize, np.image);
                    let reach = radii.0 + radii.1;
                    if d2 < reach * reach {
                        touch(previous, &mut cursor, current, np.q, np.i, np.j, np.image, d, radii);
                    }
                }
            }
            for old in &previous[cursor..] {
                untouched(old, current);
            }
            *reach = current.iter().fold((u32::MAX, 0), |(lo, hi), c| (lo.min(c.j), hi.max(c.j)));
        };
        // One block per task (no sequential runs of blocks that an idle thread could not take).
        self.contacts
            .par_iter_mut()
            .zip(self.previous_contacts.par_iter_mut())
            .zip(self.near.blocks.par_iter_mut())
            .zip(self.reach.par_iter_mut())
            .with_max_len(1)
            .enumerate()
            .for_each(kernel);
        if refilter {
            self.near.filtered(&self.domain);
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
        let g = self.gravity;
        let field = self.field;
        let slots = self.wall_slots();
        let scene = WallScene {
            walls: &self.walls,
            drum: self.drum.as_ref(),
            glued_to: &self.glued_to,
            table: &self.wall_table,
            wall_material: self.wall_material,
            dt: self.dt,
        };
        let p = &mut self.p;
        let (contacts, reach) = (&self.contacts, &self.reach);
        debug_assert!(
            contacts.iter().zip(reach).all(|(list, &(lo, hi))| list.iter().all(|c| (lo..=hi).contains(&c.j))),
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
            for list in contacts.iter().enumerate().filter(|&(b, _)| reaches(b)).map(|(_, list)| list) {
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
        for (wall, f) in self.walls.iter_mut().zip(&on_walls) {
            wall.force = *f;
        }
        if let Some(d) = self.drum.as_mut() {
            d.force = on_walls[self.walls.len()];
            d.torque = drum_torque;
        }
    }
}
