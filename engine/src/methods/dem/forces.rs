//! The force stage of DEM: the pairs of the neighbour list in parallel, by blocks of particles
//! (each pair writes only its own slot and each block lists its interacting pairs), then walls,
//! then one scatter of the interacting pairs in block order. No atomics and no allocation in the
//! step: the result does not depend on the number of threads.

use rayon::prelude::*;

use super::{Dem, PairExtra};
use crate::contact::{ContactInput, ContactOutput, ContactTable};
use crate::geometry::Domain;
use crate::math::Vec3;
use crate::particles::Particles;

const CHUNK: usize = 256;

/// Particles per task in the simple per-particle loops (plain slice loops inside each task).
pub(crate) const LOOP_CHUNK: usize = 2048;

/// Particles per force task: their pairs form one contiguous block of the neighbour list.
pub(crate) const PARTICLE_BLOCK: usize = 256;

/// The pairs of one block of particles, with the mutable per-pair state they own.
struct PairBlock<'a> {
    particles: std::ops::Range<usize>,
    first_pair: usize,
    xi: &'a mut [Vec3],
    active: &'a mut [bool],
    out: &'a mut [ContactOutput],
    extra: Option<&'a mut [PairExtra]>,
    active_list: &'a mut Vec<u32>,
    /// The pairs that interacted at the previous evaluation (global indices).
    previous: &'a mut Vec<u32>,
}

impl PairBlock<'_> {
    /// Forgets the history of pair `k` (block-local index) when it stops interacting.
    #[inline(always)]
    fn release(&mut self, k: usize) {
        self.active[k] = false;
        self.xi[k] = Vec3::zeros();
        if let Some(x) = self.extra.as_deref_mut() {
            x[k].roll = Vec3::zeros();
        }
    }
}

/// Force and torques of one interacting pair (i, j'), where j' is the image `img` of j and
/// `d = r_i - r_j'`. Writes the block-local slot `k`.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn pair_contact(
    p: &Particles,
    domain: &Domain,
    table: &ContactTable,
    dt: f64,
    block: &mut PairBlock<'_>,
    k: usize,
    i: usize,
    j: usize,
    img: [i8; 3],
    d: Vec3,
) {
    let h = 0.5 * dt;
    let (ri, rj) = (p.radius[i], p.radius[j]);
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
    let both_wet = p.wet[i] && p.wet[j];
    block.out[k] = match block.extra.as_deref_mut() {
        Some(x) => {
            let PairExtra { roll, bridge } = &mut x[k];
            law.compute(&input, &mut block.xi[k], Some(roll), both_wet.then_some(bridge), dt)
        }
        None => law.compute(&input, &mut block.xi[k], None, None, dt),
    };
}

/// Splits the per-pair arrays into disjoint blocks of `PARTICLE_BLOCK` particles.
fn split_blocks<'a>(
    start: &[u32],
    mut xi: &'a mut [Vec3],
    mut active: &'a mut [bool],
    mut out: &'a mut [ContactOutput],
    extra: &'a mut [PairExtra],
    lists: &'a mut [Vec<u32>],
    previous: &'a mut [Vec<u32>],
) -> Vec<PairBlock<'a>> {
    let n = start.len().saturating_sub(1);
    let mut extra: Option<&'a mut [PairExtra]> = (!extra.is_empty()).then_some(extra);
    let mut blocks = Vec::with_capacity(lists.len());
    for (b, (list, previous)) in lists.iter_mut().zip(previous.iter_mut()).enumerate() {
        let (i0, i1) = (b * PARTICLE_BLOCK, ((b + 1) * PARTICLE_BLOCK).min(n));
        let len = (start[i1] - start[i0]) as usize;
        let (x, rest) = std::mem::take(&mut xi).split_at_mut(len);
        xi = rest;
        let (a, rest) = std::mem::take(&mut active).split_at_mut(len);
        active = rest;
        let (o, rest) = std::mem::take(&mut out).split_at_mut(len);
        out = rest;
        let e = match extra.take() {
            Some(ex) => {
                let (e, rest) = ex.split_at_mut(len);
                extra = Some(rest);
                Some(e)
            }
            None => None,
        };
        blocks.push(PairBlock {
            particles: i0..i1,
            first_pair: start[i0] as usize,
            xi: x,
            active: a,
            out: o,
            extra: e,
            active_list: list,
            previous,
        });
    }
    blocks
}

