//! The path file of `anguilla ctl follow` (docs/autopilot.md, "Following
//! a path"): JSON, its schema [`schema`] (`docs/path.schema.json`).
//!
//! ```json
//! {
//!   "waypoints": [
//!     {"x": 0, "y": 0},
//!     {"x": 10, "y": 0, "depth": 1.5},
//!     {"x": 10, "y": 4}
//!   ],
//!   "loop": false
//! }
//! ```
//!
//! x, y in metres in the estimate's local frame (level, its origin where
//! the estimate started, heading 0 along x and 90 along y: the daemon's
//! `nav.x_m`, `nav.y_m` and `heading_deg`), depth in metres below the surface (optional: the
//! depth held on the leg that ends at the waypoint). A bad file is refused
//! with its line and what was expected; the daemon then checks each
//! waypoint (the geofence, the depth limit) and a refusal names the
//! waypoint's line.

use anguilla_ipc::{MAX_WAYPOINTS, Waypoint};
use serde::Deserialize;
use serde_json::{Value, json};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    waypoints: Vec<Point>,
    #[serde(default, rename = "loop")]
    looped: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Point {
    x: f64,
    y: f64,
    #[serde(default)]
    depth: Option<f64>,
}

/// A path read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct PathFile {
    /// Its waypoints, in order (their `index` set).
    pub waypoints: Vec<Waypoint>,
    /// After the last waypoint, back to the first.
    pub looped: bool,
    /// The line each waypoint starts on (1-based).
    pub lines: Vec<usize>,
}

impl PathFile {
    /// Reads `text`; the error names the line and what was expected.
    pub fn parse(text: &str) -> Result<PathFile, String> {
        let expected = "expected {\"waypoints\": [{\"x\": M, \"y\": M, \"depth\": M (optional)}, \
                        ...], \"loop\": false (optional)} (docs/autopilot.md)";
        let f: File = serde_json::from_str(text).map_err(|e| {
            let what = e.to_string();
            // serde_json ends its message with " at line L column C".
            let what = what
                .rsplit_once(" at line ")
                .map_or(what.as_str(), |(w, _)| w);
            format!("line {}: {what}; {expected}", e.line().max(1))
        })?;
        let lines = waypoint_lines(text);
        let line = |i: usize| lines.get(i).copied().unwrap_or(1);
        if f.waypoints.is_empty() {
            return Err(format!("line 1: no waypoints; {expected}"));
        }
        if f.waypoints.len() > MAX_WAYPOINTS {
            return Err(format!(
                "line {}: {} waypoints (expected at most {MAX_WAYPOINTS})",
                line(MAX_WAYPOINTS),
                f.waypoints.len()
            ));
        }
        let mut waypoints = Vec::with_capacity(f.waypoints.len());
        for (i, p) in f.waypoints.iter().enumerate() {
            if let Some(d) = p.depth
                && d < 0.0
            {
                return Err(format!(
                    "line {}: waypoint {i}: depth {d} m (expected metres below the surface, >= 0)",
                    line(i)
                ));
            }
            if i > 0 {
                let q = &f.waypoints[i - 1];
                if (p.x - q.x).hypot(p.y - q.y) < 1e-3 {
                    return Err(format!(
                        "line {}: waypoint {i} is where waypoint {} is (a leg of no length)",
                        line(i),
                        i - 1
                    ));
                }
            }
            waypoints.push(Waypoint {
                index: i as u32,
                x: p.x,
                y: p.y,
                depth: p.depth,
            });
        }
        if f.looped && waypoints.len() < 2 {
            return Err(format!(
                "line {}: a looped path needs at least 2 waypoints",
                line(0)
            ));
        }
        Ok(PathFile {
            waypoints,
            looped: f.looped,
            lines,
        })
    }

    /// The line of the waypoint a daemon's refusal names ("waypoint 3 ..."),
    /// if it names one.
    pub fn line_of(&self, reason: &str) -> Option<usize> {
        let rest = reason.split_once("waypoint ")?.1;
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        self.lines.get(digits.parse::<usize>().ok()?).copied()
    }
}

