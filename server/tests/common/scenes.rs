//! Scenes shared by the server's integration tests.

use serde_json::json;

/// Ten DEM disks for 100 steps: a job that runs in milliseconds.
pub fn tiny() -> String {
    json!({
        "name": "tiny", "dimension": 2, "method": "dem",
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "m", "count": 10, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "m"},
        "stop": {"steps": 100}
    })
    .to_string()
}
