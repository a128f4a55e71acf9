//! The contacts of a contact-dynamics step (`Detect` in the module documentation of
//! [`super`]): every listed pair and every grain against a boundary whose gap closes within the
//! step, comes near, or attracts, with its frame, Delassus block, local law and warm start.

use super::laws::PairLaws;
use super::{Cd, ALERT, RESTORE, SPEED_FLOOR};
use crate::geometry::neighbors::PairRef;
use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::methods::rigid::NOT_GLUED;
use crate::nscd::{image_lever, law_for};
use crate::nscd::{ContactFrame, LocalLaw, Mobility, RigidContact, Rolling, Side};
use crate::particles::Particles;

/// Key of a wall contact: `(i, WALL_KEY - w)` for wall `w`, above every particle index.
pub(super) const WALL_KEY: u32 = u32::MAX;

/// The pair a contact joins, for the warm start: `(i, j)` with `i < j` as the neighbour list
/// holds them (whichever of the two is glued to a wall), or `(i, WALL_KEY - w)` for grain `i`
/// against boundary `w`.
fn key_of(i: u32, other: Side) -> (u32, u32) {
    match other {
        Side::Body(j) | Side::Image { j, .. } => (i, j),
        Side::Boundary(w) => (i, WALL_KEY - w),
    }
}

/// What a pair carried at the end of a step, for the next one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Held {
    /// The pair ([`key_of`]).
    pub key: (u32, u32),
    /// Impulse on the key's first grain, global components, N·s (the warm start; a contact
    /// seen from the other grain, as one with a glued grain may be, takes its opposite).
    pub r: Vec3,
    /// Rolling moment impulse on the key's first grain, N·m·s (the warm start).
    pub m: Vec3,
    /// The contact pressed (compressive normal impulse): the next step's contact is a lasting
    /// one, without restitution.
    pub pressed: bool,
    /// A capillary bridge joins the pair.
    pub bridge: bool,
}

/// What a contact of the step is, beside its impulse.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Status {
    /// The pair ([`key_of`]): two grains (one may be glued to a wall: its contact is then one
    /// of the wall's), or a grain and a boundary.
    pub key: (u32, u32),
    /// The grains touch (gap within [`ALERT`] at the start of the step).
    pub touching: bool,
    /// A capillary bridge joins them.
    pub bridge: bool,
    /// The contact's part of the normal impulse is compressive at the end of the step
    /// ([`LocalLaw::contact_part`]; set after the solve).
    pub pressed: bool,
}

/// `law` with its Signorini bound raised, for a contact interpenetrated beyond `slop` of
/// `radius` (gap `g` < 0, m), to the normal velocity that removes [`RESTORE`] of the excess over
/// a step of `h` seconds (Baumgarte's stabilisation of the gap, kept gentle). Velocity Signorini
/// stops approaches, not gaps: what a solve converged to `violation_tolerance` leaves as
/// approach, a packing held at rest by stress-controlled walls accumulates step after step, until
/// it creeps to the interpenetration limit. At 1/50 of the excess per step the restoration speed
/// stays of the order of the violation that feeds it; the slop leaves alone the overlaps Moreau's
/// anticipation makes anyway. The slop should lie above the interpenetration the solve leaves in
/// the packing: contacts held at the slop's edge are pushed apart at every step, and the packing,
/// stirred, creeps instead of coming to rest (docs/methods/cd.md, "Design measurements").
fn restoring(mut law: LocalLaw, g: Real, radius: Real, h: Real, slop: Real) -> LocalLaw {
    let excess = -g - slop * radius;
    if excess > 0.0 {
        law.target = law.target.max(RESTORE * excess / h);
    }
    law
}

