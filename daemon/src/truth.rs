//! The simulated robot's ground truth, recorded beside the estimate.
//!
//! When `anguilla run` drives its built-in simulated robot, it hands the
//! simulation's true pose and motion to the recorder
//! ([`crate::run::Running::ground_truth`]), which writes them to the
//! session's MCAP file on the channel [`TOPIC`] (schema [`SCHEMA_NAME`]):
//! the daemon's estimate (`/anguilla/state`, `nav`) can then be judged
//! against the truth in any viewer. A real robot has no such channel.
//!
//! Each message is stamped with the daemon's clock (`time_ns` of the state
//! snapshot published when the truth was read, so within one state period
//! of the truth's own time), like every other channel.
//!
//! The simulated robot as its own process (`anguilla sim --truth FILE`)
//! writes the same channel alone into a file of its own ([`TruthFile`]),
//! stamped with the same clock (CLOCK_MONOTONIC, [`crate::rt::monotonic_ns`]):
//! beside a session a daemon recorded on the same machine, the two line up.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter};

use mcap::records::MessageHeader;
use serde_json::{Value, json};

use crate::mcap_log::schema::{message, number, object};

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

impl GroundTruth {
    /// The channel's message.
    pub fn message(&self) -> Value {
        let [w, x, y, z] = self.orientation;
        json!({
            "sim_time": self.sim_time,
            "position": { "x": self.position[0], "y": self.position[1], "z": self.position[2] },
            "orientation": { "x": x, "y": y, "z": z, "w": w },
            "velocity": { "x": self.velocity[0], "y": self.velocity[1], "z": self.velocity[2] },
            "speed": self.speed,
            "heading_deg": self.heading.to_degrees().rem_euclid(360.0),
            "depth": self.depth,
        })
    }
}

fn vector(what: &str, unit: &str) -> Value {
    object(
        what,
        ["x", "y", "z"]
            .map(|n| (n, number(&format!("{what}, {n} ({unit})"))))
            .into(),
    )
}

/// The channel's JSON Schema (draft 2020-12; [`crate::mcap_log::schema`]).
pub fn schema() -> Value {
    message(
        SCHEMA_NAME,
        "The simulated robot's ground truth (anguilla run against its built-in robot, or anguilla sim --truth FILE: that channel alone)",
        vec![
            (
                "sim_time",
                number("The simulation's own time since its start (s)"),
            ),
            (
                "position",
                vector(
                    "The nose's position in the world (z up; the start at the origin)",
                    "m",
                ),
            ),
            (
                "orientation",
                object(
                    "The head's orientation: unit quaternion from the model's head frame \
                     (x towards the tail, z up) to the world",
                    ["x", "y", "z", "w"]
                        .map(|n| (n, number(&format!("Quaternion component {n}"))))
                        .into(),
                ),
            ),
            (
                "velocity",
                vector("The nose's velocity in the world", "m/s"),
            ),
            (
                "speed",
                number("Forward speed at the head, positive head first (m/s)"),
            ),
            (
                "heading_deg",
                json!({
                    "type": "number", "minimum": 0, "maximum": 360,
                    "description": "The body's heading, counter-clockwise from the world's x, \
                        from the body's centroid to the nose: the operator's convention, \
                        0 ..< 360 (deg)"
                }),
            ),
            (
                "depth",
                number("Depth of the nose below the surface, positive down (m)"),
            ),
        ],
    )
}

fn mcap_err(e: mcap::McapError) -> io::Error {
    io::Error::other(e.to_string())
}

/// An MCAP file holding the ground truth alone: the channel [`TOPIC`]
/// (schema [`SCHEMA_NAME`]), the messages a session's `session.mcap`
/// holds, each stamped by the caller (`anguilla sim --truth`: the machine's
/// CLOCK_MONOTONIC, the daemon's clock).
pub struct TruthFile {
    w: mcap::Writer<BufWriter<File>>,
    channel: u16,
    seq: u32,
}

impl TruthFile {
    /// Writes into `file` (opened by the caller, e.g. made exclusively so
    /// that nothing recorded is replaced).
    pub fn from_file(file: File) -> io::Result<Self> {
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .profile("")
            .create(BufWriter::new(file))
            .map_err(mcap_err)?;
        let schema_id = w
            .add_schema(SCHEMA_NAME, "jsonschema", schema().to_string().as_bytes())
            .map_err(mcap_err)?;
        let channel = w
            .add_channel(schema_id, TOPIC, "json", &BTreeMap::new())
            .map_err(mcap_err)?;
        Ok(Self { w, channel, seq: 0 })
    }

    /// Writes the truth `t`, stamped `ns`.
    pub fn write(&mut self, ns: u64, t: &GroundTruth) -> io::Result<()> {
        self.seq = self.seq.wrapping_add(1);
        self.w
            .write_to_known_channel(
                &MessageHeader {
                    channel_id: self.channel,
                    sequence: self.seq,
                    log_time: ns,
                    publish_time: ns,
                },
                t.message().to_string().as_bytes(),
            )
            .map_err(mcap_err)
    }

    /// Ends the current chunk and flushes it: what is written so far
    /// survives a kill (`anguilla export --repair` indexes it).
    pub fn flush(&mut self) -> io::Result<()> {
        self.w.flush().map_err(mcap_err)
    }

    /// Writes the summary and the index, and closes the file.
    pub fn finish(mut self) -> io::Result<()> {
        self.w.finish().map_err(mcap_err)?;
        io::Write::flush(&mut self.w.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        crate::mcap_log::schema::check(&schema(), &m).unwrap();
        assert!((m["heading_deg"].as_f64().unwrap() - 270.0).abs() < 1e-9);
        assert_eq!(m["orientation"]["w"], 1.0);
        // A message missing a field, or with one more, does not pass.
        let mut less = m.clone();
        less.as_object_mut().unwrap().remove("depth");
        assert!(crate::mcap_log::schema::check(&schema(), &less).is_err());
        let mut more = m;
        more["yaw"] = json!(0.0);
        assert!(crate::mcap_log::schema::check(&schema(), &more).is_err());
    }
}
