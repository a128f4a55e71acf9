//! Saved states: the particles and the box at the end of a run, as JSON (`sable run
//! --save-state`, and the final state the service keeps for every finished job), and their check
//! when a scene starts from one (`start_from`, `docs/scene-format.md` §14).
//!
//! A state holds what another run needs to go on from the same configuration: each particle's
//! material (by name), radius, position, velocity and angular velocity, whether it is wet, and the
//! box (bounds, periodic axes, Lees-Edwards image offset). It does not hold the contact history
//! (tangential and rolling springs, capillary bridges): the new run starts with fresh springs, as a
//! sample taken out of one apparatus and put into another would, and a stage that runs until
//! equilibrium settles it again in a few thousand steps.

use serde::{Deserialize, Serialize};

use super::state_meshes::{check_meshes, StateMeshes};
use super::state_points::{check_points, StatePoints};
use super::violation::{Checker, EntryRule};
use crate::contact::attraction_lj::AttractionLj;
use crate::math::{Real, Vec3, AXES};
use crate::particles::aggregate::{Bonding, NO_AGGREGATE};

/// Value of [`StateFile::format`].
pub const STATE_FORMAT: &str = "sable-state";
/// Version of the state format written by this engine.
pub const STATE_VERSION: u32 = 1;

/// A saved state, as written to and read from JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateFile {
    /// Always [`STATE_FORMAT`].
    pub format: String,
    /// [`STATE_VERSION`].
    pub version: u32,
    /// 2 or 3.
    pub dimension: u8,
    /// Simulated time of the run that saved it, s (information only: a run started from a state
    /// counts its time from 0).
    #[serde(default)]
    pub time: f64,
    /// Steps of the run that saved it (information only).
    #[serde(default)]
    pub steps: u64,
    /// Lower corner of the box, m (on walled axes: the walls' positions).
    pub min: Vec<f64>,
    /// Upper corner of the box, m.
    pub max: Vec<f64>,
    /// Periodic axes (`"x"`, `"y"`, `"z"`).
    #[serde(default)]
    pub periodic: Vec<String>,
    /// Lees-Edwards image offset along x of the periodic image one period up along y, m, in
    /// [0, L_x) (0 unless the run sheared a Lees-Edwards cell).
    #[serde(default)]
    pub lees_edwards_offset: f64,
    /// Material names; particles refer to them by index.
    pub materials: Vec<String>,
    /// The particles.
    pub particles: StateParticles,
    /// The laws within each aggregate of primaries (bonded particle method), indexed by
    /// [`StateParticles::aggregate`]; empty: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bondings: Vec<StateBonding>,
    /// The grains' material points, when a run of method `mpm` saved the state
    /// ([`super::state_points`]); a run of `mpm` goes on from them, every other method starts
    /// from the disks in `particles`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material_points: Option<StatePoints>,
    /// The grains' meshes, when a run of method `fem` saved the state
    /// ([`super::state_meshes`]); a run of `fem` goes on from them, every other method starts
    /// from the disks in `particles`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub meshes: Option<StateMeshes>,
}

/// The laws between primaries of one aggregate, in a [`StateFile`]
/// ([`crate::particles::aggregate::Bonding`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateBonding {
    /// Largest attraction `F_0`, N/m in 2D (N in 3D).
    pub force: f64,
    /// Exponent `γ`.
    pub exponent: f64,
    /// Cut-off gap, m.
    pub cutoff: f64,
    /// Friction between the aggregate's primaries.
    pub friction: f64,
}

/// The particles of a [`StateFile`], one entry per particle in every array.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateParticles {
    /// Index into [`StateFile::materials`].
    pub material: Vec<u16>,
    /// Radius, m.
    pub radius: Vec<f64>,
    /// Centre, m (`dimension` components), inside the box.
    pub position: Vec<Vec<f64>>,
    /// Velocity, m/s (`dimension` components).
    pub velocity: Vec<Vec<f64>>,
    /// Angular velocity, rad/s: one component (about z) in 2D, three in 3D.
    pub angular_velocity: Vec<Vec<f64>>,
    /// Wet particles (those that carry liquid); empty: none.
    #[serde(default)]
    pub wet: Vec<bool>,
    /// The aggregate each particle is a primary of (an index into [`StateFile::bondings`]), or
    /// null; empty: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aggregate: Vec<Option<u32>>,
}

