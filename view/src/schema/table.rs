//! A schema as a Markdown table of its fields (`docs/data.md`'s generated
//! part and `anguilla foxglove`'s documentation).

use core::fmt::Write as _;

use serde_json::Value;

/// A message schema's description and the Markdown table of its fields:
/// one row per field, in the order written, objects and arrays of objects
/// opened (`nav.sensor`, `transforms[].rotation.w`).
pub fn table(schema: &Value) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{}.\n", text(&schema["description"]));
    let _ = writeln!(out, "| field | type | meaning |");
    let _ = writeln!(out, "|---|---|---|");
    rows(&mut out, "", schema);
    out
}

fn text(v: &Value) -> String {
    v.as_str().unwrap_or_default().replace('|', "\\|")
}

/// One row per property, in `required` order (the writer's), descending
/// into objects and arrays of objects.
fn rows(out: &mut String, prefix: &str, s: &Value) {
    let props = &s["properties"];
    for k in s["required"].as_array().into_iter().flatten() {
        let k = k.as_str().unwrap_or_default();
        let p = &props[k];
        let path = format!("{prefix}{k}");
        let _ = writeln!(
            out,
            "| `{path}` | {} | {} |",
            type_text(p),
            text(&p["description"])
        );
        if p["type"] == "object" {
            rows(out, &format!("{path}."), p);
        } else if p["items"]["type"] == "object" {
            rows(out, &format!("{path}[]."), &p["items"]);
        }
    }
}

fn type_text(p: &Value) -> String {
    let base = match &p["type"] {
        Value::String(t) => t.clone(),
        Value::Array(ts) => ts
            .iter()
            .filter_map(Value::as_str)
            .collect::<Vec<_>>()
            .join(" or "),
        _ if p.get("oneOf").is_some() => "integer".into(),
        _ => String::new(),
    };
    let base = if let Some(t) = p.get("title").and_then(Value::as_str)
        && p["type"] == "object"
    {
        format!("object ({t})")
    } else {
        base
    };
    if let Some(e) = p.get("enum").and_then(Value::as_array) {
        let vs: Vec<String> = e
            .iter()
            .map(|v| match v.as_str() {
                Some("") => "`\"\"`".to_string(),
                Some(s) => format!("`{s}`"),
                None => format!("`{v}`"),
            })
            .collect();
        return format!("{base}: {}", vs.join(", "));
    }
    if p["type"] == "array" {
        if p["maxItems"] == 0 {
            return "array, empty".into();
        }
        let items = &p["items"];
        let max = p["maxItems"].as_u64().unwrap_or_default();
        let inner = if items["type"] == "object" {
            items["title"]
                .as_str()
                .map_or("object".to_string(), |t| format!("object ({t})"))
        } else {
            type_text(items)
        };
        return format!("array (≤ {max}) of {inner}");
    }
    base
}
