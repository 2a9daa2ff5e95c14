//! A recorded session as the model's identification takes it
//! ([`anguilla_model::identify::Swim`], `anguilla calibrate`): the joints'
//! measured motion and torques from `/anguilla/joints`, the nose's track
//! from an external tracking file or `/sim/truth`, and the heading and
//! depth from `/sim/truth` or else the head sensor's estimate
//! (`/anguilla/state` `nav`, while its health is `ok`).

use std::path::Path;

use anguilla_model::identify::{JointSample, Swim};
use serde_json::Value;

use super::TOPICS;
use crate::truth;

/// Where a swim's heading and depth came from, and its track.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// None in the file.
    None,
    /// The head sensor's estimate.
    HeadSensor,
    /// The simulation's ground truth.
    Truth,
    /// A tracking file.
    Tracking,
}

impl Source {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Source::None => "none",
            Source::HeadSensor => "the head sensor",
            Source::Truth => "the simulation's ground truth (/sim/truth)",
            Source::Tracking => "the tracking file",
        }
    }
}

/// A session read for the fit.
#[derive(Debug, Clone)]
pub struct ReadSwim {
    /// The swim.
    pub swim: Swim,
    /// Where its track came from.
    pub track: Source,
    /// Where its heading and depth came from.
    pub attitude: Source,
    /// Joint samples without a measured torque on some axis.
    pub missing_torques: usize,
    /// What was in the file but not taken, each counted.
    pub dropped: Dropped,
}

/// What [`read`] left out of a session, counted so `anguilla calibrate`
/// can say it: nothing is dropped silently.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Dropped {
    /// `/anguilla/joints` messages that did not read: not JSON, a field
    /// missing or of another length, an angle or a rate not a number.
    pub joints: usize,
    /// `/sim/truth` messages that did not read.
    pub truth: usize,
    /// `/anguilla/state` messages that were not JSON.
    pub state: usize,
    /// Joint samples whose time was not after the one before's (kept: the
    /// first).
    pub repeated: usize,
    /// Why reading stopped before the file's end (a recording cut short:
    /// a killed daemon, a full disk), if it did: every message before the
    /// cut is read.
    pub cut: Option<String>,
}

impl Dropped {
    /// Whether anything was left out.
    pub fn any(&self) -> bool {
        self.joints + self.truth + self.state + self.repeated > 0 || self.cut.is_some()
    }
}

impl std::fmt::Display for Dropped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} unreadable joint samples (/anguilla/joints), {} unreadable /sim/truth and {} \
             unreadable /anguilla/state messages, {} joint samples repeating an earlier time",
            self.joints, self.truth, self.state, self.repeated
        )?;
        if let Some(why) = &self.cut {
            write!(f, "; read up to a cut ({why})")?;
        }
        Ok(())
    }
}

/// The largest session file [`read`] takes by default (bytes): 4 GiB,
/// about 10 hours of a 12-joint robot's recording; `anguilla calibrate
/// --max-size` sets another.
pub const MAX_SESSION_BYTES: u64 = 4 << 30;

/// Opens `path` for reading if it is a regular file of at most `max`
/// bytes, without blocking: a named pipe, a device, a socket or a
/// directory is refused by name before it is opened (and again after, on
/// the descriptor, for one swapped in meanwhile), as is a file over `max`.
/// Returns the file and its size; `what` names the option or the role in
/// messages.
pub fn open_regular(path: &Path, max: u64, what: &str) -> Result<(std::fs::File, u64), String> {
    use std::os::unix::fs::{FileTypeExt as _, OpenOptionsExt as _};
    let name = path.display();
    let check = |m: &std::fs::Metadata| -> Result<u64, String> {
        let t = m.file_type();
        if !t.is_file() {
            let kind = if t.is_fifo() {
                "a named pipe"
            } else if t.is_dir() {
                "a directory"
            } else if t.is_char_device() || t.is_block_device() {
                "a device"
            } else if t.is_socket() {
                "a socket"
            } else {
                "not a regular file"
            };
            return Err(format!(
                "{name}: {kind}, not a regular file (expected {what})"
            ));
        }
        if m.len() > max {
            return Err(format!(
                "{name}: {} bytes, more than the {max} read at most (--max-size; expected {what})",
                m.len()
            ));
        }
        Ok(m.len())
    };
    check(&std::fs::metadata(path).map_err(|e| format!("{name}: {e}"))?)?;
    // O_NONBLOCK: a pipe swapped in after the check does not block the
    // open; a regular file's reads ignore it.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_CLOEXEC)
        .open(path)
        .map_err(|e| format!("{name}: {e}"))?;
    let len = check(&file.metadata().map_err(|e| format!("{name}: {e}"))?)?;
    Ok((file, len))
}

