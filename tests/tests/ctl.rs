//! `anguilla ctl` against `anguilla run` (the built-in simulated robot):
//! each call one session that waits for the outcome and releases control;
//! exit status 0 done, 1 refused, 2 no daemon.

use std::process::{Command as Proc, Output, Stdio};
use std::time::{Duration, Instant};

use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::{
    Killed, anguilla_bin, daemon_with, output_text as text, poll_until,
};

fn ctl(prefix: &str, args: &[&str]) -> Output {
    Proc::new(anguilla_bin())
        .args(["ctl", "--prefix", prefix])
        .args(args)
        .output()
        .unwrap()
}

fn daemon(prefix: &str, tag: &str) -> Killed {
    daemon_with(prefix, tag, "")
}

#[test]
fn ctl_drives_a_session_and_says_how_it_ended() {
    let _dog = Watchdog::new("ctl", Duration::from_secs(180));
    let prefix = format!("anguilla-ctl/session-{}", std::process::id());
    let _d = daemon(&prefix, "ctl");
    // A refusal: exit 1 with the daemon's reason.
    let o = ctl(&prefix, &["reset"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("nothing to reset"), "{}", text(&o));
    // The calibration swim climbs up to 3 m: at the built-in robot's 1 m it is
    // refused (once the head sensor reads a depth; before, for that), and
    // the robot never swims.
    poll_until(
        "calibrate-swim refused for its depth",
        Duration::from_secs(30),
        || {
            let o = ctl(&prefix, &["calibrate-swim"]);
            assert_eq!(o.status.code(), Some(1), "{}", text(&o));
            let t = text(&o);
            assert!(
                t.contains("(head sensor: waiting)") || t.contains(" m deep and the swim climbs"),
                "{t}"
            );
            t.contains(
                "m deep and the swim climbs about 3 m above its start (docs/calibration.md): \
             start it at least 3.5 m deep",
            )
            .then_some(())
        },
    );
    let o = ctl(&prefix, &["status", "--json"]);
    assert!(text(&o).contains("\"mode_name\":\"idle\""), "{}", text(&o));
    // Enable waits for ready; swim for a second stops and waits for ready.
    let o = ctl(&prefix, &["enable"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("done: ready"), "{}", text(&o));
    let o = ctl(
        &prefix,
        &[
            "swim",
            "--amplitude",
            "0.5",
            "--frequency",
            "1",
            "--for",
            "1",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("done: ready"), "{}", text(&o));
    // Control was released after each call.
    let o = ctl(&prefix, &["status", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("\"holder\":null"), "{}", text(&o));
    // A swim without --for ends at Ctrl-C: stopped, ready, exit 0.
    let mut swim = Proc::new(anguilla_bin())
        .args([
            "ctl",
            "--prefix",
            &prefix,
            "swim",
            "--amplitude",
            "0.5",
            "--frequency",
            "1",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    poll_until("the swim started", Duration::from_secs(20), || {
        text(&ctl(&prefix, &["status", "--json"]))
            .contains("\"mode_name\":\"swimming\"")
            .then_some(())
    });
    unsafe { libc::kill(swim.id() as i32, libc::SIGINT) };
    poll_until("ctl swim ending at Ctrl-C", Duration::from_secs(30), || {
        swim.try_wait().unwrap()
    });
    let o = swim.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("done: ready"), "{}", text(&o));
    // E-stop, then a command refused in e-stop, then reset.
    let o = ctl(&prefix, &["estop"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("the daemon reports e-stop"),
        "{}",
        text(&o)
    );
    let o = ctl(&prefix, &["enable"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("reset first"), "{}", text(&o));
    let o = ctl(&prefix, &["reset"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("done: idle"), "{}", text(&o));
}

/// `ctl status` in an operator's words: the holder as its tool, user and
/// pid (not a hex client id); the mode's cause ("since the start", an
/// operator's E-stop "by an operator's command", not "fault"); and no
/// iceoryx2 enum names when there is no daemon.
#[test]
fn ctl_status_names_the_holder_and_the_cause_in_words() {
    let _dog = Watchdog::new("ctl-words", Duration::from_secs(120));
    let prefix = format!("anguilla-ctl/words-{}", std::process::id());
    let o = ctl(&prefix, &["status"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains(&format!("its service '{prefix}/state' does not exist")),
        "{}",
        text(&o)
    );
    assert!(!text(&o).contains("DoesNotExist"), "{}", text(&o));
    let _d = daemon(&prefix, "words");
    let o = ctl(&prefix, &["status"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("(since the start)"), "{}", text(&o));
    // This test's process holds control as a "teleop" tool would.
    let mut holder = anguilla_system_tests::process::connect(
        &prefix,
        &format!("anguilla-teleop-{}", std::process::id()),
    );
    anguilla_system_tests::process::ok(&mut holder, anguilla_ipc::Command::TakeControl);
    let o = ctl(&prefix, &["status"]);
    let me = std::process::id();
    assert!(
        text(&o).contains(&format!("teleop (user root, pid {me})"))
            || text(&o).contains(&format!("pid {me})")),
        "{}",
        text(&o)
    );
    assert!(!text(&o).contains("client 0"), "{}", text(&o));
    anguilla_system_tests::process::ok(&mut holder, anguilla_ipc::Command::EStop);
    let o = ctl(&prefix, &["status"]);
    assert!(
        text(&o).contains("e-stop (by an operator's command)"),
        "{}",
        text(&o)
    );
}

/// `anguilla monitor --json` streams each state once, at most `--rate`
/// lines a second, and ends after `--count`; without a daemon it is an
/// error naming the prefix.
#[test]
fn monitor_json_streams_paced_states() {
    let _dog = Watchdog::new("monitor", Duration::from_secs(120));
    let prefix = format!("anguilla-ctl/monitor-{}", std::process::id());
    let o = Proc::new(anguilla_bin())
        .args(["monitor", "--json", "--prefix", &prefix])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains(&format!("no anguilla daemon serves '{prefix}'")),
        "{}",
        text(&o)
    );
    assert!(o.stdout.is_empty());

    let _d = daemon(&prefix, "mon");
    let start = std::time::Instant::now();
    let o = Proc::new(anguilla_bin())
        .args([
            "monitor", "--json", "--prefix", &prefix, "--rate", "5", "--count", "4",
        ])
        .output()
        .unwrap();
    let took = start.elapsed();
    assert!(o.status.success(), "{}", text(&o));
    let seqs: Vec<u64> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).expect("a JSON line");
            v["sequence"].as_u64().expect("a sequence number")
        })
        .collect();
    assert_eq!(seqs.len(), 4);
    assert!(seqs.windows(2).all(|w| w[1] > w[0]), "{seqs:?}");
    // At 5 lines a second, four lines take at least three gaps of 200 ms
    // (a lower bound: the pace never runs faster, however loaded).
    assert!(took >= Duration::from_millis(600), "{took:?}");
}

/// The whole chain of heading and depth hold across processes: `ctl swim --heading
/// --depth` against `anguilla run` whose built-in robot carries a head
/// sensor (`[sensor] node`), watched by `ctl status --json` from another
/// process: the autopilot holds both, and the estimate reaches the held
/// heading and depth.
#[test]
fn ctl_swims_holding_a_heading_and_a_depth() {
    let _dog = Watchdog::new("ctl-hold", Duration::from_secs(180));
    let prefix = format!("anguilla-ctl/hold-{}", std::process::id());
    let _d = daemon_with(&prefix, "hold", "\n[sensor]\nnode = 20\n");
    let status = |prefix: &str| -> Option<serde_json::Value> {
        let o = ctl(prefix, &["status", "--json"]);
        (o.status.code() == Some(0))
            .then(|| serde_json::from_slice(&o.stdout).ok())
            .flatten()
    };
    // The sensor's samples arrive and it is healthy before anything else.
    let s = poll_until("the sensor ok", Duration::from_secs(20), || {
        status(&prefix).filter(|s| s["sensor"] == "ok")
    });
    let start = s["heading_deg"].as_f64().expect("a heading");
    let depth0 = s["depth_m"].as_f64().expect("a depth");
    let (heading, depth) = ((start + 45.0).rem_euclid(360.0), depth0 + 0.3);
    assert_eq!(ctl(&prefix, &["enable"]).status.code(), Some(0));
    let swim = Proc::new(anguilla_bin())
        .args(["ctl", "--prefix", &prefix, "swim", "--amplitude", "1"])
        .args(["--frequency", "1", "--heading", &format!("{heading}")])
        .args(["--depth", &format!("{depth}"), "--for", "120"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // About 15 s on a quiet machine; a starved one runs the simulated
    // robot slower than the clock, so the swim lasts until the hold is
    // reached (at most 100 s), then Ctrl-C ends it as an operator would.
    // The state every 5 s, shown if the hold is never reached.
    let mut shown = Instant::now();
    let reached = poll_until("heading and depth held", Duration::from_secs(100), || {
        let s = status(&prefix)?;
        if shown.elapsed() >= Duration::from_secs(5) {
            shown = Instant::now();
            eprintln!("{s}");
        }
        assert_ne!(
            s["cause_name"], "head sensor lost",
            "the autopilot let go: {s}"
        );
        let h = s["heading_deg"].as_f64()?;
        let d = s["depth_m"].as_f64()?;
        let dh = ((h - heading + 540.0).rem_euclid(360.0) - 180.0).abs();
        (s["autopilot"] == "heading+depth" && dh < 8.0 && (d - depth).abs() < 0.1).then_some(s)
    });
    assert_eq!(
        reached["heading_target_deg"]
            .as_f64()
            .map(|t| (t - heading).abs() < 0.01),
        Some(true)
    );
    // SAFETY: kill sends SIGINT to the child we spawned.
    unsafe { libc::kill(swim.id() as i32, libc::SIGINT) };
    let out = swim.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}

/// Issue 46, finding 8: the README's calibration recipe, run as written
/// (`cargo run --release --` is this build's `anguilla`; the recording
/// directory a fresh one; the daemon's prefix the default, as the recipe
/// has it). Before `ctl wait`, `ctl enable` raced the daemon's start (lost
/// 3 times in 4), the swim was refused and `calibrate` fitted an idle
/// session with exit 0; now every command of it succeeds, and `calibrate`
/// fits a swim.
#[test]
#[ignore = "needs the release binary the recipe names on a quiet machine (a debug daemon at CAN FD's 512 Hz, recording, misses hundreds of periods a second beside other builds and faults on a tracking error): CI runs it after the load with ANGUILLA_BIN=target/release/anguilla (.ci/run)"]
fn the_readmes_calibration_recipe_works_as_written() {
    let _dog = Watchdog::new("readme-calibration", Duration::from_secs(900));
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap();
    let at = readme
        .find("the_readmes_calibration_recipe_works_as_written")
        .expect("the recipe's heading");
    let block = &readme[at..];
    let start = block.find("```sh\n").unwrap() + 6;
    let end = start + block[start..].find("```").unwrap();
    let dir = std::env::temp_dir().join(format!("anguilla-readme-cal-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let rec = dir.join("rec");
    let script = block[start..end]
        .replace(
            "cargo run --release --",
            &format!("{}", anguilla_bin().display()),
        )
        .replace("/tmp/anguilla-cal", rec.to_str().unwrap());
    eprintln!("{script}");
    // every line but the last (the fit) must succeed as written
    let (record, fit) = script.trim_end().rsplit_once('\n').unwrap();
    assert!(fit.contains(" calibrate "), "{fit}");
    let o = Proc::new("bash")
        .args(["-e", "-c", record])
        .current_dir(&dir)
        .output()
        .unwrap();
    let shown = text(&o);
    eprintln!("{shown}");
    assert_eq!(o.status.code(), Some(0), "{shown}");
    assert!(shown.contains("the daemon is up"), "{shown}");
    assert!(shown.contains("done: ready"), "{shown}");
    // The fit sees a swim (50 s of the calibration swim's 59 move the
    // joints) and fits it: the body started 4 m deep, so it never
    // surfaces (from 1 m it did, and the fit refused the torques that came
    // with it), and the lateral and vertical drag are identified and
    // written. (Run with the release binary on a quiet machine, as CI's
    // recipe stage does: a debug daemon beside other builds misses periods
    // enough to damage the recording, which the fit then refuses by name
    // and time.)
    let o = Proc::new("bash")
        .args(["-e", "-c", fit])
        .current_dir(&dir)
        .output()
        .unwrap();
    let shown = text(&o);
    eprintln!("{shown}");
    let swum: f64 = shown
        .split("checked: ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no 'checked:' line: {shown}"));
    assert!(swum >= 50.0, "{swum} s of swimming: {shown}");
    assert_eq!(o.status.code(), Some(0), "{shown}");
    let fragment = shown
        .split("[model] fragment")
        .nth(1)
        .unwrap_or_else(|| panic!("no fragment: {shown}"));
    for written in ["\nc2 = ", "\nc3 = "] {
        assert!(
            fragment.contains(written),
            "{written:?} not written: {shown}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A path followed across processes (issue 48): `ctl goto` against
/// `anguilla run`'s built-in robot with a head sensor and a geofence is
/// done when the daemon reports the waypoint reached, which `ctl status
/// --json` then shows; a path file with a waypoint outside the fence is
/// refused naming its line, and a malformed one naming its line before
/// anything is sent.
#[test]
fn ctl_goto_and_follow_swim_to_where_they_are_told() {
    let _dog = Watchdog::new("ctl-goto", Duration::from_secs(240));
    let prefix = format!("anguilla-ctl/goto-{}", std::process::id());
    let _d = daemon_with(
        &prefix,
        "goto",
        "\n[sensor]\nnode = 20\n[guidance]\nfence-radius = 20\n",
    );
    let status = |prefix: &str| -> Option<serde_json::Value> {
        let o = ctl(prefix, &["status", "--json"]);
        (o.status.code() == Some(0))
            .then(|| serde_json::from_slice(&o.stdout).ok())
            .flatten()
    };
    poll_until("the sensor ok", Duration::from_secs(20), || {
        status(&prefix).filter(|s| s["sensor"] == "ok")
    });
    let dir = std::env::temp_dir().join(format!("anguilla-goto-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A malformed file: refused with its line, nothing sent.
    let bad = dir.join("bad.json");
    std::fs::write(
        &bad,
        "{\"waypoints\": [\n  {\"x\": 1, \"y\": \"two\"}\n]}\n",
    )
    .unwrap();
    let o = ctl(&prefix, &["follow", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("line 2") && err.contains("expected f64"),
        "{err}"
    );
    // Not enabled: the daemon refuses the path's start, said as such.
    let o = ctl(&prefix, &["goto", "3", "1"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("enable"), "{}", text(&o));
    assert_eq!(ctl(&prefix, &["enable"]).status.code(), Some(0));
    // A waypoint outside the fence: refused by the daemon, named by line.
    let far = dir.join("far.json");
    std::fs::write(
        &far,
        "{\"waypoints\": [\n  {\"x\": 0, \"y\": 0},\n  {\"x\": 30, \"y\": 0}\n]}\n",
    )
    .unwrap();
    let o = ctl(&prefix, &["follow", far.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("line 3") && err.contains("outside the geofence"),
        "{err}"
    );
    // The goto: done when reached, the state says so.
    let s = status(&prefix).expect("a state");
    let (x0, y0) = (s["x_m"].as_f64().unwrap(), s["y_m"].as_f64().unwrap());
    let (x, y) = (x0 + 3.0, y0 + 1.5);
    let o = Proc::new(anguilla_bin())
        .args(["ctl", "--prefix", &prefix, "goto"])
        .args([format!("{x}"), format!("{y}")])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("leg to waypoint 0 of 1"), "{out}");
    let s = status(&prefix).expect("a state");
    assert_eq!(s["guide"]["state"], "done", "{s}");
    let (xe, ye) = (s["x_m"].as_f64().unwrap(), s["y_m"].as_f64().unwrap());
    // Reached within the acceptance radius (0.5 m), then glided while the
    // swim stopped.
    assert!(
        (xe - x).hypot(ye - y) < 1.5,
        "at ({xe}, {ye}) for ({x}, {y})"
    );
    assert_eq!(s["mode_name"], "ready", "{s}");
    assert_eq!(s["cause_name"], "path done", "{s}");
    // A path in the robot's frame (--here): 3 m ahead of where it is,
    // whichever way it faces; a bad frame is refused with its line.
    let ahead = dir.join("ahead.json");
    std::fs::write(
        &ahead,
        "{\"waypoints\": [{\"x\": 0, \"y\": 0}, {\"x\": 3, \"y\": 0}],\n \"frame\": \"there\"}\n",
    )
    .unwrap();
    let o = ctl(&prefix, &["follow", ahead.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("line 2") && err.contains("frame") && err.contains("\"here\""),
        "{err}"
    );
    std::fs::write(
        &ahead,
        "{\"waypoints\": [{\"x\": 0, \"y\": 0}, {\"x\": 3, \"y\": 0}]}\n",
    )
    .unwrap();
    // A speed beyond the body: refused before anything is sent.
    let far_speed = ["follow", "--here", "--speed", "5", ahead.to_str().unwrap()];
    let o = ctl(&prefix, &far_speed);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("beyond this body"), "{}", text(&o));
    // Where the robot is (it may still glide after the goto).
    let s = status(&prefix).expect("a state");
    let (x0, y0) = (s["x_m"].as_f64().unwrap(), s["y_m"].as_f64().unwrap());
    let h = s["heading_deg"].as_f64().unwrap().to_radians();
    // At 0.4 m/s: the amplitude the model's steady speed gives.
    let slow = [
        "follow",
        "--here",
        "--speed",
        "0.4",
        ahead.to_str().unwrap(),
    ];
    let o = ctl(&prefix, &slow);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("--speed 0.4 m/s: amplitude 0."),
        "{}",
        text(&o)
    );
    let s = status(&prefix).expect("a state");
    assert_eq!(s["guide"]["state"], "done", "{s}");
    let g = |k: &str| s["guide"][k].as_f64().unwrap();
    let (fx, fy, tx, ty) = (g("from_x"), g("from_y"), g("to_x"), g("to_y"));
    // The leg ran 3 m along the heading from where the robot was when
    // ctl read it (a little further along its glide than here).
    let along = (fx - x0) * h.cos() + (fy - y0) * h.sin();
    let across = -(fx - x0) * h.sin() + (fy - y0) * h.cos();
    assert!(
        (-0.05..2.5).contains(&along) && across.abs() < 0.2,
        "the leg starts at ({fx}, {fy}), the robot was at ({x0}, {y0}) heading {h}"
    );
    assert!(((tx - fx).hypot(ty - fy) - 3.0).abs() < 0.01, "{s}");
    let turn = ((ty - fy).atan2(tx - fx) - h + 3.0 * std::f64::consts::PI)
        .rem_euclid(std::f64::consts::TAU)
        - std::f64::consts::PI;
    assert!(
        turn.abs() < 0.1,
        "the leg {turn} (rad) off the heading: {s}"
    );
    let (xe, ye) = (s["x_m"].as_f64().unwrap(), s["y_m"].as_f64().unwrap());
    assert!(
        (xe - tx).hypot(ye - ty) < 1.5,
        "at ({xe}, {ye}) for ({tx}, {ty}): {}",
        text(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
