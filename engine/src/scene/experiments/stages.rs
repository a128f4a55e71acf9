//! The stages a checked experiment expands into (preparation, loading, shear, ...), each with
//! its wall motions, cell servo and stop, and the step limits the experiment sets.

use crate::math::Real;
use crate::scene::model::{
    CompactionDrive, Container, Controls, Deformation, Equilibrium, Experiment, Preparation, Stage, Stop, WallDef, WallMotion,
};

/// Grains whose surface lies within this fraction of the mean diameter of a wall are glued to
/// it when plane shear between rough walls starts: the layer in contact with the wall at the
/// end of the preparation, a bumpy surface one grain thick.
pub const ROUGH_LAYER: Real = 0.5;
fn preparation_stage(p: &Preparation, container: &Container) -> Stage {
    let mut controls = Controls { friction: Some(p.friction), local_damping: Some(p.local_damping), ..Controls::default() };
    if container.walls.is_empty() {
        controls.deformation = Some(Some(Deformation::Pressure {
            target: p.pressure,
            max_strain_rate: p.max_strain_rate,
            gain: p.max_strain_rate / p.pressure,
        }));
    } else {
        // Both walls of an axis move: each at most half the rate times the length.
        controls.walls = container
            .walls
            .iter()
            .map(|w| {
                let length = container.hi[w.face.axis] - container.lo[w.face.axis];
                let max_speed = 0.5 * p.max_strain_rate * length;
                WallDef { face: w.face, motion: WallMotion::Stress { stress: p.pressure, gain: None, max_speed, integral: false } }
            })
            .collect();
    }
    Stage {
        name: "preparation".into(),
        controls,
        until: Stop { steps: Some(p.max_steps), ..Stop::default() },
        strain_axis: None,
        equilibrium: Some(p.equilibrium),
    }
}

impl Experiment {
    /// The step limits the experiment sets, with the path of the field that sets each (a
    /// server may cap them; docs/scene-format.md §13).
    pub fn step_limits(&self) -> Vec<(&'static str, u64)> {
        match self {
            Self::Isotropic { preparation } => vec![("experiment.preparation.max_steps", preparation.max_steps)],
            Self::Triaxial { preparation, max_steps, .. } => {
                let mut v = vec![("experiment.preparation.max_steps", preparation.max_steps)];
                if *max_steps < u64::MAX {
                    v.push(("experiment.max_steps", *max_steps));
                }
                v
            }
            Self::Compaction { max_steps, .. }
            | Self::Deposition { max_steps, .. }
            | Self::Drum { max_steps, .. }
            | Self::GranuleCompression { max_steps, .. } => {
                vec![("experiment.max_steps", *max_steps)]
            }
            Self::PlaneShear { preparation, max_steps, .. } => {
                let mut v = vec![("experiment.preparation.max_steps", preparation.max_steps)];
                if *max_steps < u64::MAX {
                    v.push(("experiment.max_steps", *max_steps));
                }
                v
            }
        }
    }

    /// The stages the experiment runs, in order.
    pub fn stages(&self, container: &Container) -> Vec<Stage> {
        match self {
            Self::Deposition { local_damping, equilibrium, max_steps, .. } => vec![Stage {
                name: "deposition".into(),
                controls: Controls { local_damping: Some(*local_damping), ..Controls::default() },
                until: Stop { steps: Some(*max_steps), ..Stop::default() },
                strain_axis: None,
                equilibrium: Some(*equilibrium),
            }],
            Self::Isotropic { preparation } => vec![preparation_stage(preparation, container)],
            Self::GranuleCompression { axis, acceleration, strain_rate, strain, local_damping, equilibrium, max_steps, .. } => {
                let settle = |name: &str, field: Real| Stage {
                    name: name.into(),
                    controls: Controls { centripetal: Some(field), local_damping: Some(*local_damping), ..Controls::default() },
                    until: Stop { steps: Some(*max_steps), ..Stop::default() },
                    strain_axis: None,
                    equilibrium: Some(*equilibrium),
                };
                vec![
                    settle("forming", *acceleration),
                    settle("relaxation", 0.0),
                    plate_compression(container, *axis, *strain_rate, *strain),
                ]
            }
            Self::Drum { angular_velocity, revolutions, local_damping, equilibrium, max_steps, .. } => {
                drum_stages(*angular_velocity, *revolutions, *local_damping, *equilibrium, *max_steps)
            }
            Self::Triaxial { preparation, axis, strain_rate, axial_strain, max_steps } => vec![
                preparation_stage(preparation, container),
                triaxial_loading(container, preparation, *axis, *strain_rate, *axial_strain, *max_steps),
            ],
            Self::PlaneShear { preparation, rough_walls: true, shear_rate, strain, max_steps } => {
                vec![preparation_stage(preparation, container), rough_wall_shear(container, preparation, *shear_rate, *strain, *max_steps)]
            }
            Self::PlaneShear { preparation, rough_walls: false, shear_rate, strain, max_steps } => {
                vec![preparation_stage(preparation, container), lees_edwards_shear(preparation, *shear_rate, *strain, *max_steps)]
            }
            Self::Compaction { axis, drive, max_steps } => vec![compaction_stage(container, *axis, drive, *max_steps)],
        }
    }
}

/// A granule's compression: both plates along `axis` close at half the rate each, so the gap
/// shrinks at `strain_rate`, until the strain.
fn plate_compression(container: &Container, axis: usize, strain_rate: Real, strain: Real) -> Stage {
    let walls = container
        .walls
        .iter()
        .map(|w| WallDef {
            face: w.face,
            motion: if w.face.axis == axis { WallMotion::StrainRate(-0.5 * strain_rate) } else { WallMotion::Fixed },
        })
        .collect();
    Stage {
        name: "compression".into(),
        controls: Controls { walls, close_walls: Some(axis), ..Controls::default() },
        until: Stop { strain: Some(strain), ..Stop::default() },
        strain_axis: Some(axis),
        equilibrium: None,
    }
}

