//! The checks of a scene's container (box, walls, periodicity, imposed deformation), its stop
//! criteria and its sampling.

use super::model::*;
use super::spec::*;
use super::violation::Checker;
use crate::math::{vec_from_slice, Vec3, AXES};

/// Checks the container section: box, periodic axes, walls and their material, Lees-Edwards
/// shear and imposed deformation.
pub(super) fn check_container(
    c: &mut Checker,
    s: &ContainerSpec,
    dim: usize,
    material_index: &dyn Fn(&mut Checker, &str, &str) -> usize,
) -> Container {
    let ok = c.vector("container.min", &s.min, dim) & c.vector("container.max", &s.max, dim);
    let (lo, mut hi) = if ok { (vec_from_slice(&s.min), vec_from_slice(&s.max)) } else { (Vec3::zeros(), Vec3::repeat(1.0)) };
    if dim == 2 {
        hi.z = 0.0;
    }
    for a in 0..dim {
        if ok && lo[a] >= hi[a] {
            c.fail(format!("container.max[{a}]"), format!("must be > container.min[{a}] = {}, got {}", lo[a], hi[a]));
        }
    }
    let mut periodic = [false; 3];
    for (i, name) in s.periodic.iter().enumerate() {
        match AXES[..dim].iter().position(|a| a == name) {
            Some(a) => periodic[a] = true,
            None => {
                c.fail(format!("container.periodic[{i}]"), format!("must be one of {} in {dim}D, got '{name}'", AXES[..dim].join(", ")))
            }
        }
    }
    let walls = check_walls(c, s, dim, &periodic);
    let wall_material = match (&s.wall_material, walls.is_empty()) {
        (Some(name), _) => Some(material_index(c, "container.wall_material", name)),
        (None, false) => {
            c.fail("container.wall_material", "required: the container has walls on its non-periodic faces");
            None
        }
        (None, true) => None,
    };
    let lees_edwards = s.lees_edwards.as_ref().map(|le| {
        if !(le.shear_rate.is_finite()) {
            c.fail("container.lees_edwards.shear_rate", "must be a finite number");
        }
        if !(periodic[0] && periodic[1]) {
            c.fail("container.lees_edwards", "requires x and y to be periodic (flow along x, gradient along y)");
        }
        (le.shear_rate, le.initial_profile)
    });
    let deformation = s.deformation.as_ref().map(|d| check_deformation(c, d, dim, &periodic));
    if lees_edwards.is_some() && deformation.is_some() {
        c.fail("container.deformation", "cannot be combined with lees_edwards in this version");
    }
    Container { lo, hi, periodic, walls, wall_material, lees_edwards, deformation, drum: None, granule: None }
}

/// The walls on the non-periodic faces with their motions; names of unknown or periodic walls
/// are refused.
fn check_walls(c: &mut Checker, s: &ContainerSpec, dim: usize, periodic: &[bool; 3]) -> Vec<WallDef> {
    let mut walls = Vec::new();
    for axis in (0..dim).filter(|&a| !periodic[a]) {
        for upper in [false, true] {
            let face = Face { axis, upper };
            let motion = check_wall_motion(c, &face, s.walls.get(&face.name()), dim);
            walls.push(WallDef { face, motion });
        }
    }
    for key in s.walls.keys() {
        let known = (0..dim).any(|a| [false, true].iter().any(|&u| Face { axis: a, upper: u }.name() == *key));
        if !known {
            c.fail(format!("container.walls.{key}"), "unknown wall; names are x_min, x_max, y_min, y_max (and z_min, z_max in 3D)");
        } else if (0..dim).any(|a| periodic[a] && key.starts_with(AXES[a])) {
            c.fail(format!("container.walls.{key}"), "this axis is periodic: it has no walls");
        }
    }
    walls
}

/// The motion of the wall on `face`: fixed, at a velocity, or holding a stress.
fn check_wall_motion(c: &mut Checker, face: &Face, spec: Option<&WallSpec>, dim: usize) -> WallMotion {
    match spec {
        None | Some(WallSpec::Fixed) => WallMotion::Fixed,
        Some(WallSpec::Velocity { velocity }) => {
            let path = format!("container.walls.{}.velocity", face.name());
            if c.vector(&path, velocity, dim) {
                WallMotion::Velocity(vec_from_slice(velocity))
            } else {
                WallMotion::Fixed
            }
        }
        Some(WallSpec::Stress { stress, gain, max_speed }) => {
            let path = format!("container.walls.{}", face.name());
            c.positive(&format!("{path}.stress"), *stress);
            if let Some(g) = gain {
                c.positive(&format!("{path}.gain"), *g);
            }
            if let Some(v) = max_speed {
                c.positive(&format!("{path}.max_speed"), *v);
            }
            WallMotion::Stress { stress: *stress, gain: *gain, max_speed: max_speed.unwrap_or(f64::INFINITY), integral: false }
        }
    }
}

/// The deformation imposed on a periodic cell: a strain rate, or a servo to a pressure.
fn check_deformation(c: &mut Checker, d: &DeformationSpec, dim: usize, periodic: &[bool; 3]) -> Deformation {
    match d {
        DeformationSpec::StrainRate { rate } => {
            if c.vector("container.deformation.rate", rate, dim) {
                for (a, r) in rate.iter().enumerate() {
                    if *r != 0.0 && !periodic[a] {
                        c.fail(format!("container.deformation.rate[{a}]"), "must be 0 on a non-periodic axis (move its walls instead)");
                    }
                }
            }
            Deformation::StrainRate(vec_from_slice(rate))
        }
        DeformationSpec::Pressure { target, max_strain_rate, gain } => {
            c.positive("container.deformation.target", *target);
            c.positive("container.deformation.max_strain_rate", *max_strain_rate);
            if let Some(g) = gain {
                c.positive("container.deformation.gain", *g);
            }
            if !periodic[..dim].iter().all(|&p| p) {
                c.fail("container.deformation", "a pressure-controlled cell must be periodic on every axis");
            }
            Deformation::Pressure { target: *target, max_strain_rate: *max_strain_rate, gain: gain.unwrap_or(max_strain_rate / target) }
        }
    }
}

