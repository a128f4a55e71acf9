//! One contact between a round body and a body or boundary, as the solver sees it: its
//! second member ([`Side`]), frame, levers, Delassus block, law and impulse, and what it does to
//! the bodies it joins.

use super::bodies::BodyStore;
use super::frame::ContactFrame;
use super::local::{Delassus, LocalLaw, Rolling};
#[cfg(test)]
use super::sweep::law_for;
use crate::math::{Real, Vec3};

/// The second member of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Another body (particle index).
    Body(u32),
    /// A boundary (wall, drum), by its index in [`RigidBodies::boundary_vel`]: of imposed
    /// motion, or free to translate along one direction (a stress-controlled wall).
    Boundary(u32),
    /// Another body seen through the boundary of a deforming periodic cell: body `j`'s image
    /// `k` periods away along each axis, in a cell whose lengths change at the velocity of
    /// boundary `cell` (component `a` of that velocity: dL_a/dt, m/s). The image moves at
    /// `v_j + k ⊙ V_cell`; when the cell is free to deform (a stress-controlled cell), the
    /// contact's impulse acts on it too — the cell is then a body of the contact problem, as a
    /// stress-controlled wall is.
    Image {
        /// Particle index.
        j: u32,
        /// Boundary slot of the cell.
        cell: u8,
        /// Periods crossed along x, y, z.
        k: [i8; 3],
    },
}

impl Side {
    /// The other body, if the contact is between two bodies (directly or through an image).
    #[inline(always)]
    pub fn body(&self) -> Option<u32> {
        match *self {
            Side::Body(j) | Side::Image { j, .. } => Some(j),
            Side::Boundary(_) => None,
        }
    }
}

/// A contact for the solver's tests: between `i` and `j` along `n` at levers `a_i`, `a_j`, of
/// Delassus block `w`, inelastic, frictionless, at rest, carrying nothing.
#[cfg(test)]
pub(crate) fn test_contact(i: u32, j: Side, n: Vec3, (a_i, a_j): (Real, Real), w: Delassus) -> RigidContact {
    RigidContact {
        i,
        j,
        near: false,
        frame: ContactFrame::new(2, n),
        a_i,
        a_j,
        drive: Vec3::zeros(),
        w,
        law: law_for(0.0, 0.0, 0.0, 0.0),
        r: Vec3::zeros(),
        rolling: Rolling::default(),
        scale: 0.0,
    }
}

/// `k ⊙ v`: the velocity of an image `k` periods away in a cell whose lengths change at `v`.
#[inline(always)]
pub fn image_lever(k: [i8; 3], v: &Vec3) -> Vec3 {
    Vec3::new(k[0] as Real * v.x, k[1] as Real * v.y, k[2] as Real * v.z)
}

/// One contact between a round body `i` and a body or boundary `j`, with its law for the step
/// and its impulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidContact {
    /// First body.
    pub i: u32,
    /// Second body or boundary.
    pub j: Side,
    /// A pair that is apart and not closing, in the problem only so that nothing within the
    /// step drives it in (a method's choice: CD's near pairs): it counts in the criterion as a
    /// contact only in the sweeps where it acts (carries or changes an impulse); otherwise only
    /// by what it violates. A dense packing has about as many near pairs as contacts: counted
    /// while idle, they doubled the number the mean violation divides by and the impulse scale
    /// of the relative change, and loosened both bounds as much.
    pub near: bool,
    /// Local frame; `n` points from `j` towards `i`.
    pub frame: ContactFrame,
    /// Distance from the centre of `i` to the contact point (along `-n`), m.
    pub a_i: Real,
    /// Distance from the centre of `j` to the contact point (along `n`), m (0 for a boundary).
    pub a_j: Real,
    /// Velocity of the second member's material point that does not come from the velocities
    /// of body or boundary `j`: the surface velocity of a turning drum, or the Lees-Edwards
    /// velocity of the periodic image of `j`, m/s.
    pub drive: Vec3,
    /// Local Delassus block, 1/kg.
    pub w: Delassus,
    /// The law for this step.
    pub law: LocalLaw,
    /// Impulse in local components (n, t1, t2), N·s: the warm start on entry, the solution on
    /// exit.
    pub r: Vec3,
    /// Rolling resistance and its moment impulse ([`Rolling`]; `bound` 0: none).
    pub rolling: Rolling,
    /// Impulse scale of the contact for the convergence criterion, N·s (see the module
    /// documentation): for a method like CD, `(|u_n| + |g| h + 1e-6 (|v_i| + |v_j|)) / w_n`,
    /// the impulse that stops its approach, one step of gravity, and the bodies' speeds at
    /// the level of rounding.
    pub scale: Real,
}

impl RigidContact {
    /// Local Delassus block of a contact between bodies of inverse masses and inertias
    /// `(im_i, ii_i)` and `(im_j, ii_j)` (zeros for a boundary) at lever arms `a_i`, `a_j`.
    pub fn delassus(im_i: Real, ii_i: Real, a_i: Real, im_j: Real, ii_j: Real, a_j: Real) -> Delassus {
        let translation = im_i + im_j;
        Delassus { n: translation, t: translation + a_i * a_i * ii_i + a_j * a_j * ii_j }
    }

    /// Local Delassus block of a round body of inverse mass and inertia `(im, ii)` at lever
    /// arm `a` against a boundary that translates freely along the contact normal with inverse
    /// mass `im_b` (0 for imposed motion). The boundary adds `im_b` on the normal only: plane
    /// walls move along their normal, so the block stays diagonal.
    pub fn delassus_boundary(im: Real, ii: Real, a: Real, im_b: Real) -> Delassus {
        Delassus { n: im + im_b, t: im + a * a * ii }
    }

