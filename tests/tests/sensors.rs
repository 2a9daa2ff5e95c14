//! The sensor list end to end: the built-in robot with a head sensor and a
//! tail IMU (`[sensor] tail-imu`), the daemon's snapshot listing both
//! with their kinds, healths and values, `ctl status` and the recording's
//! `/anguilla/sensors` channel showing the tail IMU from the vocabulary's
//! table alone.

use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_ipc::{SensorHealth, SensorKind, StateSnapshot};
use anguilla_system_tests::process::{F1, connect, keep_alive_for, ok, wait_for};
use anguilla_system_tests::{Robot, Watchdog};

const TAIL: u8 = 40;

fn config(name: &str) -> Config {
    let mut cfg = anguilla_system_tests::family_config(
        anguilla_protocol::Family::Anguilla,
        12,
        "sensors",
        name,
    );
    cfg.sensor.node = 20;
    cfg.sensor.tail_imu = TAIL;
    cfg.validate().expect("valid");
    cfg
}

fn entry(s: &StateSnapshot, kind: SensorKind) -> Option<&anguilla_ipc::SensorEntry> {
    s.sensors.iter().find(|e| e.kind == kind as u8)
}

/// The wrapped difference of two headings (deg).
fn wrapped(a: f32, b: f32) -> f32 {
    (a - b + 540.0).rem_euclid(360.0) - 180.0
}

#[test]
fn a_tail_imu_is_listed_beside_the_head_sensor_and_swings_more() {
    let _wd = Watchdog::new("tail imu", Duration::from_secs(120));
    let cfg = config("tail-imu");
    let robot = Robot::start_with(cfg).expect("daemon and robot start");
    let mut client = connect(&robot.prefix, "tail-imu");
    let s = wait_for(&mut client, "both sensors ok", 15.0, |s| {
        [SensorKind::HeadNav, SensorKind::TailImu].iter().all(|&k| {
            entry(s, k).is_some_and(|e| e.health == SensorHealth::Ok as u8 && e.samples > 0)
        })
    });
    // The head sensor first, then the tail IMU, then nothing.
    assert_eq!(s.sensors[0].kind, SensorKind::HeadNav as u8);
    assert_eq!(
        (s.sensors[1].kind, s.sensors[1].id),
        (SensorKind::TailImu as u8, TAIL)
    );
    assert_eq!(s.sensors[2].kind, 0);
    // Swim: the tail's heading swings about the body's far more than the
    // head's does (F1's tail beats at ±0.25 rad a joint; the head's
    // heading swings a few degrees).
    anguilla_system_tests::process::take_control_and_enable(&mut client, 5.0);
    ok(&mut client, F1);
    keep_alive_for(&mut client, 2.0, |_| {});
    let (mut head, mut tail) = (Vec::new(), Vec::new());
    keep_alive_for(&mut client, 2.0, |s| {
        if let (Some(h), Some(t)) = (entry(s, SensorKind::HeadNav), entry(s, SensorKind::TailImu)) {
            head.push(h.values[0]);
            tail.push(t.values[0]);
        }
    });
    let swing = |v: &[f32]| {
        let mean = v[0];
        let d: Vec<f32> = v.iter().map(|x| wrapped(*x, mean)).collect();
        d.iter().cloned().fold(f32::MIN, f32::max) - d.iter().cloned().fold(f32::MAX, f32::min)
    };
    let (h, t) = (swing(&head), swing(&tail));
    eprintln!(
        "heading swing over 2 s of F1: head {h:.1} deg, tail IMU {t:.1} deg ({} states)",
        head.len()
    );
    assert!(head.len() > 20, "{} states", head.len());
    assert!(t > 2.0 * h && t > 10.0, "tail swing {t} deg, head {h} deg");
    ok(&mut client, anguilla_ipc::Command::EStop);
}