fn numbers(v: &Value, key: &str) -> Option<Vec<f64>> {
    v.get(key)?
        .as_array()?
        .iter()
        .map(|x| {
            if x.is_null() {
                Some(f64::NAN)
            } else {
                x.as_f64()
            }
        })
        .collect()
}

fn pairs(v: &Value, pitch: &str, yaw: &str) -> Option<Vec<[f64; 2]>> {
    let (p, y) = (numbers(v, pitch)?, numbers(v, yaw)?);
    (p.len() == y.len()).then(|| p.into_iter().zip(y).map(|(a, b)| [a, b]).collect())
}

fn num(v: &Value, path: &[&str]) -> Option<f64> {
    let mut v = v;
    for k in path {
        v = v.get(k)?;
    }
    v.as_f64()
}

/// A record (an uncompressed one, or a chunk's compressed data) larger
/// than this ends the read: the reader's memory is bounded by it, not by
/// the file. The recorder's chunks are well under 1 MB.
const MAX_RECORD_BYTES: usize = 64 << 20;

/// Reads the session `path` (a `session.mcap`, or the session directory
/// holding one) of at most [`MAX_SESSION_BYTES`]; `tracking`, if given, is
/// the nose's track (it replaces `/sim/truth`'s). The error names the file
/// and what is wrong.
pub fn read(path: &Path, tracking: Option<Vec<[f64; 3]>>) -> Result<ReadSwim, String> {
    read_limited(path, tracking, MAX_SESSION_BYTES)
}

/// [`read`] of a file of at most `max` bytes. The file is streamed (the
/// memory taken is the samples kept and one record, not the file); a named
/// pipe, a device or a directory is refused at once ([`open_regular`]).
pub fn read_limited(
    path: &Path,
    tracking: Option<Vec<[f64; 3]>>,
    max: u64,
) -> Result<ReadSwim, String> {
    use std::io::Read as _;
    let file = if path.is_dir() {
        path.join("session.mcap")
    } else {
        path.to_path_buf()
    };
    let name = file.display().to_string();
    let (f, _) = open_regular(&file, max, "a recorded session.mcap")?;
    let stream = mcap::io::MessageReader::new_with_options(
        std::io::BufReader::new(f.take(max)),
        mcap::sans_io::LinearReaderOptions::default().with_record_length_limit(MAX_RECORD_BYTES),
    );
    let mut samples = Vec::new();
    let (mut truth_track, mut truth_att, mut nav_att) = (Vec::new(), Vec::new(), Vec::new());
    let mut head_yaw: Vec<[f64; 2]> = Vec::new();
    let mut dropped = Dropped::default();
    let mut missing_torques = 0usize;
    let mut read_any = false;
    for m in stream {
        // a recording cut short (a killed daemon) is read up to the cut
        let m = match m {
            Ok(m) => m,
            Err(e) if !read_any => return Err(format!("{name}: not an MCAP file ({e})")),
            Err(e) => {
                dropped.cut = Some(e.to_string());
                break;
            }
        };
        read_any = true;
        let topic = m.channel.topic.as_str();
        let bad = if topic == TOPICS[1] {
            &mut dropped.joints
        } else if topic == truth::TOPIC {
            &mut dropped.truth
        } else if topic == TOPICS[0] {
            &mut dropped.state
        } else {
            continue;
        };
        let Ok(v) = serde_json::from_slice::<Value>(&m.data) else {
            *bad += 1;
            continue;
        };
        let t = m.log_time as f64 * 1e-9;
        if topic == TOPICS[1] {
            let angle = pairs(&v, "measured_pitch", "measured_yaw");
            let rate = pairs(&v, "measured_pitch_velocity", "measured_yaw_velocity");
            let torque = pairs(&v, "measured_pitch_torque", "measured_yaw_torque");
            match (angle, rate, torque) {
                (Some(angle), Some(rate), Some(torque))
                    if angle.len() == rate.len()
                        && angle.len() == torque.len()
                        && angle.iter().chain(&rate).flatten().all(|x| x.is_finite()) =>
                {
                    if torque.iter().flatten().any(|x| !x.is_finite()) {
                        missing_torques += 1;
                    }
                    samples.push(JointSample {
                        t,
                        angle,
                        rate,
                        torque,
                    });
                }
                _ => dropped.joints += 1,
            }
        } else if topic == truth::TOPIC {
            let p = (
                num(&v, &["position", "x"]),
                num(&v, &["position", "y"]),
                num(&v, &["heading_deg"]),
                num(&v, &["depth"]),
            );
            let q = ["w", "x", "y", "z"].map(|k| num(&v, &["orientation", k]));
            match (p, q) {
                (
                    (Some(x), Some(y), Some(h), Some(d)),
                    [Some(qw), Some(qx), Some(qy), Some(qz)],
                ) => {
                    truth_track.push([t, x, y]);
                    truth_att.push([t, h.to_radians(), d]);
                    // the head frame's x (towards the tail) in the world
                    let (tx, ty) = (1.0 - 2.0 * (qy * qy + qz * qz), 2.0 * (qx * qy + qw * qz));
                    head_yaw.push([t, ty.atan2(tx)]);
                }
                _ => dropped.truth += 1,
            }
        } else if v.pointer("/nav/sensor").and_then(Value::as_str) == Some("ok")
            && let (Some(h), Some(d)) = (
                num(&v, &["nav", "heading_deg"]),
                num(&v, &["nav", "depth_m"]),
            )
        {
            nav_att.push([t, h.to_radians(), d]);
        }
    }
    // one sample per instant, in time order (a file's log times never go
    // back within a channel; equal times keep the first)
    let n = samples.len();
    samples.dedup_by(|b, a| b.t <= a.t);
    dropped.repeated = n - samples.len();
    for s in [&mut truth_track, &mut truth_att, &mut nav_att] {
        s.dedup_by(|b, a| b[0] <= a[0]);
    }
    head_yaw.dedup_by(|b, a| b[0] <= a[0]);
    if samples.len() < 2 {
        return Err(format!(
            "{name}: {} readable joint samples on /anguilla/joints (need at least 2; {dropped})",
            samples.len()
        ));
    }
    let (track, track_src) = match tracking {
        Some(t) => (t, Source::Tracking),
        None if !truth_track.is_empty() => (truth_track, Source::Truth),
        None => (Vec::new(), Source::None),
    };
    // the ground truth where there is one (a simulated robot: exact),
    // else the head sensor's estimate
    let (attitude, att_src) = if truth_att.len() >= 2 {
        (truth_att, Source::Truth)
    } else if nav_att.len() >= 2 {
        (nav_att, Source::HeadSensor)
    } else {
        (Vec::new(), Source::None)
    };
    let swim = Swim {
        name,
        samples,
        track,
        attitude,
        head_yaw,
    };
    swim.validate()?;
    Ok(ReadSwim {
        swim,
        track: track_src,
        attitude: att_src,
        missing_torques,
        dropped,
    })
}