/// A checked state a scene starts from: particles in the scene's material numbering.
#[derive(Debug, Clone, PartialEq)]
pub struct InitialState {
    /// Lees-Edwards image offset, m.
    pub lees_edwards_offset: Real,
    /// Centres, m.
    pub pos: Vec<Vec3>,
    /// Velocities, m/s.
    pub vel: Vec<Vec3>,
    /// Angular velocities, rad/s.
    pub omega: Vec<Vec3>,
    /// Radii, m.
    pub radius: Vec<Real>,
    /// Index of each particle's material in the scene.
    pub material: Vec<usize>,
    /// Wet flags.
    pub wet: Vec<bool>,
    /// Aggregate of each particle ([`crate::particles::aggregate::NO_AGGREGATE`]: none).
    pub aggregate: Vec<u32>,
    /// The laws within each aggregate.
    pub bondings: Vec<Bonding>,
    /// The grains' material points (checked), in the order of the particles: a run of `mpm`
    /// goes on from them.
    pub points: Option<StatePoints>,
    /// The grains' meshes (checked), in the order of the particles: a run of `fem` goes on from
    /// them.
    pub meshes: Option<StateMeshes>,
    /// The state is a checkpoint's, and the run goes on as the one that saved it
    /// ([`super::Scene::continue_saved_run`]): its particles keep the state's order and its
    /// aggregates are not relaxed again. False for a scene's `start_from`.
    pub continued: bool,
}

impl InitialState {
    /// Number-mean diameter, m.
    pub fn mean_diameter(&self) -> Real {
        2.0 * self.radius.iter().sum::<Real>() / self.radius.len().max(1) as Real
    }
}

fn vec3(v: &[f64]) -> Vec3 {
    let mut out = Vec3::zeros();
    for (k, x) in v.iter().take(3).enumerate() {
        out[k] = *x;
    }
    out
}

/// A state's box as checked: its corners, its periodic axes, and whether the corners are valid
/// vectors of the scene's dimension.
struct StateBox {
    /// Whether `min` and `max` are well-formed vectors (the checks against the box need them).
    ok: bool,
    /// Lower corner.
    lo: Vec3,
    /// Upper corner.
    hi: Vec3,
    /// Periodic axes.
    periodic: [bool; 3],
}

/// Checks a state against the scene it starts: dimension, box, periodic axes, material names
/// (`material_index` maps a name to the scene's material, reporting unknown ones) and every
/// particle. `path` is the state's field path (`start_from.state`).
pub(crate) fn check_state(
    c: &mut Checker,
    path: &str,
    s: &StateFile,
    dim: usize,
    material_index: &dyn Fn(&mut Checker, &str, &str) -> usize,
) -> InitialState {
    let bx = check_state_box(c, path, s, dim);
    let materials: Vec<usize> =
        s.materials.iter().enumerate().map(|(i, name)| material_index(c, &format!("{path}.materials[{i}]"), name)).collect();

    let p = &s.particles;
    let n = p.radius.len();
    let pp = format!("{path}.particles");
    let lengths_ok = check_particle_lengths(c, &pp, p);
    let bondings = check_bondings(c, &format!("{path}.bondings"), &s.bondings);
    let mut out = InitialState {
        lees_edwards_offset: s.lees_edwards_offset,
        pos: Vec::new(),
        vel: Vec::new(),
        omega: Vec::new(),
        radius: Vec::new(),
        material: Vec::new(),
        wet: Vec::new(),
        aggregate: Vec::new(),
        bondings,
        points: None,
        meshes: None,
        continued: false,
    };
    if !lengths_ok {
        return out;
    }
    check_soft_grains(c, path, s, dim, &bx, &mut out);
    check_particle_entries(c, path, p, dim, materials.len(), &bx);
    out.pos = p.position.iter().map(|v| vec3(v)).collect();
    out.vel = p.velocity.iter().map(|v| vec3(v)).collect();
    out.omega = p
        .angular_velocity
        .iter()
        .map(|w| if dim == 2 { Vec3::new(0.0, 0.0, w.first().copied().unwrap_or(0.0)) } else { vec3(w) })
        .collect();
    out.radius = p.radius.clone();
    out.material = p.material.iter().map(|&m| materials.get(m as usize).copied().unwrap_or(0)).collect();
    out.wet = if p.wet.is_empty() { vec![false; n] } else { p.wet.clone() };
    {
        let mut rule = EntryRule::new(c, format!("{pp}.aggregate"), "particles");
        for (i, a) in p.aggregate.iter().enumerate() {
            if a.is_some_and(|a| a as usize >= s.bondings.len()) {
                rule.fail(i, format!("must index {path}.bondings (0..{}) or be null, got {a:?}", s.bondings.len()));
            }
        }
    }
    out.aggregate =
        if p.aggregate.is_empty() { vec![NO_AGGREGATE; n] } else { p.aggregate.iter().map(|a| a.unwrap_or(NO_AGGREGATE)).collect() };
    out
}

