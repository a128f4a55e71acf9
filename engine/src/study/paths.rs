//! Paths into a scene's JSON, as a study names the parameters it sets and sweeps:
//! `materials.glass.contact.k_n`, `particles[0].count`, `method.time_step`.

use serde_json::Value;

/// One step of a path: an object key or an array index.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Key {
    Field(String),
    Index(usize),
}

/// Splits a path; `None` when it is empty or malformed.
fn parse(path: &str) -> Option<Vec<Key>> {
    let mut keys = Vec::new();
    for part in path.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if name.is_empty() {
            return None;
        }
        keys.push(Key::Field(name.to_string()));
        while let Some(stripped) = rest.strip_prefix('[') {
            let end = stripped.find(']')?;
            keys.push(Key::Index(stripped[..end].parse().ok()?));
            rest = &stripped[end + 1..];
        }
        if !rest.is_empty() {
            return None;
        }
    }
    (!keys.is_empty()).then_some(keys)
}

/// Sets `path` in `scene` to `value`, creating missing object fields. A method given by name
/// (`"method": "dem"`) becomes `{"kind": "dem"}` when a path goes into it. The error says why
/// the path cannot be set.
pub fn set(scene: &mut Value, path: &str, value: Value) -> Result<(), String> {
    let keys = parse(path).ok_or_else(|| format!("'{path}' is not a path (fields separated by dots, array items as [i])"))?;
    let mut here = scene;
    for (k, key) in keys.iter().enumerate() {
        let last = k + 1 == keys.len();
        if let (Key::Field(_), Value::String(name)) = (key, &*here) {
            if k == 1 && matches!(&keys[0], Key::Field(f) if f == "method") {
                *here = serde_json::json!({ "kind": name });
            }
        }
        here = match key {
            Key::Field(f) => {
                let Value::Object(map) = here else {
                    return Err(format!("'{path}' goes through a value that is not an object"));
                };
                if last {
                    map.insert(f.clone(), value);
                    return Ok(());
                }
                map.entry(f.clone()).or_insert_with(|| Value::Object(Default::default()))
            }
            Key::Index(i) => {
                let Value::Array(items) = here else {
                    return Err(format!("'{path}' indexes a value that is not an array"));
                };
                let n = items.len();
                let item = items.get_mut(*i).ok_or_else(|| format!("'{path}': index {i} is past the end (the array has {n} items)"))?;
                if last {
                    *item = value;
                    return Ok(());
                }
                item
            }
        };
    }
    Ok(())
}

/// The value at `path` in a JSON document, if there is one. A field name applied to an array
/// picks its item whose `name` is that name (`walls.y_max.normal_stress` in a sample).
pub fn get<'a>(doc: &'a Value, path: &str) -> Option<&'a Value> {
    let mut here = doc;
    for key in parse(path)? {
        here = match (key, here) {
            (Key::Field(f), Value::Array(items)) => {
                items.iter().find(|item| item.get("name").and_then(Value::as_str) == Some(f.as_str()))?
            }
            (Key::Field(f), _) => here.get(f)?,
            (Key::Index(i), _) => here.get(i)?,
        };
    }
    Some(here)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn paths_set_fields_items_and_a_named_method() {
        let mut s = json!({"method": "dem", "particles": [{"count": 10}], "materials": {"glass": {"contact": {"k_n": 1e5}}}});
        set(&mut s, "method.time_step", json!(1e-5)).expect("set");
        set(&mut s, "particles[0].count", json!(20)).expect("set");
        set(&mut s, "materials.glass.contact.k_n", json!(1e6)).expect("set");
        assert_eq!(s["method"], json!({"kind": "dem", "time_step": 1e-5}));
        assert_eq!(get(&s, "particles[0].count"), Some(&json!(20)));
        assert_eq!(get(&s, "materials.glass.contact.k_n"), Some(&json!(1e6)));
        assert!(set(&mut s, "particles[3].count", json!(1)).expect_err("rejected").contains("index 3 is past the end"));
        assert!(set(&mut s, "materials.glass.contact.k_n.x", json!(1)).expect_err("rejected").contains("not an object"));
        assert!(set(&mut s, "a..b", json!(1)).is_err());
        assert_eq!(get(&s, "materials.none"), None);
        let sample = json!({"walls": [{"name": "y_min", "normal_stress": 1.0}, {"name": "y_max", "normal_stress": 2.0}]});
        assert_eq!(get(&sample, "walls.y_max.normal_stress"), Some(&json!(2.0)));
        assert_eq!(get(&sample, "walls[0].normal_stress"), Some(&json!(1.0)));
        assert_eq!(get(&sample, "walls.x_max.normal_stress"), None);
    }
}
