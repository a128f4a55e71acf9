//! The parameters of soft-contact DEM (`"method": "dem"` or `{"kind": "dem", ...}`): what a
//! scene may set, their defaults and checks, and what DEM requires of a scene.

use serde::{Deserialize, Serialize};

use crate::error::EngineError;
use crate::math::Real;
use crate::methods::method::{check_threads, read_spec, Method, MethodEntry};
use crate::run::Simulation;
use crate::scene::{Checker, ElasticLaw, Material, Scene};

/// Parameters of the `dem` method as written in a scene (all optional).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemParamsSpec {
    /// Always `"dem"`.
    pub kind: String,
    /// Time step, s. Default: `time_step_fraction` × collision time.
    #[serde(default)]
    pub time_step: Option<f64>,
    /// Fraction of the collision time used as time step. Default 0.02 (t_c / 50).
    #[serde(default)]
    pub time_step_fraction: Option<f64>,
    /// Verlet skin as a fraction of the smallest diameter. Default 0.1.
    #[serde(default)]
    pub skin: Option<f64>,
    /// Impact velocity used for the Hertz collision time, m/s. Default from the scene.
    #[serde(default)]
    pub reference_velocity: Option<f64>,
    /// Largest allowed overlap as a fraction of the smaller radius. Default 0.1.
    #[serde(default)]
    pub max_overlap: Option<f64>,
    /// Threads for the force loop (0 or absent: rayon's global pool).
    #[serde(default)]
    pub threads: Option<usize>,
    /// Cundall's local (non-viscous) damping coefficient in [0, 1): each force and torque
    /// component is reduced by this fraction of its magnitude against the motion. Default 0.
    /// For quasi-static preparation only: it is not a physical law.
    #[serde(default)]
    pub local_damping: Option<f64>,
}

/// Parameters of soft-contact DEM, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct DemParams {
    /// Time step, s; `None` = `time_step_fraction` × collision time.
    pub time_step: Option<Real>,
    /// Fraction of the collision time used when `time_step` is absent.
    pub time_step_fraction: Real,
    /// Verlet skin as a fraction of the smallest diameter.
    pub skin: Real,
    /// Impact velocity for the Hertz collision time, m/s (`None`: estimated).
    pub reference_velocity: Option<Real>,
    /// Largest allowed overlap / smaller radius.
    pub max_overlap: Real,
    /// Threads for the force loop; 0 = rayon's global pool.
    pub threads: usize,
    /// Cundall's local damping coefficient in [0, 1).
    pub local_damping: Real,
}

impl Default for DemParams {
    fn default() -> Self {
        Self {
            time_step: None,
            time_step_fraction: 0.02,
            skin: 0.1,
            reference_velocity: None,
            max_overlap: 0.1,
            threads: 0,
            local_damping: 0.0,
        }
    }
}

/// The registry's line for DEM.
pub const ENTRY: MethodEntry = MethodEntry { name: "dem", parse, defaults: || Box::new(DemParams::default()), newton: false };

fn parse(object: Option<&serde_json::Value>, c: &mut Checker) -> Option<Box<dyn Method>> {
    let s: DemParamsSpec = read_spec(c, object)?;
    Some(Box::new(check(c, &s)))
}

/// Checks the parameters a scene gives, every bad one named under `method.`.
pub fn check(c: &mut Checker, s: &DemParamsSpec) -> DemParams {
    let mut p = DemParams::default();
    if let Some(dt) = s.time_step {
        if c.positive("method.time_step", dt) {
            p.time_step = Some(dt);
        }
    }
    if let Some(f) = s.time_step_fraction {
        if s.time_step.is_some() {
            c.fail("method.time_step_fraction", "give either time_step or time_step_fraction, not both");
        } else if c.within("method.time_step_fraction", f, 1e-6, 0.5) {
            p.time_step_fraction = f;
        }
    }
    if let Some(skin) = s.skin {
        if c.within("method.skin", skin, 1e-3, 2.0) {
            p.skin = skin;
        }
    }
    if let Some(v) = s.reference_velocity {
        if c.positive("method.reference_velocity", v) {
            p.reference_velocity = Some(v);
        }
    }
    if let Some(o) = s.max_overlap {
        if c.within("method.max_overlap", o, 1e-4, 1.0) {
            p.max_overlap = o;
        }
    }
    if let Some(a) = s.local_damping {
        if !(a.is_finite() && (0.0..1.0).contains(&a)) {
            c.fail("method.local_damping", format!("must be >= 0 and < 1, got {a}"));
        } else {
            p.local_damping = a;
        }
    }
    if let Some(t) = s.threads {
        p.threads = check_threads(c, t);
    }
    p
}

