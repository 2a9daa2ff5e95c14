//! A recorded session replays bit for bit; a corrupted recording is caught.

mod rig;

use anguilla_daemon::config::Config;
use anguilla_daemon::record;
use anguilla_daemon::replay::{self, ReplayError};
use anguilla_daemon::session::SessionError;
use anguilla_ipc::vocabulary::{Command, SwimParams};
use anguilla_protocol::Family;
use anguilla_protocol::frame::Frame;
use rig::{Hooked, Rig};

fn record_session(name: &str) -> std::path::PathBuf {
    record_session_with(name, false, Config::default())
}

/// Records a session: enable, swim and turn, E-stop. With `refusals`, the
/// bus refuses part of the sends of three periods of the swim.
fn record_session_with(name: &str, refusals: bool, cfg: Config) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("anguilla-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut r = Rig::new(name, &cfg);
    let (rec_tx, rec_rx) = crossbeam_channel::bounded(1 << 20);
    let (st_tx, st_rx) = crossbeam_channel::bounded(16);
    r.ctl.set_tap(rec_tx);
    let (d, c) = (dir.clone(), cfg.clone());
    let recorder = std::thread::spawn(move || {
        record::recorder(d, c, rec_rx, st_rx, crossbeam_channel::never())
    });
    // Boot (a CiA 402 drive's configuration by SDO included).
    r.run_for(0.6);
    r.command(1, Command::TakeControl);
    r.command(1, Command::Enable);
    r.run_for(0.3);
    r.command(
        1,
        Command::Swim(SwimParams {
            amplitude: 0.8,
            frequency: 1.2,
            turn: 0.5,
            pitch: 0.0,
        }),
    );
    for i in 0..10 {
        r.run_for(0.2);
        r.command(1, Command::KeepAlive);
        if refusals && i == 5 {
            // The interface "goes down" after `left` sends: later sends
            // in the period are refused (as SocketCAN's ENETDOWN), though
            // the period started on a healthy bus.
            for mut left in [0, 3, 7] {
                let now = r.now;
                let mut bus = Hooked {
                    inner: &mut r.host,
                    hook: |_: &Frame| {
                        if left == 0 {
                            return Err(anguilla_drivers::LinkError::BusOff);
                        }
                        left -= 1;
                        Ok(())
                    },
                };
                r.ctl.run_period(now, &mut bus);
                r.nodes_step();
            }
        }
    }
    r.command(2, Command::EStop);
    r.run_for(0.2);
    // A clean end, as the daemon's shutdown writes it (the `E` line).
    r.ctl.disable_all(&mut r.host);
    st_tx.send(*r.ctl.snapshot()).unwrap();
    drop(st_tx);
    assert_eq!(r.ctl.tap_dropped(), 0);
    drop(r); // closes the record channel
    recorder.join().unwrap().expect("recorder writes");
    dir
}

