//! The Foxglove messages of `/log`, `/tf` and `/body` (Foxglove's
//! published schemas `foxglove.Log`, `foxglove.FrameTransforms`,
//! `foxglove.SceneUpdate`, with what anguilla writes in them): typed, each
//! field's schema beside it ([`crate::view!`]), as anguilla's own.

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
    names(d, ["head", "head_predicted"])
}

crate::view! {
    /// The pose of a child frame in its parent (translation, then rotation)
    pub struct FrameTransform {
        /// The snapshot's time on the daemon's clock (since the controller
        /// started, not Unix time), as the message's log time
        timestamp: Time => stamp_schema,
        /// The parent frame: the world (x, y level, z up)
        parent_frame_id: &'static str => world,
        /// head: the daemon's estimate with a head sensor (heading, pitch, roll,
        /// depth, and x, y: nav.x_m, nav.y_m), else predicted; head_predicted:
        /// the model's speed and turn rate integrated in the plane
        child_frame_id: &'static str => children,
        /// The child frame's origin in the parent frame
        translation: Vector3 => vector3,
        /// The child frame's orientation in the parent frame
        rotation: Quaternion => quaternion,
    }
}

fn transforms(d: &str) -> Value {
    let one = FrameTransform::typed("foxglove.FrameTransform", &FrameTransform::description());
    array(d, one, 2)
}

crate::view! {
    /// The head's pose in the world, measured and predicted
    pub struct FrameTransforms {
        /// The transforms: head, then head_predicted
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
    /// The link's centre and orientation in the head frame (x along the link towards the tail)
    pub struct Pose {
        /// The link's centre
        position: Vector3 => vector3,
        /// The link's orientation
        orientation: Quaternion => quaternion,
    }
}

crate::view! {
    /// The link's colour
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
        pose: Pose => |d: &str| Pose::typed("foxglove.Pose", d),
        /// The ellipsoid's diameters: x the link's length, y its width, z its height
        size: Vector3 => vector3,
        /// The link's colour
        color: Color => |d: &str| Color::typed("foxglove.Color", d),
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

crate::view! {
    /// The body
    pub struct SceneEntity {
        /// The snapshot's time on the daemon's clock (since the controller
        /// started, not Unix time), as the message's log time
        timestamp: Time => stamp_schema,
        /// The frame the body is drawn in
        frame_id: &'static str => |d: &str| names(d, ["head"]),
        /// The entity: the body
        id: &'static str => |d: &str| names(d, ["body"]),
        /// How long the entity stays: 0, until replaced
        lifetime: Time => lifetime,
        /// True: the body follows its frame as the frame moves
        frame_locked: bool => boolean,
        /// Key-value pairs: none
        metadata: Unused => empty_array,
        /// Arrow primitives: none
        arrows: Unused => empty_array,
        /// Cube primitives: none
        cubes: Unused => empty_array,
        /// The links, head first
        spheres: Vec<SpherePrimitive> => links,
        /// Cylinder primitives: none
        cylinders: Unused => empty_array,
        /// Line primitives: none
        lines: Unused => empty_array,
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
        1,
    )
}

crate::view! {
    /// The body's links as ellipsoids, posed from the measured joint angles, in the head frame
    pub struct SceneUpdate {
        /// Entities deleted: none
        deletions: Unused => empty_array,
        /// The body
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
