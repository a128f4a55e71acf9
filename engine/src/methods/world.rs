//! What every particle method builds and reports the same way: the initial particles in their
//! box, the reference velocity of a scene, the shear geometry the metrics need, the walls as
//! the metrics see them, and the saved state.

use crate::error::EngineError;
use crate::geometry::Domain;
use crate::loading::Wall;
use crate::math::{Real, Vec3, AXES};
use crate::observe::{ShearGeometry, WallFace, WallView};
use crate::particles::aggregate::NO_AGGREGATE;
use crate::particles::{generate::place_particles, Particles};
use crate::scene::state::{StateBonding, StateParticles, STATE_FORMAT, STATE_VERSION};
use crate::scene::{Material, Scene, StateFile};

/// Checks that each periodic length of `domain` holds twice the interaction reach of a pair
/// of the largest particles (radius `rmax`, m) whose laws act across `reach` and whose
/// neighbour lists keep `skin` more, m: minimum images must be unique.
pub(crate) fn check_periodic_room(domain: &Domain, rmax: Real, reach: Real, skin: Real) -> Result<(), EngineError> {
    let need = 2.0 * (2.0 * rmax + reach + skin);
    for (a, axis) in AXES.iter().enumerate().take(domain.dim) {
        if domain.periodic[a] && domain.length(a) < need {
            return Err(EngineError::Build {
                field: format!("container.max[{a}]"),
                reason: format!(
                    "periodic length {:e} m along {} is below {need:e} m (twice the interaction reach): enlarge the box",
                    domain.length(a),
                    axis
                ),
            });
        }
    }
    Ok(())
}

/// The scene's box and its particles, placed, given the Lees-Edwards velocity profile and
/// sorted by cell (neighbours close in memory).
pub(crate) fn initial_particles(scene: &Scene) -> Result<(Particles, Domain), EngineError> {
    let c = &scene.container;
    let mut domain = Domain {
        dim: scene.dim,
        lo: c.lo,
        hi: c.hi,
        periodic: c.periodic,
        shear_rate: c.lees_edwards.map_or(0.0, |le| le.0),
        le_offset: 0.0,
    };
    let mut p = place_particles(scene, &domain)?;
    if p.is_empty() {
        return Err(EngineError::Build { field: "particles".into(), reason: "the scene has no particle".into() });
    }
    if let Some((rate, true)) = c.lees_edwards {
        let ymid = 0.5 * (domain.lo.y + domain.hi.y);
        for (x, v) in p.pos.iter().zip(p.vel.iter_mut()) {
            v.x += rate * (x.y - ymid);
        }
    }
    // A state's material points and meshes follow its particles' order (`mpm` and `fem` go on
    // from them), and so does a checkpoint's contact history.
    if scene.initial.as_ref().is_none_or(|st| st.points.is_none() && st.meshes.is_none() && !st.continued) {
        sort_by_cell(&mut p, &domain);
    }
    // A state saved from a sheared Lees-Edwards cell keeps its image offset.
    domain.le_offset = scene.initial.as_ref().map_or(0.0, |st| st.lees_edwards_offset);
    Ok((p, domain))
}

/// Reorders particles by cell so that neighbours sit close in memory (done once, before any
/// history exists).
fn sort_by_cell(p: &mut Particles, domain: &Domain) {
    let rmax = p.radius.iter().copied().fold(0.0, f64::max);
    let w = (4.0 * rmax).max(1e-300);
    let key = |x: &Vec3| -> (i64, i64, i64) {
        let k = |a: usize| ((x[a] - domain.lo[a]) / w).floor() as i64;
        (k(2), k(1), k(0))
    };
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_by_key(|&i| key(&p.pos[i]));
    p.permute(&order);
}

/// Floor of [`reference_velocity`], m/s.
const REFERENCE_FLOOR: Real = 0.1;

/// Fastest motion expected in a scene, m/s: the largest of [`imposed_speed`] (without the
/// stages' walls) and 0.1 m/s.
pub(crate) fn reference_velocity(scene: &Scene, p: &Particles) -> Real {
    REFERENCE_FLOOR.max(imposed_speed(scene, p, false))
}

