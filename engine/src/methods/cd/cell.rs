//! The deforming periodic cell of contact dynamics.
//!
//! Rigid grains cannot follow DEM's remapping of positions (LAMMPS's `fix deform remap x`): a
//! jammed packing cannot be compressed at all, and an imposed affine squeeze of every pair would
//! leave the contact problem without a solution. Here the grains keep their positions and
//! velocities, and the cell's lengths `L_a` move: the image of grain `j` `k` periods away sits at
//! `x_j + k ⊙ L` and moves at `v_j + k ⊙ dL/dt`, so only the contacts across the cell's boundary
//! ([`crate::nscd::Side::Image`]) see the deformation, as the contacts of a wall see the wall.
//!
//! - Imposed strain rates `r`: `dL_a/dt = r_a L_a`, a boundary of imposed motion.
//! - A pressure or normal-stress target: the cell is a body of the contact problem, like a
//!   stress-controlled wall. Its one degree of freedom `s` (m/s) moves the lengths along a unit
//!   `direction` (`dL/dt = s direction`; for the pressure, `direction ∝ L` on every periodic
//!   axis, so the strain rate `s / |L|` is the same on each; for a normal stress, the axis). Its
//!   inertia is [`Cell::mass`]; each step the target pushes it by `-σ Σ_a A_a direction_a` over
//!   the step (`A_a = V / L_a`, the face normal to `a`), and the contacts across the boundary push
//!   back. At rest the two balance: since every grain is in balance, the force the contacts
//!   carry across the boundary, `-Σ k_a f_a` over them, is `σ_aa A_a` (the virial over all
//!   contacts reduces to the boundary terms), so the cell holds the target stress. The speed ends
//!   each step within `max_strain_rate × |L|`. The servo's `gain` is not used: the cell's answer
//!   is set by its mass, not by a gain.

use crate::geometry::Domain;
use crate::loading::CellDeformation;
use crate::math::{Real, Vec3};
use crate::nscd::Mobility;
use crate::scene::Deformation;

/// A deforming periodic cell.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Cell {
    /// What is imposed.
    pub kind: Deformation,
    /// Speed of the free degree of freedom along `direction`, m/s (stress targets).
    pub(super) speed: Real,
    /// Mass of the free degree of freedom, kg.
    pub(super) mass: Real,
}

impl Cell {
    /// The cell of `kind`, at rest, whose free degree of freedom (if any) has `mass` kg.
    pub fn new(kind: Deformation, mass: Real) -> Self {
        Self { kind, speed: 0.0, mass }
    }

    /// Unit direction along which a stress-controlled cell's lengths move, its target stress,
    /// and the largest speed of its degree of freedom, `max_strain_rate × |L|` over the axes
    /// it moves, m/s (`None` for imposed rates).
    fn servo(&self, domain: &Domain) -> Option<(Vec3, Real, Real)> {
        let mut direction = Vec3::zeros();
        let (target, max_rate) = match self.kind {
            Deformation::StrainRate(_) => return None,
            Deformation::Pressure { target, max_strain_rate, .. } => {
                for a in (0..domain.dim).filter(|&a| domain.periodic[a]) {
                    direction[a] = domain.length(a);
                }
                (target, max_strain_rate)
            }
            Deformation::NormalStress { axis, target, max_strain_rate, .. } => {
                if domain.periodic[axis] {
                    direction[axis] = 1.0;
                }
                (target, max_strain_rate)
            }
        };
        let norm = direction.norm();
        let lengths = (0..domain.dim).filter(|&a| direction[a] != 0.0).map(|a| domain.length(a).powi(2)).sum::<Real>().sqrt();
        (norm > 0.0).then(|| (direction / norm, target, max_rate * lengths))
    }

    /// `Σ_a A_a direction_a`, m^(D-1): the work the target stress does per unit of the free
    /// degree of freedom's displacement, per Pa.
    fn area(direction: &Vec3, domain: &Domain) -> Real {
        let volume = domain.volume();
        (0..domain.dim).map(|a| direction[a] * volume / domain.length(a)).sum()
    }

    /// The velocity of the cell's lengths over the step of `h` seconds before the contacts act
    /// (for a stress target, the speed pushed by the target), and how it may move.
    pub fn velocity(&self, domain: &Domain, h: Real) -> (Vec3, Mobility) {
        match self.servo(domain) {
            None => {
                let Deformation::StrainRate(r) = self.kind else { return (Vec3::zeros(), Mobility::FIXED) };
                let mut v = Vec3::zeros();
                for a in (0..domain.dim).filter(|&a| domain.periodic[a]) {
                    v[a] = r[a] * domain.length(a);
                }
                (v, Mobility::FIXED)
            }
            Some((direction, target, max_speed)) => {
                let push = -target * Self::area(&direction, domain) * h / self.mass;
                (direction * (self.speed + push), Mobility { direction, inv_mass: 1.0 / self.mass, partner: None, max_speed })
            }
        }
    }

