//! The scene format: what users write ([`spec`]), the checked form methods build from
//! ([`model`]), and the validation between them ([`validate`]). A scene knows no method: its
//! `method` is read by the method registry (`methods::plan_scene`), which pairs the
//! scene with the method that runs it.

mod container;
pub mod experiments;
mod materials;
pub mod model;
pub mod presets;
mod sets;
pub mod spec;
pub mod state;
pub mod state_meshes;
pub mod state_points;
mod state_rules;
pub mod validate;
mod violation;

pub use model::*;
pub use spec::SceneSpec;
pub use state::{InitialState, StateFile};
pub use validate::{parse_scene, validate};
pub use violation::{format_violations, Checker, Violation};