/// Checks a state's format, version and dimension, its box, periodic axes and Lees-Edwards offset.
fn check_state_box(c: &mut Checker, path: &str, s: &StateFile, dim: usize) -> StateBox {
    if s.format != STATE_FORMAT {
        c.fail(format!("{path}.format"), format!("must be '{STATE_FORMAT}', got '{}'", s.format));
    }
    if s.version != STATE_VERSION {
        c.fail(format!("{path}.version"), format!("this engine reads version {STATE_VERSION}, got {}", s.version));
    }
    if s.dimension as usize != dim {
        c.fail(format!("{path}.dimension"), format!("the state is {}D, the scene {dim}D: they must agree", s.dimension));
    }
    let ok_box = c.vector(&format!("{path}.min"), &s.min, dim) & c.vector(&format!("{path}.max"), &s.max, dim);
    let (lo, hi) = (vec3(&s.min), vec3(&s.max));
    if ok_box {
        for a in 0..dim {
            if lo[a] >= hi[a] {
                c.fail(format!("{path}.max[{a}]"), format!("must be > min[{a}] = {}, got {}", lo[a], hi[a]));
            }
        }
    }
    let mut periodic = [false; 3];
    for (i, name) in s.periodic.iter().enumerate() {
        match AXES[..dim].iter().position(|a| a == name) {
            Some(a) => periodic[a] = true,
            None => c.fail(format!("{path}.periodic[{i}]"), format!("must be one of {} in {dim}D, got '{name}'", AXES[..dim].join(", "))),
        }
    }
    let offset = s.lees_edwards_offset;
    if offset != 0.0 {
        let lx = hi.x - lo.x;
        if !(periodic[0] && periodic[1]) {
            c.fail(format!("{path}.lees_edwards_offset"), "must be 0 unless x and y are periodic");
        } else if !(offset.is_finite() && offset >= 0.0 && (!ok_box || offset < lx)) {
            c.fail(format!("{path}.lees_edwards_offset"), format!("must be in [0, L_x = {lx}), got {offset}"));
        }
    }
    StateBox { ok: ok_box, lo, hi, periodic }
}

/// Checks that the particles exist and that every per-particle array has one entry each (`wet`
/// and `aggregate` may be empty); false when a length is wrong.
fn check_particle_lengths(c: &mut Checker, pp: &str, p: &StateParticles) -> bool {
    let n = p.radius.len();
    if n == 0 {
        c.fail(format!("{pp}.radius"), "the state has no particle");
    }
    let mut lengths_ok = true;
    for (name, len) in [
        ("material", p.material.len()),
        ("position", p.position.len()),
        ("velocity", p.velocity.len()),
        ("angular_velocity", p.angular_velocity.len()),
    ] {
        if len != n {
            c.fail(format!("{pp}.{name}"), format!("must have one entry per particle ({n}, the length of radius), got {len}"));
            lengths_ok = false;
        }
    }
    if !p.wet.is_empty() && p.wet.len() != n {
        c.fail(format!("{pp}.wet"), format!("must be empty or have one entry per particle ({n}), got {}", p.wet.len()));
        lengths_ok = false;
    }
    if !p.aggregate.is_empty() && p.aggregate.len() != n {
        c.fail(format!("{pp}.aggregate"), format!("must be empty or have one entry per particle ({n}), got {}", p.aggregate.len()));
        lengths_ok = false;
    }
    lengths_ok
}

