//! # sable-engine
//!
//! The numerical core of Sable: the scene format and its validation ([`scene`]), particle
//! storage and placement ([`particles`]), the box and neighbour search ([`geometry`]), contact
//! laws ([`contact`]), loading ([`loading`]), simulation methods ([`methods`]), the metrics
//! shared by all methods ([`observe`]), the run loop ([`run`]), the method advisor
//! ([`advise`]) and speed-against-accuracy studies ([`study`]).
//!
//! Data flows one way: scene JSON → [`methods::Plan`] (the validated [`scene::Scene`], which
//! knows no method, with the method from the [`methods::registry`] that runs it) → the method's
//! [`run::Simulation`] → [`observe::Sample`]s. The engine does no I/O and has no async runtime.
//!
//! ```
//! let json = r#"{
//!   "dimension": 2, "method": "dem",
//!   "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e5},
//!                           "restitution": 0.5, "friction": 0.3}},
//!   "particles": [{"material": "glass", "count": 20,
//!                  "size": {"kind": "monodisperse", "diameter": 0.001},
//!                  "placement": {"kind": "random"}}],
//!   "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
//!   "gravity": [0, -9.81],
//!   "stop": {"steps": 200}
//! }"#;
//! let plan = sable_engine::methods::plan_scene(json).expect("valid scene");
//! let mut sim = plan.build().expect("buildable");
//! let runner = sable_engine::run::Runner::for_scene(&plan);
//! let summary = runner.run(sim.as_mut(), &mut |_, _| {}).expect("stable");
//! assert_eq!(summary.steps, 200);
//! ```

pub mod advise;
pub mod constitutive;
pub mod contact;
pub mod error;
pub mod geometry;
pub mod loading;
pub mod math;
pub mod methods;
pub mod nscd;
pub mod observe;
pub mod particles;
pub mod resume;
pub mod run;
pub mod scene;
pub mod study;

pub use error::{EngineError, InstabilityCause};

/// Version of the engine, stored with every job's results.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
