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
    /// Fraction of the way from its current speed to the commanded one that a servo wall goes in
    /// one step, in (0, 1] (see [`Wall::servo`]).
    pub smoothing: Real,
    /// Force exerted by the particles on the wall at the last evaluation, N.
    pub force: Vec3,
}

impl Wall {
    /// A wall at `position` with its imposed velocity (zero for fixed and servo walls).
    /// `dashpot_per_area` (N·s/m per m^(D-1)) is the viscous stiffness of the wall contacts, which
    /// sets the servo's smoothing.
    pub fn new(face: Face, position: Real, motion: WallMotion, default_gain: Real, dashpot_per_area: Real) -> Self {
        let (velocity, gain) = match motion {
            WallMotion::Fixed => (Vec3::zeros(), 0.0),
            WallMotion::Velocity(v) => (v, 0.0),
            WallMotion::Stress { gain, .. } => (Vec3::zeros(), gain.unwrap_or(default_gain)),
        };
        // The loop through the dashpots multiplies a speed change by -gain × c within the step
        // (c = dashpot_per_area). Below 1 it converges by itself and the wall jumps to the
        // commanded speed (as LAMMPS-style servos do). At 1 or more it would flip for ever;
        // relaxing the speed by `smoothing` per step leaves the factor
        // 1 - smoothing (1 + gain c_actual): zero for the estimate, and within (-1, 1) as long as
        // 1 + gain c_actual < 2 (1 + gain c).
        let loop_gain = gain * dashpot_per_area.max(0.0);
        let smoothing = if loop_gain < 1.0 { 1.0 } else { 1.0 / (1.0 + loop_gain) };
        Self { face, position, velocity, motion, gain, smoothing, force: Vec3::zeros() }
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

    /// Updates the servo velocity from the measured stress: the wall is commanded inward at
    /// `gain (target - measured)`, bounded by `max_speed`, and its speed goes the fraction
    /// `smoothing` of the way there in the step.
    ///
    /// Why the smoothing: the contact dashpots turn the wall's own speed into force within the
    /// same step, so a servo that jumps to the commanded speed feeds back
    /// `gain × dashpot_per_area` per step; above 1 the wall flips direction every step — a
    /// limit cycle that holds the stress only on average and keeps the grains agitated (found
    /// by `tests/physics_walls.rs`). Relaxing the speed damps that loop without lowering the
    /// gain, so the lag behind a moving sample (`v / gain`) stays as small as before.
    pub fn servo(&mut self, area: Real) {
        if let WallMotion::Stress { stress, max_speed, .. } = self.motion {
            let command = (self.gain * (stress - self.normal_stress(area))).clamp(-max_speed, max_speed);
            let current = self.velocity.dot(&self.normal());
            self.velocity = self.normal() * (current + self.smoothing * (command - current));
        }
    }

    /// Moves the wall by its normal velocity over `dt`.
    pub fn advance(&mut self, dt: Real) {
        self.position += self.velocity[self.face.axis] * dt;
    }
}
