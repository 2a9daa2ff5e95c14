//! The Foxglove messages of `/log`, `/tf` and `/body` (Foxglove's
//! published schemas `foxglove.Log`, `foxglove.FrameTransforms`,
//! `foxglove.SceneUpdate`, with what anguilla writes in them): typed, each
//! field's schema beside it ([`crate::view!`]), as anguilla's own. Each is
//! a subset of Foxglove's: the same field names and types, with the
//! values anguilla writes (its frames, its entities, the primitives it
//! draws) enumerated and every list it leaves empty of length 0.

use serde_json::{Value, json};

use crate::schema::{
    LOG_LEVELS, array, boolean, count, empty_array, message, names, number, string,
};
use anguilla_ipc::MAX_JOINTS;

/// A list the writer always leaves empty (a field of Foxglove's schema
/// anguilla does not use).
pub type Unused = [u8; 0];

fn stamp_schema(d: &str) -> Value {
    json!({
        "type": "object",
        "title": "time",
        "description": d,
        "properties": {
            "sec": { "type": "integer", "minimum": 0, "description": "Whole seconds (s)" },
            "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999,
                      "description": "Nanoseconds past sec (ns)" }
        },
        "required": ["sec", "nsec"],
        "additionalProperties": false
    })
}

/// A time of Foxglove's schemas (`time`), here the daemon's clock.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: u64,
    /// Nanoseconds past `sec`.
    pub nsec: u64,
}

impl Time {
    /// The time `ns` nanoseconds after the clock's start.
    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: ns / 1_000_000_000,
            nsec: ns % 1_000_000_000,
        }
    }
}

fn level_schema(d: &str) -> Value {
    let levels: Vec<Value> = LOG_LEVELS
        .iter()
        .map(|(c, name, what)| json!({ "const": c, "title": name, "description": what }))
        .collect();
    json!({ "title": "foxglove.LogLevel", "description": d, "oneOf": levels })
}

crate::view! {
    /// A log line: a mode change, a fault, refused commands, the autopilot letting go
    pub struct Log {
        /// The snapshot's time on the daemon's clock (since the controller
        /// started, not Unix time), as the message's log time
        timestamp: Time => stamp_schema,
        /// Log level
        level: u8 => level_schema,
        /// The text
        message: String => string,
        /// Who logs: anguilla
        name: &'static str => string,
        /// Source file: empty
        file: &'static str => string,
        /// Line in the file: 0
        line: u32 => count,
    }
}

impl Log {
    /// The line `message` at `level` (foxglove.LogLevel), at `ns`.
    pub fn new(ns: u64, level: u8, message: String) -> Self {
        Self {
            timestamp: Time::from_ns(ns),
            level,
            message,
            name: "anguilla",
            file: "",
            line: 0,
        }
    }

    /// The message's schema (`foxglove.Log`).
    pub fn schema() -> Value {
        message("foxglove.Log", &Self::description(), Self::properties())
    }
}

crate::view! {
    /// A vector (m)
    pub struct Vector3 {
        /// x (m)
        x: f64 => number,
        /// y (m)
        y: f64 => number,
        /// z (m)
        z: f64 => number,
    }
}

fn vector3(d: &str) -> Value {
    Vector3::typed("foxglove.Vector3", d)
}

crate::view! {
    /// An orientation
    pub struct Quaternion {
        /// x (unit quaternion)
        x: f64 => number,
        /// y
        y: f64 => number,
        /// z
        z: f64 => number,
        /// w
        w: f64 => number,
    }
}

fn quaternion(d: &str) -> Value {
    Quaternion::typed("foxglove.Quaternion", d)
}

fn world(d: &str) -> Value {
    names(d, ["world"])
}

fn children(d: &str) -> Value {
    names(d, ["head", "head_predicted", "truth"])
}