#[test]
fn a_recorded_session_replays_bit_for_bit() {
    let dir = record_session("replay-ok");
    for f in ["session.log", "bus.log", "config.toml", "state.bin"] {
        assert!(dir.join(f).exists(), "{f} written");
    }
    // bus.log is a candump log any can-utils reader opens.
    let log = std::fs::read_to_string(dir.join("bus.log")).unwrap();
    let entries: Vec<_> = anguilla_protocol::candump::Reader::new(log.as_bytes()).collect();
    assert!(entries.len() > 1000);
    assert!(entries.iter().all(|e| e.is_ok()));
    let report = replay::replay(&dir).expect("replays");
    assert!(report.identical(), "{:?}", report.mismatch);
    assert!(report.periods > 400);
    assert!(report.frames > 5000);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The CiA 402 and ODrive masters replay bit for bit too: SDO
/// configuration, controlwords, setpoints, quick stop.
#[test]
fn every_drive_family_replays_bit_for_bit() {
    for (name, drive) in [
        ("replay-cia402", Family::Cia402),
        ("replay-odrive", Family::Odrive),
    ] {
        let mut cfg = Config::default();
        cfg.robot.drive = drive;
        let dir = record_session_with(name, false, cfg);
        let report = replay::replay(&dir).expect("replays");
        assert!(report.identical(), "{name}: {:?}", report.mismatch);
        // 3.1 s at the automatic rate (89.3 Hz CiA 402, 75.2 Hz ODrive).
        assert!(report.periods > 200, "{name}: {} periods", report.periods);
        assert!(report.frames > 4000, "{name}: {} frames", report.frames);
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A session recorded with a USBL replays while its port is taken (the
/// daemon still running, on the robot): a sensor off the bus is not
/// replayed (its fixes are not among the session's inputs, and the frames
/// sent do not depend on them), so its source is not opened.
#[test]
fn a_session_with_a_usbl_replays_while_its_port_is_taken() {
    let probe = std::net::UdpSocket::bind("127.0.0.1:0").expect("a port");
    let addr = probe.local_addr().expect("its address");
    drop(probe);
    let mut cfg = Config::default();
    cfg.sensor.node = 20;
    cfg.sensor.usbl = Some(anguilla_daemon::sensors::usbl::UsblConfig {
        source: format!("udp:{addr}"),
        ..Default::default()
    });
    let dir = record_session_with("replay-usbl", false, cfg);
    let _daemon = std::net::UdpSocket::bind(addr).expect("the port, as a running daemon holds it");
    let report = replay::replay(&dir).expect("replays without opening the USBL's source");
    assert!(report.identical(), "{:?}", report.mismatch);
    assert!(report.periods > 400, "{} periods", report.periods);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sends_the_bus_refused_are_recorded_and_refused_again_in_the_replay() {
    let dir = record_session_with("replay-refused", true, Config::default());
    let session = std::fs::read_to_string(dir.join("session.log")).unwrap();
    let refused = session.lines().filter(|l| l.starts_with("X ")).count();
    assert!(refused > 10, "{refused} refused sends recorded");
    // Not on the wire, so not in the candump log.
    let log = std::fs::read_to_string(dir.join("bus.log")).unwrap();
    let sent = session.lines().filter(|l| l.starts_with("T ")).count();
    let received = session.lines().filter(|l| l.starts_with("R ")).count();
    assert_eq!(log.lines().count(), sent + received);
    let report = replay::replay(&dir).expect("replays");
    assert!(report.identical(), "{:?}", report.mismatch);
    // Without the first refusal, the replay sends that frame where the
    // recording has the next one refused: a mismatch that says so.
    let i = session.find("\nX ").unwrap() + 1;
    let end = i + session[i..].find('\n').unwrap() + 1;
    let mut changed = session.clone();
    changed.replace_range(i..end, "");
    std::fs::write(dir.join("session.log"), &changed).unwrap();
    let report = replay::replay(&dir).unwrap();
    let (_, what) = report.mismatch.expect("a mismatch");
    assert!(
        what.contains("(refused), replayed") && what.ends_with("(sent)"),
        "{what}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_tampered_recording_is_a_mismatch_or_an_error_naming_the_line() {
    let dir = record_session("replay-tampered");
    let path = dir.join("session.log");
    let text = std::fs::read_to_string(&path).unwrap();
    // Change one sent frame's payload: the replay must notice.
    let i = text.find("\nT 0C1#").expect("a setpoint for node 1") + 1;
    let mut changed = text.clone();
    let line_end = i + text[i..].find('\n').unwrap();
    let last = line_end - 1;
    let flipped = if &text[last..line_end] == "0" {
        "1"
    } else {
        "0"
    };
    changed.replace_range(last..line_end, flipped);
    std::fs::write(&path, &changed).unwrap();
    let report = replay::replay(&dir).unwrap();
    assert!(!report.identical());
    // A malformed line is an error that names it.
    let line_no = changed[..i].lines().count() + 1;
    let mut broken = changed.clone();
    broken.replace_range(i..i + 1, "Q");
    std::fs::write(&path, &broken).unwrap();
    match replay::replay(&dir) {
        Err(ReplayError::Session(SessionError::Line { line, what, .. })) => {
            assert_eq!(line, line_no);
            assert!(what.contains("unknown line tag 'Q'"), "{what}");
        }
        other => panic!("expected a line error, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cut_recording_is_truncated_not_different() {
    let dir = record_session("replay-cut");
    let path = dir.join("session.log");
    let text = std::fs::read_to_string(&path).unwrap();
    let full = replay::replay(&dir).unwrap();
    assert!(full.identical() && full.truncated_at.is_none());
    // Killed mid-session: cut in the middle of a line two thirds in.
    let cut = text.len() * 2 / 3;
    std::fs::write(&path, &text[..cut]).unwrap();
    let r = replay::replay(&dir).unwrap();
    assert!(r.identical(), "{:?}", r.mismatch);
    let whole_lines = text[..cut].matches('\n').count();
    assert_eq!(r.truncated_at, Some(whole_lines));
    assert!(
        r.periods > 10 && r.periods < full.periods,
        "{} of {}",
        r.periods,
        full.periods
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_period_at_the_end_of_time_and_an_endless_line_are_not_taken_for_an_end() {
    let dir = record_session("replay-sentinel");
    let path = dir.join("session.log");
    let text = std::fs::read_to_string(&path).unwrap();
    // A period line at u64::MAX used to end the replay as "identical".
    let at = text.find("\nP ").unwrap() + 1;
    let line_end = at + text[at..].find('\n').unwrap();
    let mut forged = text.clone();
    forged.replace_range(at..line_end, "P 18446744073709551615 0");
    std::fs::write(&path, &forged).unwrap();
    let r = replay::replay(&dir).unwrap();
    assert!(!r.identical(), "a forged period must not pass");
    // A line of 10 MB is refused at once, naming it, not read whole.
    let mut huge = text.clone();
    huge.insert_str(at, &format!("R {}\n", "7".repeat(10 << 20)));
    std::fs::write(&path, &huge).unwrap();
    match replay::replay(&dir) {
        Err(ReplayError::Session(SessionError::Line { what, .. })) => {
            assert!(what.contains("a line longer than 4096 bytes"), "{what}")
        }
        other => panic!("expected a line error, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_replay_with_another_configuration_says_so() {
    let dir = record_session("replay-foreign-config");
    let path = dir.join("config.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    // Comments and layout do not matter...
    std::fs::write(&path, format!("# edited by hand\n{text}")).unwrap();
    assert!(replay::replay(&dir).unwrap().identical());
    // ...another configuration does.
    let mut cfg = Config::from_toml(&text, "recorded").unwrap();
    cfg.gait.max_turn += 0.5;
    std::fs::write(&path, cfg.to_toml()).unwrap();
    match replay::replay(&dir) {
        Err(e @ ReplayError::ForeignConfig { .. }) => {
            assert!(
                e.to_string()
                    .contains("not the configuration this session was recorded with"),
                "{e}"
            )
        }
        other => panic!("expected a foreign-configuration error, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}
