//! What a method is to the rest of the engine: [`Method`], its checked parameters that fit a
//! scene and build its simulation, and [`MethodEntry`], its line in the [`super::registry`].

use std::any::Any;
use std::fmt::Debug;

use crate::error::EngineError;
use crate::run::Simulation;
use crate::scene::{Checker, Scene};

/// A method with its checked parameters, ready to run a scene.
pub trait Method: Debug + Send + Sync + 'static {
    /// The method's name as written in scene files (`"dem"`, ...).
    fn name(&self) -> &'static str;
    /// The method's own rules on a validated scene (what it cannot run, what its parameters
    /// require of the scene), every broken one reported to `c`; and the defaults it takes from
    /// the scene (`given`: the scene's `method` object as written, to tell a default from a
    /// value the scene set).
    fn fit(&mut self, scene: &Scene, given: &serde_json::Value, c: &mut Checker);
    /// Builds the simulation of `scene`.
    fn build(&self, scene: &Scene) -> Result<Box<dyn Simulation>, EngineError>;
    /// Threads the method asks for (0: the pool it runs in).
    fn threads(&self) -> usize;
    /// Sets the threads the method asks for.
    fn set_threads(&mut self, threads: usize);
    /// A copy.
    fn clone_box(&self) -> Box<dyn Method>;
    /// For [`crate::methods::Plan::params`].
    fn as_any(&self) -> &dyn Any;
    /// For [`crate::methods::Plan::params_mut`].
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl Clone for Box<dyn Method> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// Reads a method's parameters from the scene's `method` object (`None`: a bare name, every
/// default); `None` back when the object cannot be read (the reason is in the checker).
pub type ParseMethod = fn(Option<&serde_json::Value>, &mut Checker) -> Option<Box<dyn Method>>;

/// What a registered method reads from a scene's `method`.
pub struct MethodEntry {
    /// The name scenes give (`"dem"`).
    pub name: &'static str,
    /// Its parameters from the scene's `method` object.
    pub parse: ParseMethod,
    /// Its parameters when the advisor picks it (`"method": "auto"`).
    pub defaults: fn() -> Box<dyn Method>,
    /// It solves each step by Newton iterations that `--trace` can record
    /// ([`crate::run::Simulation::trace_newton`]).
    pub newton: bool,
}

/// A method object's parameters as `T`, unknown fields rejected at their path under `method.`.
/// `None` (a bare name) gives `T`'s defaults.
pub fn read_spec<T: serde::de::DeserializeOwned + Default>(c: &mut Checker, object: Option<&serde_json::Value>) -> Option<T> {
    let Some(v) = object else { return Some(T::default()) };
    match serde_path_to_error::deserialize::<_, T>(v) {
        Ok(p) => Some(p),
        Err(e) => {
            c.fail(format!("method.{}", e.path()), e.into_inner().to_string());
            None
        }
    }
}

/// Checks a method's `threads`.
pub fn check_threads(c: &mut Checker, t: usize) -> usize {
    if t > 1024 {
        c.fail("method.threads", format!("must be <= 1024, got {t}"));
        return 0;
    }
    t
}

/// The part of [`Method`] that is the same for every method: its name, its threads (at the
/// field path given), `clone_box` and the `Any` views.
#[macro_export]
#[doc(hidden)]
macro_rules! method_common {
    ($name:literal, $($threads:ident).+) => {
        fn name(&self) -> &'static str {
            $name
        }
        fn threads(&self) -> usize {
            self.$($threads).+
        }
        fn set_threads(&mut self, threads: usize) {
            self.$($threads).+ = threads;
        }
        fn clone_box(&self) -> Box<dyn $crate::methods::method::Method> {
            Box::new(self.clone())
        }
        fn as_any(&self) -> &dyn std::any::Any {
            self
        }
        fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
            self
        }
    };
}
