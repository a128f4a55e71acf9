//! The force stage of DEM: every pair of the neighbour list in parallel (each pair writes only
//! its own slot), then a per-particle gather in a fixed order, then walls. No atomics, no
//! allocation: the result does not depend on the number of threads.

use rayon::prelude::*;

use super::{Dem, PairExtra, PairSlot};
use crate::contact::{ContactInput, ContactOutput};
use crate::math::Vec3;

const CHUNK: usize = 256;

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
        let kernel = |base: usize, slots: &mut [PairSlot], mut extra: Option<&mut [PairExtra]>| {
            for (k, slot) in slots.iter_mut().enumerate() {
                let q = base + k;
                let (i, j) = (nl.pi[q] as usize, nl.pj[q] as usize);
                let (d, dvx) = domain.separation(&p.pos[i], &p.pos[j]);
                let (ri, rj) = (p.radius[i], p.radius[j]);
                let dist2 = d.norm_squared();
                let bonded = extra.as_ref().is_some_and(|e| e[k].bridge);
                if dist2 >= (ri + rj) * (ri + rj) && !bonded {
                    slot.xi = Vec3::zeros();
                    slot.out = ContactOutput::default();
                    if let Some(e) = extra.as_deref_mut() {
                        e[k].roll = Vec3::zeros();
                    }
                    continue;
                }
                let dist = dist2.sqrt();
                let n = d / dist;
                let delta = ri + rj - dist;
                let (a_i, a_j) = (ri - 0.5 * delta, rj - 0.5 * delta);
                let (wi, wj) = (p.omega[i], p.omega[j]);
                let mut v_rel = p.vel[i] - p.vel[j];
                v_rel.x -= dvx;
                let v_c = v_rel - (wi * a_i + wj * a_j).cross(&n);
                // End-of-step prediction from the previous accelerations.
                let h = 0.5 * dt;
                let dv = (p.force[i] * p.inv_mass[i] - p.force[j] * p.inv_mass[j]) * h;
                let (dwi, dwj) = (p.torque[i] * (h * p.inv_inertia[i]), p.torque[j] * (h * p.inv_inertia[j]));
                let v_damp = v_c + dv - (dwi * a_i + dwj * a_j).cross(&n);
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
                slot.out = match extra.as_deref_mut() {
                    Some(e) => {
                        let PairExtra { roll, bridge } = &mut e[k];
                        law.compute(&input, &mut slot.xi, Some(roll), both_wet.then_some(bridge), dt)
                    }
                    None => law.compute(&input, &mut slot.xi, None, None, dt),
                };
            }
        };
        let run = |slots: &mut [PairSlot], extra: &mut [PairExtra]| {
            if extra.is_empty() {
                slots.par_chunks_mut(CHUNK).enumerate().for_each(|(c, s)| kernel(c * CHUNK, s, None));
            } else {
                slots
                    .par_chunks_mut(CHUNK)
                    .zip(extra.par_chunks_mut(CHUNK))
                    .enumerate()
                    .for_each(|(c, (s, e))| kernel(c * CHUNK, s, Some(e)));
            }
        };
        match &self.pool {
            Some(pool) => pool.install(|| run(&mut self.slots, &mut self.extra)),
            None => run(&mut self.slots, &mut self.extra),
        }
    }

    fn gather(&mut self) {
        let nl = &self.nl;
        let slots = &self.slots;
        let g = self.gravity;
        let mass = &self.p.mass;
        let (wall_f, wall_t) = (&self.wall_total_f, &self.wall_total_t);
        let run = |force: &mut [Vec3], torque: &mut [Vec3]| {
            force.par_iter_mut().zip(torque.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(|(i, (f, t))| {
                let mut fi = g * mass[i];
                let mut ti = Vec3::zeros();
                if let (Some(wf), Some(wt)) = (wall_f.get(i), wall_t.get(i)) {
                    fi += wf;
                    ti += wt;
                }
                for s in &slots[nl.start[i] as usize..nl.start[i + 1] as usize] {
                    fi += s.out.force;
                    ti += s.out.torque_i;
                }
                for &q in &nl.rev[nl.rev_start[i] as usize..nl.rev_start[i + 1] as usize] {
                    let s = &slots[q as usize];
                    fi -= s.out.force;
                    ti += s.out.torque_j;
                }
                *f = fi;
                *t = ti;
            })
        };
        let (force, torque) = (&mut self.p.force, &mut self.p.torque);
        match &self.pool {
            Some(pool) => pool.install(|| run(force, torque)),
            None => run(force, torque),
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
        let (tf, tt) = (&mut self.wall_total_f, &mut self.wall_total_t);
        match &self.pool {
            Some(pool) => pool.install(|| run(tf, tt, &mut self.wall_xi, &mut self.wall_roll, &mut self.wall_f)),
            None => run(tf, tt, &mut self.wall_xi, &mut self.wall_roll, &mut self.wall_f),
        }
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
