//! Plane walls on the faces of the box.

use crate::math::{Real, Vec3};
use crate::scene::{Face, WallMotion};

/// Steps over which the integral part of a stress servo removes a steady lag (see
/// [`Wall::servo`]).
pub const SERVO_INTEGRAL_STEPS: Real = 1000.0;

/// Relative stress error within which the integral part of a servo leaks instead of growing:
/// a steady lag is brought down to about this fraction of the target.
pub const SERVO_DEADBAND: Real = 0.005;

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
    /// Integral part of the servo's command, m/s (see [`Wall::servo`]).
    integral: Real,
    /// Servo gain used when a stress control gives none, m/(s·Pa).
    default_gain: Real,
    /// Viscous stiffness of the wall contacts per area (sets `smoothing`).
    dashpot_per_area: Real,
}

impl Wall {
    /// A wall at `position` with its imposed velocity (zero for fixed and servo walls).
    /// `dashpot_per_area` (N·s/m per m^(D-1)) is the viscous stiffness of the wall contacts, which
    /// sets the servo's smoothing.
    pub fn new(face: Face, position: Real, motion: WallMotion, default_gain: Real, dashpot_per_area: Real) -> Self {
        let mut wall = Self {
            face,
            position,
            velocity: Vec3::zeros(),
            motion: WallMotion::Fixed,
            gain: 0.0,
            smoothing: 1.0,
            force: Vec3::zeros(),
            integral: 0.0,
            default_gain,
            dashpot_per_area,
        };
        wall.set_motion(motion);
        wall
    }

    /// The servo gain used when a stress control gives none, m/(s·Pa).
    pub fn default_gain(&self) -> Real {
        self.default_gain
    }

    /// Sets the servo gain used when a stress control gives none (m/(s·Pa)), and the current
    /// gain if the wall uses it: a run that goes on from a checkpoint keeps the gain its walls
    /// had, which was derived from a time step its build would not find again. The wall's
    /// velocity and servo integral are kept.
    pub fn set_default_gain(&mut self, gain: Real) {
        self.default_gain = gain;
        let (velocity, integral) = (self.velocity, self.integral);
        self.set_motion(self.motion);
        (self.velocity, self.integral) = (velocity, integral);
    }

    /// Changes how the wall moves (a new stage of a loading program); it keeps its position.
    pub fn set_motion(&mut self, motion: WallMotion) {
        let (velocity, gain) = match motion {
            WallMotion::Fixed | WallMotion::StrainRate(_) => (Vec3::zeros(), 0.0),
            WallMotion::Velocity(v) => (v, 0.0),
            WallMotion::Stress { gain, .. } => (Vec3::zeros(), gain.unwrap_or(self.default_gain)),
            WallMotion::Shearing { .. } => (Vec3::zeros(), self.default_gain),
        };
        // The loop through the dashpots multiplies a speed change by -gain × c within the step
        // (c = dashpot_per_area). Below 1 it converges by itself and the wall jumps to the
        // commanded speed (as LAMMPS-style servos do). At 1 or more it would flip for ever;
        // relaxing the speed by `smoothing` per step leaves the factor
        // 1 - smoothing (1 + gain c_actual): zero for the estimate, and within (-1, 1) as long as
        // 1 + gain c_actual < 2 (1 + gain c).
        let loop_gain = gain * self.dashpot_per_area.max(0.0);
        self.smoothing = if loop_gain < 1.0 { 1.0 } else { 1.0 / (1.0 + loop_gain) };
        self.motion = motion;
        self.velocity = velocity;
        self.gain = gain;
        self.integral = 0.0;
    }

    /// What moves the wall on from one step to the next: its velocity (m/s) and its servo's
    /// integral part (m/s), for a checkpoint ([`crate::resume::Clock`]).
    pub fn servo_state(&self) -> [Real; 4] {
        [self.velocity.x, self.velocity.y, self.velocity.z, self.integral]
    }

    /// Sets what [`Wall::servo_state`] returned.
    pub fn set_servo_state(&mut self, s: [Real; 4]) {
        self.velocity = Vec3::new(s[0], s[1], s[2]);
        self.integral = s[3];
    }

    /// Target of a stress-controlled wall, Pa.
    pub fn target_stress(&self) -> Option<Real> {
        match self.motion {
            WallMotion::Stress { stress, .. } | WallMotion::Shearing { stress, .. } => Some(stress),
            _ => None,
        }
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
    ///
    /// The command has an integral part (a PI controller): a proportional servo alone lags by
    /// `v / gain` while the wall must keep moving at speed `v` — a lateral wall that follows a
    /// dilating sample in a biaxial test held about 1.5 times its target that way. The integral
    /// gathers `gain × error / SERVO_INTEGRAL_STEPS` per step, so a steady lag is removed over
    /// about [`SERVO_INTEGRAL_STEPS`] steps, slow against the proportional response (tens of
    /// steps) so the loop stays stable. It is frozen while the command is clamped at `max_speed`
    /// (no wind-up while a loose sample is compressed) and bounded by `max_speed`. Within
    /// [`SERVO_DEADBAND`] of the target it leaks away instead of growing: against the
    /// stick-slip of a packing at rest a pure integrator hunts for ever (found by
    /// `tests/physics_walls.rs`: the walls kept creeping), while the proportional part alone
    /// comes to rest exactly at the target.
    ///
    /// A wall driven at a strain rate gets its speed from the current box length `length` along
    /// its axis; a shearing wall slides at its shear rate times that length.
    pub fn servo(&mut self, area: Real, length: Real) {
        if let WallMotion::StrainRate(rate) = self.motion {
            // d(hi)/dt = rate L for the upper wall, d(lo)/dt = -rate L for the lower one.
            let speed = rate * length;
            self.velocity = Vec3::zeros();
            self.velocity[self.face.axis] = if self.face.upper { speed } else { -speed };
        }
        let (servo, slide) = match self.motion {
            WallMotion::Stress { stress, max_speed, integral, .. } => (Some((stress, max_speed, integral)), Vec3::zeros()),
            WallMotion::Shearing { stress, shear_rate, flow, max_speed } => {
                let mut slide = Vec3::zeros();
                slide[flow] = shear_rate * length;
                (Some((stress, max_speed, true)), slide)
            }
            _ => (None, Vec3::zeros()),
        };
        if let Some((stress, max_speed, integral)) = servo {
            let error = stress - self.normal_stress(area);
            let proportional = self.gain * error;
            let raw = proportional + self.integral;
            let command = raw.clamp(-max_speed, max_speed);
            if !integral {
                self.integral = 0.0;
            } else if error.abs() <= SERVO_DEADBAND * stress {
                // Close enough: the integral leaks away, leaving the proportional servo, which
                // is at rest only at zero error.
                self.integral *= 1.0 - 1.0 / SERVO_INTEGRAL_STEPS;
            } else if raw == command {
                self.integral = (self.integral + proportional / SERVO_INTEGRAL_STEPS).clamp(-max_speed, max_speed);
            }
            let current = self.velocity.dot(&self.normal());
            self.velocity = self.normal() * (current + self.smoothing * (command - current)) + slide;
        }
    }

    /// Moves the wall by its normal velocity over `dt`.
    pub fn advance(&mut self, dt: Real) {
        self.position += self.velocity[self.face.axis] * dt;
    }
}
