//! Imposed loading: walls that are fixed, move at an imposed velocity or are servo-controlled
//! to a normal stress; homogeneous deformation of the periodic cell; the rotating drum.

pub mod cell;
pub mod drum;
pub mod walls;

pub use cell::CellDeformation;
pub use drum::Drum;
pub use walls::Wall;
