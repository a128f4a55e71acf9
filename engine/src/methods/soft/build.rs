//! What building a soft-grain method on a scene shares, whatever its grains are made of
//! (material points or meshes): the placed disks the grains are made from, the smallest of them
//! (the size of a cell or an element follows from it), one constitutive law per deformable
//! material, the container's walls as the system's planes, the time step and the steps'
//! settings.

use nalgebra::Vector2;

use super::contact::{Sides, Wall as PlaneWall};
use super::params::{Dynamics, SoftSolver};
use super::Settings;
use crate::constitutive::ConstitutiveLaw;
use crate::error::EngineError;
use crate::geometry::Domain;
use crate::loading::Wall;
use crate::math::Real;
use crate::methods::world;
use crate::particles::Particles;
use crate::scene::{Material, Scene};

type V2 = Vector2<Real>;

/// The disks the grains of method `name` are made from, placed as rigid disks are (the scene's
/// sizes and placements, or a saved state's grains as disks of their current area), and the
/// box; an error unless the scene is 2D (the soft-grain methods are plane strain).
pub fn placed(scene: &Scene, name: &str) -> Result<(Particles, Domain), EngineError> {
    if scene.dim != 2 {
        return Err(EngineError::Build { field: "dimension".into(), reason: format!("method {name} is 2D (plane strain)") });
    }
    world::initial_particles(scene)
}

/// The smallest diameter of disks of `radii` (m), m.
pub fn smallest_diameter(radii: &[Real]) -> Real {
    radii.iter().copied().fold(Real::INFINITY, Real::min) * 2.0
}

/// One constitutive law per deformable material of `scene`: each material's law (its index in
/// the laws; `None` for a rigid material), and the laws.
pub fn laws(scene: &Scene) -> (Vec<Option<usize>>, Vec<Box<dyn ConstitutiveLaw>>) {
    let mut law_of: Vec<Option<usize>> = vec![None; scene.materials.len()];
    let mut laws: Vec<Box<dyn ConstitutiveLaw>> = Vec::new();
    for (m, mat) in scene.materials.iter().enumerate() {
        if let Some(spec) = &mat.deformable {
            law_of[m] = Some(laws.len());
            laws.push(crate::constitutive::build(spec));
        }
    }
    (law_of, laws)
}

/// Grain `k`'s law (its index, from [`laws`]) and material; an error naming method `name`
/// when the material is not deformable.
pub fn grain_law<'a>(
    scene: &'a Scene,
    law_of: &[Option<usize>],
    particles: &Particles,
    k: usize,
    name: &str,
) -> Result<(usize, &'a Material), EngineError> {
    let m = particles.material[k] as usize;
    match (law_of.get(m).copied().flatten(), scene.materials.get(m)) {
        (Some(law), Some(mat)) => Ok((law, mat)),
        _ => Err(EngineError::Build {
            field: "particles".into(),
            reason: format!("grain {k}'s material is not deformable: method {name} needs deformable grains"),
        }),
    }
}

/// The container's walls as the system's planes (a grain–wall pair's friction is the geometric
/// mean of the grain's and the wall material's, which validation requires when there are walls).
pub fn planes(scene: &Scene, walls: &[Wall]) -> Vec<PlaneWall> {
    let friction = scene.container.wall_material.and_then(|w| scene.materials.get(w)).map_or(0.0, |m| m.friction);
    walls
        .iter()
        .map(|w| {
            let mut point = V2::zeros();
            point[w.face.axis] = w.position;
            let normal = w.normal();
            PlaneWall { point, normal: V2::new(normal.x, normal.y), velocity: V2::new(w.velocity.x, w.velocity.y), friction }
        })
        .collect()
}

/// The settings of steps of `dt` (s) on `scene` from the method's `solver` settings, contacts
/// held on both sides of each pair (`both`) or on one; `auto` dynamics resolved on the scene
/// (the checks leave `auto` only with θ = 1, and refuse quasi-static steps with another).
pub fn settings(scene: &Scene, solver: &SoftSolver, dt: Real, both: bool) -> Settings {
    let quasi_static = match solver.dynamics {
        Dynamics::QuasiStatic => true,
        Dynamics::Inertial => false,
        Dynamics::Auto => crate::advise::soft_inertia(scene).is_ok(),
    };
    Settings {
        dt,
        theta: solver.theta,
        gravity: V2::new(scene.gravity.x, scene.gravity.y),
        quasi_static,
        newton_tolerance: solver.newton_tolerance,
        max_newton: solver.max_newton,
        contact: solver.contact(both),
        sides: if both { Sides::Both } else { Sides::One },
    }
}

/// The time step, s: the scene's, or the one in which the fastest imposed motion on the
/// `particles` covers `max_displacement` of `size` (a grid cell or an element, m).
pub fn time_step(scene: &Scene, particles: &Particles, solver: &SoftSolver, size: Real) -> Real {
    let speed = world::imposed_speed(scene, particles, true).max(1e-3 * size);
    solver.time_step.unwrap_or(solver.max_displacement * size / speed)
}