/// The law of a pair that is open over the step but attracts (`cohesion` > 0, N·s): the
/// Signorini bound at position level, `U_n >= -(g + (1 - theta) h u_n) / (theta h)` — the
/// approach that closes the gap `g` by the end of the step under the theta-scheme — so that the
/// attraction acts freely (`r_n = -cohesion`) unless it would pull the grains into each other,
/// where the contact stops them. `ahead` is `(1 - theta) h`, `theta_h` is `theta h`, s. An impact
/// within the range of attraction is inelastic.
fn open_law(g: Real, u_n: Real, ahead: Real, theta_h: Real, mu: Real, cohesion: Real) -> LocalLaw {
    LocalLaw { target: -(g + ahead * u_n) / theta_h, friction: mu, cohesion, viscosity: 0.0 }
}

/// The law of a pair that is open over the step and does not attract, and whose start
/// velocity does not close it within the step, but is near (see the module documentation,
/// `Detect`), for a step of `h` seconds (theta-scheme, `theta`): its gap `g` (m) may end the
/// step `allow` (m) deep, no deeper, whatever happens within the step:
/// `g + h (theta U_n + (1 - theta) u_n) >= -allow`, `u_n` its normal velocity at the start
/// (m/s). Frictionless: it is a stop against grains driven within the step into neighbours the
/// anticipation left out, not a contact the pair is known to make (with friction, such stops
/// added enough redundancy to lock Gauss-Seidel into a cycle in a rotating drum of 300 disks).
fn near_law(g: Real, u_n: Real, h: Real, theta: Real, allow: Real) -> LocalLaw {
    LocalLaw { target: (-allow - g - (1.0 - theta) * h * u_n) / (theta * h), friction: 0.0, cohesion: 0.0, viscosity: 0.0 }
}

/// How a candidate's gap stands over the step.
#[derive(Debug, Clone, Copy)]
struct Approach {
    /// Gap at the start of the step, m.
    g: Real,
    /// The smaller radius, m.
    r: Real,
    /// Normal velocity at the start of the step (positive apart), m/s.
    u_n: Real,
    /// Gap below which the contact counts as closed, m ([`ALERT`] of `r`).
    alert: Real,
    /// The gap closes by the theta point of the step at the start velocity.
    closing: bool,
    /// Within `max_interpenetration` of `r` and not closing over the whole step.
    near: bool,
}

/// A contact found, with what its status records.
struct Found {
    contact: RigidContact,
    key: (u32, u32),
    touching: bool,
    bridge: bool,
    /// Gap and radius of a closing contact, for the interpenetration record.
    closing: Option<(Real, Real)>,
}

/// What every candidate of one detection reads.
struct Scan<'a> {
    p: &'a Particles,
    domain: &'a Domain,
    laws: &'a PairLaws,
    dim: usize,
    /// Step, s; implicitness; `(1 - theta) h`; gravity's velocity over the step, m/s.
    h: Real,
    theta: Real,
    ahead: Real,
    gh: Real,
    slop: Real,
    near_gap: Real,
    previous: &'a [Held],
    glued_to: &'a [u16],
    wall_mobility: &'a [Mobility],
    /// The deforming cell's slot, its velocity at the start of the step and mobility, and
    /// whether a contact across the boundary along each axis sees it move.
    cell: usize,
    cell_v0: Vec3,
    cell_mobility: Mobility,
    moving: [bool; 3],
}

