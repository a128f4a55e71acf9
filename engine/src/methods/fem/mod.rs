//! Deformable grains by the finite element method with contact dynamics (FEM-CD; docs/physics.md
//! §6, Nezamabadi 2020, §1.2.3, as LMGC90 does it), in 2D plane strain: each grain meshed
//! with quadrilaterals, integrated implicitly, its law one of the shared
//! [`crate::constitutive`] laws.
//!
//! - [`mesh`]: the grains' meshes (a disk's O-grid, a rectangle);
//! - [`element`]: the four-node F-bar quadrilateral at finite strain, its forces and tangent;
//! - [`sparse`]: a grain's Newton matrix and its sparse Cholesky factor (faer);
//! - [`body`]: one meshed body, its θ-method step and its static equilibrium;
//! - [`system`]: the meshed grains' step with their contacts (the shared
//!   [`crate::methods::soft::contact`], solved by [`crate::nscd`]);
//! - [`sim`]: `"method": "fem"` on a scene, and its saved states' meshes.

// The kernels index small fixed arrays (2x2 blocks, 8x8 element matrices) by their axes.
#![allow(clippy::needless_range_loop)]

pub mod body;
pub mod element;
pub mod mesh;
pub mod params;
pub use params::{FemParams, FemParamsSpec};
pub mod sim;
pub mod sparse;
pub mod system;

#[cfg(test)]
mod tests;
