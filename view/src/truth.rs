//! The simulated robot's ground truth as viewers see it: the channel
//! [`TOPIC`] (schema [`SCHEMA_NAME`]) beside the estimate, in a session's
//! MCAP file when `anguilla run` drives its built-in robot, or alone in
//! `anguilla sim --truth FILE`'s. A real robot has no such channel.

use serde_json::{Value, json};

use nalgebra::UnitQuaternion;

use crate::foxglove::{Quaternion, Vector3};
use crate::pose::Pose;
use crate::schema::{message, number, object};

/// The channel's topic.
pub const TOPIC: &str = "/sim/truth";
/// The channel's schema name.
pub const SCHEMA_NAME: &str = "anguilla.SimTruth";

/// The simulated robot's true state at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GroundTruth {
    /// The simulation's own time (s), from its start.
    pub sim_time: f64,
    /// The nose's position (m; world frame, x and y horizontal, z up; the
    /// robot starts at the origin).
    pub position: [f64; 3],
    /// The head's orientation, unit quaternion `[w, x, y, z]`, from the
    /// model's head frame (x towards the tail, z up) to the world.
    pub orientation: [f64; 4],
    /// The nose's velocity (m/s, world frame).
    pub velocity: [f64; 3],
    /// Forward speed at the head (m/s, positive head first).
    pub speed: f64,
    /// The body's heading (rad, counter-clockwise from the world's x): the
    /// direction from the body's centroid to the nose, the operator's and
    /// the autopilot's convention.
    pub heading: f64,
    /// Depth of the nose below the surface (m, positive down).
    pub depth: f64,
}

/// A vector's schema here: each component described by the vector's own
/// text (the values are [`Vector3`]s).
fn xyz(what: &str, unit: &str) -> Value {
    object(
        what,
        ["x", "y", "z"]
            .map(|n| (n, number(&format!("{what}, {n} ({unit})"))))
            .into(),
    )
}

fn metres(d: &str) -> Value {
    xyz(d, "m")
}

fn metres_per_second(d: &str) -> Value {
    xyz(d, "m/s")
}

/// An orientation's schema here (the values are [`Quaternion`]s).
fn xyzw(what: &str) -> Value {
    object(
        what,
        ["x", "y", "z", "w"]
            .map(|n| (n, number(&format!("Quaternion component {n}"))))
            .into(),
    )
}

fn degrees(d: &str) -> Value {
    json!({ "type": "number", "minimum": 0, "maximum": 360, "description": d })
}

crate::view! {
    /// The simulated robot's ground truth (anguilla run against its built-in
    /// robot, or anguilla sim --truth FILE: that channel alone)
    pub struct Truth {
        /// The simulation's own time since its start (s)
        sim_time: f64 => number,
        /// The nose's position in the world (z up; the start at the origin)
        position: Vector3 => metres,
        /// The head's orientation: unit quaternion from the model's head frame
        /// (x towards the tail, z up) to the world
        orientation: Quaternion => xyzw,
        /// The nose's velocity in the world
        velocity: Vector3 => metres_per_second,
        /// Forward speed at the head, positive head first (m/s)
        speed: f64 => number,
        /// The body's heading, counter-clockwise from the world's x, from the
        /// body's centroid to the nose: the operator's convention, 0 ..< 360 (deg)
        heading_deg: f64 => degrees,
        /// Depth of the nose below the surface, positive down (m)
        depth: f64 => number,
    }
}

fn vector([x, y, z]: [f64; 3]) -> Vector3 {
    Vector3 { x, y, z }
}

impl From<&GroundTruth> for Truth {
    fn from(t: &GroundTruth) -> Self {
        let [w, x, y, z] = t.orientation;
        Self {
            sim_time: t.sim_time,
            position: vector(t.position),
            orientation: Quaternion { x, y, z, w },
            velocity: vector(t.velocity),
            speed: t.speed,
            heading_deg: t.heading.to_degrees().rem_euclid(360.0),
            depth: t.depth,
        }
    }
}