crate::view! {
    /// The pose of a child frame in its parent (translation, then rotation)
    pub struct FrameTransform {
        /// The snapshot's time on the daemon's clock (since the controller
        /// started, not Unix time), as the message's log time; truth's: the
        /// ground truth's, as on /sim/truth
        timestamp: Time => stamp_schema,
        /// The parent frame: the world (x, y level, z up)
        parent_frame_id: &'static str => world,
        /// head: the daemon's estimate with a head sensor (heading, pitch, roll,
        /// depth, and x, y: nav.x_m, nav.y_m), else predicted; head_predicted:
        /// the model's speed and turn rate integrated in the plane; truth: the
        /// simulated robot's true nose and head attitude (x forward, as head),
        /// in a recording of the built-in robot only, stamped with the truth's
        /// own time
        child_frame_id: &'static str => children,
        /// The child frame's origin in the parent frame
        translation: Vector3 => vector3,
        /// The child frame's orientation in the parent frame
        rotation: Quaternion => quaternion,
    }
}

fn transforms(d: &str) -> Value {
    let one = FrameTransform::typed("foxglove.FrameTransform", &FrameTransform::description());
    array(d, one, 3)
}

crate::view! {
    /// The head's pose in the world, measured and predicted (and the
    /// simulated robot's true one)
    pub struct FrameTransforms {
        /// The transforms: head, then head_predicted, then truth when a new
        /// ground truth came since the snapshot before
        transforms: Vec<FrameTransform> => transforms,
    }
}

impl FrameTransforms {
    /// The message's schema (`foxglove.FrameTransforms`).
    pub fn schema() -> Value {
        message(
            "foxglove.FrameTransforms",
            &Self::description(),
            Self::properties(),
        )
    }
}

crate::view! {
    /// A primitive's position and orientation in its entity's frame
    pub struct Pose {
        /// Its position in the entity's frame
        position: Vector3 => vector3,
        /// Its orientation in the entity's frame
        orientation: Quaternion => quaternion,
    }
}

impl Pose {
    /// At `position`, not turned.
    pub fn at(position: Vector3) -> Self {
        Self {
            position,
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            },
        }
    }
}

fn pose(d: &str) -> Value {
    Pose::typed("foxglove.Pose", d)
}

crate::view! {
    /// A colour
    pub struct Color {
        /// Red (0..=1)
        r: f64 => number,
        /// Green (0..=1)
        g: f64 => number,
        /// Blue (0..=1)
        b: f64 => number,
        /// Alpha (0..=1)
        a: f64 => number,
    }
}

crate::view! {
    /// One link of the body as an ellipsoid
    pub struct SpherePrimitive {
        /// The link's centre and orientation in the head frame (x along the
        /// link towards the tail)
        pose: Pose => pose,
        /// The ellipsoid's diameters: x the link's length, y its width, z its height
        size: Vector3 => vector3,
        /// The link's colour
        color: Color => color,
    }
}

fn color(d: &str) -> Value {
    Color::typed("foxglove.Color", d)
}

/// `foxglove.LineType` `LINE_LIST`: individual segments, points 0-1, 2-3, …
pub const LINE_LIST: u8 = 2;

fn line_type(d: &str) -> Value {
    let list = json!({
        "const": LINE_LIST,
        "title": "LINE_LIST",
        "description": "Individual line segments: 0-1, 2-3, 4-5, ..."
    });
    json!({ "title": "foxglove.LineType", "description": d, "oneOf": [list] })
}

/// The legs `/body`'s guide entity remembers and draws, the oldest
/// forgotten first: a line primitive has at most a segment (two points)
/// for each.
pub const GUIDE_LEGS: usize = 64;

fn points(d: &str) -> Value {
    let one = Vector3::typed("foxglove.Point3", "A point in the world frame");
    array(d, one, 2 * GUIDE_LEGS)
}

crate::view! {
    /// Segments in the world frame: the path's legs, or the cross-track error
    pub struct LinePrimitive {
        /// How the points make lines: LINE_LIST, each pair a segment
        line_type as "type": u8 => line_type,
        /// The points' origin: the world frame's, not turned
        pose: Pose => pose,
        /// The lines' thickness (pixels on the screen)
        thickness: f64 => number,
        /// True: the thickness is in pixels, whatever the distance
        scale_invariant: bool => boolean,
        /// The segments' ends, in pairs, in the world frame (m)
        points: Vec<Vector3> => points,
        /// The lines' colour
        color: Color => color,
        /// Per-point colours: none (color for all)
        colors: Unused => empty_array,
        /// Indices into points: none (the points in order)
        indices: Unused => empty_array,
    }
}