/// Fastest motion the scene sets, m/s (0 if none): [`Scene::imposed_speed`] with the placed
/// particles' fastest initial speed.
pub(crate) fn imposed_speed(scene: &Scene, p: &Particles, stages: bool) -> Real {
    scene.imposed_speed(p.vel.iter().map(|x| x.norm()).fold(0.0, f64::max), stages)
}

/// Sets the Lees-Edwards shear rate to `rate` (1/s), adding the change of the velocity profile
/// to every grain (`v_x += Δγ̇ (y - y_mid)`); the grains must be in the box (wrapped), so that
/// each gets the profile of its own position, and the pairs across the sheared boundary must be
/// found again afterwards (their images' velocities changed).
pub(crate) fn impose_shear_rate(domain: &mut Domain, p: &mut Particles, rate: Real) {
    let change = rate - domain.shear_rate;
    let ymid = 0.5 * (domain.lo.y + domain.hi.y);
    for (x, v) in p.pos.iter().zip(p.vel.iter_mut()) {
        v.x += change * (x.y - ymid);
    }
    domain.shear_rate = rate;
}

/// Area (length in 2D) of the faces normal to `axis`, m^(D-1).
pub(crate) fn wall_area(domain: &Domain, axis: usize) -> Real {
    (0..domain.dim).filter(|&a| a != axis).map(|a| domain.length(a)).product()
}

/// Largest relative error of a stress-controlled wall against its target (0 if none).
pub(crate) fn wall_stress_error(walls: &[Wall], domain: &Domain) -> Real {
    let mut error: Real = 0.0;
    for w in walls {
        if let Some(target) = w.target_stress() {
            error = error.max((w.normal_stress(wall_area(domain, w.face.axis)) - target).abs() / target);
        }
    }
    error
}

/// The walls as the metrics see them.
pub(crate) fn wall_views(walls: &[Wall], domain: &Domain) -> Vec<WallView> {
    walls
        .iter()
        .map(|w| WallView {
            name: w.face.name(),
            position: w.position,
            normal: w.normal(),
            force: w.force,
            area: wall_area(domain, w.face.axis),
        })
        .collect()
}

/// The walls as snapshots draw them.
pub(crate) fn wall_faces(walls: &[Wall]) -> Vec<WallFace> {
    walls
        .iter()
        .map(|w| WallFace { name: w.face.name(), axis: w.face.axis, position: w.position, normal: w.normal(), force: w.force })
        .collect()
}

