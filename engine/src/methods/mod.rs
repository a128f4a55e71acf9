//! Simulation methods. Each implements [`Simulation`](crate::run::Simulation); [`build`] picks
//! the one a scene asks for.

pub mod cd;
pub mod dem;
pub mod fem;
pub mod mpm;
pub mod soft;
pub(crate) mod world;

use crate::error::EngineError;
use crate::run::Simulation;
use crate::scene::{Method, Scene};

/// Builds the simulation of a validated scene with its method.
pub fn build(scene: &Scene) -> Result<Box<dyn Simulation>, EngineError> {
    match &scene.method {
        Method::Dem(params) => Ok(Box::new(dem::Dem::new(scene, params)?)),
        Method::Cd(params) => Ok(Box::new(cd::Cd::new(scene, params)?)),
        Method::Mpm(params) => Ok(Box::new(mpm::sim::mpm(scene, params)?)),
        Method::Fem(params) => Ok(Box::new(fem::sim::fem(scene, params)?)),
    }
}
