//! The checked container: the box's faces and walls with their motions, periodicity,
//! Lees-Edwards shear, the periodic cell's imposed deformation, the drum and the granule's ball.

use crate::math::{Real, Vec3};

/// Which face of the box a wall closes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Face {
    /// Axis 0, 1, 2.
    pub axis: usize,
    /// True for the upper face (`x_max`), false for the lower one.
    pub upper: bool,
}

impl Face {
    /// `x_min`, `y_max`, ...
    pub fn name(&self) -> String {
        format!("{}_{}", crate::math::AXES[self.axis], if self.upper { "max" } else { "min" })
    }
    /// Unit normal pointing into the box.
    pub fn inward_normal(&self) -> Vec3 {
        let mut n = Vec3::zeros();
        n[self.axis] = if self.upper { -1.0 } else { 1.0 };
        n
    }
}

/// How a wall moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WallMotion {
    /// At rest.
    Fixed,
    /// Imposed velocity, m/s.
    Velocity(Vec3),
    /// Moves along its axis at `rate × L`, `L` the current box length on that axis, so that
    /// the length changes at the constant true strain rate `rate`, 1/s (negative compresses),
    /// while the opposite wall is fixed.
    StrainRate(Real),
    /// Servo to a compressive normal stress.
    Stress {
        /// Target, Pa.
        stress: Real,
        /// Gain, m/(s·Pa); `None` = default from stiffness and time step.
        gain: Option<Real>,
        /// Speed limit, m/s.
        max_speed: Real,
        /// Add the integral action of [`crate::loading::Wall::servo`] (walls that must follow
        /// a deforming sample, such as the lateral walls of a biaxial test); plain servo walls
        /// of the container are proportional only.
        integral: bool,
    },
    /// The upper wall of a shear cell: servo-controlled along its axis to a compressive
    /// normal stress (with the integral action), while it slides along `flow` at
    /// `shear_rate × L`, `L` the current gap, so that the gap shears at a constant rate
    /// against a fixed opposite wall.
    Shearing {
        /// Target normal stress, Pa.
        stress: Real,
        /// Shear rate, 1/s.
        shear_rate: Real,
        /// Axis of the sliding.
        flow: usize,
        /// Speed limit along the axis, m/s.
        max_speed: Real,
    },
}

/// A wall on one face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallDef {
    /// The face.
    pub face: Face,
    /// Motion.
    pub motion: WallMotion,
}

/// Imposed homogeneous deformation of the periodic cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Deformation {
    /// Constant true strain rates, 1/s.
    StrainRate(Vec3),
    /// Servo of one axis's length to a normal stress σ_aa (the other axes keep their length):
    /// the height of a sheared Lees-Edwards cell under an imposed normal stress.
    NormalStress {
        /// The controlled axis.
        axis: usize,
        /// Target σ_aa, Pa.
        target: Real,
        /// Largest strain-rate magnitude, 1/s.
        max_strain_rate: Real,
        /// Gain, 1/(s·Pa).
        gain: Real,
    },
    /// Isotropic pressure servo.
    Pressure {
        /// Target, Pa.
        target: Real,
        /// Largest strain-rate magnitude, 1/s.
        max_strain_rate: Real,
        /// Gain, 1/(s·Pa).
        gain: Real,
    },
}

/// The container.
#[derive(Debug, Clone)]
pub struct Container {
    /// Lower corner, m.
    pub lo: Vec3,
    /// Upper corner, m.
    pub hi: Vec3,
    /// Periodic axes.
    pub periodic: [bool; 3],
    /// Walls on every non-periodic face (in 2D, z has none).
    pub walls: Vec<WallDef>,
    /// Material of the walls.
    pub wall_material: Option<usize>,
    /// Lees-Edwards shear rate, 1/s, and whether particles start on the profile.
    pub lees_edwards: Option<(Real, bool)>,
    /// Deformation of the periodic cell.
    pub deformation: Option<Deformation>,
    /// A rotating drum inscribed in the box (set by the `drum` experiment).
    pub drum: Option<DrumDef>,
    /// The ball (disk in 2D) the grains are placed in to form a granule (set by the
    /// `granule_compression` experiment).
    pub granule: Option<Ball>,
}

/// A ball (a disk in 2D: its z is not used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Centre, m.
    pub center: Vec3,
    /// Radius, m.
    pub radius: Real,
}

/// A cylindrical wall (a circle in 2D) about an axis of the box, which may turn about it: the
/// rotating drum. Its surface is made of the container's wall material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrumDef {
    /// Axis of the cylinder (z in 2D).
    pub axis: usize,
    /// A point of the axis, m (its coordinate along the axis is not used).
    pub center: Vec3,
    /// Inner radius, m.
    pub radius: Real,
    /// Unit vector of gravity (perpendicular to the axis), for the measurements of the bed.
    pub down: Vec3,
}
