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

/// Reads the session `path` (a `session.mcap`, or the session directory
/// holding one); `tracking`, if given, is the nose's track (it replaces
/// `/sim/truth`'s). The error names the file and what is wrong.
pub fn read(path: &Path, tracking: Option<Vec<[f64; 3]>>) -> Result<ReadSwim, String> {
    let file = if path.is_dir() {
        path.join("session.mcap")
    } else {
        path.to_path_buf()
    };
    let name = file.display().to_string();
    let bytes = std::fs::read(&file).map_err(|e| format!("{name}: {e}"))?;
    let stream =
        mcap::MessageStream::new(&bytes).map_err(|e| format!("{name}: not an MCAP file ({e})"))?;
    let mut samples = Vec::new();
    let (mut truth_track, mut truth_att, mut nav_att) = (Vec::new(), Vec::new(), Vec::new());
    let mut head_yaw: Vec<[f64; 2]> = Vec::new();
    let mut bad = 0usize;
    let mut missing_torques = 0usize;
    let mut read_any = false;
    for m in stream {
        // a recording cut short (a killed daemon) is read up to the cut
        let m = match m {
            Ok(m) => m,
            Err(e) if !read_any => return Err(format!("{name}: not an MCAP file ({e})")),
            Err(_) => break,
        };
        read_any = true;
        let topic = m.channel.topic.as_str();
        if topic != TOPICS[0] && topic != TOPICS[1] && topic != truth::TOPIC {
            continue;
        }
        let Ok(v) = serde_json::from_slice::<Value>(&m.data) else {
            bad += 1;
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
                _ => bad += 1,
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
                _ => bad += 1,
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
    samples.dedup_by(|b, a| b.t <= a.t);
    for s in [&mut truth_track, &mut truth_att, &mut nav_att] {
        s.dedup_by(|b, a| b[0] <= a[0]);
    }
    head_yaw.dedup_by(|b, a| b[0] <= a[0]);
    if samples.len() < 2 {
        return Err(format!(
            "{name}: {} readable joint samples on /anguilla/joints (need at least 2; {bad} messages did not read)",
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
