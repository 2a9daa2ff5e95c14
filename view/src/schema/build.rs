//! The builders a channel's schema is written with: a closed object of
//! described properties, and the leaf types (numbers with their units in
//! the description, counts, bit sets, names, codes, arrays).

use serde_json::{Map, Value, json};

/// The JSON Schema dialect of every schema here (`$schema`).
pub const DIALECT: &str = "https://json-schema.org/draft/2020-12/schema";

/// A property: its name and its schema.
pub type Property = (&'static str, Value);

fn closed(title: Option<&str>, description: &str, properties: Vec<Property>) -> Map<String, Value> {
    let mut m = Map::new();
    if let Some(t) = title {
        m.insert("title".into(), json!(t));
    }
    m.insert("description".into(), json!(description));
    m.insert("type".into(), json!("object"));
    let required: Vec<Value> = properties.iter().map(|(k, _)| json!(k)).collect();
    m.insert(
        "properties".into(),
        Value::Object(
            properties
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
        ),
    );
    m.insert("required".into(), Value::Array(required));
    m.insert("additionalProperties".into(), json!(false));
    m
}

/// A message's schema: a closed object (every property required, in this
/// order, and no other) named `title`, with `$schema` set.
pub fn message(title: &str, description: &str, properties: Vec<Property>) -> Value {
    let mut m = closed(Some(title), description, properties);
    m.insert("$schema".into(), json!(DIALECT));
    Value::Object(m)
}

/// A closed object inside a message (every property required, in this
/// order, and no other).
pub fn object(description: &str, properties: Vec<Property>) -> Value {
    Value::Object(closed(None, description, properties))
}

/// A closed object of a named type (e.g. `foxglove.Vector3`).
pub fn typed_object(title: &str, description: &str, properties: Vec<Property>) -> Value {
    Value::Object(closed(Some(title), description, properties))
}

/// A float of the state: a number, or `null` where it is not finite (JSON
/// has no NaN; `serde_json` writes one as `null`). Say its unit in
/// `description`.
pub fn real(description: &str) -> Value {
    json!({ "type": ["number", "null"], "description": description })
}

/// A number that is always finite (the writer guarantees it).
pub fn number(description: &str) -> Value {
    json!({ "type": "number", "description": description })
}

/// A count or a clock: an integer ≥ 0.
pub fn count(description: &str) -> Value {
    json!({ "type": "integer", "minimum": 0, "description": description })
}

/// An integer ≥ 0 and ≤ `max` (a bit set).
pub fn bits(description: &str, max: u64) -> Value {
    json!({ "type": "integer", "minimum": 0, "maximum": max, "description": description })
}

/// A boolean.
pub fn boolean(description: &str) -> Value {
    json!({ "type": "boolean", "description": description })
}

/// A string.
pub fn string(description: &str) -> Value {
    json!({ "type": "string", "description": description })
}

/// A string that is one of `names`.
pub fn names<'a>(description: &str, names: impl IntoIterator<Item = &'a str>) -> Value {
    let names: Vec<&str> = names.into_iter().collect();
    json!({ "type": "string", "enum": names, "description": description })
}

/// An integer code, one of `codes` (code, meaning); the description ends
/// with the list of meanings.
pub fn codes(description: &str, codes: &[(u64, String)]) -> Value {
    let list: Vec<String> = codes.iter().map(|(c, n)| format!("{c} {n}")).collect();
    let values: Vec<u64> = codes.iter().map(|(c, _)| *c).collect();
    json!({
        "type": "integer",
        "enum": values,
        "description": format!("{description}: {}", list.join(", ")),
    })
}

/// An array of `items`, at most `max` long.
pub fn array(description: &str, items: Value, max: usize) -> Value {
    json!({ "type": "array", "items": items, "maxItems": max, "description": description })
}

/// An array the writer always leaves empty (a field the published schema
/// has that we do not use).
pub fn empty_array(description: &str) -> Value {
    json!({ "type": "array", "maxItems": 0, "description": description })
}
