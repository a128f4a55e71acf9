//! A contact law evaluated for a batch of contacts at once, field by field (struct of arrays).
//!
//! A contact is a long chain of dependent operations — a square root and divisions for the
//! normal, the spring's rescale, the Coulomb cap. Evaluated one contact at a time the processor
//! waits on each link; laid out as arrays over a batch, every step of the chain is a loop the
//! compiler turns into vector instructions over several contacts, and the chains of different
//! contacts overlap. In a settled bed of 10,000 spheres (22,500 lasting contacts) the contact
//! laws took two thirds of a step.
//!
//! [`PairLaw::compute_batch`] gives, contact by contact, the same values as
//! [`PairLaw::compute`] to the last bit: the same operations in the same order, with the
//! branches of the scalar law turned into selections. It covers the laws without rolling
//! resistance and liquid bridges ([`PairLaw::batchable`]); the caller evaluates the others one
//! by one.

// Loops over a batch index several arrays at the same position: an index is the plain way to
// write them, and what the vectoriser reads best.
#![allow(clippy::needless_range_loop)]

use super::model::{ContactInput, NormalLaw, PairLaw, TangentialLaw};
use super::NormalForce;
use crate::math::Vec3;

/// Contacts per batch.
pub const LANES: usize = 32;

/// The inputs of a batch of contacts, the fields of [`super::ContactInput`] as arrays; the
/// first `len` entries are in use.
#[derive(Debug, Clone)]
pub struct BatchInput {
    /// Contacts in use.
    pub len: usize,
    /// Unit normal from j to i, components.
    pub n: [[f64; LANES]; 3],
    /// Overlap, m.
    pub delta: [f64; LANES],
    /// Effective radius R*, m.
    pub r_eff: [f64; LANES],
    /// Effective mass m*, kg.
    pub m_eff: [f64; LANES],
    /// Levers from the centres of i and j to the contact point, m.
    pub a_i: [f64; LANES],
    /// See `a_i`.
    pub a_j: [f64; LANES],
    /// Relative velocity of the contact point at mid-step, m/s.
    pub v_c: [[f64; LANES]; 3],
    /// The same predicted at the end of the step, m/s.
    pub v_damp: [[f64; LANES]; 3],
    /// Mean spin about the normal, rad/s.
    pub spin_n: [f64; LANES],
}

impl BatchInput {
    /// Contact `k` as the scalar law takes it, with the spins of i and j (for the relative
    /// rotation, which only rolling resistance reads) and the radii.
    pub fn contact(&self, k: usize, w_i: &[[f64; LANES]; 3], w_j: &[[f64; LANES]; 3], (r_i, r_j): (f64, f64)) -> ContactInput {
        let v = |a: &[[f64; LANES]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
        ContactInput {
            n: v(&self.n),
            delta: self.delta[k],
            r_i,
            r_j,
            r_eff: self.r_eff[k],
            m_eff: self.m_eff[k],
            a_i: self.a_i[k],
            a_j: self.a_j[k],
            v_c: v(&self.v_c),
            v_damp: v(&self.v_damp),
            w_rel: v(w_i) - v(w_j),
            spin_n: self.spin_n[k],
        }
    }
}

impl Default for BatchInput {
    fn default() -> Self {
        let z = [0.0; LANES];
        Self { len: 0, n: [z; 3], delta: z, r_eff: z, m_eff: z, a_i: z, a_j: z, v_c: [z; 3], v_damp: [z; 3], spin_n: z }
    }
}

/// The tangential springs of a batch (m), updated in place.
#[derive(Debug, Clone, Default)]
pub struct BatchSprings {
    /// Components x, y, z.
    pub xi: [[f64; LANES]; 3],
}

/// What the contacts of a batch exert: the force on i (N) and the torques on i and j (N·m).
#[derive(Debug, Clone)]
pub struct BatchOutput {
    /// Force on i.
    pub force: [[f64; LANES]; 3],
    /// Torque on i.
    pub torque_i: [[f64; LANES]; 3],
    /// Torque on j.
    pub torque_j: [[f64; LANES]; 3],
}

impl Default for BatchOutput {
    fn default() -> Self {
        let z = [[0.0; LANES]; 3];
        Self { force: z, torque_i: z, torque_j: z }
    }
}

/// `a` where `c` holds, else `b`: the branch of the scalar law, as a selection.
#[inline(always)]
fn select(c: bool, a: f64, b: f64) -> f64 {
    if c {
        a
    } else {
        b
    }
}

impl PairLaw {
    /// True if [`PairLaw::compute_batch`] covers this law: no rolling resistance, no capillary
    /// bridge.
    pub fn batchable(&self) -> bool {
        self.rolling.is_none() && self.capillary.is_none()
    }

