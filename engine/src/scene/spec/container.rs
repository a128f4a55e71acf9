//! The `container` section: the box, its walls and their motions, periodicity, Lees-Edwards
//! shear and the periodic cell's imposed deformation.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// The container: a box with walls on non-periodic faces.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContainerSpec {
    /// Lower corner, m (left out when the scene starts from a state, whose box it takes).
    #[serde(default)]
    pub min: Vec<f64>,
    /// Upper corner, m (left out when the scene starts from a state).
    #[serde(default)]
    pub max: Vec<f64>,
    /// Periodic axes (`"x"`, `"y"`, `"z"`).
    #[serde(default)]
    pub periodic: Vec<String>,
    /// Wall of each non-periodic face, by name (`x_min`, `x_max`, ...). Missing faces are fixed.
    #[serde(default)]
    pub walls: BTreeMap<String, WallSpec>,
    /// Material of the walls (required when the box has walls).
    #[serde(default)]
    pub wall_material: Option<String>,
    /// Lees-Edwards shear: flow along x, gradient along y (both periodic).
    #[serde(default)]
    pub lees_edwards: Option<LeesEdwardsSpec>,
    /// Homogeneous deformation of the periodic cell.
    #[serde(default)]
    pub deformation: Option<DeformationSpec>,
}

/// Motion of one wall.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum WallSpec {
    /// Does not move.
    Fixed,
    /// Moves at an imposed velocity (m/s, length = dimension); the normal part moves the wall,
    /// the tangential part slides its surface.
    Velocity {
        /// Velocity, m/s.
        velocity: Vec<f64>,
    },
    /// Servo-controlled to an imposed compressive normal stress, Pa.
    Stress {
        /// Target normal stress, Pa (> 0).
        stress: f64,
        /// Servo gain, m/(s·Pa). Default from the contact stiffness and time step.
        #[serde(default)]
        gain: Option<f64>,
        /// Largest wall speed, m/s. Default: unbounded.
        #[serde(default)]
        max_speed: Option<f64>,
    },
}

/// Lees-Edwards periodic shear.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeesEdwardsSpec {
    /// Shear rate d u_x / d y, 1/s.
    pub shear_rate: f64,
    /// Start particles on the linear velocity profile. Default false.
    #[serde(default)]
    pub initial_profile: bool,
}

/// Homogeneous deformation of the periodic directions.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DeformationSpec {
    /// Constant true strain rate on each axis, 1/s (negative compresses; length = dimension;
    /// non-zero only on periodic axes).
    StrainRate {
        /// Rates, 1/s.
        rate: Vec<f64>,
    },
    /// Isotropic servo of the periodic axes to a target mean pressure p, Pa.
    Pressure {
        /// Target pressure, Pa (> 0).
        target: f64,
        /// Largest strain rate magnitude, 1/s (> 0).
        max_strain_rate: f64,
        /// Gain, 1/(s·Pa). Default max_strain_rate / target.
        #[serde(default)]
        gain: Option<f64>,
    },
}