impl Scan<'_> {
    /// What the pair carried at the last step, if anything: the warm start, and whether it was
    /// pressed (a lasting contact, whose impact is over: no restitution) or bridged.
    fn held(&self, key: (u32, u32)) -> Option<Held> {
        self.previous.binary_search_by(|e| e.key.cmp(&key)).ok().map(|k| self.previous[k])
    }

    /// The wall grain `i` is glued to, if any.
    fn glued(&self, i: usize) -> Option<usize> {
        self.glued_to.get(i).copied().filter(|&w| w != NOT_GLUED).map(|w| w as usize)
    }

    /// The approach of gap `g` (smaller radius `r`) at normal velocity `u_n`; `near` if the gap
    /// is within `max_interpenetration` of `r`.
    fn approach(&self, g: Real, r: Real, u_n: Real, near: bool) -> Approach {
        let alert = ALERT * r;
        // Not closing over the whole step at its start velocity either.
        Approach { g, r, u_n, alert, closing: g + self.ahead * u_n <= alert, near: near && g + self.h * u_n > 0.0 }
    }

    /// The local law of the step: a closing contact's impact (none for a lasting one) with the
    /// gap's restoration, an open but attracting pair's position-level bound, or a near pair's
    /// stop.
    fn law(&self, a: &Approach, e: Real, mu: Real, cohesion: Real, old: Option<Held>) -> LocalLaw {
        if a.closing {
            let e = if old.is_some_and(|o| o.pressed) { 0.0 } else { e };
            restoring(law_for(a.u_n, e, mu, cohesion), a.g, a.r, self.h, self.slop)
        } else if cohesion != 0.0 {
            open_law(a.g, a.u_n, self.ahead, self.theta * self.h, mu, cohesion)
        } else {
            near_law(a.g, a.u_n, self.h, self.theta, self.slop * a.r)
        }
    }

    /// The contact of grain `i` with its listed neighbour `pr`, if the pair closes, comes near
    /// or attracts within the step.
    fn pair(&self, i: usize, pr: &PairRef) -> Option<Found> {
        let (p, laws) = (self.p, self.laws);
        let j = pr.j as usize;
        let (glued_i, glued_j) = (self.glued(i), self.glued(j));
        if glued_i.is_some() && glued_j.is_some() {
            return None;
        }
        let k = pr.image;
        let d = p.pos[i] - p.pos[j] - self.domain.image_shift(k);
        let dist = d.norm();
        let (ri, rj) = (p.radius[i], p.radius[j]);
        let (g, r) = (dist - ri - rj, ri.min(rj));
        let attraction = laws.attraction(p.material[i], p.material[j]);
        // Primaries of one aggregate: the bond's attraction instead of the materials'.
        let bond = p.bonding(i, j);
        let range = bond.map_or_else(|| attraction.range(), |b| b.attraction.range());
        let near = g <= self.near_gap * r;
        if !near && self.ahead == 0.0 && g > range {
            return None;
        }
        let n = d / dist;
        let drive = Vec3::new(self.domain.image_velocity(k[1]), 0.0, 0.0);
        // The spins do not move the contact point along the normal of round bodies.
        let u_n = (p.vel[i] - p.vel[j] - drive - image_lever(k, &self.cell_v0)).dot(&n);
        let a = self.approach(g, r, u_n, near);
        if !a.closing && !a.near && g > range {
            return None;
        }
        let old = self.held((i as u32, pr.j));
        let wet = p.wet[i] && p.wet[j] && bond.is_none();
        // A capillary bridge forms on contact and holds up to its rupture distance.
        let bridge =
            attraction.capillary.filter(|cap| wet && (g <= a.alert || (old.is_some_and(|o| o.bridge) && g <= cap.rupture_distance)));
        let h = self.h;
        let cohesion = match bond {
            // The bond's attraction at the step's start gap (F_0 in contact).
            Some(b) => -h * b.attraction.force(g, ri, rj),
            None => {
                h * (attraction.constant.filter(|&(_, d0)| g <= d0.max(a.alert)).map_or(0.0, |(f0, _)| f0)
                    - bridge.map_or(0.0, |cap| cap.force(g, ri, rj)))
            }
        };
        if !a.closing && !a.near && cohesion == 0.0 {
            return None;
        }
        let (a_i, a_j) = (ri + 0.5 * g, rj + 0.5 * g);
        // Primaries of one aggregate touch without bouncing (the sources' inelastic,
        // frictionless contacts, or the bond's friction).
        let (e, mu) = bond.map_or_else(|| laws.pair(p.material[i], p.material[j]), |b| (0.0, b.friction));
        let mut law = self.law(&a, e, mu, cohesion, old);
        // The bridge's liquid resists the approach, implicitly (force per m/s of
        // approach at the gap of the step's start, times the step).
        if let (true, Some(lub)) = (bridge.is_some(), attraction.lubrication) {
            law.viscosity = h * lub.force(g, 1.0, ri, rj);
        }
        // The contact from the free grain's side: a grain glued to a wall is part of it
        // (the contact then is one of the wall's, seen from the other grain: normal,
        // levers and drive turned round); across a deforming cell's boundary the image
        // moves with the cell.
        let across = (0..3).any(|a| k[a] != 0 && self.moving[a]);
        let (first, second, side, n, a_first, a_second, drive) = match (glued_i, glued_j) {
            (None, None) if across => (i, j, Side::Image { j: pr.j, cell: self.cell as u8, k }, n, a_i, a_j, drive),
            (None, None) => (i, j, Side::Body(pr.j), n, a_i, a_j, drive),
            (None, Some(w)) => (i, j, Side::Boundary(w as u32), n, a_i, a_j, drive),
            (Some(w), _) => (j, i, Side::Boundary(w as u32), -n, a_j, a_i, -drive),
        };
        let frame = ContactFrame::new(self.dim, n);
        // -1 when the contact is seen from the key's second grain.
        let turned = if first == i { 1.0 } else { -1.0 };
        let (f, o) = (first, second);
        let mut w = RigidContact::delassus(p.inv_mass[f], p.inv_inertia[f], a_first, p.inv_mass[o], p.inv_inertia[o], a_second);
        let mobility = match side {
            Side::Boundary(b) => Some((self.wall_mobility[b as usize], self.wall_mobility[b as usize].direction)),
            Side::Image { k, .. } => Some((self.cell_mobility, image_lever(k, &self.cell_mobility.direction))),
            Side::Body(_) => None,
        };
        if let Some((m, lever)) = mobility.filter(|(m, _)| m.inv_mass > 0.0) {
            w = RigidContact::with_moving_boundary(w, &n, &lever, m.inv_mass);
        }
        let rolling = Rolling {
            bound: if bond.is_some() { 0.0 } else { laws.rolling(p.material[i], p.material[j]) * ri * rj / (ri + rj) },
            w: p.inv_inertia[i] + p.inv_inertia[j],
            m: old.map_or(Vec3::zeros(), |o| o.m * turned),
        };
        let contact = RigidContact {
            i: first as u32,
            j: side,
            near: !a.closing && cohesion == 0.0,
            frame,
            a_i: a_first,
            a_j: a_second,
            drive,
            w,
            law,
            r: old.map_or(Vec3::zeros(), |o| frame.to_local(&(o.r * turned))),
            rolling,
            scale: (u_n.abs() + self.gh + SPEED_FLOOR * (p.vel[i].norm() + p.vel[j].norm())) / w.n + cohesion,
        };
        let closing = a.closing.then_some((g, r));
        Some(Found { contact, key: (i as u32, pr.j), touching: g <= a.alert, bridge: bridge.is_some(), closing })
    }

    /// The contact of grain `i` with boundary `k` (a plane wall, or the drum's slot after
    /// them): `n` from the surface towards the grain, `dist` from the grain's centre to the
    /// contact point, `v_b` the surface's velocity there, `drive` its part that is not the
    /// boundary's translation (the drum's rotation).
    fn boundary(&self, i: usize, k: usize, n: Vec3, dist: Real, v_b: Vec3, drive: Vec3) -> Option<Found> {
        if self.glued(i).is_some() {
            return None;
        }
        let (p, laws) = (self.p, self.laws);
        let r = p.radius[i];
        let g = dist - r;
        let attraction = laws.wall_attraction(p.material[i]);
        let near = g <= self.near_gap * r;
        if !near && self.ahead == 0.0 && g > attraction.range() {
            return None;
        }
        let u_n = (p.vel[i] - v_b).dot(&n);
        let a = self.approach(g, r, u_n, near);
        if !a.closing && !a.near && g > attraction.range() {
            return None;
        }
        let cohesion = self.h * attraction.constant.filter(|&(_, d0)| g <= d0.max(a.alert)).map_or(0.0, |(f0, _)| f0);
        if !a.closing && !a.near && cohesion == 0.0 {
            return None;
        }
        let frame = ContactFrame::new(self.dim, n);
        let (e, mu) = laws.wall(p.material[i]);
        let key = key_of(i as u32, Side::Boundary(k as u32));
        let old = self.held(key);
        let wd = RigidContact::delassus_boundary(p.inv_mass[i], p.inv_inertia[i], dist, self.wall_mobility[k].inv_mass);
        let rolling = Rolling { bound: laws.wall_rolling(p.material[i]) * r, w: p.inv_inertia[i], m: old.map_or(Vec3::zeros(), |o| o.m) };
        let contact = RigidContact {
            i: i as u32,
            j: Side::Boundary(k as u32),
            near: !a.closing && cohesion == 0.0,
            frame,
            a_i: dist,
            a_j: 0.0,
            drive,
            w: wd,
            law: self.law(&a, e, mu, cohesion, old),
            r: old.map_or(Vec3::zeros(), |o| frame.to_local(&o.r)),
            rolling,
            scale: (u_n.abs() + self.gh + SPEED_FLOOR * (p.vel[i].norm() + v_b.norm())) / wd.n + cohesion,
        };
        Some(Found { contact, key, touching: g <= a.alert, bridge: false, closing: a.closing.then_some((g, r)) })
    }
}