    /// `w` with a boundary that moves as `lever × s` for a degree of freedom `s` of inverse
    /// mass `im_b` added, at a contact of normal `n`: `im_b (n·lever)²` on the normal and
    /// `im_b (|lever|² - (n·lever)²)` on the tangents (the diagonal of the block; its
    /// off-diagonal terms are left out, as everywhere in the local blocks: NLGS converges to
    /// the same fixed point, since each visit recomputes the velocities from the bodies). For a
    /// plane wall (`lever` along `n`) this is [`RigidContact::delassus_boundary`].
    pub fn with_moving_boundary(w: Delassus, n: &Vec3, lever: &Vec3, im_b: Real) -> Delassus {
        let along = n.dot(lever);
        let across = (lever.norm_squared() - along * along).max(0.0);
        Delassus { n: w.n + im_b * along * along, t: w.t + im_b * across }
    }

    /// Relative velocity of the contact point of `i` against that of `j` (global), m/s.
    #[inline(always)]
    pub fn relative_velocity(&self, vel: &[Vec3], omega: &[Vec3], boundary_vel: &[Vec3]) -> Vec3 {
        self.relative_with(|i| vel[i], |i| omega[i], |k| boundary_vel[k])
    }

    /// [`RigidContact::relative_velocity`] within the solve.
    #[inline(always)]
    pub(super) fn velocity_in(&self, bodies: &impl BodyStore) -> Vec3 {
        self.relative_with(|i| bodies.vel(i), |i| bodies.omega(i), |k| bodies.boundary_vel(k))
    }

    #[inline(always)]
    fn relative_with(&self, vel: impl Fn(usize) -> Vec3, omega: impl Fn(usize) -> Vec3, boundary_vel: impl Fn(usize) -> Vec3) -> Vec3 {
        let i = self.i as usize;
        let n = &self.frame.n;
        let mut spin = omega(i) * self.a_i;
        let mut u = vel(i) - self.drive;
        match self.j {
            Side::Body(j) => {
                let j = j as usize;
                u -= vel(j);
                spin += omega(j) * self.a_j;
            }
            Side::Boundary(k) => u -= boundary_vel(k as usize),
            Side::Image { j, cell, k } => {
                let j = j as usize;
                u -= vel(j) + image_lever(k, &boundary_vel(cell as usize));
                spin += omega(j) * self.a_j;
            }
        }
        u - spin.cross(n)
    }

    /// Applies the global impulse `p` (on `i`; `-p` on `j`) to the bodies' velocities.
    #[inline(always)]
    pub(super) fn apply(&self, p: &Vec3, bodies: &mut impl BodyStore) {
        let i = self.i as usize;
        let n = &self.frame.n;
        let nxp = n.cross(p);
        bodies.add_vel(i, p * bodies.inv_mass(i));
        bodies.add_omega(i, -nxp * (self.a_i * bodies.inv_inertia(i)));
        match self.j {
            Side::Body(j) => {
                let j = j as usize;
                bodies.add_vel(j, -p * bodies.inv_mass(j));
                bodies.add_omega(j, -nxp * (self.a_j * bodies.inv_inertia(j)));
            }
            Side::Boundary(k) => {
                let m = bodies.mobility(k as usize);
                if m.inv_mass > 0.0 {
                    let dv = m.direction * (p.dot(&m.direction) * m.inv_mass);
                    bodies.add_boundary_vel(k as usize, -dv);
                    if let Some(other) = m.partner {
                        bodies.add_boundary_vel(other as usize, dv);
                    }
                }
            }
            Side::Image { j, cell, k } => {
                let j = j as usize;
                bodies.add_vel(j, -p * bodies.inv_mass(j));
                bodies.add_omega(j, -nxp * (self.a_j * bodies.inv_inertia(j)));
                let m = bodies.mobility(cell as usize);
                if m.inv_mass > 0.0 {
                    // The image's velocity is v_j + k ⊙ V: the cell takes -p through the lever
                    // k ⊙ direction.
                    let lever = image_lever(k, &m.direction);
                    bodies.add_boundary_vel(cell as usize, -m.direction * (p.dot(&lever) * m.inv_mass));
                }
            }
        }
    }

    /// Applies the moment impulse `m` (on `i`; `-m` on `j`) to the bodies' spins.
    #[inline(always)]
    pub(super) fn apply_moment(&self, m: &Vec3, bodies: &mut impl BodyStore) {
        let i = self.i as usize;
        bodies.add_omega(i, m * bodies.inv_inertia(i));
        if let Some(j) = self.j.body() {
            let j = j as usize;
            bodies.add_omega(j, -m * bodies.inv_inertia(j));
        }
    }

    /// The rolling velocity of the contact: the tangential part of `omega_i - omega_j`, rad/s
    /// (`omega_j` a boundary's own spin).
    #[inline(always)]
    pub(super) fn rolling_velocity(&self, bodies: &impl BodyStore) -> Vec3 {
        let mut w = bodies.omega(self.i as usize);
        match self.j {
            Side::Body(j) | Side::Image { j, .. } => w -= bodies.omega(j as usize),
            Side::Boundary(k) => w -= bodies.boundary_omega(k as usize),
        }
        let n = &self.frame.n;
        w - n * n.dot(&w)
    }

    /// Force this contact exerts on `i` over a step of `h` seconds (global), N.
    pub fn force(&self, h: Real) -> Vec3 {
        self.frame.to_global(&self.r) / h
    }
}