pub(super) fn check_stop(c: &mut Checker, s: &StopSpec, container: &Container) -> Stop {
    if s.time.is_none() && s.steps.is_none() && s.packing_fraction.is_none() && s.strain.is_none() {
        c.fail("stop", "give at least one of time, steps, packing_fraction, strain");
    }
    if let Some(t) = s.time {
        c.positive("stop.time", t);
    }
    if s.steps == Some(0) {
        c.fail("stop.steps", "must be >= 1");
    }
    if let Some(phi) = s.packing_fraction {
        c.within("stop.packing_fraction", phi, 0.0, 1.0);
    }
    if let Some(e) = s.strain {
        c.positive("stop.strain", e);
        let wall_moves = |w: &WallDef| match w.motion {
            WallMotion::Fixed => false,
            WallMotion::Velocity(v) => v[w.face.axis] != 0.0,
            WallMotion::StrainRate(r) => r != 0.0,
            WallMotion::Stress { .. } | WallMotion::Shearing { .. } => true,
        };
        let deforms = container.lees_edwards.is_some_and(|(rate, _)| rate != 0.0)
            || container.deformation.is_some_and(|d| match d {
                Deformation::StrainRate(r) => r != Vec3::zeros(),
                Deformation::Pressure { .. } | Deformation::NormalStress { .. } => true,
            })
            || container.walls.iter().any(wall_moves);
        if !deforms {
            c.fail(
                "stop.strain",
                "the container never changes shape (no wall moving along its normal, no cell deformation, \
                 no Lees-Edwards shear rate): strain would stay 0",
            );
        }
    }
    if (s.packing_fraction.is_some() || s.strain.is_some()) && s.time.is_none() && s.steps.is_none() {
        c.fail("stop", "a packing_fraction or strain target also needs a time or steps limit, in case it is never reached");
    }
    Stop { time: s.time, steps: s.steps, packing_fraction: s.packing_fraction, strain: s.strain }
}

pub(super) fn check_sampling(c: &mut Checker, s: Option<&SamplingSpec>, stop: &Stop) -> Sampling {
    match s {
        Some(SamplingSpec { every_steps: Some(n), every_time: None }) => {
            if *n == 0 {
                c.fail("sampling.every_steps", "must be >= 1");
            }
            Sampling::Steps((*n).max(1))
        }
        Some(SamplingSpec { every_steps: None, every_time: Some(t) }) => {
            c.positive("sampling.every_time", *t);
            Sampling::Time(*t)
        }
        Some(_) => {
            c.fail("sampling", "give exactly one of every_steps, every_time");
            Sampling::Steps(1000)
        }
        None => match (stop.steps, stop.time) {
            (Some(n), _) => Sampling::Steps((n / 100).max(1)),
            (None, Some(t)) => Sampling::Time(t / 100.0),
            _ => Sampling::Steps(1000),
        },
    }
}

/// The container of a scene, whose box is the saved state's when it starts from one (the scene
/// then gives no box, and the same periodic axes).
pub(super) fn check_box(
    c: &mut Checker,
    spec: &ContainerSpec,
    state: Option<&super::state::StateFile>,
    dim: usize,
    material_index: &dyn Fn(&mut Checker, &str, &str) -> usize,
) -> Container {
    let Some(st) = state else { return check_container(c, spec, dim, material_index) };
    if !spec.min.is_empty() || !spec.max.is_empty() {
        c.fail("container.min", "leave container.min and container.max out with start_from: the box is the state's");
    }
    let mut periodic: Vec<&str> = spec.periodic.iter().map(String::as_str).collect();
    let mut theirs: Vec<&str> = st.periodic.iter().map(String::as_str).collect();
    periodic.sort_unstable();
    theirs.sort_unstable();
    if periodic != theirs {
        c.fail(
            "container.periodic",
            format!("must match the periodic axes of the state it starts from ([{}]), got [{}]", theirs.join(", "), periodic.join(", ")),
        );
    }
    let spec_box = ContainerSpec { min: st.min.clone(), max: st.max.clone(), ..spec.clone() };
    check_container(c, &spec_box, dim, material_index)
}

/// The whole run's limits of a scene with an experiment: time and steps only, its stages ending
/// by their own criteria.
pub(super) fn check_experiment_limits(c: &mut Checker, limits: Option<&StopSpec>) -> Stop {
    let Some(s) = limits else { return Stop::default() };
    for (field, set) in [("packing_fraction", s.packing_fraction.is_some()), ("strain", s.strain.is_some())] {
        if set {
            c.fail(
                format!("stop.{field}"),
                "not with an experiment, whose stages end by their own criteria (stop may limit time and steps)",
            );
        }
    }
    if let Some(t) = s.time {
        c.positive("stop.time", t);
    }
    if s.steps == Some(0) {
        c.fail("stop.steps", "must be >= 1");
    }
    Stop { time: s.time, steps: s.steps, ..Stop::default() }
}
