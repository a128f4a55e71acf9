//! Deformable grains by the implicit material point method with contact dynamics (MPM-CD;
//! docs/physics.md §5, Nezamabadi 2020, §1.2.2, Nezamabadi et al., Comput. Phys. Commun. 237, 17,
//! 2019), in 2D plane strain.
//!
//! - [`grid`]: the background grid and its quadratic B-spline shape functions;
//! - [`points`]: the material points of the grains;
//! - [`grain`]: a grain: its points, law, friction, size and outline;
//! - [`outline`]: each grain's outline, a polygon riding on its outer points;
//! - [`field`]: one grain's nodal field, its θ-method residual and Newton matrix;
//! - [`ghost`]: the ghost penalty on the nodes a grain's points barely reach;
//! - [`banded`]: the banded Cholesky factorisation of that matrix;
//! - [`contact`]: the contacts between grains' outlines and with walls, as a problem of the
//!   shared contact solver ([`crate::nscd`]);
//! - [`system`]: the step;
//! - [`measure`]: the grains' centroids, areas, shapes and contacts as the metrics see them;
//! - [`sim`]: the method on a scene, as a [`crate::run::Simulation`].

// The kernels index small fixed arrays (3x3 stencils, 2x2 blocks) by their axes.
#![allow(clippy::needless_range_loop)]

pub mod banded;
pub mod contact;
pub mod field;
pub mod ghost;
pub mod grain;
pub mod grid;
pub mod measure;
pub mod outline;
pub mod params;
pub use params::{MpmParams, MpmParamsSpec};
pub mod points;
pub mod sim;
pub mod system;

#[cfg(test)]
mod tests;