/// The line (1-based) each object of the `waypoints` array opens on: the
/// `{` at depth 2 (the file's object, then the array), outside strings.
fn waypoint_lines(text: &str) -> Vec<usize> {
    let (mut depth, mut line, mut in_string, mut escaped) = (0usize, 1usize, false, false);
    let mut out = Vec::new();
    for c in text.chars() {
        if in_string {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => {}
            }
            if c == '\n' {
                line += 1;
            }
            continue;
        }
        match c {
            '\n' => line += 1,
            '"' => in_string = true,
            '{' | '[' => {
                if c == '{' && depth == 2 {
                    out.push(line);
                }
                depth += 1;
            }
            '}' | ']' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    out
}

/// The path file's JSON Schema (`docs/path.schema.json`).
pub fn schema() -> Value {
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "anguilla path",
        "description": "A path for `anguilla ctl follow` (docs/autopilot.md, \"Following a path\"): waypoints in the estimate's local frame (its origin where the estimate started; the daemon's nav.x_m, nav.y_m).",
        "type": "object",
        "additionalProperties": false,
        "required": ["waypoints"],
        "properties": {
            "waypoints": {
                "description": "The waypoints, in order: the robot joins the line from the first to the second wherever it is, and follows each leg in turn.",
                "type": "array",
                "minItems": 1,
                "maxItems": MAX_WAYPOINTS,
                "items": {
                    "type": "object",
                    "additionalProperties": false,
                    "required": ["x", "y"],
                    "properties": {
                        "x": {"type": "number", "description": "x (m)"},
                        "y": {"type": "number", "description": "y (m)"},
                        "depth": {
                            "type": "number",
                            "minimum": 0,
                            "description": "The depth held on the leg that ends here (m below the surface; at most the daemon's [autopilot] max-depth); without it, the depth held before, or none"
                        }
                    }
                }
            },
            "loop": {
                "type": "boolean",
                "default": false,
                "description": "After the last waypoint, back to the first, until stopped (at least 2 waypoints)"
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_file_is_read_with_its_lines() {
        let text = "{\n  \"waypoints\": [\n    {\"x\": 0, \"y\": 0},\n    {\"x\": 10, \"y\": 0,\n     \"depth\": 1.5}\n  ],\n  \"loop\": true\n}\n";
        let p = PathFile::parse(text).expect("a good path");
        assert!(p.looped);
        assert_eq!(p.lines, [3, 4]);
        assert_eq!(p.waypoints[1].depth, Some(1.5));
        assert_eq!(p.waypoints[1].index, 1);
        assert_eq!(
            p.line_of("waypoint 1 (10.00, 0.00) m is outside the geofence"),
            Some(4)
        );
    }

    #[test]
    fn a_bad_path_file_is_refused_with_the_line_and_what_was_expected() {
        for (text, says) in [
            ("", "line 1: EOF"),
            ("{\"waypoints\": []}", "no waypoints"),
            (
                "{\n\"waypoints\": [\n{\"x\": 0, \"y\": \"a\"}]}",
                "line 3: invalid type: string \"a\", expected f64",
            ),
            (
                "{\"waypoints\": [{\"x\": 0, \"y\": 0, \"z\": 1}]}",
                "unknown field `z`",
            ),
            (
                "{\"waypoints\": [{\"x\": 0, \"y\": 0}],\n\"speed\": 1}",
                "line 2: unknown field `speed`",
            ),
            (
                "{\"waypoints\": [\n{\"x\": 0, \"y\": 0},\n{\"x\": 0, \"y\": 0}]}",
                "line 3: waypoint 1 is where waypoint 0 is",
            ),
            (
                "{\"waypoints\": [\n{\"x\": 0, \"y\": 0, \"depth\": -1}]}",
                "line 2: waypoint 0: depth -1 m",
            ),
            (
                "{\"waypoints\": [{\"x\": 0, \"y\": 0}], \"loop\": true}",
                "a looped path needs at least 2",
            ),
            ("{\"waypoints\": [{\"x\": 1e999, \"y\": 0}]}", "line 1"),
        ] {
            let e = PathFile::parse(text).expect_err(text);
            assert!(e.contains(says), "{text:?}: {e}");
        }
        let many: Vec<String> = (0..=MAX_WAYPOINTS)
            .map(|i| format!("{{\"x\": {i}, \"y\": 0}}"))
            .collect();
        let e = PathFile::parse(&format!("{{\"waypoints\": [{}]}}", many.join(",\n")))
            .expect_err("too many");
        assert!(e.contains("at most 64"), "{e}");
    }

    /// The documented schema is this one, and the example of the docs
    /// reads.
    #[test]
    fn the_schema_file_is_generated() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/path.schema.json");
        let text = format!(
            "{}\n",
            serde_json::to_string_pretty(&schema()).expect("JSON")
        );
        if std::env::var_os("ANGUILLA_BLESS").is_some() {
            std::fs::write(path, &text).expect("written");
        }
        let on_disk = std::fs::read_to_string(path).unwrap_or_default();
        assert_eq!(
            on_disk, text,
            "docs/path.schema.json is out of date: rerun with ANGUILLA_BLESS=1"
        );
        let example = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/path.json");
        let text = std::fs::read_to_string(example).expect("examples/path.json");
        PathFile::parse(&text).expect("the example reads");
    }
}
