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
//! `nav.x_m`, `nav.y_m` and `heading_deg`), or in a frame the operator
//! sets ([`PathFrame`]: `"frame": {"x": 5, "y": -2, "heading": 30}`, the
//! path's origin and the heading of its x axis in the estimate's frame, or
//! `"frame": "here"`, the robot's position and heading when the path
//! starts); depth in metres below the surface (optional: the
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
    #[serde(default)]
    frame: Option<Value>,
}

/// Where a path file's x, y are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathFrame {
    /// The estimate's local frame (the default, `"frame": "estimate"`).
    Estimate,
    /// A frame the operator set: its origin `x`, `y` (m) and the heading
    /// of its x axis (deg, counter-clockwise from the estimate's x), in
    /// the estimate's frame.
    Set {
        /// The origin's x (m).
        x: f64,
        /// The origin's y (m).
        y: f64,
        /// The heading of the path's x axis (deg).
        heading: f64,
    },
    /// The robot's position and heading when the path starts
    /// (`"frame": "here"`, `ctl follow --here`): x ahead, y to its left.
    Here,
}

/// What a frame is written as.
const FRAME_EXPECTED: &str =
    "expected \"estimate\", \"here\" or {\"x\": M, \"y\": M, \"heading\": DEG (optional)}";

impl PathFrame {
    /// The frame of a file's `"frame"` value.
    fn of(v: &Value) -> Result<PathFrame, String> {
        match v {
            Value::String(s) if s == "estimate" => Ok(PathFrame::Estimate),
            Value::String(s) if s == "here" => Ok(PathFrame::Here),
            Value::Object(o) => {
                if let Some(k) = o
                    .keys()
                    .find(|k| !["x", "y", "heading"].contains(&k.as_str()))
                {
                    return Err(format!("frame: unknown field {k:?}; {FRAME_EXPECTED}"));
                }
                let num = |k: &str, need: bool| match o.get(k) {
                    None if !need => Ok(0.0),
                    Some(n) if n.as_f64().is_some_and(f64::is_finite) => {
                        Ok(n.as_f64().unwrap_or(0.0))
                    }
                    _ => Err(format!(
                        "frame: {k:?} missing or not a finite number; {FRAME_EXPECTED}"
                    )),
                };
                Ok(PathFrame::Set {
                    x: num("x", true)?,
                    y: num("y", true)?,
                    heading: num("heading", false)?,
                })
            }
            other => Err(format!("frame: {other}; {FRAME_EXPECTED}")),
        }
    }
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
    /// Where its x, y are.
    pub frame: PathFrame,
}

