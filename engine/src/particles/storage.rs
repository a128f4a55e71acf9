//! Struct-of-arrays storage of spherical particles (disks in 2D).
//!
//! In 2D a disk is a cylinder of unit thickness (1 m): mass `rho pi R²` (kg per metre of
//! thickness), moment of inertia `m R² / 2`. In 3D a sphere has `m = rho 4/3 pi R³`,
//! `I = 2/5 m R²` (docs/physics.md §1).

use super::aggregate::{Bonding, NO_AGGREGATE};
use crate::math::{Real, Vec3};

/// All particles of a simulation; index `i` addresses the same particle in every array.
#[derive(Debug, Clone, Default)]
pub struct Particles {
    /// Centres, m.
    pub pos: Vec<Vec3>,
    /// Velocities, m/s.
    pub vel: Vec<Vec3>,
    /// Angular velocities, rad/s (along z only in 2D).
    pub omega: Vec<Vec3>,
    /// Total force of the last evaluation, N.
    pub force: Vec<Vec3>,
    /// Total torque of the last evaluation, N·m.
    pub torque: Vec<Vec3>,
    /// Radii, m.
    pub radius: Vec<Real>,
    /// Masses, kg.
    pub mass: Vec<Real>,
    /// 1 / mass, 1/kg.
    pub inv_mass: Vec<Real>,
    /// 1 / moment of inertia, 1/(kg·m²) (0 with `inv_mass` for a grain whose motion is
    /// imposed, such as one glued to a wall).
    pub inv_inertia: Vec<Real>,
    /// Material index.
    pub material: Vec<u16>,
    /// Carries liquid (capillary bridges form only between wet particles).
    pub wet: Vec<bool>,
    /// The aggregate (bonded particle method's grain) the particle is a primary of, an index
    /// into `bondings`, or [`NO_AGGREGATE`].
    pub aggregate: Vec<u32>,
    /// The laws within each aggregate (one entry per aggregate, not per particle).
    pub bondings: Vec<Bonding>,
}

impl Particles {
    /// True if the particle moves freely (false for a grain whose motion is imposed: glued
    /// to a wall, it is part of the wall).
    pub fn is_free(&self, i: usize) -> bool {
        self.inv_mass[i] > 0.0
    }

    /// Kinetic energy of particle `i` with velocity `v` (translation and rotation), J; zero
    /// for a grain whose motion is imposed (its energy is the drive's).
    pub fn kinetic_energy_at(&self, i: usize, v: &Vec3) -> Real {
        if !self.is_free(i) {
            return 0.0;
        }
        0.5 * self.mass[i] * v.norm_squared() + 0.5 * self.omega[i].norm_squared() / self.inv_inertia[i]
    }

    /// The laws between particles `i` and `j` if they are primaries of one aggregate.
    #[inline(always)]
    pub fn bonding(&self, i: usize, j: usize) -> Option<&Bonding> {
        let a = *self.aggregate.get(i)?;
        if a == NO_AGGREGATE || self.aggregate.get(j) != Some(&a) {
            return None;
        }
        self.bondings.get(a as usize)
    }

    /// Number of aggregates.
    pub fn aggregate_count(&self) -> usize {
        self.bondings.len()
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True if there is no particle.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Mass of a particle of radius `r` and density `rho` in `dim` dimensions, kg.
    pub fn mass_of(dim: usize, r: Real, rho: Real) -> Real {
        if dim == 2 {
            rho * std::f64::consts::PI * r * r
        } else {
            rho * 4.0 / 3.0 * std::f64::consts::PI * r * r * r
        }
    }

    /// Volume (area in 2D) of a particle of radius `r`, m³ (m² in 2D).
    pub fn volume_of(dim: usize, r: Real) -> Real {
        if dim == 2 {
            std::f64::consts::PI * r * r
        } else {
            4.0 / 3.0 * std::f64::consts::PI * r * r * r
        }
    }

    /// Appends a particle.
    #[allow(clippy::too_many_arguments)]
    pub fn push(&mut self, dim: usize, pos: Vec3, vel: Vec3, r: Real, density: Real, material: u16, wet: bool) {
        let m = Self::mass_of(dim, r, density);
        let inertia = if dim == 2 { 0.5 * m * r * r } else { 0.4 * m * r * r };
        self.pos.push(pos);
        self.vel.push(vel);
        self.omega.push(Vec3::zeros());
        self.force.push(Vec3::zeros());
        self.torque.push(Vec3::zeros());
        self.radius.push(r);
        self.mass.push(m);
        self.inv_mass.push(1.0 / m);
        self.inv_inertia.push(1.0 / inertia);
        self.material.push(material);
        self.wet.push(wet);
        self.aggregate.push(NO_AGGREGATE);
    }

    /// Reorders every array by `order` (new index k holds old particle `order[k]`).
    pub fn permute(&mut self, order: &[usize]) {
        fn apply<T: Clone>(v: &mut Vec<T>, order: &[usize]) {
            *v = order.iter().map(|&k| v[k].clone()).collect();
        }
        apply(&mut self.pos, order);
        apply(&mut self.vel, order);
        apply(&mut self.omega, order);
        apply(&mut self.force, order);
        apply(&mut self.torque, order);
        apply(&mut self.radius, order);
        apply(&mut self.mass, order);
        apply(&mut self.inv_mass, order);
        apply(&mut self.inv_inertia, order);
        apply(&mut self.material, order);
        apply(&mut self.wet, order);
        apply(&mut self.aggregate, order);
    }

    /// Heap bytes held by the arrays.
    pub fn heap_bytes(&self) -> usize {
        let v3 = std::mem::size_of::<Vec3>();
        let r = std::mem::size_of::<Real>();
        5 * self.pos.capacity() * v3
            + 4 * self.radius.capacity() * r
            + self.material.capacity() * 2
            + self.wet.capacity()
            + self.aggregate.capacity() * 4
            + self.bondings.capacity() * std::mem::size_of::<Bonding>()
    }
}
