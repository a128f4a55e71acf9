//! Helpers shared by the physics tests.
#![allow(dead_code)]

use sable_engine::methods::dem::Dem;
use sable_engine::scene::{parse_scene, Method, Scene};

/// Parses a scene given as a JSON value, panicking with the violations if invalid.
pub fn scene(v: serde_json::Value) -> Scene {
    match parse_scene(&v.to_string()) {
        Ok(s) => s,
        Err(e) => panic!("invalid test scene: {e:?}"),
    }
}

/// Builds the DEM simulation of a scene.
pub fn dem(s: &Scene) -> Dem {
    let Method::Dem(p) = &s.method else { panic!("not a DEM scene") };
    match Dem::new(s, p) {
        Ok(d) => d,
        Err(e) => panic!("cannot build test scene: {e}"),
    }
}

/// A material object with a linear law.
pub fn linear_material(k_n: f64, e: f64, mu: f64) -> serde_json::Value {
    serde_json::json!({"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": e, "friction": mu})
}

/// Builds the contact-dynamics simulation of a scene.
pub fn cd(s: &Scene) -> sable_engine::methods::cd::Cd {
    let Method::Cd(p) = &s.method else { panic!("not a CD scene") };
    match sable_engine::methods::cd::Cd::new(s, p) {
        Ok(d) => d,
        Err(e) => panic!("cannot build test scene: {e}"),
    }
}
