//! The deposition's results ([`DepositionResult`]) and the deposit of a final state.

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::particles::Particles;
use crate::scene::StateFile;

/// Results of a deposition under gravity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DepositionResult {
    /// Height of the deposit above the floor, m: twice the mean height of its solid volume (exact
    /// for a layer of uniform packing fraction; a few stray grains on top barely move it).
    pub bed_height: f64,
    /// Packing fraction of the deposit: solid volume / (floor area × `bed_height`).
    pub phi_bed: f64,
    /// Normal stress on the floor at the end, Pa (the weight of the deposit per floor area,
    /// less what the side walls carry).
    pub floor_stress: f64,
    /// Time the grains took to fall and settle, s.
    pub time: f64,
}

/// Height and packing fraction of a deposit resting on the floor of axis `axis` (the upper
/// wall if `floor_upper`): twice the mean height of the solid volume above the floor, and the
/// solid volume over the floor area times that height.
pub fn deposit_of(state: &StateFile, axis: usize, floor_upper: bool) -> (Real, Real) {
    let dim = state.dimension as usize;
    let p = &state.particles;
    let (mut volume, mut moment) = (0.0, 0.0);
    for (x, &r) in p.position.iter().zip(&p.radius) {
        let v = Particles::volume_of(dim, r);
        let above = match (x.get(axis), floor_upper) {
            (Some(x), false) => x - state.min[axis],
            (Some(x), true) => state.max[axis] - x,
            (None, _) => 0.0,
        };
        volume += v;
        moment += v * above;
    }
    if volume <= 0.0 {
        return (0.0, 0.0);
    }
    let height = 2.0 * moment / volume;
    let area: Real = (0..dim).filter(|&a| a != axis).map(|a| state.max[a] - state.min[a]).product();
    (height, if height > 0.0 && area > 0.0 { volume / (area * height) } else { 0.0 })
}