crate::view! {
    /// A flat disc: the position estimate's uncertainty
    pub struct CylinderPrimitive {
        /// The disc's centre, the estimated nose (nav.x_m, nav.y_m, and
        /// minus nav.depth_m), level
        pose: Pose => pose,
        /// The disc's bounding box: x and y its diameter, twice
        /// nav.position_sigma_m (1 sigma each way); z its thickness
        size: Vector3 => vector3,
        /// The bottom face's diameter over the box's: 1
        bottom_scale: f64 => number,
        /// The top face's diameter over the box's: 1
        top_scale: f64 => number,
        /// The disc's colour (translucent)
        color: Color => color,
    }
}

fn lifetime(d: &str) -> Value {
    json!({
        "type": "object", "title": "duration",
        "description": d,
        "properties": {
            "sec": { "type": "integer", "description": "Whole seconds (s)" },
            "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999,
                      "description": "Nanoseconds past sec (ns)" }
        },
        "required": ["sec", "nsec"],
        "additionalProperties": false
    })
}

fn links(d: &str) -> Value {
    let one = SpherePrimitive::typed("foxglove.SpherePrimitive", &SpherePrimitive::description());
    array(d, one, MAX_JOINTS + 1)
}

fn discs(d: &str) -> Value {
    let one = CylinderPrimitive::typed(
        "foxglove.CylinderPrimitive",
        &CylinderPrimitive::description(),
    );
    array(d, one, 1)
}

fn lines(d: &str) -> Value {
    let one = LinePrimitive::typed("foxglove.LinePrimitive", &LinePrimitive::description());
    array(d, one, 3)
}

crate::view! {
    /// The body, or the guide (the path and the position's uncertainty)
    pub struct SceneEntity {
        /// The snapshot's time on the daemon's clock (since the controller
        /// started, not Unix time), as the message's log time
        timestamp: Time => stamp_schema,
        /// The frame the entity is drawn in: head (the body), world (the guide)
        frame_id: &'static str => |d: &str| names(d, ["head", "world"]),
        /// The entity: body, or guide
        id: &'static str => |d: &str| names(d, ["body", "guide"]),
        /// How long the entity stays: 0, until replaced
        lifetime: Time => lifetime,
        /// True (the body): it follows its frame as the frame moves; false
        /// (the guide): drawn where the world frame is
        frame_locked: bool => boolean,
        /// Key-value pairs: none
        metadata: Unused => empty_array,
        /// Arrow primitives: none
        arrows: Unused => empty_array,
        /// Cube primitives: none
        cubes: Unused => empty_array,
        /// The body's links, head first (the guide: none)
        spheres: Vec<SpherePrimitive> => links,
        /// The guide's uncertainty disc, while there is an estimate (the body: none)
        cylinders: Vec<CylinderPrimitive> => discs,
        /// The guide's lines: the past legs (dim), the current leg (bright),
        /// the cross-track error while following (red), each while there is
        /// one (the body: none)
        lines: Vec<LinePrimitive> => lines,
        /// Triangle list primitives: none
        triangles: Unused => empty_array,
        /// Text primitives: none
        texts: Unused => empty_array,
        /// Model primitives: none
        models: Unused => empty_array,
    }
}

fn entities(d: &str) -> Value {
    array(
        d,
        SceneEntity::typed("foxglove.SceneEntity", &SceneEntity::description()),
        2,
    )
}

crate::view! {
    /// The body's links as ellipsoids, posed from the measured joint angles,
    /// in the head frame; and the guide in the world frame: the path's legs,
    /// the cross-track error and the position estimate's uncertainty
    pub struct SceneUpdate {
        /// Entities deleted: none (an empty guide replaces one drawn before)
        deletions: Unused => empty_array,
        /// The body, then the guide (from the first snapshot with something
        /// to draw on)
        entities: Vec<SceneEntity> => entities,
    }
}

impl SceneUpdate {
    /// The message's schema (`foxglove.SceneUpdate`).
    pub fn schema() -> Value {
        message(
            "foxglove.SceneUpdate",
            &Self::description(),
            Self::properties(),
        )
    }
}