    /// Ends a step of `h` seconds: the free speed takes the velocity `end` the contacts left
    /// (within `max_strain_rate × |L|`, the bound of its [`Mobility`]), and the lengths move about the cell's centre by the
    /// theta-scheme between `start` and that end velocity (imposed rates: by `exp(r h)`).
    /// Returns the end velocity.
    pub fn finish(&mut self, domain: &mut Domain, start: Vec3, end: Vec3, h: Real, theta: Real) -> Vec3 {
        if let Deformation::StrainRate(r) = self.kind {
            // Imposed rates: exactly exp(r h) per step about the centre, DEM's scaling of its box.
            CellDeformation::new(self.kind).deform(domain, h);
            return Vec3::from_fn(|a, _| if a < domain.dim { r[a] * domain.length(a) } else { 0.0 });
        }
        let end = match self.servo(domain) {
            None => end,
            Some((direction, _, limit)) => {
                self.speed = end.dot(&direction).clamp(-limit, limit);
                direction * self.speed
            }
        };
        for a in 0..domain.dim {
            let dl = h * (theta * end[a] + (1.0 - theta) * start[a]);
            if dl != 0.0 {
                domain.lo[a] -= 0.5 * dl;
                domain.hi[a] += 0.5 * dl;
            }
        }
        end
    }

    /// The stress the contacts held against the target over an interval, Pa: `impulse` is the
    /// generalised impulse they gave the free degree of freedom over `time` seconds (`None`
    /// for imposed rates).
    pub fn stress_error(&self, domain: &Domain, impulse: Real, time: Real) -> Option<Real> {
        let (direction, target, _) = self.servo(domain)?;
        let measured = impulse / (time * Self::area(&direction, domain));
        Some((measured - target).abs() / target)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(side: Real) -> Domain {
        Domain { dim: 2, lo: Vec3::zeros(), hi: Vec3::new(side, side, 0.0), periodic: [true, true, false], shear_rate: 0.0, le_offset: 0.0 }
    }

    /// The pressure cell moves both lengths alike; its push is the target's work; the speed is
    /// bounded by the largest strain rate; the lengths move by the theta-scheme about the centre.
    #[test]
    fn a_pressure_cell_is_pushed_by_its_target_and_bounded() {
        let mut d = square(2.0);
        let mut cell = Cell::new(Deformation::Pressure { target: 10.0, max_strain_rate: 0.1, gain: 0.0 }, 4.0);
        let (v, m) = cell.velocity(&d, 0.5);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        // Σ A_a dir_a = 2 × (2 × s); push = -10 × 4 s × 0.5 / 4.
        assert!((m.direction - Vec3::new(s, s, 0.0)).norm() < 1e-15 && m.inv_mass == 0.25);
        assert!((v - m.direction * (-10.0 * 4.0 * s * 0.5 / 4.0)).norm() < 1e-12, "{v}");
        // A fast end velocity is cut to 0.1 × |L| = 0.1 × 2√2.
        let end = cell.finish(&mut d, v, m.direction * -10.0, 0.5, 1.0);
        assert!((end.norm() - 0.1 * 2.0 * 2f64.sqrt()).abs() < 1e-12);
        assert!((d.length(0) - (2.0 + 0.5 * end.x)).abs() < 1e-12 && (d.lo.x + d.hi.x - 2.0).abs() < 1e-12);
        // Balanced: an impulse of target × area over the time gives no error.
        let area = 2.0 * d.length(0) * s;
        assert!(cell.stress_error(&d, 10.0 * area * 3.0, 3.0).is_some_and(|e| e < 1e-12));
    }

    /// Imposed strain rates move each length at its rate times the length, as a boundary of
    /// imposed motion.
    #[test]
    fn imposed_rates_are_a_boundary_of_imposed_motion() {
        let d = square(2.0);
        let cell = Cell::new(Deformation::StrainRate(Vec3::new(-0.1, 0.2, 0.0)), 1.0);
        let (v, m) = cell.velocity(&d, 0.5);
        assert_eq!(m, Mobility::FIXED);
        assert!((v - Vec3::new(-0.2, 0.4, 0.0)).norm() < 1e-15);
        assert!(cell.stress_error(&d, 1.0, 1.0).is_none());
    }
}
