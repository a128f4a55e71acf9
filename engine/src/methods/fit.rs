//! What each family of methods can run, checked on a validated scene: the rigid-grain methods
//! (`dem`, `cd`) rigid grains, the soft-grain methods (`mpm`, `fem`) deformable grains in a
//! walled 2D box. Every misfit is named by its field.

use crate::scene::{Checker, Experiment, Material, Scene, WallMotion};

/// The materials of the scene's grains (its sets' and the state's it starts from), each with
/// the field that names it, in order and once each.
fn grain_materials(scene: &Scene) -> Vec<(String, &Material)> {
    let mut out = Vec::new();
    if let Some(st) = &scene.initial {
        let mut used: Vec<usize> = st.material.clone();
        used.sort_unstable();
        used.dedup();
        out.extend(used.into_iter().filter_map(|m| scene.materials.get(m)).map(|m| ("start_from.state.materials".to_string(), m)));
    }
    for (i, set) in scene.sets.iter().enumerate() {
        if let Some(m) = scene.materials.get(set.material) {
            out.push((format!("particles[{i}].material"), m));
        }
    }
    out
}

/// A method for rigid grains (`method`): no deformable material among the grains.
pub(crate) fn rigid_grains(scene: &Scene, method: &str, c: &mut Checker) {
    for (field, m) in grain_materials(scene).into_iter().filter(|(_, m)| m.deformable.is_some()) {
        c.fail(field, format!("'{}' is deformable: its grains need method mpm or fem (method {method} moves rigid grains)", m.name));
    }
}

/// A method for deformable grains (`name`, with `time_step_given` when the scene set its step):
/// deformable grains, dry, in 2D, between walls that do not shear, under an experiment it runs.
pub(crate) fn soft_grains(scene: &Scene, name: &str, time_step_given: bool, c: &mut Checker) {
    for (field, m) in grain_materials(scene).into_iter().filter(|(_, m)| m.deformable.is_none()) {
        c.fail(
            field,
            format!("method {name} needs deformable grains: give material '{}' a deformable law instead of a contact law", m.name),
        );
    }
    if scene.initial.as_ref().is_some_and(|st| st.wet.iter().any(|&w| w)) {
        c.fail("start_from.state.particles.wet", format!("not with method {name} (no capillary law between deformable grains)"));
    }
    for (i, _) in scene.sets.iter().enumerate().filter(|(_, s)| s.wet_fraction > 0.0) {
        c.fail(format!("particles[{i}].wet_fraction"), format!("not with method {name} (no capillary law between deformable grains)"));
    }
    if let Some(what) = aggregates(scene) {
        c.fail(
            "method",
            format!("{what} bonded_primaries aggregates, which run by contact dynamics (as Nezamabadi 2020 ran them) or by DEM: use method cd (or auto) or dem, not {name}"),
        );
    }
    if scene.dim != 2 {
        c.fail("dimension", format!("method {name} is 2D (plane strain) in this version"));
    }
    if scene.container.periodic.iter().any(|&p| p) {
        c.fail("container.periodic", format!("not with method {name}: its grains meet walls only"));
    }
    if scene.container.lees_edwards.is_some() {
        c.fail("container.lees_edwards", format!("not with method {name} (it needs walls all round)"));
    }
    if scene.container.deformation.is_some() {
        c.fail("container.deformation", format!("not with method {name} (it needs walls all round)"));
    }
    for w in &scene.container.walls {
        match w.motion {
            WallMotion::Stress { max_speed, .. } if !max_speed.is_finite() && !time_step_given => c.fail(
                format!("container.walls.{}.max_speed", w.face.name()),
                format!("required with method {name} (unless method.time_step is given): the fastest wall sets the time step"),
            ),
            WallMotion::Shearing { .. } => {
                c.fail(format!("container.walls.{}", w.face.name()), format!("shearing walls are not available with method {name}"))
            }
            _ => {}
        }
    }
    if let Some(e) = &scene.experiment {
        if !matches!(e, Experiment::Isotropic { .. } | Experiment::Triaxial { .. } | Experiment::Compaction { .. }) {
            c.fail(
                "experiment.kind",
                format!(
                    "the {} experiment is not available with method {name}: it runs isotropic, biaxial and compaction",
                    e.kind(scene.dim)
                ),
            );
        }
    }
}

/// Where the scene's aggregates of bonded primaries come from, as the start of a sentence
/// ("particles[0] are", "start_from holds"), if it has any.
pub(crate) fn aggregates(scene: &Scene) -> Option<String> {
    match scene.sets.iter().position(|s| s.aggregate.is_some()) {
        Some(k) => Some(format!("particles[{k}] are")),
        None => scene.initial.as_ref().filter(|st| !st.bondings.is_empty()).map(|_| "start_from holds".to_string()),
    }
}