/// Checks a state's material points and meshed grains (2D only) and keeps them in `out`.
fn check_soft_grains(c: &mut Checker, path: &str, s: &StateFile, dim: usize, bx: &StateBox, out: &mut InitialState) {
    let n = s.particles.radius.len();
    let (lo, hi) = (bx.lo, bx.hi);
    if let Some(points) = &s.material_points {
        let field = format!("{path}.material_points");
        if dim != 2 {
            c.fail(field, "only in 2D (material points are a plane-strain method's)");
        } else if bx.ok && check_points(c, &field, points, n, [lo.x, lo.y], [hi.x, hi.y]) {
            out.points = Some(points.clone());
        }
    }
    if let Some(meshes) = &s.meshes {
        let field = format!("{path}.meshes");
        if dim != 2 {
            c.fail(field, "only in 2D (meshed grains are a plane-strain method's)");
        } else if bx.ok && check_meshes(c, &field, meshes, n, [lo.x, lo.y], [hi.x, hi.y]) {
            out.meshes = Some(meshes.clone());
        }
    }
}

/// Checks every particle's radius, material index, vectors, and position inside the box.
fn check_particle_entries(c: &mut Checker, path: &str, p: &StateParticles, dim: usize, n_materials: usize, bx: &StateBox) {
    let pp = format!("{path}.particles");
    {
        let mut rule = EntryRule::new(c, format!("{pp}.radius"), "particles");
        for (i, r) in p.radius.iter().enumerate() {
            if !(r.is_finite() && *r > 0.0) {
                rule.fail(i, format!("must be > 0, got {r}"));
            }
        }
    }
    {
        let mut rule = EntryRule::new(c, format!("{pp}.material"), "particles");
        for (i, m) in p.material.iter().enumerate() {
            if *m as usize >= n_materials {
                rule.fail(i, format!("must index {path}.materials (0..{n_materials}), got {m}"));
            }
        }
    }
    let omega_len = if dim == 2 { 1 } else { 3 };
    for (name, arrays, want) in
        [("position", &p.position, dim), ("velocity", &p.velocity, dim), ("angular_velocity", &p.angular_velocity, omega_len)]
    {
        let mut rule = EntryRule::new(c, format!("{pp}.{name}"), "particles");
        for (i, v) in arrays.iter().enumerate() {
            if v.len() != want {
                rule.fail(i, format!("must have {want} components, got {}", v.len()));
            } else if v.iter().any(|x| !x.is_finite()) {
                rule.fail(i, "must be finite numbers".to_string());
            }
        }
    }
    if bx.ok {
        let (lo, hi, periodic) = (bx.lo, bx.hi, bx.periodic);
        let mut rule = EntryRule::new(c, format!("{pp}.position"), "particles");
        for (i, v) in p.position.iter().enumerate() {
            if v.len() == dim && v.iter().all(|x| x.is_finite()) {
                if let Some(a) = (0..dim).find(|&a| !(v[a] >= lo[a] && if periodic[a] { v[a] < hi[a] } else { v[a] <= hi[a] })) {
                    rule.fail(i, format!("lies outside the box along {} ({} not in [{}, {}])", AXES[a], v[a], lo[a], hi[a]));
                }
            }
        }
    }
}

/// The laws of a state's aggregates, by the rules of a scene's `bonded_primaries` model.
fn check_bondings(c: &mut Checker, path: &str, bondings: &[StateBonding]) -> Vec<Bonding> {
    bondings
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let p = format!("{path}[{k}]");
            c.positive(&format!("{p}.force"), b.force);
            if !(b.exponent.is_finite() && b.exponent > 1.0) {
                c.fail(format!("{p}.exponent"), format!("must be > 1, got {}", b.exponent));
            }
            c.positive(&format!("{p}.cutoff"), b.cutoff);
            c.non_negative(&format!("{p}.friction"), b.friction);
            Bonding { attraction: AttractionLj { f0: b.force, gamma: b.exponent, cutoff: b.cutoff }, friction: b.friction }
        })
        .collect()
}
