//! The theory a DEM stability limit is compared with (docs/physics.md §2.10, §10.2): velocity
//! Verlet on a linear contact is stable for `dt < 2/ω0`, `ω0 = sqrt(k_n/m*)`, for one contact;
//! dense packings fail earlier (a grain's contacts add up their stiffness).

use serde_json::Value;

use super::report::Theory;
use super::search::SearchSpec;
use crate::methods::dem::{Dem, DemParams};
use crate::methods::plan_scene;

/// The predicted limit of a search on a DEM scene's time step (`method.time_step`), its
/// fraction of the collision time (`method.time_step_fraction`), or a linear stiffness at a
/// fixed step (`materials.NAME.contact.k_n`); `None` for other knobs and methods. The limit is
/// that of the stiffest, lightest contact the scene can make, evaluated on the scene at the
/// search's lower end.
pub fn dem_limit(scene: &Value, search: &SearchSpec) -> Option<Theory> {
    let probe = super::probe_scene(scene, search, search.low).ok()?;
    let s = plan_scene(&probe.to_string()).ok()?;
    let params = s.params::<DemParams>()?;
    let dem = Dem::new(&s, params).ok()?;
    let c = dem.collision_time();
    let p = search.parameter.as_str();
    let (value, what) = if p == "method.time_step" {
        (c.dt_limit, format!("2/ω0 of the {}", c.limiting))
    } else if p == "method.time_step_fraction" {
        (c.dt_limit / c.t_c, format!("2/ω0 over the collision time of the {}", c.limiting))
    } else if p.starts_with("materials.") && p.ends_with(".contact.k_n") && params.time_step.is_some() {
        // ω0 ∝ sqrt(k): the stiffness at which 2/ω0 falls to the fixed step.
        let k = super::paths::get(&probe, p)?.as_f64()?;
        let dt = dem.time_step();
        (k * (c.dt_limit / dt).powi(2), format!("the stiffness at which 2/ω0 of the {} equals the step {dt:.3e} s", c.limiting))
    } else {
        return None;
    };
    (value.is_finite() && value > 0.0).then_some(Theory { value, what, ratio: None })
}
