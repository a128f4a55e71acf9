//! A validated scene and the method that runs it: [`plan_scene`] reads a scene file, checks the
//! scene ([`crate::scene::validate`]), reads its `method` through the [`registry`], lets the
//! method check what it needs of the scene, and for `"method": "auto"` asks the advisor.

use std::ops::{Deref, DerefMut};

use super::method::Method;
use super::registry::{self, Request};
use crate::advise::{advise, Advice};
use crate::error::EngineError;
use crate::run::Simulation;
use crate::scene::{Checker, Scene, SceneSpec, Violation};

/// A validated scene with the method that will run it.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The scene, which knows no method.
    pub scene: Scene,
    /// The method and its parameters.
    pub method: Box<dyn Method>,
    /// Why this method: the scene named it, or the advisor's reasons.
    pub reason: String,
    /// The advisor's full answer when the scene asked for `auto`.
    pub advice: Option<Advice>,
}

impl Deref for Plan {
    type Target = Scene;
    fn deref(&self) -> &Scene {
        &self.scene
    }
}

impl DerefMut for Plan {
    fn deref_mut(&mut self) -> &mut Scene {
        &mut self.scene
    }
}

/// The reason recorded for a method the scene named.
pub const CHOSEN_BY_THE_SCENE: &str = "chosen by the scene";

impl Plan {
    /// The method's name as written in scene files.
    pub fn method_name(&self) -> &'static str {
        self.method.name()
    }

    /// Builds the simulation.
    pub fn build(&self) -> Result<Box<dyn Simulation>, EngineError> {
        self.method.build(&self.scene)
    }

    /// The method's parameters as `T` (e.g. [`super::dem::DemParams`]), if the method is that one.
    pub fn params<T: 'static>(&self) -> Option<&T> {
        self.method.as_any().downcast_ref()
    }

    /// The method's parameters as `T`, to change.
    pub fn params_mut<T: 'static>(&mut self) -> Option<&mut T> {
        self.method.as_any_mut().downcast_mut()
    }

    /// The advice for this plan: the one `auto` took, or what the advisor would choose for a
    /// scene that named its method (`requested` says which).
    pub fn advice(&self) -> Advice {
        match &self.advice {
            Some(a) => a.clone(),
            None => Advice { requested: self.method_name().to_string(), ..advise(&self.scene) },
        }
    }
}

/// Parses scene JSON text, validates the scene and its method.
///
/// Structural errors (bad JSON, wrong type, unknown field) are reported with their path, one at a
/// time since the document cannot be read past them; rule violations are all reported together.
pub fn plan_scene(json: &str) -> Result<Plan, Vec<Violation>> {
    plan(&crate::scene::validate::read_spec(json)?)
}

/// Validates a parsed scene and its method.
pub fn plan(spec: &SceneSpec) -> Result<Plan, Vec<Violation>> {
    let mut c = Checker::default();
    let request = registry::parse(&mut c, &spec.method);
    let scene = crate::scene::validate::check(spec, &mut c);
    let (method, reason, advice) = match request {
        Some(Request::Named(mut m)) => {
            m.fit(&scene, &spec.method, &mut c);
            (Some(m), CHOSEN_BY_THE_SCENE.to_string(), None)
        }
        // The advisor reads a valid scene only.
        Some(Request::Auto) if c.violations.is_empty() => {
            let (mut m, reason, advice) = choose(&scene);
            m.fit(&scene, &spec.method, &mut c);
            // What the chosen method refuses is the advisor's choice's, not the scene's.
            for v in &mut c.violations {
                v.rule = format!("auto chose {}: {}", m.name(), v.rule);
            }
            (Some(m), reason, advice)
        }
        _ => (None, String::new(), None),
    };
    match method {
        Some(method) if c.violations.is_empty() => Ok(Plan { scene, method, reason, advice }),
        _ => Err(c.violations),
    }
}

/// The method `auto` takes for a valid scene: contact dynamics for aggregates of rigid
/// primaries (as the sources ran them), else the advisor's choice.
fn choose(scene: &Scene) -> (Box<dyn Method>, String, Option<Advice>) {
    if super::fit::aggregates(scene).is_some() {
        let reason = "aggregates of rigid primaries run by contact dynamics, as Nezamabadi (2020, §1.2.1) ran them".to_string();
        return ((super::cd::params::ENTRY.defaults)(), reason, None);
    }
    let mut advice = advise(scene);
    advice.requested = "auto".into();
    let method = registry::entry(&advice.method).map_or_else(|| (super::dem::params::ENTRY.defaults)(), |e| (e.defaults)());
    (method, advice.summary(), Some(advice))
}

#[cfg(test)]
mod tests;
