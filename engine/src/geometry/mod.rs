//! Space: the periodic (and Lees-Edwards) box, the neighbour search, and the reference geometry
//! of a quadrilateral element.

pub mod domain;
pub mod near_pairs;
pub mod neighbors;
pub mod quad;

pub use domain::Domain;
pub use near_pairs::NearPairs;
pub use neighbors::NeighborList;
