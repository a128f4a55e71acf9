//! The rotating drum: a cylindrical wall (a circle in 2D) turning about its axis at an imposed
//! angular velocity. Grains touch it from inside.

use crate::math::{Real, Vec3};
use crate::observe::snapshot::{DrumShell, DRUM_SEGMENTS};
use crate::observe::DrumView;
use crate::scene::DrumDef;

/// A drum and the load the grains put on it.
#[derive(Debug, Clone, PartialEq)]
pub struct Drum {
    /// Geometry.
    pub def: DrumDef,
    /// Angular velocity, rad/s (right-handed about the axis).
    pub angular_velocity: Real,
    /// Force exerted by the particles on the drum at the last evaluation, N.
    pub force: Vec3,
    /// Torque about the axis exerted by the particles on the drum at the last evaluation, N·m
    /// (the drive must supply its opposite).
    pub torque: Real,
}

impl Drum {
    /// A drum at rest.
    pub fn new(def: DrumDef) -> Self {
        Self { def, angular_velocity: 0.0, force: Vec3::zeros(), torque: 0.0 }
    }

    /// Unit vector of the axis.
    pub fn axis_vector(&self) -> Vec3 {
        let mut e = Vec3::zeros();
        e[self.def.axis] = 1.0;
        e
    }

    /// Part of `x - centre` perpendicular to the axis, m.
    pub fn radial(&self, x: &Vec3) -> Vec3 {
        let mut d = x - self.def.center;
        d[self.def.axis] = 0.0;
        d
    }

    /// Gap between a sphere (disk) of radius `r` at `x` and the drum's inner surface, m
    /// (negative: they overlap).
    #[inline]
    pub fn gap(&self, x: &Vec3, r: Real) -> Real {
        self.def.radius - self.radial(x).norm() - r
    }

    /// Contact of a sphere (disk) of radius `r` at `x` with the drum's inner surface: the unit
    /// normal pointing into the drum (from the surface towards the grain) and the overlap, m;
    /// `None` when they do not touch.
    #[inline]
    pub fn touch(&self, x: &Vec3, r: Real) -> Option<(Vec3, Real)> {
        let d = self.radial(x);
        let rho = d.norm();
        let delta = r + rho - self.def.radius;
        if delta <= 0.0 || rho == 0.0 {
            return None;
        }
        Some((-d / rho, delta))
    }

    /// Velocity of the drum's material at `x` (a point of its surface), m/s.
    #[inline]
    pub fn surface_velocity(&self, x: &Vec3) -> Vec3 {
        (self.axis_vector() * self.angular_velocity).cross(&self.radial(x))
    }

    /// The point of the drum's surface on the ray from the axis through `x`, m (the point of
    /// contact with a grain centred at `x`).
    pub fn surface_point(&self, x: &Vec3) -> Vec3 {
        let d = self.radial(x);
        let rho = d.norm();
        if rho > 0.0 {
            x - d + d * (self.def.radius / rho)
        } else {
            *x
        }
    }

    /// Torque about the axis of a force `f` (N) applied at `x`, N·m.
    pub fn torque_of(&self, x: &Vec3, f: &Vec3) -> Real {
        self.radial(x).cross(f)[self.def.axis]
    }
    /// The drum as the measurements see it.
    pub fn view(&self) -> DrumView {
        DrumView {
            axis: self.def.axis,
            center: self.def.center,
            radius: self.def.radius,
            angular_velocity: self.angular_velocity,
            down: self.def.down,
            torque: self.torque,
        }
    }

    /// The drum for drawing, from the forces the grains centred at `x` receive from it,
    /// `(x, f)` (N), each applied on the segment the grain touches.
    pub fn shell(&self, loads: impl Iterator<Item = (Vec3, Vec3)>) -> DrumShell {
        let mut shell = DrumShell {
            axis: self.def.axis,
            center: self.def.center,
            radius: self.def.radius,
            segment_force: vec![Vec3::zeros(); DRUM_SEGMENTS],
        };
        for (x, f) in loads.filter(|(_, f)| *f != Vec3::zeros()) {
            let k = shell.segment_of(&self.surface_point(&x));
            shell.segment_force[k] -= f;
        }
        shell
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drum() -> Drum {
        Drum::new(DrumDef { axis: 2, center: Vec3::new(1.0, 1.0, 0.0), radius: 1.0, down: Vec3::new(0.0, -1.0, 0.0) })
    }

    #[test]
    fn grains_touch_from_inside_with_the_normal_towards_the_axis() {
        let d = drum();
        assert!(d.touch(&Vec3::new(1.5, 1.0, 3.0), 0.4).is_none());
        let (n, delta) = d.touch(&Vec3::new(1.8, 1.0, 3.0), 0.25).expect("touches");
        assert!((delta - 0.05).abs() < 1e-12);
        assert!((n - Vec3::new(-1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn the_surface_turns_counter_clockwise_for_a_positive_rate() {
        let mut d = drum();
        d.angular_velocity = 2.0;
        // At the bottom (y = 0) the surface moves towards +x at ω R.
        let v = d.surface_velocity(&Vec3::new(1.0, 0.0, 0.0));
        assert!((v - Vec3::new(2.0, 0.0, 0.0)).norm() < 1e-12);
        // A force along +y at the right-hand side turns it the same way.
        assert!((d.torque_of(&Vec3::new(2.0, 1.0, 0.0), &Vec3::new(0.0, 3.0, 0.0)) - 3.0).abs() < 1e-12);
    }
}
