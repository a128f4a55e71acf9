//! Particle storage (struct of arrays) and the generators that place particles of a scene.

pub mod generate;
pub mod storage;

pub use storage::Particles;