/// Parses a tracking file: CSV lines `time,x,y` (s on the session's clock,
/// as the recording's log times; m, horizontal), an optional header line,
/// `#` comments. The error names the line and what was expected.
pub fn parse_tracking(text: &str, origin: &str) -> Result<Vec<[f64; 3]>, String> {
    let mut out: Vec<[f64; 3]> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed: Option<Vec<f64>> = fields.iter().map(|f| f.parse::<f64>().ok()).collect();
        match parsed {
            None if out.is_empty() && i == 0 => continue, // a header
            Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => {
                if out.last().is_some_and(|p| v[0] <= p[0]) {
                    return Err(format!(
                        "{origin} line {}: time {} is not after the line before's",
                        i + 1,
                        v[0]
                    ));
                }
                out.push([v[0], v[1], v[2]]);
            }
            _ => {
                return Err(format!(
                    "{origin} line {}: \"{line}\" (expected time_s,x_m,y_m: three numbers)",
                    i + 1
                ));
            }
        }
    }
    if out.len() < 2 {
        return Err(format!(
            "{origin}: {} track points (expected at least 2 lines time_s,x_m,y_m)",
            out.len()
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracking_files_parse_and_bad_lines_are_named() {
        let t = parse_tracking("time_s,x_m,y_m\n# mocap\n0.0,0,0\n0.05, 0.01, 0.0\n", "f").unwrap();
        assert_eq!(t, vec![[0.0, 0.0, 0.0], [0.05, 0.01, 0.0]]);
        for (text, needle) in [
            ("0,0,0\n1,2\n", "f line 2: \"1,2\" (expected time_s,x_m,y_m"),
            ("0,0,0\n0,1,1\n", "f line 2: time 0 is not after"),
            ("0,0,0\n1,nan,0\n", "f line 2"),
            ("t,x,y\n", "f: 0 track points"),
            ("0,0,0\nx,1,1\n", "f line 2: \"x,1,1\""),
        ] {
            let e = parse_tracking(text, "f").unwrap_err();
            assert!(e.contains(needle), "{text:?}: {e}");
        }
    }

    /// A session of 10 joint samples of one joint at 100 Hz, with corrupt
    /// ones among them: `bad_json` not JSON, `short` a field missing,
    /// `repeated` at the time of the sample before, and `truth_bad`
    /// /sim/truth messages without a position.
    fn corrupt_session(path: &Path, bad_json: usize, short: usize, repeated: usize) {
        let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .create(file)
            .unwrap();
        let none = std::collections::BTreeMap::new();
        let joints = w.add_channel(0, TOPICS[1], "json", &none).unwrap();
        let truth_ch = w.add_channel(0, truth::TOPIC, "json", &none).unwrap();
        let mut seq = 0;
        let mut put = |w: &mut mcap::Writer<_>, ch: u16, t_ms: u64, data: &[u8]| {
            seq += 1;
            let header = mcap::records::MessageHeader {
                channel_id: ch,
                sequence: seq,
                log_time: t_ms * 1_000_000,
                publish_time: t_ms * 1_000_000,
            };
            w.write_to_known_channel(&header, data).unwrap();
        };
        let good = |x: f64| {
            serde_json::json!({
                "measured_pitch": [0.0], "measured_yaw": [x],
                "measured_pitch_velocity": [0.0], "measured_yaw_velocity": [0.1],
                "measured_pitch_torque": [0.0], "measured_yaw_torque": [0.01],
            })
            .to_string()
        };
        for i in 0..10u64 {
            put(&mut w, joints, 10 * i, good(0.01 * i as f64).as_bytes());
        }
        for i in 0..bad_json as u64 {
            put(&mut w, joints, 200 + i, b"{\"measured_pitch\": [0.0");
        }
        for i in 0..short as u64 {
            put(&mut w, joints, 300 + i, b"{\"measured_pitch\": [0.0]}");
        }
        for _ in 0..repeated {
            put(&mut w, joints, 90, good(0.5).as_bytes());
        }
        put(&mut w, truth_ch, 95, b"{\"heading_deg\": 3}");
        w.finish().unwrap();
    }

    /// Issue 45: samples that do not read are counted, by kind, not
    /// dropped in silence.
    #[test]
    fn unreadable_and_repeated_samples_are_counted() {
        let dir = std::env::temp_dir().join(format!("anguilla-swim-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("session.mcap");
        corrupt_session(&f, 3, 2, 4);
        let r = read(&dir, None).unwrap();
        assert_eq!(r.swim.samples.len(), 10);
        assert_eq!(
            r.dropped,
            Dropped {
                joints: 5,
                truth: 1,
                state: 0,
                repeated: 4,
                cut: None
            }
        );
        assert!(
            r.dropped.to_string().starts_with(
                "5 unreadable joint samples (/anguilla/joints), 1 unreadable /sim/truth"
            ),
            "{}",
            r.dropped
        );
        // A recording cut short: read to the cut, and the cut said.
        let bytes = std::fs::read(&f).unwrap();
        std::fs::write(&f, &bytes[..bytes.len() * 3 / 4]).unwrap();
        let r = read(&f, None).unwrap();
        assert!(r.dropped.cut.is_some(), "{:?}", r.dropped);
        assert!(r.dropped.to_string().contains("read up to a cut"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Issue 45: a named pipe is refused at once, not read for ever; a
    /// file over the limit is refused by its size.
    #[test]
    fn a_named_pipe_or_an_oversized_file_is_refused_before_reading() {
        let dir = std::env::temp_dir().join(format!("anguilla-swim-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("session.mcap");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        // Opened for reading as any file, it would wait for a writer for
        // ever: a watchdog of 60 s (a bound on a hang, not on speed).
        let (tx, rx) = std::sync::mpsc::channel();
        let d = dir.clone();
        std::thread::spawn(move || tx.send(read(&d, None).map(|_| ())));
        let e = rx
            .recv_timeout(std::time::Duration::from_secs(60))
            .expect("reading a named pipe still blocked after 60 s")
            .unwrap_err();
        assert!(
            e.contains(
                "session.mcap: a named pipe, not a regular file (expected a recorded session.mcap)"
            ),
            "{e}"
        );
        std::fs::remove_file(&fifo).unwrap();
        corrupt_session(&fifo, 0, 0, 0);
        let len = std::fs::metadata(&fifo).unwrap().len();
        let e = read_limited(&fifo, None, len - 1).unwrap_err();
        assert!(
            e.contains(&format!(
                "{len} bytes, more than the {} read at most",
                len - 1
            )),
            "{e}"
        );
        assert!(read_limited(&fifo, None, len).is_ok());
        let e = read(Path::new("/dev/null"), None).unwrap_err();
        assert!(e.contains("/dev/null: a device, not a regular file"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_that_is_not_a_recording_is_named() {
        let dir = std::env::temp_dir().join(format!("anguilla-swim-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("x.mcap");
        std::fs::write(&f, b"not mcap").unwrap();
        let e = read(&f, None).unwrap_err();
        assert!(e.contains("x.mcap: not an MCAP file"), "{e}");
        let e = read(&dir.join("missing.mcap"), None).unwrap_err();
        assert!(e.contains("missing.mcap: No such file"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
