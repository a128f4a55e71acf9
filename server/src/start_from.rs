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

/// The scene with its `start_from` replaced by `{"state": STATE}`, STATE being a saved state as
/// the store keeps it (gzip-compressed JSON).
pub fn with_state(scene: &Value, state_gz: &[u8]) -> Result<Value, String> {
    let text = sable_worker::source::gunzip(state_gz, MAX_STATE_BYTES).map_err(|e| format!("cannot be read: {e}"))?;
    let state: Value = serde_json::from_str(&text).map_err(|e| format!("is not JSON: {e}"))?;
    let mut scene = scene.clone();
    if let Some(obj) = scene.as_object_mut() {
        obj.insert("start_from".into(), serde_json::json!({ "state": state }));
    }
    Ok(scene)
}

/// A rule broken inside an inlined state (`start_from.state...`), reported on the reference
/// the user wrote instead (`reference` = `start_from.job` or `start_from.file`); `None` for
/// any other field.
pub fn on_reference(field: &str, reference: &str) -> Option<String> {
    field.strip_prefix("start_from.state").map(|rest| format!("{reference}{rest}"))
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
        let scene = json!({"start_from": {"job": 3}, "dimension": 2});
        let gz = sable_worker::source::gzip(r#"{"format": "sable-state"}"#);
        assert_eq!(with_state(&scene, &gz), Ok(json!({"start_from": {"state": {"format": "sable-state"}}, "dimension": 2})));
        assert!(with_state(&scene, b"not gzip").is_err());
        assert_eq!(
            on_reference("start_from.state.particles.radius[3]", "start_from.job").as_deref(),
            Some("start_from.job.particles.radius[3]")
        );
        assert_eq!(on_reference("particles", "start_from.job"), None);
    }
}