/// A drum's stages: filling at rest until equilibrium, then rotation for the revolutions.
fn drum_stages(angular_velocity: Real, revolutions: Real, local_damping: Real, equilibrium: Equilibrium, max_steps: u64) -> Vec<Stage> {
    let filling = Stage {
        name: "filling".into(),
        controls: Controls { local_damping: Some(local_damping), drum_angular_velocity: Some(0.0), ..Controls::default() },
        until: Stop { steps: Some(max_steps), ..Stop::default() },
        strain_axis: None,
        equilibrium: Some(equilibrium),
    };
    let period = 2.0 * std::f64::consts::PI / angular_velocity.abs();
    let rotation = Stage {
        name: "rotation".into(),
        controls: Controls { drum_angular_velocity: Some(angular_velocity), ..Controls::default() },
        until: Stop { time: Some(revolutions * period), ..Stop::default() },
        strain_axis: None,
        equilibrium: None,
    };
    vec![filling, rotation]
}

/// A biaxial or triaxial loading: the upper wall along `axis` moves in at the strain rate, the
/// lateral walls hold the preparation's pressure.
fn triaxial_loading(
    container: &Container,
    preparation: &Preparation,
    axis: usize,
    strain_rate: Real,
    axial_strain: Real,
    max_steps: u64,
) -> Stage {
    let mut walls = Vec::new();
    for w in &container.walls {
        let motion = if w.face.axis != axis {
            WallMotion::Stress { stress: preparation.pressure, gain: None, max_speed: f64::INFINITY, integral: true }
        } else if w.face.upper {
            WallMotion::StrainRate(-strain_rate)
        } else {
            WallMotion::Fixed
        };
        walls.push(WallDef { face: w.face, motion });
    }
    Stage {
        name: "loading".into(),
        controls: Controls { walls, ..Controls::default() },
        until: Stop { strain: Some(axial_strain), steps: (max_steps < u64::MAX).then_some(max_steps), ..Stop::default() },
        strain_axis: Some(axis),
        equilibrium: None,
    }
}

/// Plane shear between rough walls: the grains within ROUGH_LAYER of a wall are glued to it;
/// y_max slides along x at the shear rate times the gap and holds the normal stress.
fn rough_wall_shear(container: &Container, preparation: &Preparation, shear_rate: Real, strain: Real, max_steps: u64) -> Stage {
    let walls = container
        .walls
        .iter()
        .map(|w| WallDef {
            face: w.face,
            motion: if w.face.upper {
                WallMotion::Shearing { stress: preparation.pressure, shear_rate, flow: 0, max_speed: f64::INFINITY }
            } else {
                WallMotion::Fixed
            },
        })
        .collect();
    Stage {
        name: "shear".into(),
        controls: Controls { walls, glue: Some(ROUGH_LAYER), ..Controls::default() },
        until: Stop { time: Some(strain / shear_rate), steps: (max_steps < u64::MAX).then_some(max_steps), ..Stop::default() },
        strain_axis: None,
        equilibrium: None,
    }
}

/// Plane shear in a Lees-Edwards cell whose height a servo sets to hold the normal stress.
fn lees_edwards_shear(preparation: &Preparation, shear_rate: Real, strain: Real, max_steps: u64) -> Stage {
    let p = preparation.pressure;
    // The height must open as fast as the flow dilates (a rate of order the shear
    // rate times a dilatancy angle), not only at the preparation's rate.
    let max_strain_rate = preparation.max_strain_rate.max(shear_rate);
    let servo = Deformation::NormalStress { axis: 1, target: p, max_strain_rate, gain: max_strain_rate / p };
    Stage {
        name: "shear".into(),
        controls: Controls { deformation: Some(Some(servo)), shear_rate: Some(shear_rate), ..Controls::default() },
        until: Stop { strain: Some(strain), steps: (max_steps < u64::MAX).then_some(max_steps), ..Stop::default() },
        strain_axis: None,
        equilibrium: None,
    }
}

/// A compaction: the upper wall along `axis` moves in at a speed up to a strain, or holds a
/// stress until equilibrium.
fn compaction_stage(container: &Container, axis: usize, drive: &CompactionDrive, max_steps: u64) -> Stage {
    let walls = container
        .walls
        .iter()
        .map(|w| {
            let motion = match (w.face.axis == axis && w.face.upper, drive) {
                (false, _) => WallMotion::Fixed,
                (true, CompactionDrive::Velocity { speed, .. }) => {
                    let mut v = crate::math::Vec3::zeros();
                    v[axis] = -speed;
                    WallMotion::Velocity(v)
                }
                (true, CompactionDrive::Stress { stress, max_speed, .. }) => {
                    WallMotion::Stress { stress: *stress, gain: None, max_speed: *max_speed, integral: false }
                }
            };
            WallDef { face: w.face, motion }
        })
        .collect();
    let (until, equilibrium) = match drive {
        CompactionDrive::Velocity { strain, .. } => (Stop { strain: Some(*strain), steps: Some(max_steps), ..Stop::default() }, None),
        CompactionDrive::Stress { equilibrium, .. } => (Stop { steps: Some(max_steps), ..Stop::default() }, Some(*equilibrium)),
    };
    Stage { name: "compaction".into(), controls: Controls { walls, ..Controls::default() }, until, strain_axis: Some(axis), equilibrium }
}
