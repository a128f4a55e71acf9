//! Simulation methods. Each method folder holds everything about it: its parameters, their
//! defaults and checks (`params.rs`), what it requires of a scene, and its
//! [`Simulation`](crate::run::Simulation); [`method`] says what a method is to the engine, and
//! the [`registry`] lists them; [`plan_scene`] reads a
//! scene file into a [`Plan`], the validated scene with the method that runs it.

pub mod cd;
pub mod dem;
pub mod fem;
pub(crate) mod fit;
pub mod method;
pub mod mpm;
pub mod plan;
pub mod registry;
pub mod rigid;
pub mod soft;
pub(crate) mod world;

pub use method::Method;
pub use plan::{plan, plan_scene, Plan};
