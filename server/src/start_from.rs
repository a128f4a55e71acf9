//! `start_from.job` in a submitted scene (docs/scene-format.md §14): the scene names a job of
//! this service, whose final state replaces the reference before the engine reads the scene. At
//! submission the state is inlined only to validate the scene; the job keeps the scene as
//! submitted (small, and its hash names what the user wrote), and the state is inlined again
//! when a worker leases it.

use serde_json::Value;

/// Largest final state read back, bytes once decompressed (about two million particles in 3D).
pub const MAX_STATE_BYTES: u64 = 1 << 30;

/// The job a scene starts from, when `start_from` holds `job` alone (anything else is left to
/// the engine's checks).
pub fn referenced_job(scene: &Value) -> Option<i64> {
    let start = scene.get("start_from")?.as_object()?;
    if start.len() != 1 {
        return None;
    }
    start.get("job")?.as_i64()
}

/// Replaces the scene's `start_from` by `{"state": STATE}`, STATE being the JSON text of a saved
/// state.
pub fn inline_state(scene: &mut Value, state_json: &str) -> Result<(), serde_json::Error> {
    let state: Value = serde_json::from_str(state_json)?;
    if let Some(obj) = scene.as_object_mut() {
        obj.insert("start_from".into(), serde_json::json!({ "state": state }));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn only_a_lone_job_reference_is_resolved() {
        assert_eq!(referenced_job(&json!({"start_from": {"job": 3}})), Some(3));
        assert_eq!(referenced_job(&json!({"start_from": {"job": 3, "file": "a.json"}})), None);
        assert_eq!(referenced_job(&json!({"start_from": {"job": "3"}})), None);
        assert_eq!(referenced_job(&json!({"particles": []})), None);
        let mut scene = json!({"start_from": {"job": 3}, "dimension": 2});
        inline_state(&mut scene, r#"{"format": "sable-state"}"#).expect("valid JSON");
        assert_eq!(scene, json!({"start_from": {"state": {"format": "sable-state"}}, "dimension": 2}));
    }
}