impl GroundTruth {
    /// The head's true pose as `/tf`'s frame `truth`, drawn beside the
    /// estimated `head`: the nose's position, and the orientation turned
    /// from the model's head frame (x towards the tail) to the forward one
    /// (x forward, y left, z up: [`anguilla_model::forward_turn`]), as
    /// `head`'s. The simulation's world is the estimate's: both start at
    /// the origin, the heading counted from x. `None` when a value is not
    /// finite or the orientation is no rotation (zero).
    pub fn head_pose(&self) -> Option<Pose> {
        let [w, x, y, z] = self.orientation;
        let q = nalgebra::Quaternion::new(w, x, y, z);
        let finite = self
            .position
            .iter()
            .chain(&self.orientation)
            .all(|v| v.is_finite());
        let norm = q.norm();
        if !finite || !norm.is_finite() || norm <= 1e-9 {
            return None;
        }
        let r = UnitQuaternion::from_quaternion(q) * anguilla_model::forward_turn();
        Some(Pose {
            translation: self.position,
            rotation: [r.i, r.j, r.k, r.w],
        })
    }

    /// The channel's message.
    pub fn message(&self) -> Value {
        crate::to_json(&Truth::from(self))
    }
}

/// The channel's JSON Schema (draft 2020-12; [`crate::schema`]).
pub fn schema() -> Value {
    message(SCHEMA_NAME, &Truth::description(), Truth::properties())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schema::check;

    /// Every key of a message is a property of the schema, every required
    /// property is present, and a heading of −90° is written as 270°.
    #[test]
    fn the_message_matches_its_schema() {
        let t = GroundTruth {
            sim_time: 1.5,
            position: [1.0, -2.0, 0.25],
            orientation: [1.0, 0.0, 0.0, 0.0],
            velocity: [-0.2, 0.0, 0.0],
            speed: 0.2,
            heading: -std::f64::consts::FRAC_PI_2,
            depth: 0.75,
        };
        let m = t.message();
        check(&schema(), &m).unwrap();
        assert!((m["heading_deg"].as_f64().unwrap() - 270.0).abs() < 1e-9);
        assert_eq!(m["orientation"]["w"], 1.0);
        // A message missing a field, or with one more, does not pass.
        let mut less = m.clone();
        less.as_object_mut().unwrap().remove("depth");
        assert!(check(&schema(), &less).is_err());
        let mut more = m;
        more["yaw"] = json!(0.0);
        assert!(check(&schema(), &more).is_err());
    }

    /// The truth frame is x forward, as the estimate's head: a robot
    /// heading along the world's y (its model frame's x, towards the tail,
    /// along −y) has its frame's x along +y; once in `/tf`, stamped with
    /// the truth's time; never with a value that is not finite.
    #[test]
    fn the_truth_frame_is_the_head_frame_forward_on_tf_once() {
        let half = std::f64::consts::FRAC_PI_4;
        // The model frame turned by −90° about z: its x (the tail) along −y.
        let t = GroundTruth {
            position: [1.0, 2.0, -0.5],
            orientation: [half.cos(), 0.0, 0.0, -half.sin()],
            ..GroundTruth::default()
        };
        let p = t.head_pose().unwrap();
        assert_eq!(p.translation, [1.0, 2.0, -0.5], "the nose");
        let [x, y, z, w] = p.rotation;
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let forward = q * nalgebra::Vector3::x();
        assert!(
            (forward - nalgebra::Vector3::y()).norm() < 1e-12,
            "{forward}"
        );
        let up = q * nalgebra::Vector3::z();
        assert!((up - nalgebra::Vector3::z()).norm() < 1e-12, "{up}");
        let mut scene = crate::Scene::new(4);
        let s = anguilla_ipc::StateSnapshot {
            time_ns: 2_000_000_000,
            ..Default::default()
        };
        scene.truth(1_500_000_000, &t);
        let tf = |scene: &mut crate::Scene| {
            let m = scene.messages(&s);
            let tf = m.into_iter().find(|(ch, _)| *ch == 3).unwrap().1;
            check(&crate::schema::all()[3].1, &tf).unwrap();
            tf["transforms"].as_array().unwrap().clone()
        };
        let first = tf(&mut scene);
        assert_eq!(first.len(), 3);
        assert_eq!(first[2]["child_frame_id"], "truth");
        assert_eq!(
            first[2]["timestamp"],
            json!({ "sec": 1, "nsec": 500_000_000 })
        );
        assert_eq!(first[2]["translation"]["y"], 2.0);
        assert_eq!(tf(&mut scene).len(), 2, "a truth goes out once");
        for bad in [
            GroundTruth::default(), // a zero quaternion: no rotation
            GroundTruth {
                position: [f64::NAN, 0.0, 0.0],
                ..t
            },
            GroundTruth {
                orientation: [1.0, f64::INFINITY, 0.0, 0.0],
                ..t
            },
        ] {
            assert_eq!(bad.head_pose(), None, "{bad:?}");
            scene.truth(1, &bad);
            assert_eq!(tf(&mut scene).len(), 2);
        }
    }
}
