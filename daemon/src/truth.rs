//! The simulated robot's ground truth, recorded beside the estimate (the
//! message and its schema: [`anguilla_view::truth`]).
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

pub use anguilla_view::truth::{GroundTruth, SCHEMA_NAME, TOPIC, schema};

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