/// A pose in the plane: x, y (m) and heading (deg), in the estimate's
/// frame.
pub type PlanePose = (f64, f64, f64);

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
        let frame = match &f.frame {
            None => PathFrame::Estimate,
            Some(v) => {
                PathFrame::of(v).map_err(|e| format!("line {}: {e}", key_line(text, "frame")))?
            }
        };
        Ok(PathFile {
            waypoints,
            looped: f.looped,
            lines,
            frame,
        })
    }

    /// The waypoints in the estimate's frame, for the daemon: moved and
    /// turned from the path's [`PathFrame`]; `here` is the robot's pose
    /// (from the daemon's state; `None` without a position estimate,
    /// which a path in the frame `here` needs).
    pub fn placed(&self, here: Option<PlanePose>) -> Result<Vec<Waypoint>, String> {
        let (ox, oy, heading) = match self.frame {
            PathFrame::Estimate => (0.0, 0.0, 0.0),
            PathFrame::Set { x, y, heading } => (x, y, heading),
            PathFrame::Here => here.filter(|p| p.0.is_finite() && p.1.is_finite() && p.2.is_finite()).ok_or_else(|| {
                "the path's frame is \"here\": it needs the daemon's position and heading (a head sensor with an estimate), and there is none".to_string()
            })?,
        };
        let (sin, cos) = heading.to_radians().sin_cos();
        Ok(self
            .waypoints
            .iter()
            .map(|w| Waypoint {
                x: ox + w.x * cos - w.y * sin,
                y: oy + w.x * sin + w.y * cos,
                ..*w
            })
            .collect())
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

/// The line (1-based) a top-level key first appears on (1 if not found).
fn key_line(text: &str, key: &str) -> usize {
    let quoted = format!("\"{key}\"");
    text.find(&quoted)
        .map_or(1, |i| text[..i].matches('\n').count() + 1)
}

/// The path file's JSON Schema (`docs/path.schema.json`).
pub fn schema() -> Value {
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "anguilla path",
        "description": "A path for `anguilla ctl follow` (docs/autopilot.md, \"Following a path\"): waypoints in the estimate's local frame (its origin where the estimate started; the daemon's nav.x_m, nav.y_m), or in the frame `frame` sets.",
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
            },
            "frame": {
                "description": "Where the waypoints' x, y are: \"estimate\" (the default: the estimate's local frame), \"here\" (the robot's position and heading when the path starts: x ahead, y to its left), or a frame set by its origin and the heading of its x axis in the estimate's frame",
                "oneOf": [
                    {"type": "string", "enum": ["estimate", "here"]},
                    {
                        "type": "object",
                        "additionalProperties": false,
                        "required": ["x", "y"],
                        "properties": {
                            "x": {"type": "number", "description": "The origin's x (m, estimate's frame)"},
                            "y": {"type": "number", "description": "The origin's y (m, estimate's frame)"},
                            "heading": {"type": "number", "default": 0, "description": "The heading of the path's x axis (deg, counter-clockwise from the estimate's x)"}
                        }
                    }
                ]
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

    /// The frames: the estimate's by default, one set by origin and
    /// heading (turned: the path's x along the estimate's y at 90°), and
    /// "here", which needs the robot's pose.
    #[test]
    fn a_path_is_placed_in_its_frame() {
        let text = |frame: &str| {
            format!("{{\"waypoints\": [{{\"x\": 0, \"y\": 0}}, {{\"x\": 10, \"y\": 2}}]{frame}}}")
        };
        let p = PathFile::parse(&text("")).unwrap();
        assert_eq!(p.frame, PathFrame::Estimate);
        let w = p.placed(None).unwrap();
        assert_eq!((w[1].x, w[1].y), (10.0, 2.0));
        let p =
            PathFile::parse(&text(", \"frame\": {\"x\": 5, \"y\": -1, \"heading\": 90}")).unwrap();
        let w = p.placed(None).unwrap();
        let near = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(near(w[0].x, 5.0) && near(w[0].y, -1.0), "{w:?}");
        assert!(near(w[1].x, 3.0) && near(w[1].y, 9.0), "{w:?}");
        assert_eq!((w[1].index, w[1].depth), (1, None));
        let p = PathFile::parse(&text(", \"frame\": \"here\"")).unwrap();
        assert_eq!(p.frame, PathFrame::Here);
        let e = p.placed(None).unwrap_err();
        assert!(e.contains("needs the daemon's position"), "{e}");
        assert!(p.placed(Some((f64::NAN, 0.0, 0.0))).is_err());
        let w = p.placed(Some((1.0, 1.0, 180.0))).unwrap();
        assert!(near(w[1].x, -9.0) && near(w[1].y, -1.0), "{w:?}");
    }

    /// A bad frame is refused with its line and what was expected.
    #[test]
    fn a_bad_frame_is_refused_with_its_line() {
        for (frame, want) in [
            ("\"there\"", "frame: \"there\""),
            ("{\"x\": 1}", "\"y\" missing"),
            ("{\"x\": 1, \"y\": 2, \"z\": 3}", "unknown field \"z\""),
            (
                "{\"x\": \"a\", \"y\": 2}",
                "\"x\" missing or not a finite number",
            ),
            ("7", "frame: 7"),
        ] {
            let t = format!("{{\"waypoints\": [{{\"x\": 0, \"y\": 0}}],\n \"frame\": {frame}}}");
            let e = PathFile::parse(&t).unwrap_err();
            assert!(
                e.starts_with("line 2: ") && e.contains(want) && e.contains("expected"),
                "{frame}: {e}"
            );
        }
    }
}