impl Cd {
    /// The contacts of the step from the current positions and velocities (see the module
    /// documentation), with their warm-start impulses; records the interpenetration.
    pub(super) fn detect(&mut self) {
        let (h, theta) = (self.h, self.params.theta);
        let cell = self.cell_slot;
        let (cell_v0, cell_mobility) = (self.cell_vel, self.wall_mobility[cell]);
        let scan = Scan {
            p: &self.w.p,
            domain: &self.w.domain,
            laws: &self.laws,
            dim: self.w.dim,
            h,
            theta,
            ahead: (1.0 - theta) * h,
            gh: self.w.gravity.norm() * h,
            slop: self.params.slop,
            // Pairs this close (as a fraction of the smaller radius) that their start velocity
            // does not close within the step are contacts of it too ([`near_law`]).
            near_gap: self.params.max_interpenetration,
            previous: &self.previous,
            glued_to: &self.w.glued_to,
            wall_mobility: &self.wall_mobility,
            cell,
            cell_v0,
            cell_mobility,
            moving: std::array::from_fn(|a| self.cell.is_some() && (cell_v0[a] != 0.0 || cell_mobility.direction[a] != 0.0)),
        };
        self.contacts.clear();
        self.status.clear();
        let (mut worst, mut sum, mut count): (Real, Real, usize) = (0.0, 0.0, 0);
        let mut keep = |found: Option<Found>| {
            let Some(f) = found else { return };
            if let Some((g, r)) = f.closing {
                if g < 0.0 {
                    worst = worst.max(-g / r);
                    sum += -g / r;
                }
                count += 1;
            }
            self.contacts.push(f.contact);
            self.status.push(Status { key: f.key, touching: f.touching, bridge: f.bridge, pressed: false });
        };
        let (p, nl) = (scan.p, &self.nl);
        for i in 0..p.len() {
            let (s, e) = (nl.start[i] as usize, nl.start[i + 1] as usize);
            for pr in &nl.pair[s..e] {
                keep(scan.pair(i, pr));
            }
        }
        for (w, wall) in self.w.walls.iter().enumerate() {
            let n = wall.normal();
            let a = wall.face.axis;
            for i in 0..p.len() {
                keep(scan.boundary(i, w, n, (p.pos[i][a] - wall.position) * n[a], wall.velocity, Vec3::zeros()));
            }
        }
        if let Some(drum) = &self.w.drum {
            let k = self.w.walls.len();
            for i in 0..p.len() {
                let d = drum.radial(&p.pos[i]);
                let rho = d.norm();
                if rho > 0.0 {
                    let v = drum.surface_velocity(&drum.surface_point(&p.pos[i]));
                    keep(scan.boundary(i, k, -d / rho, drum.def.radius - rho, v, v));
                }
            }
        }
        self.interpenetration = (worst, if count > 0 { sum / count as Real } else { 0.0 });
    }
}
