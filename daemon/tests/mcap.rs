//! The session's MCAP file (docs/data.md): a recorded session's file has the
//! five channels with their schemas, one message per recorded snapshot on
//! each data channel, monotonic daemon-clock timestamps and a summary; a
//! file whose writer died keeps every chunk flushed before; `export`
//! rebuilds the same channels from `state.bin`. (CI also reads a daemon's
//! file with the independent Python `mcap` reader: `scripts/check-mcap`.)

use anguilla_testkit::lockstep;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anguilla_daemon::mcap_log::{self, McapLog};
use anguilla_daemon::record;
use anguilla_ipc::Hold;
use anguilla_ipc::vocabulary::Command;
use anguilla_view::TOPICS;
use lockstep::{Rig, config};

/// Records a session of the swimming robot with a head sensor: swim, hold
/// a heading, e-stop. Every tenth snapshot goes to the recorder (as the
/// daemon's state thread does). Returns the directory and the snapshots
/// sent.
fn record(name: &str) -> (PathBuf, usize) {
    record_with(name, false)
}

/// [`record`], and with `truth` the simulated robot's ground truth every
/// 20th tick (as `anguilla run` hands it over); returns the snapshots sent.
fn record_with(name: &str, truth: bool) -> (PathBuf, usize) {
    let dir = std::env::temp_dir().join(format!("anguilla-mcap-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let cfg = config();
    let mut rig = Rig::new(&cfg, 11, [0.0; 3]);
    let (rec_tx, rec_rx) = crossbeam_channel::bounded(1 << 20);
    let (st_tx, st_rx) = crossbeam_channel::bounded(1 << 12);
    rig.ctl.set_tap(rec_tx);
    let (truth_tx, truth_rx) = crossbeam_channel::bounded(1 << 12);
    let (d, c) = (dir.clone(), cfg.clone());
    let recorder = std::thread::spawn(move || record::recorder(d, c, rec_rx, st_rx, truth_rx));
    let mut sent = 0;
    let mut k = 0u64;
    let mut tick = |rig: &Rig| {
        k += 1;
        if k.is_multiple_of(10) {
            st_tx.send(*rig.state()).unwrap();
            sent += 1;
        }
        if truth && k.is_multiple_of(20) {
            let t = rig.truth();
            let g = anguilla_daemon::truth::GroundTruth {
                sim_time: t.time.as_secs_f64(),
                position: t.position,
                orientation: t.orientation,
                velocity: t.velocity,
                speed: t.forward_speed,
                heading: t.heading,
                depth: t.depth,
            };
            truth_tx.send((rig.state().time_ns, g)).unwrap();
        }
    };
    rig.swim(1.0);
    rig.run(2.0, &mut tick);
    let h = rig.state().nav.heading_deg as f64;
    rig.ok(Command::Hold(Hold {
        heading: Some(h + 30.0),
        depth: None,
    }));
    rig.run(2.0, &mut tick);
    rig.ok(Command::EStop);
    rig.run(0.5, &mut tick);
    drop(st_tx);
    drop(rig); // closes the record channel
    recorder.join().unwrap().expect("the recorder writes");
    (dir, sent)
}

/// Messages per topic, and whether each topic's log times never go back.
fn read(path: &Path) -> (BTreeMap<String, usize>, bool, Option<mcap::Summary>) {
    let bytes = std::fs::read(path).unwrap();
    let mut counts = BTreeMap::new();
    let mut last: BTreeMap<String, u64> = BTreeMap::new();
    let mut monotonic = true;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let Ok(m) = m else { break };
        let topic = m.channel.topic.clone();
        let t = last.entry(topic.clone()).or_insert(0);
        monotonic &= m.log_time >= *t;
        *t = m.log_time;
        *counts.entry(topic).or_insert(0) += 1;
    }
    let summary = mcap::Summary::read(&bytes).ok().flatten();
    (counts, monotonic, summary)
}

#[test]
fn a_recorded_session_has_its_channels_one_message_per_snapshot_and_a_summary() {
    let (dir, sent) = record("session");
    assert!(sent > 30, "{sent} snapshots");
    let (counts, monotonic, summary) = read(&dir.join("session.mcap"));
    for topic in ["/anguilla/state", "/anguilla/joints", "/tf", "/body"] {
        assert_eq!(counts.get(topic), Some(&sent), "{topic}: {counts:?}");
    }
    // Log lines: at least the modes (ready, swimming, e-stop).
    assert!(counts.get("/log").is_some_and(|&n| n >= 3), "{counts:?}");
    assert!(monotonic, "log times go back");
    let summary = summary.expect("a finished file has a summary");
    let mut schemas: Vec<_> = summary
        .channels
        .values()
        .map(|c| {
            let s = c.schema.as_ref().expect("a schema");
            (
                c.topic.clone(),
                s.name.clone(),
                s.encoding.clone(),
                c.message_encoding.clone(),
            )
        })
        .collect();
    schemas.sort();
    let topics: Vec<_> = schemas.iter().map(|s| s.0.as_str()).collect();
    let mut want = TOPICS.to_vec();
    want.sort();
    assert_eq!(topics, want);
    assert!(
        schemas.iter().all(|s| s.2 == "jsonschema" && s.3 == "json"),
        "{schemas:?}"
    );
    assert!(
        schemas
            .iter()
            .any(|s| s.0 == "/body" && s.1 == "foxglove.SceneUpdate"),
        "{schemas:?}"
    );
    // export rebuilds the same channels and counts from state.bin.
    let again = dir.join("again.mcap");
    let done = mcap_log::export(&dir, &again).expect("export");
    assert_eq!(done.snapshots, sent as u64);
    assert_eq!(done.partial_bytes, 0);
    let (counts2, _, summary2) = read(&again);
    assert_eq!(counts2, counts);
    assert!(summary2.is_some());
    layout_names_only_fields_the_file_has(&dir.join("session.mcap"));
    every_message_matches_its_channels_schema(&dir.join("session.mcap"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The simulated robot's ground truth goes to `/sim/truth` (schema
/// `anguilla.SimTruth`), one message per sample, with the body's heading
/// in the operator's convention: after a swim and a held turn it agrees
/// with the daemon's estimate within a few degrees.
#[test]
fn ground_truth_goes_to_its_own_channel() {
    let (dir, sent) = record_with("truth", true);
    let bytes = std::fs::read(dir.join("session.mcap")).unwrap();
    let (mut truths, mut last_state) = (Vec::new(), None);
    // /tf's truth frames (stamp, x, y, z), and /body's guide discs.
    let (mut truth_frames, mut discs) = (Vec::new(), 0);
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        match m.channel.topic.as_str() {
            "/tf" => {
                for t in v["transforms"].as_array().unwrap() {
                    if t["child_frame_id"] == "truth" {
                        let ns = t["timestamp"]["sec"].as_u64().unwrap() * 1_000_000_000
                            + t["timestamp"]["nsec"].as_u64().unwrap();
                        let p = ["x", "y", "z"].map(|k| t["translation"][k].as_f64().unwrap());
                        truth_frames.push((ns, p));
                    }
                }
            }
            "/body" => {
                let guide = v["entities"].as_array().unwrap().get(1);
                discs += guide.map_or(0, |g| g["cylinders"].as_array().unwrap().len());
            }
            "/sim/truth" => {
                let schema = m.channel.schema.as_ref().unwrap();
                assert_eq!(schema.name, "anguilla.SimTruth");
                let schema: serde_json::Value = serde_json::from_slice(&schema.data).unwrap();
                if let Err(e) = anguilla_view::schema::check(&schema, &v) {
                    panic!("/sim/truth message {}: {e}", truths.len());
                }
                truths.push((m.log_time, v));
            }
            "/anguilla/state" => last_state = Some(v),
            _ => {}
        }
    }
    // 4.5 s at the lockstep rate, a sample every 20 ticks.
    assert!(truths.len() > 20, "{} truth messages", truths.len());
    assert!(sent > truths.len());
    // Each truth goes out once, on the next snapshot's /tf, at its own
    // time and position; two between snapshots (a late recorder) leave
    // the older out.
    assert!(
        truth_frames.len() > truths.len() / 2 && truth_frames.len() <= truths.len(),
        "{} truth frames, {} truths",
        truth_frames.len(),
        truths.len()
    );
    for (ns, p) in &truth_frames {
        let (_, t) = truths
            .iter()
            .find(|(t, _)| t == ns)
            .expect("its /sim/truth");
        let q = ["x", "y", "z"].map(|k| t["position"][k].as_f64().unwrap());
        assert_eq!(*p, q, "at {ns} ns");
    }
    // The head sensor's estimate: the position's uncertainty is drawn.
    assert!(discs > 0, "no uncertainty disc in /body");
    let truth = truths.last().unwrap().1["heading_deg"].as_f64().unwrap();
    let state = last_state.unwrap();
    let estimate = state["nav"]["heading_deg"]
        .as_f64()
        .expect("the estimate's heading in the state");
    // The estimate follows the simulated fusion IMU (0.005 rad of attitude
    // noise, about 0.3°) through the same body axis; 5° still catches the
    // conventions this channel is for: the head's yaw instead of the
    // body's (it swings by 10° and more), or the tail-first axis (180°).
    let diff = ((truth - estimate + 540.0).rem_euclid(360.0) - 180.0).abs();
    assert!(
        diff < 5.0,
        "truth {truth:.1} deg, estimate {estimate:.1} deg"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every message of the controller's own snapshots conforms to the schema
/// its channel's schema record carries (`anguilla_view::schema::check`).
fn every_message_matches_its_channels_schema(path: &Path) {
    let bytes = std::fs::read(path).unwrap();
    let mut checked = BTreeMap::<String, usize>::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.expect("a finished file reads to its end");
        let schema = m.channel.schema.as_ref().expect("a schema");
        let schema: serde_json::Value = serde_json::from_slice(&schema.data).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        let n = checked.entry(m.channel.topic.clone()).or_insert(0);
        if let Err(e) = anguilla_view::schema::check(&schema, &v) {
            panic!("{} message {n}: {e}", m.channel.topic);
        }
        *n += 1;
    }
    assert_eq!(checked.len(), TOPICS.len(), "{checked:?}");
}

/// deploy/foxglove-layout.json plots message paths (`/topic.field[i]`):
/// every one names a topic and a field the recording has.
fn layout_names_only_fields_the_file_has(path: &Path) {
    let bytes = std::fs::read(path).unwrap();
    let mut last: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        last.insert(
            m.channel.topic.clone(),
            serde_json::from_slice(&m.data).unwrap(),
        );
    }
    let layout_path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../deploy/foxglove-layout.json"
    );
    let layout: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(layout_path).unwrap()).unwrap();
    let mut paths = Vec::new();
    for panel in layout["configById"].as_object().unwrap().values() {
        for p in panel["paths"].as_array().into_iter().flatten() {
            paths.push(p["value"].as_str().unwrap().to_owned());
        }
    }
    assert!(paths.len() >= 8, "{paths:?}");
    for p in &paths {
        let (topic, fields) = p.split_once('.').expect("topic.field");
        let mut v = last
            .get(topic)
            .unwrap_or_else(|| panic!("{p}: no topic {topic}"));
        for field in fields.split('.') {
            let (name, index) = match field.split_once('[') {
                Some((n, _)) => (n, true),
                None => (field, false),
            };
            v = v
                .get(name)
                .unwrap_or_else(|| panic!("{p}: no field {name}"));
            if index {
                let a = v
                    .as_array()
                    .unwrap_or_else(|| panic!("{p}: {name} is no array"));
                v = &a[0];
            }
        }
    }
}

#[test]
fn a_writer_that_dies_leaves_every_flushed_chunk_readable() {
    let dir = std::env::temp_dir().join(format!("anguilla-mcap-dies-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("killed.mcap");
    let cfg = config();
    let mut log = McapLog::create(&path, &cfg).unwrap();
    let mut s = anguilla_ipc::StateSnapshot::default();
    for i in 0..50u64 {
        s.time_ns = i * 100_000_000;
        s.sequence = i;
        log.write(&s).unwrap();
        if i == 29 {
            log.flush().unwrap();
        }
    }
    // Killed: no finish, nothing after the flush reaches the disk.
    std::mem::forget(log);
    let (counts, monotonic, summary) = read(&path);
    assert!(summary.is_none(), "no summary without a finish");
    assert_eq!(counts.get("/anguilla/state"), Some(&30), "{counts:?}");
    assert!(monotonic);
    // Repaired: the same messages, with the summary and index indexed
    // readers need; a whole file is copied as it is.
    let fixed = dir.join("repaired.mcap");
    let r = mcap_log::repair(&path, &fixed).unwrap();
    assert!(r.cut.is_some(), "the cut is reported");
    let (fixed_counts, fixed_monotonic, fixed_summary) = read(&fixed);
    assert_eq!(fixed_counts, counts);
    assert!(fixed_monotonic);
    let fixed_summary = fixed_summary.expect("a repaired file has a summary");
    assert_eq!(fixed_summary.channels.len(), r.channels);
    assert_eq!(r.messages, counts.values().sum::<usize>() as u64);
    let again = mcap_log::repair(&fixed, &dir.join("again.mcap")).unwrap();
    assert_eq!((again.messages, again.cut), (r.messages, None));
    let e = mcap_log::repair(&dir.join("nothing.mcap"), &dir.join("x.mcap")).unwrap_err();
    assert!(e.to_string().contains("nothing.mcap"), "{e}");
    // A session directory whose state.bin was cut mid-snapshot exports
    // the whole ones, and says how much it left out.
    let size = core::mem::size_of::<anguilla_ipc::StateSnapshot>();
    let snapshot = anguilla_ipc::StateSnapshot::default();
    // SAFETY: a #[repr(C)] snapshot of integers and floats, read as bytes.
    let bytes = unsafe { core::slice::from_raw_parts(&snapshot as *const _ as *const u8, size) };
    let mut data = bytes.repeat(3);
    data.truncate(2 * size + 100);
    std::fs::write(dir.join("state.bin"), &data).unwrap();
    std::fs::write(dir.join("config.toml"), cfg.to_toml()).unwrap();
    let done = mcap_log::export(&dir, &dir.join("cut.mcap")).unwrap();
    assert_eq!((done.snapshots, done.partial_bytes), (2, 100));
    // A snapshot of another layout version is named.
    let mut old = snapshot;
    old.layout_version = 4;
    // SAFETY: as above.
    let old_bytes = unsafe { core::slice::from_raw_parts(&old as *const _ as *const u8, size) };
    std::fs::write(dir.join("state.bin"), old_bytes).unwrap();
    let e = mcap_log::export(&dir, &dir.join("old.mcap")).unwrap_err();
    assert!(e.to_string().contains("layout version 4"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// docs/body.svg, the README's picture of the `/body` scene: the robot of
/// the lockstep rig after 3 s of a turning swim, drawn from the same links
/// the MCAP scene carries (rewritten with ANGUILLA_BLESS=1).
#[test]
fn the_readme_picture_is_the_scene() {
    let cfg = config();
    let mut rig = Rig::new(&cfg, 12, [0.0; 3]);
    rig.swim(1.0);
    rig.ok(Command::Swim(anguilla_ipc::vocabulary::SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.8,
        pitch: 0.3,
    }));
    rig.run(3.0, |_| {});
    let dir = std::env::temp_dir().join(format!("anguilla-mcap-svg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = anguilla_view::Scene::new(cfg.robot.joints);
    let s = rig.state();
    let links = log.links(s);
    assert_eq!(links.len(), cfg.robot.joints + 1);
    // Chained: each link starts where the one before ends (0.5 mm).
    for w in links.windows(2) {
        let end =
            w[0].centre + w[0].orientation * nalgebra::Vector3::new(w[0].length / 2.0, 0.0, 0.0);
        let start =
            w[1].centre - w[1].orientation * nalgebra::Vector3::new(w[1].length / 2.0, 0.0, 0.0);
        assert!((end - start).norm() < 5e-4, "{end} vs {start}");
    }
    // The head link starts at the nose and runs backwards.
    assert!(links[0].centre.x < 0.0 && links[0].centre.x > -0.1);
    let svg = log.body_svg(s);
    assert_eq!(svg.matches("<ellipse").count(), 2 * links.len());
    fits(&svg);
    // A body bent far more than any gait bends it still fits: every joint
    // at 0.6 rad of yaw (the body curls past a half circle) and 0.4 rad of
    // pitch.
    let mut curled = *s;
    for j in curled.joints.iter_mut() {
        (j.measured_yaw, j.measured_pitch) = (0.6, 0.4);
    }
    fits(&log.body_svg(&curled));
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/body.svg");
    if std::env::var_os("ANGUILLA_BLESS").is_some() {
        std::fs::write(path, &svg).unwrap();
    }
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == svg,
        "docs/body.svg is out of date: rerun with ANGUILLA_BLESS=1"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The numbers of `attr="..."` in an SVG element's text, in order.
fn numbers(element: &str, attr: &str) -> Vec<f64> {
    let value = element
        .split(&format!(" {attr}=\""))
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .unwrap_or_else(|| panic!("no {attr} in {element}"));
    value
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter(|t| !t.is_empty())
        .map(|t| t.parse().unwrap())
        .collect()
}

/// Every ellipse of `svg` lies inside its viewBox and clear of every label
/// (a label's box: its baseline less the font size to 4 px below it, 8 px
/// a character wide, wider than sans-serif 13 px draws them).
fn fits(svg: &str) {
    let view = numbers(svg.lines().next().unwrap(), "viewBox");
    let (w, h) = (view[2], view[3]);
    let labels: Vec<[f64; 4]> = svg
        .lines()
        .filter(|l| l.starts_with("<text"))
        .map(|l| {
            let (x, y, size) = (
                numbers(l, "x")[0],
                numbers(l, "y")[0],
                numbers(l, "font-size")[0],
            );
            let text = l.split('>').nth(1).unwrap().trim_end_matches("</text");
            [x, y - size, x + 8.0 * text.chars().count() as f64, y + 4.0]
        })
        .collect();
    assert_eq!(labels.len(), 2, "{svg}");
    for l in svg.lines().filter(|l| l.starts_with("<ellipse")) {
        let (cx, cy) = (numbers(l, "cx")[0], numbers(l, "cy")[0]);
        let (rx, ry) = (numbers(l, "rx")[0], numbers(l, "ry")[0]);
        let angle = numbers(l, "transform")[0].to_radians();
        // The rotated ellipse's bounding box (0.1 px: the file's rounding).
        let hx = (rx * angle.cos()).hypot(ry * angle.sin()) - 0.1;
        let hy = (rx * angle.sin()).hypot(ry * angle.cos()) - 0.1;
        let b = [cx - hx, cy - hy, cx + hx, cy + hy];
        assert!(
            b[0] >= 0.0 && b[1] >= 0.0 && b[2] <= w && b[3] <= h,
            "{l} leaves the {w}×{h} picture"
        );
        for t in &labels {
            let apart = b[2] < t[0] || t[2] < b[0] || b[3] < t[1] || t[3] < b[1];
            assert!(apart, "{l} covers the label at {t:?}");
        }
    }
}

/// The recording's `bus.state` codes (named in `anguilla_view`, below the
/// drivers) are the drivers' [`BusState`] codes, every one of them.
#[test]
fn the_views_bus_states_are_the_drivers() {
    use anguilla_drivers::BusState;
    let drivers: Vec<(u64, String)> = BusState::ALL
        .into_iter()
        .map(|s| {
            let c = s.code();
            (u64::from(c), anguilla_ipc::bus_state_name(c).to_string())
        })
        .collect();
    assert_eq!(anguilla_view::schema::bus_state_codes(), drivers);
}