/// A method's own thread pool of `threads` threads, or `None` for rayon's global pool (0).
pub(crate) fn own_pool(threads: usize) -> Result<Option<rayon::ThreadPool>, EngineError> {
    if threads == 0 {
        return Ok(None);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map(Some)
        .map_err(|e| EngineError::Build { field: "method.threads".into(), reason: format!("cannot start {threads} threads: {e}") })
}

/// The container's walls at its faces, for a method whose walls need no servo gain of their own
/// (contact dynamics, MPM: the contact solver holds them).
pub(crate) fn container_walls(c: &crate::scene::Container) -> Vec<Wall> {
    c.walls
        .iter()
        .map(|w| {
            let pos = if w.face.upper { c.hi[w.face.axis] } else { c.lo[w.face.axis] };
            Wall::new(w.face, pos, w.motion, 0.0, 0.0)
        })
        .collect()
}

/// Runs `f` (one step of a method) on the method's own thread pool when it has one, so that
/// every parallel loop of the step uses it; the pool is taken out of `slot` for the call and
/// put back.
pub(crate) fn in_own_pool<S, R>(sim: &mut S, slot: fn(&mut S) -> &mut Option<rayon::ThreadPool>, f: impl FnOnce(&mut S) -> R + Send) -> R
where
    S: Send,
    R: Send,
{
    match slot(sim).take() {
        Some(pool) => {
            let r = pool.install(|| f(sim));
            *slot(sim) = Some(pool);
            r
        }
        None => f(sim),
    }
}

/// Where a shear rate is defined: a Lees-Edwards cell, or a wall sliding tangentially against
/// the opposite one.
pub(crate) fn shear_geometry(domain: &Domain, walls: &[Wall]) -> Option<ShearGeometry> {
    if domain.sheared() {
        return Some(ShearGeometry { rate: domain.shear_rate, flow: 0, gradient: 1, streaming: true });
    }
    for w in walls {
        let a = w.face.axis;
        let mut tangential = w.velocity;
        tangential[a] = 0.0;
        if let Some(flow) = (0..domain.dim).find(|&b| b != a && tangential[b] != 0.0) {
            let gap = domain.length(a);
            let opposite = walls.iter().find(|o| o.face.axis == a && o.face.upper != w.face.upper);
            let rel = tangential[flow] - opposite.map_or(0.0, |o| o.velocity[flow]);
            return Some(ShearGeometry { rate: rel / gap, flow, gradient: a, streaming: false });
        }
    }
    None
}

/// Copies of the positions and velocities brought back into the periodic box (particles
/// return into it only at neighbour builds; crossing a Lees-Edwards boundary changes the
/// velocity too).
pub(crate) fn wrapped(domain: &Domain, p: &Particles) -> (Vec<Vec3>, Vec<Vec3>) {
    let (mut position, mut velocity) = (p.pos.clone(), p.vel.clone());
    for (x, v) in position.iter_mut().zip(velocity.iter_mut()) {
        domain.wrap(x, v);
    }
    (position, velocity)
}

/// The particles and box now, as a state file to start another run from.
pub(crate) fn saved_state(time: Real, steps: u64, domain: &Domain, materials: &[Material], p: &Particles) -> StateFile {
    let d = domain.dim;
    let mut st = StateFile {
        format: STATE_FORMAT.to_string(),
        version: STATE_VERSION,
        dimension: d as u8,
        time,
        steps,
        min: domain.lo.as_slice()[..d].to_vec(),
        max: domain.hi.as_slice()[..d].to_vec(),
        periodic: (0..d).filter(|&a| domain.periodic[a]).map(|a| AXES[a].to_string()).collect(),
        lees_edwards_offset: domain.le_offset,
        materials: Vec::new(),
        particles: StateParticles {
            material: Vec::with_capacity(p.len()),
            radius: p.radius.clone(),
            wet: if p.wet.iter().any(|&w| w) { p.wet.clone() } else { Vec::new() },
            aggregate: if p.bondings.is_empty() {
                Vec::new()
            } else {
                p.aggregate.iter().map(|&a| (a != NO_AGGREGATE).then_some(a)).collect()
            },
            ..StateParticles::default()
        },
        bondings: p
            .bondings
            .iter()
            .map(|b| StateBonding {
                force: b.attraction.f0,
                exponent: b.attraction.gamma,
                cutoff: b.attraction.cutoff,
                friction: b.friction,
            })
            .collect(),
        material_points: None,
        meshes: None,
    };
    // Only the materials the particles use (walls' and unused ones need not exist where the
    // state goes), numbered in order of first use.
    let mut number: Vec<Option<u16>> = vec![None; materials.len()];
    for &m in &p.material {
        let slot = &mut number[m as usize];
        let k = *slot.get_or_insert_with(|| {
            st.materials.push(materials[m as usize].name.clone());
            (st.materials.len() - 1) as u16
        });
        st.particles.material.push(k);
    }
    let (position, velocity) = wrapped(domain, p);
    let q = &mut st.particles;
    q.position = position.iter().map(|x| x.as_slice()[..d].to_vec()).collect();
    q.velocity = velocity.iter().map(|v| v.as_slice()[..d].to_vec()).collect();
    q.angular_velocity = p.omega.iter().map(|w| if d == 2 { vec![w.z] } else { w.as_slice().to_vec() }).collect();
    st
}
