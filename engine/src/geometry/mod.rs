//! Space: the periodic (and Lees-Edwards) box and the neighbour search.

pub mod domain;
pub mod near_pairs;
pub mod neighbors;

pub use domain::Domain;
pub use near_pairs::NearPairs;
pub use neighbors::NeighborList;
