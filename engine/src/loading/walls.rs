//! Plane walls on the faces of the box.

use crate::math::{Real, Vec3};
use crate::scene::{Face, WallMotion};

/// A wall closing one face of the box.
#[derive(Debug, Clone, PartialEq)]
pub struct Wall {
    /// The face it closes.
    pub face: Face,
    /// Coordinate along the face's axis, m.
    pub position: Real,
    /// Current velocity, m/s (normal part moves the wall, tangential part slides its surface).
    pub velocity: Vec3,
    /// How it moves.
    pub motion: WallMotion,
    /// Servo gain, m/(s·Pa) (stress-controlled walls).
    pub gain: Real,
    /// Force exerted by the particles on the wall at the last evaluation, N.
    pub force: Vec3,
}

impl Wall {
    /// A wall at `position` with its imposed velocity (zero for fixed and servo walls).
    pub fn new(face: Face, position: Real, motion: WallMotion, default_gain: Real) -> Self {
        let (velocity, gain) = match motion {
            WallMotion::Fixed => (Vec3::zeros(), 0.0),
            WallMotion::Velocity(v) => (v, 0.0),
            WallMotion::Stress { gain, .. } => (Vec3::zeros(), gain.unwrap_or(default_gain)),
        };
        Self { face, position, velocity, motion, gain, force: Vec3::zeros() }
    }

    /// Unit normal pointing into the box.
    pub fn normal(&self) -> Vec3 {
        self.face.inward_normal()
    }

    /// Compressive normal stress from the last force, Pa, for a wall of the given area.
    pub fn normal_stress(&self, area: Real) -> Real {
        if area > 0.0 {
            -self.force.dot(&self.normal()) / area
        } else {
            0.0
        }
    }

    /// Updates the servo velocity from the measured stress: the wall moves inward at
    /// `gain (target - measured)`, bounded by `max_speed`.
    pub fn servo(&mut self, area: Real) {
        if let WallMotion::Stress { stress, max_speed, .. } = self.motion {
            let speed = (self.gain * (stress - self.normal_stress(area))).clamp(-max_speed, max_speed);
            self.velocity = self.normal() * speed;
        }
    }

    /// Moves the wall by its normal velocity over `dt`.
    pub fn advance(&mut self, dt: Real) {
        self.position += self.velocity[self.face.axis] * dt;
    }
}