impl Dem {
    /// Computes every force and torque of the current configuration.
    pub(crate) fn compute_forces(&mut self) {
        self.pair_forces();
        if !self.walls.is_empty() {
            self.wall_forces();
        }
        self.gather();
    }

    fn pair_forces(&mut self) {
        let p = &self.p;
        let nl = &self.nl;
        let domain = &self.domain;
        let table = &self.table;
        let dt = self.dt;
        // Positions and radii packed together: one load per neighbour in the loop below.
        let pos = &self.p.pos;
        let radius = &self.p.radius;
        self.xr.par_chunks_mut(LOOP_CHUNK).zip(pos.par_chunks(LOOP_CHUNK)).zip(radius.par_chunks(LOOP_CHUNK)).for_each(|((v, x), r)| {
            for ((v, x), r) in v.iter_mut().zip(x).zip(r) {
                *v = [x.x, x.y, x.z, *r];
            }
        });
        let xr = &self.xr;
        // One task per block of particles: its pairs form one contiguous range of the list.
        // Pass 1 finds the touching pairs; the loop does nothing else so that it stays in
        // registers (most listed pairs do not touch), and touching pairs go to `pair_contact`,
        // out of line. Pass 2 visits the pairs that interacted at the previous evaluation and
        // were not found touching: a capillary bridge keeps interacting past contact, the others
        // forget their history. Only pairs active last time can hold a bridge (bridges form on
        // contact), so no test of the bridge state is needed in pass 1.
        let kernel = |block: &mut PairBlock<'_>| {
            let first = block.first_pair;
            std::mem::swap(block.active_list, block.previous);
            block.active_list.clear();
            for &q in block.previous.iter() {
                block.active[q as usize - first] = false;
            }
            for i in block.particles.clone() {
                let [xi, yi, zi, ri] = xr[i];
                let (s, e) = (nl.start[i] as usize, nl.start[i + 1] as usize);
                for (off, pr) in nl.pair[s..e].iter().enumerate() {
                    let [xj, yj, zj, rj] = xr[pr.j as usize];
                    let (mut dx, mut dy, mut dz) = (xi - xj, yi - yj, zi - zj);
                    if pr.image != [0, 0, 0] {
                        let sh = domain.image_shift(pr.image);
                        dx -= sh.x;
                        dy -= sh.y;
                        dz -= sh.z;
                    }
                    let reach = ri + rj;
                    if dx * dx + dy * dy + dz * dz < reach * reach {
                        let k = s + off - first;
                        block.active[k] = true;
                        block.active_list.push((s + off) as u32);
                        pair_contact(p, domain, table, dt, block, k, i, pr.j as usize, pr.image, Vec3::new(dx, dy, dz));
                    }
                }
            }
            for idx in 0..block.previous.len() {
                let q = block.previous[idx] as usize;
                let k = q - first;
                if block.active[k] {
                    continue;
                }
                if block.extra.as_ref().is_some_and(|x| x[k].bridge) {
                    let (i, pr) = (nl.pi[q] as usize, nl.pair[q]);
                    let d = nl.separation(q, &p.pos, domain).0;
                    block.active[k] = true;
                    block.active_list.push(q as u32);
                    pair_contact(p, domain, table, dt, block, k, i, pr.j as usize, pr.image, d);
                } else {
                    block.release(k);
                }
            }
        };
        let mut blocks = split_blocks(
            &self.nl.start,
            &mut self.pair_xi,
            &mut self.pair_active,
            &mut self.pair_out,
            &mut self.extra,
            &mut self.active_lists,
            &mut self.previous_lists,
        );
        blocks.par_iter_mut().for_each(kernel);
    }

    fn gather(&mut self) {
        let g = self.gravity;
        let mass = &self.p.mass;
        let (wall_f, wall_t) = (&self.wall_total_f, &self.wall_total_t);
        let run = |force: &mut [Vec3], torque: &mut [Vec3]| {
            force.par_chunks_mut(LOOP_CHUNK).zip(torque.par_chunks_mut(LOOP_CHUNK)).enumerate().for_each(|(c, (fs, ts))| {
                let base = c * LOOP_CHUNK;
                for (k, (f, t)) in fs.iter_mut().zip(ts.iter_mut()).enumerate() {
                    let i = base + k;
                    *f = g * mass[i];
                    *t = Vec3::zeros();
                    if let (Some(wf), Some(wt)) = (wall_f.get(i), wall_t.get(i)) {
                        *f += wf;
                        *t += wt;
                    }
                }
            })
        };
        run(&mut self.p.force, &mut self.p.torque);
        // Scatter the interacting pairs, block after block: a fixed order for any thread count.
        // Only pairs that interact are visited, which in most scenes is a small part of the list.
        let (pi, pair, out) = (&self.nl.pi, &self.nl.pair, &self.pair_out);
        let (force, torque) = (&mut self.p.force, &mut self.p.torque);
        for list in &self.active_lists {
            for &q in list {
                let q = q as usize;
                let (i, j) = (pi[q] as usize, pair[q].j as usize);
                let o = &out[q];
                force[i] += o.force;
                force[j] -= o.force;
                torque[i] += o.torque_i;
                torque[j] += o.torque_j;
            }
        }
    }

    fn wall_forces(&mut self) {
        let nw = self.walls.len();
        let walls = &self.walls;
        let table = &self.table;
        let wall_mat = self.wall_material;
        let dt = self.dt;
        let p = &self.p;
        let (pos, vel, omega, radius, mass, material) = (&p.pos, &p.vel, &p.omega, &p.radius, &p.mass, &p.material);
        let (inv_mass, inv_inertia) = (&p.inv_mass, &p.inv_inertia);
        let (force, torque) = (&p.force, &p.torque);
        let run = |total_f: &mut [Vec3], total_t: &mut [Vec3], xi: &mut [Vec3], roll: &mut [Vec3], wf: &mut [Vec3]| {
            total_f
                .par_iter_mut()
                .zip(total_t.par_iter_mut())
                .zip(xi.par_chunks_mut(nw))
                .zip(roll.par_chunks_mut(nw))
                .zip(wf.par_chunks_mut(nw))
                .enumerate()
                .with_min_len(CHUNK)
                .for_each(|(i, ((((f, t), xi), roll), wf))| {
                    let r = radius[i];
                    let law = table.get(material[i] as usize, wall_mat);
                    // Forces of the previous step, for the end-of-step velocity prediction.
                    let (dv, dw) = (force[i] * (0.5 * dt * inv_mass[i]), torque[i] * (0.5 * dt * inv_inertia[i]));
                    *f = Vec3::zeros();
                    *t = Vec3::zeros();
                    for (w, wall) in walls.iter().enumerate() {
                        let n = wall.normal();
                        let a = wall.face.axis;
                        let dist = (pos[i][a] - wall.position) * n[a];
                        let delta = r - dist;
                        if delta <= 0.0 {
                            xi[w] = Vec3::zeros();
                            roll[w] = Vec3::zeros();
                            wf[w] = Vec3::zeros();
                            continue;
                        }
                        let a_i = r - delta;
                        let v_c = vel[i] - (omega[i] * a_i).cross(&n) - wall.velocity;
                        let v_damp = v_c + dv - (dw * a_i).cross(&n);
                        let input = ContactInput {
                            n,
                            delta,
                            r_i: r,
                            r_j: f64::INFINITY,
                            r_eff: r,
                            m_eff: mass[i],
                            a_i,
                            a_j: 0.0,
                            v_c,
                            v_damp,
                            w_rel: omega[i],
                            spin_n: 0.5 * omega[i].dot(&n),
                        };
                        let out = law.compute(&input, &mut xi[w], Some(&mut roll[w]), None, dt);
                        *f += out.force;
                        *t += out.torque_i;
                        wf[w] = out.force;
                    }
                })
        };
        run(&mut self.wall_total_f, &mut self.wall_total_t, &mut self.wall_xi, &mut self.wall_roll, &mut self.wall_f);
        // Reaction on each wall, summed in a fixed order.
        const BLOCK: usize = 1024;
        let partial: Vec<Vec<Vec3>> = self
            .wall_f
            .par_chunks(BLOCK * nw)
            .map(|c| {
                let mut s = vec![Vec3::zeros(); nw];
                for per in c.chunks(nw) {
                    for (w, f) in per.iter().enumerate() {
                        s[w] += f;
                    }
                }
                s
            })
            .collect();
        for wall in &mut self.walls {
            wall.force = Vec3::zeros();
        }
        for s in partial {
            for (w, f) in s.iter().enumerate() {
                self.walls[w].force -= f;
            }
        }
    }
}
