//! Particle storage (struct of arrays), the generators that place particles of a scene, and the
//! aggregates of primaries that make the bonded particle method's grains.

pub mod aggregate;
pub mod generate;
pub mod storage;

pub use storage::Particles;
