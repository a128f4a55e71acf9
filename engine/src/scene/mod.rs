//! The scene format: what users write ([`spec`]), the checked form methods build from
//! ([`model`]), and the validation between them ([`validate`]).

pub mod bench_suite;
pub mod experiments;
pub mod model;
pub mod presets;
pub mod spec;
pub mod state;
pub mod state_meshes;
pub mod state_points;
pub mod validate;
mod violation;

pub use model::*;
pub use spec::SceneSpec;
pub use state::{InitialState, StateFile};
pub use validate::{parse_scene, validate};
pub use violation::{format_violations, Violation};
