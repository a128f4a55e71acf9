//! Velocity Verlet's half kicks (with Cundall's local damping) and drift, and the end-of-step
//! predictions of velocities and spins ([`Kin`]) the contact dashpots read.

use rayon::prelude::*;

use super::tasks::LOOP_CHUNK;
use super::Dem;
use crate::math::{Real, Vec3};

impl Dem {
    /// Half kick of velocities and spins, then drift of the particles by `v dt` with the new
    /// velocity, in one pass (the first half of velocity Verlet), which saves a sweep over memory
    /// and a parallel region per step; the pass also packs positions and velocities for the
    /// force stage. The drift reports the largest displacement to the near pairs, and the
    /// largest displacement since the last neighbour build to the neighbour stage
    /// ([`Dem::drift2`]). (The second half kick runs inside the gather of the force stage.)
    pub(super) fn kick_and_drift(&mut self) {
        let h = 0.5 * self.dt;
        let dt = self.dt;
        let alpha = self.params.local_damping;
        let reference = self.nl.reference_positions();
        let measured = reference.len() == self.w.p.len();
        let p = &mut self.w.p;
        let (force, torque, inv_mass, inv_inertia, radius) = (&p.force, &p.torque, &p.inv_mass, &p.inv_inertia, &p.radius);
        // No wrap after the drift: particles return into the box at the next neighbour build.
        let (largest2, drift2) = p
            .vel
            .par_chunks_mut(LOOP_CHUNK)
            .zip(p.omega.par_chunks_mut(LOOP_CHUNK))
            .zip(p.pos.par_chunks_mut(LOOP_CHUNK))
            .zip(self.xr.par_chunks_mut(LOOP_CHUNK).zip(self.kin.par_chunks_mut(LOOP_CHUNK)))
            .enumerate()
            .map(|(c, (((vs, ws), xs), (xrs, kins)))| {
                let (mut largest2, mut drift2): (Real, Real) = (0.0, 0.0);
                let r = c * LOOP_CHUNK..c * LOOP_CHUNK + vs.len();
                let refs = if measured { &reference[r.clone()] } else { &[] };
                let parts =
                    force[r.clone()].iter().zip(&torque[r.clone()]).zip(&inv_mass[r.clone()]).zip(&inv_inertia[r.clone()]).zip(&radius[r]);
                let state = vs.iter_mut().zip(ws.iter_mut()).zip(xs.iter_mut()).zip(xrs.iter_mut().zip(kins.iter_mut()));
                for (k, ((((v, w), x), (xr, kin)), ((((f, t), im), ii), rad))) in state.zip(parts).enumerate() {
                    half_kick(v, w, f, t, h * im, h * ii, alpha);
                    *kin = Kin::predicted(v, w, f, t, h * im, h * ii);
                    let step = *v * dt;
                    *x += step;
                    largest2 = largest2.max(step.norm_squared());
                    if let Some(x0) = refs.get(k) {
                        drift2 = drift2.max((*x - x0).norm_squared());
                    }
                    *xr = [x.x, x.y, x.z, *rad];
                }
                (largest2, drift2)
            })
            .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1)));
        self.near.add_motion(largest2.sqrt());
        self.drift2 = measured.then_some(drift2);
        self.xr_current = true;
        self.kin_current = true;
    }
    /// Packs every particle's velocities and predictions ([`Kin`]) from the current state.
    pub(super) fn pack_kinematics(&mut self) {
        let h = 0.5 * self.dt;
        let p = &self.w.p;
        self.kin.par_chunks_mut(LOOP_CHUNK).enumerate().for_each(|(c, kins)| {
            for (k, kin) in kins.iter_mut().enumerate() {
                let i = c * LOOP_CHUNK + k;
                *kin = Kin::predicted(&p.vel[i], &p.omega[i], &p.force[i], &p.torque[i], h * p.inv_mass[i], h * p.inv_inertia[i]);
            }
        });
        self.kin_current = true;
    }
}
/// The end-of-step predictions of a particle's velocity and spin from its last force and torque
/// (`v + F h/m`, `w + T h/I`), which the contact dashpots use; written by the drift for the force
/// stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Kin {
    /// Predicted velocity at the end of the step, m/s.
    pub vp: Vec3,
    /// Predicted angular velocity at the end of the step, rad/s.
    pub wp: Vec3,
}

impl Kin {
    /// The prediction for a particle with velocity `v`, spin `w`, last force `f` and torque `t`
    /// (`h_im` = h/m, `h_ii` = h/I, h half the step).
    #[inline(always)]
    pub(super) fn predicted(v: &Vec3, w: &Vec3, f: &Vec3, t: &Vec3, h_im: Real, h_ii: Real) -> Self {
        Self { vp: v + f * h_im, wp: w + t * h_ii }
    }
}

/// Half kick of one particle: `v += F h/m`, `w += T h/I` (`h_im` = h/m, `h_ii` = h/I), with
/// Cundall's local damping when `alpha > 0`.
#[inline(always)]
pub(super) fn half_kick(v: &mut Vec3, w: &mut Vec3, f: &Vec3, t: &Vec3, h_im: Real, h_ii: Real, alpha: Real) {
    if alpha > 0.0 {
        *v += local_damping(f, v, alpha) * h_im;
        *w += local_damping(t, w, alpha) * h_ii;
    } else {
        *v += f * h_im;
        *w += t * h_ii;
    }
}

/// Cundall's local damping (Cundall & Strack 1979; Yade's `NewtonIntegrator.damping`): each
/// component of the force is reduced by `alpha` times its magnitude when it drives the motion
/// and increased when it opposes it, `F_k (1 - alpha sign(F_k v_k))`.
#[inline(always)]
fn local_damping(f: &Vec3, v: &Vec3, alpha: Real) -> Vec3 {
    let damp = |fk: Real, vk: Real| {
        let s = fk * vk;
        let sign = if s > 0.0 {
            1.0
        } else if s < 0.0 {
            -1.0
        } else {
            0.0
        };
        fk * (1.0 - alpha * sign)
    };
    Vec3::new(damp(f.x, v.x), damp(f.y, v.y), damp(f.z, v.z))
}
