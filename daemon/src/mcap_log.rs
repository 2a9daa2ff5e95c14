//! The session's MCAP file (docs/data.md): what robotics tools open —
//! Foxglove, Lichtblick, PlotJuggler — beside the bit-exact `bus.log`.
//!
//! One message per recorded [`StateSnapshot`] on each channel, stamped with
//! the daemon's clock (`time_ns`, from the controller's start), JSON
//! encoded, each channel with its JSON Schema ([`schema`]; the fields,
//! their units and codes in `docs/data.md`):
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/anguilla/state` | `anguilla.State` | mode, cause, faults, gait target and actual, predictions, bus and loop statistics, the head sensor's estimate and the autopilot |
//! | `/anguilla/joints` | `anguilla.Joints` | per joint (head first): commanded, measured angle and rate, feed-forward and measured torque, pitch and yaw |
//! | `/log` | `foxglove.Log` | mode changes, faults, refused commands |
//! | `/tf` | `foxglove.FrameTransforms` | `world` → `head` (measured with a head sensor, else predicted) and `world` → `head_predicted` (the model's speed and turn rate, integrated) |
//! | `/body` | `foxglove.SceneUpdate` | the body's links as ellipsoids sized from the body profile, posed from the measured joint angles, in frame `head` |
//!
//! The writer finishes a chunk at every [`McapLog::flush`] (the recorder
//! calls it each second), so a killed daemon leaves a file readable up to
//! its last chunk; [`McapLog::finish`] writes the summary and index.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

use anguilla_ipc::pose::{HeadTrack, Pose};
use anguilla_model::Body;
use mcap::records::MessageHeader;
use nalgebra::{UnitQuaternion, Vector3};
use serde_json::{Value, json};

use crate::config::Config;
use anguilla_ipc::{Cause, FaultSet, HoldState, Mode, Raw as _, SensorHealth, StateSnapshot};

pub mod schema;
pub mod swim;

/// The channels, in the order they are created.
pub const TOPICS: [&str; 6] = [
    "/anguilla/state",
    "/anguilla/joints",
    "/log",
    "/tf",
    "/body",
    "/anguilla/sensors",
];

fn err(e: mcap::McapError) -> io::Error {
    io::Error::other(e.to_string())
}

fn stamp(ns: u64) -> Value {
    json!({ "sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000 })
}

/// `v`, or 0 if it is not finite.
fn finite(v: f32) -> f64 {
    if v.is_finite() { v as f64 } else { 0.0 }
}

fn quat(q: &UnitQuaternion<f64>) -> Value {
    json!({ "x": q.i, "y": q.j, "z": q.k, "w": q.w })
}

fn vec3(v: &Vector3<f64>) -> Value {
    json!({ "x": v.x, "y": v.y, "z": v.z })
}

/// One link of the body, posed in the head frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Its centre (m).
    pub centre: Vector3<f64>,
    /// Its axes: x along the link towards the tail.
    pub orientation: UnitQuaternion<f64>,
    /// Its length (m).
    pub length: f64,
    /// Its semi-axes across: (left, up) (m).
    pub semi_axes: (f64, f64),
}

/// The schemas of [`TOPICS`], in order: (name, JSON schema text); see
/// [`schema`].
pub fn schemas() -> [(&'static str, Vec<u8>); 6] {
    schema::all().map(|(name, s)| (name, s.to_string().into_bytes()))
}

/// The body's links as the robot configured by `cfg` has them, head
/// first: the body cut into `joints + 1` equal parts, each one's length
/// and its semi-axes (width, height) at its middle (m). The recording's
/// `/body` and the ROS 2 node's URDF draw these.
pub fn segments(cfg: &Config) -> Vec<(f64, f64, f64)> {
    let body = Body::paper();
    let n = cfg.robot.joints + 1;
    let l = body.length / n as f64;
    (0..n)
        .map(|k| {
            let (a, b) = body.semi_axes((k as f64 + 0.5) / n as f64);
            (l, a, b)
        })
        .collect()
}

/// Turns snapshots into the channels' messages (the MCAP file's and the
/// live server's): keeps what needs the snapshot before (the predicted
/// head's dead reckoning, the changes logged).
#[derive(Debug, Clone)]
pub struct Scene {
    last: Option<StateSnapshot>,
    /// The head's track (the predicted head dead-reckoned in the plane).
    track: HeadTrack,
    /// Each link's length and its semi-axes (m), head first.
    links: Vec<(f64, f64, f64)>,
}

impl Scene {
    /// The scene of a robot configured by `cfg`.
    pub fn new(cfg: &Config) -> Self {
        Self {
            last: None,
            track: HeadTrack::default(),
            links: segments(cfg),
        }
    }

    /// The messages of one snapshot: (index in [`TOPICS`], JSON), one on
    /// every channel but `/log`, which gets one per change.
    pub fn messages(&mut self, s: &StateSnapshot) -> Vec<(usize, Value)> {
        let ns = s.time_ns;
        let mut out = vec![(0, state_json(s)), (1, joints_json(s))];
        for (level, message) in log_lines(self.last.as_ref(), s) {
            let v = json!({ "timestamp": stamp(ns), "level": level, "message": message,
                            "name": "anguilla", "file": "", "line": 0 });
            out.push((2, v));
        }
        // The head: measured with a head sensor, else predicted; the
        // predicted one integrated in the plane (ipc::pose, as ROS 2's tf).
        let (head, predicted) = self.track.update(s);
        let tf = |child: &str, p: &Pose| {
            let [x, y, z] = p.translation;
            let [qx, qy, qz, qw] = p.rotation;
            json!({ "timestamp": stamp(ns), "parent_frame_id": "world", "child_frame_id": child,
                    "translation": { "x": x, "y": y, "z": z },
                    "rotation": { "x": qx, "y": qy, "z": qz, "w": qw } })
        };
        out.push((
            3,
            json!({ "transforms": [tf("head", &head), tf("head_predicted", &predicted)] }),
        ));
        out.push((4, self.scene_json(s, ns)));
        out.push((5, sensors_json(s)));
        self.last = Some(*s);
        out
    }

    /// The links, head first, in the head frame (x forward, y left, z
    /// up): centre, orientation, length and semi-axes, chained from the
    /// nose through the measured joint angles (each joint pitches about y,
    /// then yaws about the pitched z).
    pub fn links(&self, s: &StateSnapshot) -> Vec<Link> {
        // In the model's head frame the body runs along +x (towards the
        // tail); the head frame is the forward one.
        let flip = anguilla_model::forward_turn();
        let mut r = UnitQuaternion::identity();
        let mut p = Vector3::zeros();
        let joints = (s.joint_count as usize).min(s.joints.len());
        let mut out = Vec::with_capacity(self.links.len());
        for (k, &(l, a, b)) in self.links.iter().enumerate() {
            if k > 0 && k - 1 < joints {
                let j = &s.joints[k - 1];
                r = r
                    * UnitQuaternion::from_euler_angles(0.0, finite(j.measured_pitch), 0.0)
                    * UnitQuaternion::from_euler_angles(0.0, 0.0, finite(j.measured_yaw));
            }
            let centre = p + r * Vector3::new(l / 2.0, 0.0, 0.0);
            p += r * Vector3::new(l, 0.0, 0.0);
            out.push(Link {
                centre: flip * centre,
                orientation: flip * r,
                length: l,
                semi_axes: (a, b),
            });
        }
        out
    }

    fn scene_json(&self, s: &StateSnapshot, ns: u64) -> Value {
        let links = self.links(s);
        let n = links.len();
        let spheres: Vec<Value> = links
            .iter()
            .enumerate()
            .map(|(k, l)| {
                let shade = 0.35 + 0.5 * k as f64 / n as f64;
                json!({
                    "pose": { "position": vec3(&l.centre), "orientation": quat(&l.orientation) },
                    "size": { "x": l.length, "y": 2.0 * l.semi_axes.0, "z": 2.0 * l.semi_axes.1 },
                    "color": { "r": 0.1, "g": shade, "b": 0.6, "a": 1.0 }
                })
            })
            .collect();
        json!({ "deletions": [], "entities": [{
            "timestamp": stamp(ns), "frame_id": "head", "id": "body",
            "lifetime": { "sec": 0, "nsec": 0 }, "frame_locked": true, "metadata": [],
            "arrows": [], "cubes": [], "spheres": spheres, "cylinders": [], "lines": [],
            "triangles": [], "texts": [], "models": []
        }]})
    }

    /// The `/body` scene of `s` drawn as an SVG: seen from above and from
    /// the side, each link an ellipse (its ellipsoid's outline), the head
    /// on the right. The README's picture comes from here.
    ///
    /// Both views share one scale, chosen so that the whole body fits the
    /// picture's width and each view at most 220 pixels of
    /// height, however the body is bent; each view's label has a strip of
    /// its own above the drawing, so no link covers it.
    pub fn body_svg(&self, s: &StateSnapshot) -> String {
        use core::fmt::Write as _;
        let links = self.links(s);
        let views = [
            ("from above (head on the right)", Self::outlines(&links, 0)),
            ("from the side", Self::outlines(&links, 1)),
        ];
        // The extents in metres: one horizontal range for both views, so the
        // head is at the same x in both; a vertical one per view.
        let mut u = (f64::INFINITY, f64::NEG_INFINITY);
        let mut v = [(f64::INFINITY, f64::NEG_INFINITY); 2];
        for (k, (_, outlines)) in views.iter().enumerate() {
            for e in outlines {
                let (hu, hv) = e.half_extents();
                u = (u.0.min(e.u - hu), u.1.max(e.u + hu));
                v[k] = (v[k].0.min(e.v - hv), v[k].1.max(e.v + hv));
            }
        }
        // A body of no links still gets a (blank) picture.
        let span = |r: (f64, f64)| if r.1 > r.0 { r.1 - r.0 } else { 0.0 };
        let width = SVG_WIDTH - 2.0 * SVG_MARGIN;
        let scale = v
            .iter()
            .map(|&r| SVG_VIEW_MAX / span(r).max(1e-9))
            .fold(width / span(u).max(1e-9), f64::min);
        let x0 = SVG_MARGIN + (width - span(u) * scale) / 2.0;
        let mut o = String::new();
        let mut body = String::new();
        let mut top = SVG_MARGIN;
        for (k, (label, outlines)) in views.iter().enumerate() {
            let _ = writeln!(
                body,
                "<text x=\"{SVG_MARGIN}\" y=\"{:.1}\" fill=\"#9bc\" font-family=\"sans-serif\" font-size=\"{SVG_FONT}\">{label}</text>",
                top + SVG_FONT
            );
            let y0 = top + SVG_LABEL;
            for (n, e) in outlines.iter().enumerate() {
                let x = x0 + (e.u - u.0) * scale;
                let y = y0 + (v[k].1 - e.v) * scale;
                let green = 90 + (120 * n / outlines.len().max(1)) as u32;
                let _ = writeln!(
                    body,
                    "<ellipse cx=\"{x:.1}\" cy=\"{y:.1}\" rx=\"{:.1}\" ry=\"{:.1}\" transform=\"rotate({:.1} {x:.1} {y:.1})\" fill=\"rgb(26,{green},153)\" stroke=\"#cde\" stroke-width=\"0.6\"/>",
                    e.rx * scale,
                    e.ry * scale,
                    -e.angle.to_degrees(),
                );
            }
            top = y0 + span(v[k]) * scale + SVG_MARGIN;
        }
        let h = top.ceil();
        let w = SVG_WIDTH;
        let _ = writeln!(
            o,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">"
        );
        let _ = writeln!(o, "<rect width=\"100%\" height=\"100%\" fill=\"#0b2233\"/>");
        o.push_str(&body);
        let _ = writeln!(o, "</svg>");
        o
    }

    /// Each link's outline in one view (0: from above, x right and y up;
    /// 1: from the side, x right and z up), in metres.
    fn outlines(links: &[Link], view: usize) -> Vec<Outline> {
        links
            .iter()
            .map(|l| {
                let axis = l.orientation * Vector3::x();
                let (u, v, au, av, minor) = if view == 0 {
                    (l.centre.x, l.centre.y, axis.x, axis.y, l.semi_axes.0)
                } else {
                    (l.centre.x, l.centre.z, axis.x, axis.z, l.semi_axes.1)
                };
                Outline {
                    u,
                    v,
                    // The link's length as seen in this view, never a sliver.
                    rx: l.length / 2.0 * au.hypot(av).max(0.05),
                    ry: minor,
                    angle: av.atan2(au),
                }
            })
            .collect()
    }
}

/// The picture's width (px), its margin, its font size and the strip each
/// view's label takes above it.
const SVG_WIDTH: f64 = 640.0;
const SVG_MARGIN: f64 = 12.0;
const SVG_FONT: f64 = 13.0;
const SVG_LABEL: f64 = 24.0;
/// The most height (px) one view of the body may take.
const SVG_VIEW_MAX: f64 = 220.0;

/// One link drawn in one view: an ellipse centred on (`u`, `v`), semi-axes
/// `rx` along the link and `ry` across it, its long axis `angle` (rad)
/// counter-clockwise from `u`.
struct Outline {
    u: f64,
    v: f64,
    rx: f64,
    ry: f64,
    angle: f64,
}

impl Outline {
    /// Half the width and half the height of its bounding box.
    fn half_extents(&self) -> (f64, f64) {
        let (sin, cos) = self.angle.sin_cos();
        (
            (self.rx * cos).hypot(self.ry * sin),
            (self.rx * sin).hypot(self.ry * cos),
        )
    }
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
            scene: Scene::new(cfg),
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
    /// its own channel ([`crate::truth::TOPIC`]), created with the first.
    pub fn write_truth(&mut self, ns: u64, t: &crate::truth::GroundTruth) -> io::Result<()> {
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

/// What [`export`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Exported {
    /// Snapshots written.
    pub snapshots: u64,
    /// Bytes at the end of `state.bin` that were not a whole snapshot (a
    /// recording cut short), left out.
    pub partial_bytes: usize,
}

/// Writes `out` from a recorded session directory `dir` (its
/// `config.toml` and `state.bin`): the MCAP file of a session recorded
/// without one, or again.
pub fn export(dir: &Path, out: &Path) -> io::Result<Exported> {
    export_with(dir, out, &mut |_, _| {})
}

/// [`export`], telling `progress(snapshots done, snapshots in all)` every
/// [`crate::replay::PROGRESS_EVERY`] snapshots and at the end.
pub fn export_with(
    dir: &Path,
    out: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> io::Result<Exported> {
    let file = File::create(out)
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", out.display())))?;
    export_into(dir, file, progress)
}

/// [`export_with`] into `file`, opened by the caller.
pub fn export_into(
    dir: &Path,
    file: File,
    progress: &mut dyn FnMut(u64, u64),
) -> io::Result<Exported> {
    let cfg = Config::load(&dir.join("config.toml"))
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
    let mut log = McapLog::from_file(file, &cfg)?;
    let (_, n, partial) = for_each_state(dir, |i, total, s| {
        if i.is_multiple_of(crate::replay::PROGRESS_EVERY) {
            progress(i, total);
        }
        log.write(s)
    })?;
    log.finish()?;
    progress(n, n);
    Ok(Exported {
        snapshots: n,
        partial_bytes: partial,
    })
}

/// Reads the session `dir`'s configuration and calls `f` with each
/// snapshot of its `state.bin`, its index and their count: the snapshots
/// `anguilla export` turns into MCAP and rosbag2 files. Returns the
/// configuration, the snapshots read and the bytes at the end that were
/// not a whole snapshot (a recording cut short). A snapshot of another
/// layout version is an error that says which.
pub fn for_each_state(
    dir: &Path,
    mut f: impl FnMut(u64, u64, &StateSnapshot) -> io::Result<()>,
) -> io::Result<(Config, u64, usize)> {
    let named = |what: &str, e: io::Error| io::Error::new(e.kind(), format!("{what}: {e}"));
    let cfg_path = dir.join("config.toml");
    let cfg = Config::load(&cfg_path)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
    let states = dir.join("state.bin");
    let bytes = std::fs::read(&states).map_err(|e| named(&states.display().to_string(), e))?;
    let size = core::mem::size_of::<StateSnapshot>();
    let total = (bytes.len() / size) as u64;
    let mut n = 0u64;
    for (i, chunk) in bytes.chunks_exact(size).enumerate() {
        let s = StateSnapshot::from_bytes(chunk)
            .ok_or_else(|| io::Error::from(io::ErrorKind::InvalidData))?;
        if s.layout_version != anguilla_ipc::LAYOUT_VERSION {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "{}: snapshot {i} has layout version {} (this anguilla reads {}); \
                     export it with the anguilla that recorded it",
                    states.display(),
                    s.layout_version,
                    anguilla_ipc::LAYOUT_VERSION
                ),
            ));
        }
        f(i as u64, total, &s)?;
        n += 1;
    }
    Ok((cfg, n, bytes.len() % size))
}

/// What [`repair`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Repaired {
    /// Messages copied (every one readable before the cut).
    pub messages: u64,
    /// Channels copied.
    pub channels: usize,
    /// Why reading stopped: `None` when the file was whole.
    pub cut: Option<String>,
}

/// Copies the MCAP file `input` into a complete one at `out`: every
/// message readable in order before the end or the cut (a daemon killed
/// mid-chunk leaves a file without summary and index, which indexed
/// readers refuse), on the same channels and schemas, then the summary
/// and index. Any channel is kept, `/sim/truth` included (which an
/// [`export`] from `state.bin` cannot give back).
pub fn repair(input: &Path, out: &Path) -> io::Result<Repaired> {
    let file = File::create(out)
        .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", out.display())))?;
    repair_into(input, file)
}

/// [`repair`] into `out`, opened by the caller.
pub fn repair_into(input: &Path, out: File) -> io::Result<Repaired> {
    let named =
        |what: &Path, e: io::Error| io::Error::new(e.kind(), format!("{}: {e}", what.display()));
    let bytes = std::fs::read(input).map_err(|e| named(input, e))?;
    let stream = mcap::MessageStream::new(&bytes).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{}: not an MCAP file ({e})", input.display()),
        )
    })?;
    let file = BufWriter::new(out);
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .profile("")
        .create(file)
        .map_err(err)?;
    // The input's channel ids to the output's.
    let mut channels: BTreeMap<u16, u16> = BTreeMap::new();
    let (mut messages, mut cut) = (0u64, None);
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                cut = Some(e.to_string());
                break;
            }
        };
        let id = match channels.get(&m.channel.id) {
            Some(&id) => id,
            None => {
                let schema_id = match &m.channel.schema {
                    Some(s) => w.add_schema(&s.name, &s.encoding, &s.data).map_err(err)?,
                    None => 0,
                };
                let id = w
                    .add_channel(
                        schema_id,
                        &m.channel.topic,
                        &m.channel.message_encoding,
                        &m.channel.metadata,
                    )
                    .map_err(err)?;
                channels.insert(m.channel.id, id);
                id
            }
        };
        w.write_to_known_channel(
            &MessageHeader {
                channel_id: id,
                sequence: m.sequence,
                log_time: m.log_time,
                publish_time: m.publish_time,
            },
            &m.data,
        )
        .map_err(err)?;
        messages += 1;
    }
    w.finish().map_err(err)?;
    io::Write::flush(&mut w.into_inner())?;
    Ok(Repaired {
        messages,
        channels: channels.len(),
        cut,
    })
}

/// What changed between two snapshots, as log lines (level, text):
/// foxglove.Log levels 2 info, 3 warning, 4 error.
fn log_lines(last: Option<&StateSnapshot>, s: &StateSnapshot) -> Vec<(u8, String)> {
    let mut out = Vec::new();
    let mode = Mode::from_code(s.mode).map_or("unknown", Mode::name);
    let cause = Cause::from_code(s.cause).map_or("unknown", Cause::name);
    if last.is_none_or(|l| l.mode != s.mode) {
        let level = match Mode::from_code(s.mode) {
            Some(Mode::Fault | Mode::EStop) => 4,
            _ => 2,
        };
        out.push((level, format!("mode {mode} (cause: {cause})")));
    }
    let faults = FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    if last.is_some_and(|l| l.fault_kinds != s.fault_kinds || l.fault_nodes != s.fault_nodes)
        && !faults.is_empty()
    {
        out.push((4, format!("faults: {faults}")));
    }
    if let Some(l) = last
        && s.refused_commands > l.refused_commands
    {
        out.push((
            3,
            format!(
                "{} command(s) refused ({} since start)",
                s.refused_commands - l.refused_commands,
                s.refused_commands
            ),
        ));
    }
    if let Some(l) = last
        && s.nav.hold_exit != l.nav.hold_exit
        && s.nav.hold_exit != 0
    {
        let why = SensorHealth::from_code(s.nav.hold_exit).map_or("unknown", SensorHealth::name);
        out.push((3, format!("the autopilot let go: head sensor {why}")));
    }
    // A hold that stops converging (or cannot), or converges again; the
    // robot at the surface, or back under.
    if let Some(l) = last {
        for (now, was, words) in [
            (
                s.nav.heading_hold,
                l.nav.heading_hold,
                s.nav.heading_words(),
            ),
            (s.nav.depth_hold, l.nav.depth_hold, s.nav.depth_words()),
        ] {
            if let Some(line) = hold_line(now, was, words) {
                out.push(line);
            }
        }
        if s.nav.surfaced != l.nav.surfaced {
            out.push(surface_line(s.nav.surfaced != 0, s.nav.depth_m));
        }
    }
    // A joint whose torque-residual alarm rose or cleared, named with its
    // axis and sign.
    if let Some(l) = last {
        let n = (s.joint_count as usize).min(s.joints.len());
        for (j, (now, was)) in s.joints[..n].iter().zip(&l.joints).enumerate() {
            if now.residual_alarm == was.residual_alarm {
                continue;
            }
            use anguilla_ipc::residual_bits as rb;
            for (axis, on, below, r) in [
                (
                    "pitch",
                    rb::PITCH,
                    rb::PITCH_BELOW,
                    now.pitch_torque_residual,
                ),
                ("yaw", rb::YAW, rb::YAW_BELOW, now.yaw_torque_residual),
            ] {
                let (a, b) = (
                    now.residual_alarm & (on | below),
                    was.residual_alarm & (on | below),
                );
                if a == b {
                    continue;
                }
                if a & on != 0 {
                    let sign = if a & below != 0 { "less" } else { "more" };
                    out.push((
                        3,
                        format!(
                            "joint {} {axis}: torque residual {r:+.2}, the joint needs {sign} \
                             torque than the model predicts (a snag, fouling, a failing \
                             actuator, a tether pulling?)",
                            j + 1
                        ),
                    ));
                } else {
                    out.push((
                        2,
                        format!(
                            "joint {} {axis}: torque residual back within its band",
                            j + 1
                        ),
                    ));
                }
            }
        }
    }
    // A sensor whose health changed, named by its kind and node id (after
    // the start: its first health is in `/anguilla/sensors`).
    if let Some(l) = last {
        for (e, was) in s.sensors.iter().zip(&l.sensors) {
            if e.kind == 0 || (e.kind, e.id, e.health) == (was.kind, was.id, was.health) {
                continue;
            }
            let kind = e
                .sensor_kind()
                .map_or("unknown sensor", anguilla_ipc::SensorKind::name);
            let health = SensorHealth::from_code(e.health);
            let level = match health {
                Some(SensorHealth::Ok | SensorHealth::Waiting) => 2,
                _ => 3,
            };
            let health = health.map_or("unknown", SensorHealth::name);
            out.push((level, format!("sensor {kind} (node {}): {health}", e.id)));
        }
    }
    out
}

/// The log line (level, text) for a hold state that went from `was` to
/// `now`, `words` its state in words: a hold that stops converging (a
/// warning) or converges again; none for other changes.
pub fn hold_line(now: u8, was: u8, words: Option<String>) -> Option<(u8, String)> {
    let failed = |c: u8| HoldState::from_code(c).is_some_and(HoldState::failed);
    let words = words?;
    if failed(now) && now != was {
        Some((3, format!("hold {words}")))
    } else if failed(was) && !failed(now) && now != HoldState::Off as u8 {
        Some((2, format!("hold {words}")))
    } else {
        None
    }
}

/// The log line (level, text) for the robot reaching the surface (by the
/// daemon's estimate, a warning) or leaving it.
pub fn surface_line(surfaced: bool, depth: f32) -> (u8, String) {
    if surfaced {
        (3, format!("surfaced: the depth estimate is {depth:.2} m"))
    } else {
        (2, format!("back under the surface: depth {depth:.2} m"))
    }
}

/// `/anguilla/state`'s message; its schema is [`schema::state`].
fn state_json(s: &StateSnapshot) -> Value {
    let gait = |g: &anguilla_ipc::GaitSnapshot| json!({ "amplitude": g.amplitude, "frequency": g.frequency, "turn": g.turn, "pitch": g.pitch });
    let n = &s.nav;
    json!({
        "time_ns": s.time_ns,
        "sequence": s.sequence,
        "mode": Mode::from_code(s.mode).map_or(schema::UNKNOWN, Mode::name),
        "cause": Cause::from_code(s.cause).map_or(schema::UNKNOWN, Cause::name),
        "fault_kinds": s.fault_kinds,
        "fault_nodes": s.fault_nodes,
        "feedforward_dropped": s.feedforward_dropped != 0,
        "predicted_head_speed": s.predicted_head_speed,
        "predicted_turn_rate": s.predicted_turn_rate,
        "gait_target": gait(&s.gait_target),
        "gait_actual": gait(&s.gait_actual),
        "bus": { "tx_frames": s.bus.tx_frames, "rx_frames": s.bus.rx_frames,
                 "tx_dropped": s.bus.tx_dropped, "malformed": s.bus.malformed,
                 "errors": s.bus.errors, "rx_overruns": s.bus.rx_overruns,
                 "bus_off_count": s.bus.bus_off_count, "state": s.bus.state },
        "loop": { "period_ns": s.loop_stats.period_ns, "jitter_p99_ns": s.loop_stats.jitter_p99_ns,
                  "jitter_max_ns": s.loop_stats.jitter_max_ns,
                  "compute_p99_ns": s.loop_stats.compute_p99_ns,
                  "periods": s.loop_stats.periods, "overruns": s.loop_stats.overruns },
        "clamped_setpoints": s.clamped_setpoints,
        "refused_commands": s.refused_commands,
        "records_lost": s.records_lost,
        "nav": { "sensor": SensorHealth::from_code(n.sensor).map_or(schema::UNKNOWN, SensorHealth::name),
                 "hold": n.hold,
                 "heading_hold": HoldState::from_code(n.heading_hold).map_or(schema::UNKNOWN, HoldState::name),
                 "depth_hold": HoldState::from_code(n.depth_hold).map_or(schema::UNKNOWN, HoldState::name),
                 "surfaced": n.surfaced != 0,
                 "heading_deg": n.heading_deg, "pitch_deg": n.pitch_deg,
                 "roll_deg": n.roll_deg, "depth_m": n.depth_m, "depth_rate": n.depth_rate,
                 "heading_target_deg": n.heading_target_deg, "depth_target_m": n.depth_target_m,
                 "rate_innovation": n.rate_innovation, "depth_innovation": n.depth_innovation,
                 "samples": n.samples, "lost_samples": n.lost_samples },
    })
}

/// `/anguilla/sensors`'s message: every sensor of the snapshot's list, its
/// values named by its kind; its schema is [`schema::sensors`].
fn sensors_json(s: &StateSnapshot) -> Value {
    let list: Vec<Value> = s
        .sensors
        .iter()
        .filter(|e| e.kind != 0)
        .map(|e| {
            let values: Vec<Value> = e
                .named_values()
                .map(|(name, unit, v)| json!({ "name": name, "unit": unit, "value": finite(v) }))
                .collect();
            json!({
                "kind": e.sensor_kind().map_or(schema::UNKNOWN, anguilla_ipc::SensorKind::name),
                "id": e.id,
                "health": SensorHealth::from_code(e.health).map_or(schema::UNKNOWN, SensorHealth::name),
                "samples": e.samples,
                "values": values,
            })
        })
        .collect();
    json!({ "time_ns": s.time_ns, "sensors": list })
}

/// `/anguilla/joints`'s message; its schema is [`schema::joints`].
fn joints_json(s: &StateSnapshot) -> Value {
    let n = (s.joint_count as usize).min(s.joints.len());
    let js = &s.joints[..n];
    let col = |f: &dyn Fn(&anguilla_ipc::JointSnapshot) -> f32| -> Vec<f32> {
        js.iter().map(f).collect()
    };
    json!({
        "commanded_pitch": col(&|j| j.commanded_pitch),
        "commanded_yaw": col(&|j| j.commanded_yaw),
        "measured_pitch": col(&|j| j.measured_pitch),
        "measured_yaw": col(&|j| j.measured_yaw),
        "commanded_pitch_velocity": col(&|j| j.commanded_pitch_velocity),
        "commanded_yaw_velocity": col(&|j| j.commanded_yaw_velocity),
        "measured_pitch_velocity": col(&|j| j.measured_pitch_velocity),
        "measured_yaw_velocity": col(&|j| j.measured_yaw_velocity),
        "feedforward_pitch_torque": col(&|j| j.predicted_pitch_torque),
        "feedforward_yaw_torque": col(&|j| j.predicted_yaw_torque),
        "measured_pitch_torque": col(&|j| j.measured_pitch_torque),
        "measured_yaw_torque": col(&|j| j.measured_yaw_torque),
        "pitch_torque_residual": col(&|j| j.pitch_torque_residual),
        "yaw_torque_residual": col(&|j| j.yaw_torque_residual),
        "residual_alarm": js.iter().map(|j| j.residual_alarm).collect::<Vec<_>>(),
        "node_state": js.iter().map(|j| j.node_state).collect::<Vec<_>>(),
        "node_alive": js.iter().map(|j| j.node_alive).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod log_tests {
    use super::*;

    /// A sensor's change of health is a `/log` line naming its kind and
    /// node; an unchanged one says nothing.
    #[test]
    fn a_sensor_that_changes_health_is_named_in_the_log() {
        let mut a = StateSnapshot::default();
        a.sensors[1] = anguilla_ipc::SensorEntry {
            kind: anguilla_ipc::SensorKind::TailImu as u8,
            id: 40,
            health: SensorHealth::Ok as u8,
            ..Default::default()
        };
        let mut b = a;
        assert!(log_lines(Some(&a), &b).is_empty());
        b.sensors[1].health = SensorHealth::Silent as u8;
        assert_eq!(
            log_lines(Some(&a), &b),
            [(3, "sensor tail-imu (node 40): silent".to_string())]
        );
        assert_eq!(
            log_lines(Some(&b), &a),
            [(2, "sensor tail-imu (node 40): ok".to_string())]
        );
    }

    /// Issue 46: a hold that stops converging is a warning naming its
    /// values; converging and holding are not news, converging again is;
    /// the robot at the surface is a warning, back under a note.
    #[test]
    fn a_hold_that_stops_converging_and_surfacing_are_logged() {
        let mut a = StateSnapshot::default();
        a.nav.depth_hold = HoldState::Converging as u8;
        a.nav.depth_m = 2.5;
        a.nav.depth_target_m = 1.2;
        let mut b = a;
        b.nav.depth_hold = HoldState::Holding as u8;
        assert!(log_lines(Some(&a), &b).is_empty());
        b.nav.depth_hold = HoldState::NotConverging as u8;
        assert_eq!(
            log_lines(Some(&a), &b),
            [(
                3,
                "hold not converging: depth 2.50 m for 1.20 m".to_string()
            )]
        );
        assert_eq!(
            log_lines(Some(&b), &a),
            [(2, "hold converging: depth 2.50 m for 1.20 m".to_string())]
        );
        let mut c = b;
        c.nav.depth_hold = HoldState::Surface as u8;
        c.nav.surfaced = 1;
        c.nav.depth_m = 0.01;
        assert_eq!(
            log_lines(Some(&b), &c),
            [
                (
                    3,
                    "hold cannot: at the surface: depth 0.01 m for 1.20 m".to_string()
                ),
                (3, "surfaced: the depth estimate is 0.01 m".to_string())
            ]
        );
        // Released: no line for the hold.
        let mut d = c;
        d.nav.depth_hold = 0;
        d.nav.surfaced = 0;
        assert_eq!(
            log_lines(Some(&c), &d),
            [(2, "back under the surface: depth 0.01 m".to_string())]
        );
    }
}
