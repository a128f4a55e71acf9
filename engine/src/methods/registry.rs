//! The methods a scene can name: one [`MethodEntry`] per method in [`REGISTRY`], each reading
//! its own `method` object into checked parameters ([`Method`]). A new method is a folder with
//! its parameters and its `Simulation`, plus one line here.

use super::method::{Method, MethodEntry};
use crate::scene::Checker;

/// Every method of this version, in the order error messages list them.
pub const REGISTRY: [MethodEntry; 4] =
    [super::dem::params::ENTRY, super::cd::params::ENTRY, super::mpm::params::ENTRY, super::fem::params::ENTRY];

/// Names a scene may give that are not a method of the registry, with what to do instead.
const NOT_METHODS: [(&str, &str); 1] = [(
    "bpm",
    "the bonded particle method is a model of the grains, run by contact dynamics: give the particle set \"model\": {\"kind\": \"bonded_primaries\", ...} and \"method\": \"cd\"",
)];

/// The registered method named `name`.
pub fn entry(name: &str) -> Option<&'static MethodEntry> {
    REGISTRY.iter().find(|e| e.name == name)
}

/// The methods whose steps `--trace` can record ([`MethodEntry::newton`]).
pub fn traced() -> Vec<&'static str> {
    REGISTRY.iter().filter(|e| e.newton).map(|e| e.name).collect()
}

/// The names a scene may give: the registry's and `auto`.
pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|e| e.name).chain(["auto"]).collect()
}

/// What a scene's `method` asks for.
#[derive(Debug)]
pub enum Request {
    /// A named method with its parameters.
    Named(Box<dyn Method>),
    /// The advisor's choice.
    Auto,
}

/// Reads a scene's `method` (a name, or an object with a `kind`); `None` when it cannot be
/// read, with the reason in `c`.
pub fn parse(c: &mut Checker, v: &serde_json::Value) -> Option<Request> {
    // A plain name is reported at `method`, an object's name at `method.kind`.
    let (kind, kind_path, object) = match v {
        serde_json::Value::String(s) => (s.as_str(), "method", None),
        serde_json::Value::Object(map) => {
            let Some(kind) = map.get("kind").and_then(|k| k.as_str()) else {
                c.fail("method.kind", "must be a string naming the method (e.g. \"dem\")");
                return None;
            };
            (kind, "method.kind", Some(v))
        }
        _ => {
            c.fail("method", "must be a method name or an object with a \"kind\"");
            return None;
        }
    };
    if let Some((_, instead)) = NOT_METHODS.iter().find(|(n, _)| *n == kind) {
        c.fail(kind_path, *instead);
        return None;
    }
    if kind == "auto" {
        for key in object.and_then(|o| o.as_object()).into_iter().flat_map(|m| m.keys()).filter(|k| *k != "kind") {
            c.fail(
                format!("method.{key}"),
                format!(
                    "auto chooses the method and its parameters; name the method ({}) to set them",
                    REGISTRY.map(|e| e.name).join(", ")
                ),
            );
        }
        return Some(Request::Auto);
    }
    let Some(entry) = entry(kind) else {
        c.fail(kind_path, format!("unknown method '{kind}'; known: {}", names().join(", ")));
        return None;
    };
    (entry.parse)(object, c).map(Request::Named)
}
