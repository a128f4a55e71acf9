//! How DEM's per-particle loops are cut into parallel tasks (shared by the force, bond, wall
//! and integration passes, which must agree on the blocks).

/// Particles per task in the simple per-particle loops (plain slice loops inside each task).
pub(crate) const LOOP_CHUNK: usize = 2048;

/// Particles per force task: their pairs form one contiguous block of the neighbour list.
pub(crate) const PARTICLE_BLOCK: usize = 256;