impl Method for DemParams {
    fn fit(&mut self, scene: &Scene, _given: &serde_json::Value, c: &mut Checker) {
        crate::methods::fit::rigid_grains(scene, "dem", c);
        for m in scene.materials.iter().filter(|m| m.deformable.is_none()) {
            check_restitution(c, m);
        }
        check_aggregates(scene, c);
    }

    fn build(&self, scene: &Scene) -> Result<Box<dyn Simulation>, EngineError> {
        Ok(Box::new(super::Dem::new(scene, self)?))
    }

    crate::method_common!("dem", threads);
}

/// DEM's restitution is a damping ratio: a perfectly plastic impact (0) is beyond it, and a
/// linear contact whose damping may not pull cannot lose more than critical damping takes.
fn check_restitution(c: &mut Checker, m: &Material) {
    let field = format!("materials.{}.restitution", m.name);
    let e = m.restitution;
    if e == 0.0 {
        c.fail(field, "must be > 0 with method dem (a perfectly plastic impact, 0, is method cd's), got 0");
        return;
    }
    let linear = matches!(m.law, ElasticLaw::Linear { .. });
    if linear && m.limit_damping && e > 0.0 && e < crate::contact::damping::MIN_LIMITED_RESTITUTION {
        c.fail(
            field,
            format!(
                "must be >= {} with the linear law when limit_damping is true (an overdamped contact cannot reach lower); got {}",
                crate::contact::damping::MIN_LIMITED_RESTITUTION,
                e
            ),
        );
    }
}

/// Largest overlap of two touching primaries under the attraction `F_0`, as a fraction of the
/// smallest primary's diameter, that DEM accepts: the model's primaries are rigid.
const DEM_PRIMARY_OVERLAP: Real = 0.01;

/// The rules of the scene's aggregates of bonded primaries run by DEM, from its sets and from
/// the state it starts from.
fn check_aggregates(scene: &Scene, c: &mut Checker) {
    for (k, set) in scene.sets.iter().enumerate() {
        if let (Some(a), Some(m)) = (&set.aggregate, scene.materials.get(set.material)) {
            check_aggregate(c, &format!("particles[{k}].model"), a.bonding, a.primaries.min_diameter(), m);
        }
    }
    // The aggregates a saved state holds: the same rules, with the primaries it holds.
    if let Some(st) = &scene.initial {
        // One pass over the particles: each aggregate's smallest primary and its material.
        let mut of: Vec<(Real, Option<usize>)> = vec![(Real::INFINITY, None); st.bondings.len()];
        for (i, &a) in st.aggregate.iter().enumerate() {
            if let (Some(o), Some(&r)) = (of.get_mut(a as usize), st.radius.get(i)) {
                o.0 = o.0.min(2.0 * r);
                o.1 = o.1.or(st.material.get(i).copied());
            }
        }
        for (k, (b, (d_min, material))) in st.bondings.iter().zip(of).enumerate() {
            if let Some(m) = material.and_then(|m| scene.materials.get(m)) {
                check_aggregate(c, &format!("start_from.state.bondings[{k}]"), *b, d_min, m);
            }
        }
    }
}

/// The rules of aggregates bonded by `b` (a set's model, or a saved state's bonding, named by
/// `path`) whose primaries are of material `m`, the smallest `d_min` across, run by DEM: the
/// primaries touch by their material's contact law, which must therefore carry the bond's
/// friction, and hold `F_0` at an overlap of at most [`DEM_PRIMARY_OVERLAP`] of `d_min`.
fn check_aggregate(c: &mut Checker, path: &str, b: crate::particles::aggregate::Bonding, d_min: Real, m: &Material) {
    if b.friction != m.friction {
        c.fail(
            format!("{path}.friction"),
            format!(
                "with method dem the primaries of one aggregate touch by their material's contact law: must equal materials.{}.friction ({}), got {} (method cd takes a friction of its own)",
                m.name, m.friction, b.friction
            ),
        );
    }
    if !(d_min.is_finite() && d_min > 0.0 && b.attraction.f0 > 0.0) {
        return;
    }
    let law = crate::contact::ContactTable::new(std::slice::from_ref(m));
    let overlap = DEM_PRIMARY_OVERLAP * d_min;
    let held = crate::contact::NormalForce::elastic(&law.get(0, 0).normal, overlap, 0.25 * d_min);
    if held < b.attraction.f0 {
        c.fail(
            format!("materials.{}.contact", m.name),
            format!(
                "with method dem the primaries are rigid: their contact must hold the attraction F_0 = {} at an overlap of {:.0}% of the smallest primary's diameter ({overlap:.3e} m), where this law gives {held:.3e} (the linear law needs k_n >= {:.3e})",
                b.attraction.f0,
                100.0 * DEM_PRIMARY_OVERLAP,
                b.attraction.f0 / overlap
            ),
        );
    }
}
