//! Scalar and vector types used throughout the engine.
//!
//! Every simulation is stored in three dimensions. A 2D scene (disks) keeps every z component
//! at exactly zero: branch vectors, forces and velocities stay in the plane and torques and
//! angular velocities point along z, so one implementation serves both dimensions.

/// The floating-point type of every physical quantity (SI units).
pub type Real = f64;

/// A 3-vector of [`Real`].
pub type Vec3 = nalgebra::Vector3<Real>;

/// A 3x3 matrix of [`Real`] (stress tensors).
pub type Mat3 = nalgebra::Matrix3<Real>;

/// Axis names in order, used in field paths and wall names.
pub const AXES: [&str; 3] = ["x", "y", "z"];

/// Builds a [`Vec3`] from a slice of length 2 or 3 (missing z is zero).
pub fn vec_from_slice(v: &[Real]) -> Vec3 {
    Vec3::new(v.first().copied().unwrap_or(0.0), v.get(1).copied().unwrap_or(0.0), v.get(2).copied().unwrap_or(0.0))
}
