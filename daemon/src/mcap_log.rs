//! The session's MCAP file (docs/data.md): what robotics tools open —
//! Foxglove, Lichtblick, PlotJuggler — beside the bit-exact `bus.log`.
//!
//! One message per recorded [`StateSnapshot`] on each channel, stamped with
//! the daemon's clock (`time_ns`, from the controller's start), JSON
//! encoded, each channel with its JSON Schema ([`anguilla_view::schema`]; the fields,
//! their units and codes in `docs/data.md`):
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/anguilla/state` | `anguilla.State` | mode, cause, faults, gait target and actual, predictions, bus and loop statistics, the head sensor's estimate and the autopilot |
//! | `/anguilla/joints` | `anguilla.Joints` | per joint (head first): commanded, measured angle and rate, feed-forward and measured torque, pitch and yaw |
//! | `/log` | `foxglove.Log` | mode changes, faults, refused commands |
//! | `/tf` | `foxglove.FrameTransforms` | `world` → `head` (measured with a head sensor, else predicted), `world` → `head_predicted` (the model's speed and turn rate, integrated), and with the built-in simulated robot `world` → `truth` (its true head, from the newest ground truth) |
//! | `/body` | `foxglove.SceneUpdate` | entity `body`: the body's links as ellipsoids sized from the body profile, posed from the measured joint angles, in frame `head`; entity `guide`, in frame `world`: the path's legs (past ones dim, the current one bright), the cross-track error (red, while following) and the position's 1σ disc, at the estimate's depth |
//!
//! The writer finishes a chunk at every [`McapLog::flush`] (the recorder
//! calls it each second), so a killed daemon leaves a file readable up to
//! its last chunk; [`McapLog::finish`] writes the summary and index.
//!
//! The messages and their schemas are [`anguilla_view`]'s (its [`Scene`]
//! turns snapshots into the channels' messages; the live Foxglove server
//! uses the same). Its files: this one, the writer; `export.rs` and
//! `repair.rs`, the files written after a session; [`swim`].

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

use mcap::records::MessageHeader;

use crate::config::Config;
use anguilla_ipc::StateSnapshot;

mod export;
mod repair;
pub mod swim;

use anguilla_view::{Scene, TOPICS, schemas};
pub use export::{Exported, export, export_into, export_with, for_each_state};
pub use repair::{Repaired, repair, repair_into};

fn err(e: mcap::McapError) -> io::Error {
    io::Error::other(e.to_string())
}

/// The session's MCAP writer.
pub struct McapLog {
    w: mcap::Writer<BufWriter<File>>,
    ids: [u16; TOPICS.len()],
    seq: u32,
    scene: Scene,
    /// The ground truth's channel, added with its first message.
    truth: Option<u16>,
}

impl McapLog {
    /// Creates `path` for a robot configured by `cfg`.
    pub fn create(path: &Path, cfg: &Config) -> io::Result<Self> {
        Self::from_file(File::create(path)?, cfg)
    }

    /// Writes into `file` (opened by the caller: a tool's output made
    /// exclusively beside its target, `anguilla::user_file`).
    pub fn from_file(file: File, cfg: &Config) -> io::Result<Self> {
        let file = BufWriter::new(file);
        let compression = match cfg.recording.compression.as_str() {
            "zstd" => Some(mcap::Compression::Zstd),
            _ => None,
        };
        let mut w = mcap::WriteOptions::new()
            .compression(compression)
            // zstd in the recorder thread itself: the mcap crate's default
            // (a worker thread per physical core) adds threads that compete
            // with the loop for the CPU and, with `[realtime] lock-memory`,
            // about 63 MB of locked buffers (VmLck 105 MB with them, 41.8 MB
            // without). At level 1 (the crate's default is 3) its
            // context is 2.5 MB smaller and it costs less CPU
            // (docs/performance.md has both sizes).
            .compression_threads(0)
            .compression_level(1)
            .profile("")
            .create(file)
            .map_err(err)?;
        let mut ids = [0u16; TOPICS.len()];
        for (i, (name, data)) in schemas().iter().enumerate() {
            let schema_id = w.add_schema(name, "jsonschema", data).map_err(err)?;
            ids[i] = w
                .add_channel(schema_id, TOPICS[i], "json", &BTreeMap::new())
                .map_err(err)?;
        }
        Ok(Self {
            w,
            ids,
            seq: 0,
            scene: Scene::new(cfg.robot.joints),
            truth: None,
        })
    }

    /// Writes one snapshot to every channel (and `/log` when something
    /// changed), stamped with the daemon's clock.
    pub fn write(&mut self, s: &StateSnapshot) -> io::Result<()> {
        let ns = s.time_ns;
        for (channel, v) in self.scene.messages(s) {
            self.seq = self.seq.wrapping_add(1);
            let data = v.to_string();
            self.w
                .write_to_known_channel(
                    &MessageHeader {
                        channel_id: self.ids[channel],
                        sequence: self.seq,
                        log_time: ns,
                        publish_time: ns,
                    },
                    data.as_bytes(),
                )
                .map_err(err)?;
        }
        Ok(())
    }

    /// Writes the simulated robot's ground truth at daemon time `ns` to
    /// its own channel ([`crate::truth::TOPIC`]), created with the first;
    /// the next snapshot's `/tf` carries it as the frame `truth`
    /// ([`Scene::truth`]).
    pub fn write_truth(&mut self, ns: u64, t: &crate::truth::GroundTruth) -> io::Result<()> {
        self.scene.truth(ns, t);
        let channel_id = match self.truth {
            Some(id) => id,
            None => {
                let schema = crate::truth::schema().to_string();
                let schema_id = self
                    .w
                    .add_schema(crate::truth::SCHEMA_NAME, "jsonschema", schema.as_bytes())
                    .map_err(err)?;
                let id = self
                    .w
                    .add_channel(schema_id, crate::truth::TOPIC, "json", &BTreeMap::new())
                    .map_err(err)?;
                *self.truth.insert(id)
            }
        };
        self.seq = self.seq.wrapping_add(1);
        let data = t.message().to_string();
        self.w
            .write_to_known_channel(
                &MessageHeader {
                    channel_id,
                    sequence: self.seq,
                    log_time: ns,
                    publish_time: ns,
                },
                data.as_bytes(),
            )
            .map_err(err)
    }

    /// Ends the current chunk and flushes it: what is written so far
    /// survives a kill.
    pub fn flush(&mut self) -> io::Result<()> {
        self.w.flush().map_err(err)?;
        Ok(())
    }

    /// Writes the summary and the index, and closes the file.
    pub fn finish(mut self) -> io::Result<()> {
        self.w.finish().map_err(err)?;
        // the buffer's last bytes, whose error a drop would lose
        io::Write::flush(&mut self.w.into_inner())
    }
}
