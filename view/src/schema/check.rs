//! The validator the tests check every written message with: the subset
//! of JSON Schema 2020-12 that the builders use (types, `required`,
//! `additionalProperties: false`, `enum`, bounds, `items`, `maxItems`),
//! with the path of the first mismatch.

use serde_json::Value;

/// Checks `value` against `schema` structurally: types, `properties` (a
/// key the schema does not name is an error where `additionalProperties`
/// is false), `required`, `items`, `maxItems`, `enum`, `const`, `oneOf`,
/// `minimum` and `maximum`. It knows only the keywords the builders here
/// use, and refuses a schema with another one rather than pass it
/// unchecked. The error names the path (`nav.sensor`, `spheres[3].size.x`).
pub fn check(schema: &Value, value: &Value) -> Result<(), String> {
    check_at("", schema, value)
}

fn check_at(path: &str, schema: &Value, value: &Value) -> Result<(), String> {
    let at = if path.is_empty() { "(message)" } else { path };
    let s = schema
        .as_object()
        .ok_or_else(|| format!("{at}: the schema is not an object"))?;
    for key in s.keys() {
        if !matches!(
            key.as_str(),
            "$schema"
                | "title"
                | "description"
                | "type"
                | "properties"
                | "required"
                | "additionalProperties"
                | "items"
                | "maxItems"
                | "enum"
                | "const"
                | "oneOf"
                | "minimum"
                | "maximum"
        ) {
            return Err(format!("{at}: schema keyword {key} is not checked here"));
        }
    }
    if let Some(t) = s.get("type") {
        let types: Vec<&str> = match t {
            Value::String(t) => vec![t.as_str()],
            Value::Array(ts) => ts.iter().filter_map(Value::as_str).collect(),
            _ => return Err(format!("{at}: type {t} is not a type")),
        };
        if !types.iter().any(|t| is_type(t, value)) {
            return Err(format!("{at}: {value} is not of type {t}"));
        }
    }
    if let Some(e) = s.get("enum").and_then(Value::as_array)
        && !e.contains(value)
    {
        return Err(format!(
            "{at}: {value} is not one of {}",
            Value::Array(e.clone())
        ));
    }
    if let Some(c) = s.get("const")
        && c != value
    {
        return Err(format!("{at}: {value} is not {c}"));
    }
    if let Some(one) = s.get("oneOf").and_then(Value::as_array) {
        let n = one
            .iter()
            .filter(|b| check_at(path, b, value).is_ok())
            .count();
        if n != 1 {
            return Err(format!(
                "{at}: {value} matches {n} of oneOf's schemas, not 1"
            ));
        }
    }
    if let Some(x) = value.as_f64() {
        if let Some(min) = s.get("minimum").and_then(Value::as_f64)
            && x < min
        {
            return Err(format!("{at}: {value} is below the minimum {min}"));
        }
        if let Some(max) = s.get("maximum").and_then(Value::as_f64)
            && x > max
        {
            return Err(format!("{at}: {value} is above the maximum {max}"));
        }
    }
    if let Some(o) = value.as_object() {
        let props = s.get("properties").and_then(Value::as_object);
        for r in s
            .get("required")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            let r = r.as_str().unwrap_or_default();
            if !o.contains_key(r) {
                return Err(format!("{at}: required property {r} is missing"));
            }
        }
        for (k, v) in o {
            let p = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            match props.and_then(|ps| ps.get(k)) {
                Some(ps) => check_at(&p, ps, v)?,
                None if s.get("additionalProperties") == Some(&Value::Bool(false)) => {
                    return Err(format!("{p}: not a property of the schema"));
                }
                None => {}
            }
        }
    }
    if let Some(a) = value.as_array() {
        if let Some(max) = s.get("maxItems").and_then(Value::as_u64)
            && a.len() as u64 > max
        {
            return Err(format!("{at}: {} items, at most {max}", a.len()));
        }
        if let Some(items) = s.get("items") {
            for (i, v) in a.iter().enumerate() {
                check_at(&format!("{path}[{i}]"), items, v)?;
            }
        }
    }
    Ok(())
}

fn is_type(t: &str, v: &Value) -> bool {
    match t {
        "null" => v.is_null(),
        "boolean" => v.is_boolean(),
        "string" => v.is_string(),
        "object" => v.is_object(),
        "array" => v.is_array(),
        "number" => v.is_number(),
        "integer" => v.is_u64() || v.is_i64(),
        _ => false,
    }
}
