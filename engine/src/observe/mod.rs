//! Measured quantities, computed the same way for every method (docs/physics.md §8): packing
//! fraction, coordination with and without rattlers, Love-Weber stress, p, q, effective friction,
//! inertial number, energies and wall loads.
//!
//! A method describes its state at sampling time as a [`SystemView`] (bodies and contacts) and
//! [`measure`] turns it into a [`Sample`].

pub mod cluster;
pub mod compaction_laws;
pub mod contacts;
pub mod drum;
mod drum_surface;
pub mod grains;
pub mod granule;
pub mod least_squares;
pub mod metrics;
pub mod power;
pub mod results;
pub mod sample;
pub mod snapshot;
pub mod vtk;

pub use cluster::ClusterSample;
pub use contacts::{rattler_threshold, ContactRecord};
pub use drum::{DrumSample, DrumView, ProfileBin};
pub use grains::{GrainSample, PrimarySample};
pub use granule::GranuleResult;
pub use metrics::{measure, DeformableView, ShearGeometry, SystemView, WallView};
pub use power::{power_fit, PowerFit};
pub use results::drum::DrumResult;
pub use results::{Analysis, ExperimentResult};
pub use sample::{DeformableSample, Sample, SolverSample, StrainSample, Stress, WallSample};
pub use snapshot::{MaterialPoints, Snapshot, WallFace};
