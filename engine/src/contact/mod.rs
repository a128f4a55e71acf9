//! Contact laws, one small type per law and role, composed into a [`PairLaw`] per pair of
//! materials (docs/physics.md §2).
//!
//! To add a normal law: write `normal_<name>.rs` with a type implementing [`NormalForce`], add a
//! variant to [`NormalLaw`] and a row to [`model::LAW_NAMES`]; nothing in the solvers changes. The
//! hot loop dispatches through the enum, never through a trait object.

pub mod attraction_lj;
pub mod batch;
pub mod capillary_richefeu;
pub mod damping;
pub mod lubrication;
pub mod model;
pub mod normal_hertz;
pub mod normal_linear;
pub mod rolling;
pub mod tangential;

pub use model::{ContactInput, ContactOutput, ContactTable, NormalLaw, PairLaw, TangentialLaw};

/// A normal force law: elastic part, its tangent stiffness, damping coefficient and energy.
/// `delta` is the overlap (m, > 0 in contact), `r_eff` = R*, `m_eff` = m*.
pub trait NormalForce {
    /// Tangent stiffness d f / d delta, N/m.
    fn stiffness(&self, delta: f64, r_eff: f64) -> f64;
    /// Elastic force, N (repulsive positive).
    fn elastic(&self, delta: f64, r_eff: f64) -> f64;
    /// Viscous coefficient gamma_n, N·s/m.
    fn damping(&self, delta: f64, r_eff: f64, m_eff: f64) -> f64;
    /// Elastic energy stored at overlap delta, J.
    fn energy(&self, delta: f64, r_eff: f64) -> f64;
}