    /// Evaluates the first `input.len` contacts of a batch: the same values as
    /// [`PairLaw::compute`] for each (the law must be [`PairLaw::batchable`]), with springs
    /// `xi` updated in place. Every lane is computed, in use or not (loops of a fixed length
    /// become vector instructions); the lanes past `input.len` hold whatever they held and their
    /// results are to be ignored. On a processor with AVX2 the loops run four contacts per
    /// instruction instead of two (chosen at run time; the results are the same to the bit:
    /// no operation is fused).
    pub fn compute_batch(&self, input: &BatchInput, springs: &mut BatchSprings, out: &mut BatchOutput, dt: f64) {
        compute_batch(self, input, springs, out, dt);
    }
}

#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn compute_batch(law: &PairLaw, input: &BatchInput, springs: &mut BatchSprings, out: &mut BatchOutput, dt: f64) {
    law.evaluate(input, springs, out, dt);
}

impl PairLaw {
    #[inline(always)]
    fn evaluate(&self, input: &BatchInput, springs: &mut BatchSprings, out: &mut BatchOutput, dt: f64) {
        debug_assert!(self.batchable());
        let len = LANES;
        let [nx, ny, nz] = &input.n;
        let [vcx, vcy, vcz] = &input.v_c;
        let [vdx, vdy, vdz] = &input.v_damp;
        let [xx, xy, xz] = &mut springs.xi;
        let mut f_normal = [0.0; LANES];
        let mut gamma_n = [0.0; LANES];
        let mut vn = [0.0; LANES];
        // Normal force: elastic part and dashpot, floored at zero when asked.
        match self.normal {
            NormalLaw::Linear(l) => {
                for k in 0..len {
                    gamma_n[k] = l.damping(input.delta[k], input.r_eff[k], input.m_eff[k]);
                }
            }
            NormalLaw::Hertz(h) => {
                for k in 0..len {
                    gamma_n[k] = h.damping(input.delta[k], input.r_eff[k], input.m_eff[k]);
                }
            }
        }
        for k in 0..len {
            vn[k] = vdx[k] * nx[k] + vdy[k] * ny[k] + vdz[k] * nz[k];
        }
        match self.normal {
            NormalLaw::Linear(l) => {
                for k in 0..len {
                    f_normal[k] = l.elastic(input.delta[k], input.r_eff[k]) + gamma_n[k] * -vn[k];
                }
            }
            NormalLaw::Hertz(h) => {
                for k in 0..len {
                    f_normal[k] = h.elastic(input.delta[k], input.r_eff[k]) + gamma_n[k] * -vn[k];
                }
            }
        }
        for k in 0..len {
            let touching = input.delta[k] > 0.0;
            let floored = self.limit_damping && f_normal[k] < 0.0;
            f_normal[k] = select(touching && !floored, f_normal[k], 0.0);
        }
        let [fx, fy, fz] = &mut out.force;
        let [tix, tiy, tiz] = &mut out.torque_i;
        let [tjx, tjy, tjz] = &mut out.torque_j;
        // Without friction for the whole run there is no tangential force and no spring.
        let tangential = self.friction > 0.0 || self.tangential_history;
        // Tangential stiffness and dashpot.
        let mut k_t = [0.0; LANES];
        let mut gamma_t = [0.0; LANES];
        match self.tangential {
            TangentialLaw::Linear { k_t: k, damping_ratio } => {
                for kk in 0..len {
                    k_t[kk] = k;
                    gamma_t[kk] = damping_ratio * gamma_n[kk];
                }
            }
            TangentialLaw::Mindlin { g_star, damp } => {
                for k in 0..len {
                    let kt = 8.0 * g_star * (input.r_eff[k] * input.delta[k]).sqrt();
                    k_t[k] = kt;
                    gamma_t[k] = damp * (kt * input.m_eff[k]).sqrt();
                }
            }
        }
        // The loops below are short on purpose: each becomes vector instructions.
        // 1. Carry the spring with the contact frame (super::tangential::carry_spring).
        for k in 0..len {
            let (n0, n1, n2) = (nx[k], ny[k], nz[k]);
            let (x0, x1, x2) = (xx[k], xy[k], xz[k]);
            let len2 = x0 * x0 + x1 * x1 + x2 * x2;
            let s = input.spin_n[k] * dt;
            let c = n0 * x0 + n1 * x1 + n2 * x2;
            let (w0, w1, w2) = ((x1 * n2 - x2 * n1) * s, (x2 * n0 - x0 * n2) * s, (x0 * n1 - x1 * n0) * s);
            let kept = 1.0 - c * c / len2;
            let e = 1.0 - kept * (1.0 + s * s);
            let series = 1.0 + e * (0.5 + e * (0.375 + e * 0.3125));
            let exact = (1.0 / (kept * (1.0 + s * s))).sqrt();
            let scale = select(e.abs() < 1e-4, series, select(kept > 0.0, exact, 0.0));
            let carried = len2 != 0.0;
            xx[k] = select(carried, (x0 - w0 - n0 * c) * scale, x0);
            xy[k] = select(carried, (x1 - w1 - n1 * c) * scale, x1);
            xz[k] = select(carried, (x2 - w2 - n2 * c) * scale, x2);
        }
        // 2. Advance it by the mid-step tangential velocity; the trial force with the dashpot
        // on the predicted one (super::tangential::tangential_force).
        let (mut f_t, mut mag2) = ([[0.0; LANES]; 3], [0.0; LANES]);
        for k in 0..len {
            let (n0, n1, n2) = (nx[k], ny[k], nz[k]);
            let vcn = vcx[k] * n0 + vcy[k] * n1 + vcz[k] * n2;
            let (vt0, vt1, vt2) = (vcx[k] - n0 * vcn, vcy[k] - n1 * vcn, vcz[k] - n2 * vcn);
            let (vd0, vd1, vd2) = (vdx[k] - n0 * vn[k], vdy[k] - n1 * vn[k], vdz[k] - n2 * vn[k]);
            xx[k] += vt0 * dt;
            xy[k] += vt1 * dt;
            xz[k] += vt2 * dt;
            let (kt, gt) = (k_t[k], gamma_t[k]);
            let (f0, f1, f2) = (-(xx[k] * kt + vd0 * gt), -(xy[k] * kt + vd1 * gt), -(xz[k] * kt + vd2 * gt));
            (f_t[0][k], f_t[1][k], f_t[2][k]) = (f0, f1, f2);
            mag2[k] = f0 * f0 + f1 * f1 + f2 * f2;
        }
        // 3. The Coulomb cap: a sliding contact's force is scaled onto it and its spring holds
        // that force alone; separated grains forget their spring.
        for k in 0..len {
            let cap = self.friction * f_normal[k].max(0.0);
            let sliding = mag2[k] > cap * cap;
            let ratio = select(mag2[k] > 0.0, cap / mag2[k].sqrt(), 1.0);
            let kt = k_t[k];
            let spring = kt > 0.0;
            let kept_force = input.delta[k] > 0.0 && tangential;
            let [f0, f1, f2] = &mut f_t;
            for (f, x) in [(&mut f0[k], &mut xx[k]), (&mut f1[k], &mut xy[k]), (&mut f2[k], &mut xz[k])] {
                let capped = select(sliding, *f * ratio, *f);
                let reset = select(sliding, select(spring, -capped / kt, 0.0), *x);
                *x = select(kept_force, reset, 0.0);
                *f = select(kept_force, capped, 0.0);
            }
        }
        // 4. Force on i and the torques of the tangential force.
        for k in 0..len {
            let (n0, n1, n2) = (nx[k], ny[k], nz[k]);
            let (f0, f1, f2) = (f_t[0][k], f_t[1][k], f_t[2][k]);
            let fnorm = f_normal[k];
            fx[k] = n0 * fnorm + f0;
            fy[k] = n1 * fnorm + f1;
            fz[k] = n2 * fnorm + f2;
            let (c0, c1, c2) = (n1 * f2 - n2 * f1, n2 * f0 - n0 * f2, n0 * f1 - n1 * f0);
            let (ai, aj) = (input.a_i[k], input.a_j[k]);
            // (+ 0.0: the scalar law adds its zero rolling moment, which turns -0 into +0.)
            tix[k] = -c0 * ai + 0.0;
            tiy[k] = -c1 * ai + 0.0;
            tiz[k] = -c2 * ai + 0.0;
            tjx[k] = -c0 * aj;
            tjy[k] = -c1 * aj;
            tjz[k] = -c2 * aj;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::ContactTable;
    use crate::scene::{ElasticLaw, Material};
    use rand::{Rng, SeedableRng};

    fn material(law: ElasticLaw, mu: f64, limit: bool) -> Material {
        Material {
            name: "m".into(),
            density: 2500.0,
            law,
            restitution: 0.6,
            friction: mu,
            tangential_damping_ratio: 0.5,
            limit_damping: limit,
            rolling: None,
            liquid: None,
            cohesion: None,
            deformable: None,
        }
    }

    /// Random contacts: overlaps from none to 2% of the radius (and a few separated), springs
    /// from none to well past the Coulomb cap, velocities that make some dashpots pull.
    fn random_inputs(rng: &mut impl Rng, count: usize) -> Vec<(ContactInput, Vec3)> {
        (0..count)
            .map(|k| {
                let mut v = || Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
                let n = v().normalize();
                let (v_c, v_damp, w) = (v() * 0.1, v() * 0.1, v() * 100.0);
                let xi = if k % 5 == 0 { Vec3::zeros() } else { v() * 1e-5 };
                let (r_i, r_j) = (rng.gen_range(4e-4..6e-4), rng.gen_range(4e-4..6e-4));
                let delta = if k % 7 == 0 { -1e-6 } else { rng.gen_range(0.0..0.02) * r_i };
                let input = ContactInput {
                    n,
                    delta,
                    r_i,
                    r_j,
                    r_eff: r_i * r_j / (r_i + r_j),
                    m_eff: rng.gen_range(1e-7..1e-6),
                    a_i: r_i - 0.5 * delta,
                    a_j: r_j - 0.5 * delta,
                    v_c,
                    v_damp,
                    w_rel: w,
                    spin_n: 0.5 * w.dot(&n),
                };
                (input, xi)
            })
            .collect()
    }

    #[test]
    fn a_batch_gives_the_scalar_law_to_the_last_bit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let laws = [
            ElasticLaw::Linear { k_n: 1e4, k_t: 2857.0 },
            ElasticLaw::Linear { k_n: 1e4, k_t: 0.0 },
            ElasticLaw::HertzMindlin { young: 1e8, poisson: 0.3 },
        ];
        for law in laws {
            for (mu, limit) in [(0.5, true), (0.5, false), (0.0, true), (0.05, true)] {
                let pair = *ContactTable::new(&[material(law, mu, limit)]).get(0, 0);
                assert!(pair.batchable());
                let contacts = random_inputs(&mut rng, 2 * LANES + 5);
                for chunk in contacts.chunks(LANES) {
                    let (mut input, mut springs, mut out) = (BatchInput::default(), BatchSprings::default(), BatchOutput::default());
                    input.len = chunk.len();
                    for (k, (c, xi)) in chunk.iter().enumerate() {
                        for a in 0..3 {
                            input.n[a][k] = c.n[a];
                            input.v_c[a][k] = c.v_c[a];
                            input.v_damp[a][k] = c.v_damp[a];
                            springs.xi[a][k] = xi[a];
                        }
                        (input.delta[k], input.r_eff[k], input.m_eff[k]) = (c.delta, c.r_eff, c.m_eff);
                        (input.a_i[k], input.a_j[k], input.spin_n[k]) = (c.a_i, c.a_j, c.spin_n);
                    }
                    pair.compute_batch(&input, &mut springs, &mut out, 1e-6);
                    for (k, (c, xi)) in chunk.iter().enumerate() {
                        let mut xi = *xi;
                        let want = pair.compute(c, &mut xi, None, None, 1e-6);
                        for a in 0..3 {
                            let what = format!("{law:?} mu {mu} limit {limit}, contact {k}, axis {a}");
                            assert_eq!(out.force[a][k].to_bits(), want.force[a].to_bits(), "force, {what}");
                            assert_eq!(out.torque_i[a][k].to_bits(), want.torque_i[a].to_bits(), "torque i, {what}");
                            assert_eq!(out.torque_j[a][k].to_bits(), want.torque_j[a].to_bits(), "torque j, {what}");
                            assert_eq!(springs.xi[a][k].to_bits(), xi[a].to_bits(), "spring, {what}");
                        }
                    }
                }
            }
        }
    }
}
