//! Space: the periodic (and Lees-Edwards) box and the neighbour search.

pub mod domain;
pub mod neighbors;

pub use domain::Domain;
pub use neighbors::NeighborList;
