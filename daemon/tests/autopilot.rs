//! Heading and depth hold on the simulated robot (twelve vertebra nodes,
//! the swimming body, a head sensor with noise and bias walk), closed loop
//! on simulated time: heading hold reaches and keeps its
//! targets and rejects a cross current, the estimate follows the truth,
//! and every sensor fault ends a hold in the documented safe state (the
//! swim stops smoothly, straight; cause "head sensor lost"; the snapshot
//! says which fault). Figures: `cargo bench -p anguilla-daemon --bench
//! autopilot`.

use anguilla_testkit::lockstep;

use anguilla_ipc::vocabulary::{Cause, Command, Mode};
use anguilla_ipc::{Hold, HoldState, SensorHealth};
use lockstep::*;

/// Control periods in one gait period at 1 Hz.
fn per_gait_period(rig: &Rig) -> usize {
    (1e9 / rig.ctl.period_ns().as_nanos() as f64).round() as usize
}

/// Swims straight for 4 s and returns the estimated heading (deg).
fn swimming(rig: &mut Rig) -> f64 {
    rig.swim(1.0);
    rig.run(4.0, |_| {});
    assert_eq!(
        SensorHealth::from_code(rig.state().nav.sensor),
        Some(SensorHealth::Ok)
    );
    rig.state().nav.heading_deg as f64
}

fn hold_heading(rig: &mut Rig, deg: f64) {
    rig.ok(Command::Hold(Hold {
        heading: Some(deg),
        depth: None,
    }));
}

/// A heading step: the worst excursion beyond the target (deg, in the
/// step's direction) and the largest error over the last `keep` seconds of
/// `seconds`, both of the body's true heading.
fn step_response(rig: &mut Rig, from: f64, step: f64, seconds: f64, keep: f64) -> (f64, f64) {
    let target = from + step;
    hold_heading(rig, target);
    let mut body = BodyHeading::new(per_gait_period(rig));
    let (mut overshoot, mut late) = (0.0f64, 0.0f64);
    let start = rig.time();
    rig.run(seconds, |r| {
        let e = angle_diff_deg(body.push(&r.truth()), target);
        overshoot = overshoot.max(e * step.signum());
        if r.time() - start > seconds - keep {
            late = late.max(e.abs());
        }
    });
    (overshoot, late)
}

#[test]
fn heading_hold_reaches_and_keeps_its_targets_with_sensor_noise() {
    let mut rig = Rig::new(&config(), 1, [0.0; 3]);
    let h0 = swimming(&mut rig);
    // +60°, then −120°: each within ±5° for the last 4 s of 12 s, with an
    // overshoot under 10 % of the step (the bench measured 2.9° and 2.8°).
    let (over, late) = step_response(&mut rig, h0, 60.0, 12.0, 4.0);
    assert!(over < 6.0, "+60° step overshoots by {over:.1}°");
    assert!(late < 5.0, "+60° step: {late:.1}° off after 8 s");
    let (over, late) = step_response(&mut rig, h0 + 60.0, -120.0, 12.0, 4.0);
    assert!(over < 12.0, "−120° step overshoots by {over:.1}°");
    assert!(late < 5.0, "−120° step: {late:.1}° off after 8 s");
    let s = rig.state();
    assert_eq!(s.mode, Mode::Swimming as u8);
    assert_eq!(s.nav.hold, 1, "heading held");
    assert!((s.nav.heading_target_deg as f64 - (h0 - 60.0).rem_euclid(360.0)).abs() < 1e-3);
}

#[test]
fn heading_hold_rejects_a_cross_current() {
    // The robot heads along −x (180°); the current flows along +y at
    // 0.1 m/s, across its path.
    let mut rig = Rig::new(&config(), 3, [0.0, 0.1, 0.0]);
    let h0 = swimming(&mut rig);
    hold_heading(&mut rig, h0);
    let mut body = BodyHeading::new(per_gait_period(&rig));
    let (mut sum, mut n) = (0.0, 0);
    rig.run(20.0, |r| {
        let e = angle_diff_deg(body.push(&r.truth()), h0);
        if r.time() > 14.0 {
            sum += e;
            n += 1;
        }
    });
    let steady = sum / n as f64;
    assert!(
        steady.abs() < 3.0,
        "steady heading error {steady:.2}° in a 0.1 m/s cross current"
    );
}

#[test]
fn the_estimate_follows_the_truth() {
    let mut rig = Rig::new(&config(), 4, [0.0; 3]);
    let h0 = swimming(&mut rig);
    hold_heading(&mut rig, h0 + 90.0);
    let (mut att, mut depth) = (0.0f64, 0.0f64);
    rig.run(10.0, |r| {
        let t = r.truth();
        let est = r.ctl.nav().expect("a sensor").estimate();
        att = att.max(est.attitude.angle_to(&true_attitude(&t)).to_degrees());
        depth = depth.max((est.depth - true_depth(&t)).abs());
    });
    // The sensor's attitude noise is 0.005 rad (0.3°) per axis.
    assert!(att < 2.0, "attitude error up to {att:.2}°");
    // Pressure noise 20 Pa is 2 mm of water.
    assert!(depth < 0.02, "depth error up to {depth:.3} m");
}

/// Depth hold against a current with a vertical part (0.05 m/s down, 0.1
/// m/s across): the integral and the depth filter's learnt rate bias take
/// it out.
#[test]
fn depth_hold_rejects_a_current_pushing_down() {
    let mut rig = Rig::new(&config(), 10, [0.0, 0.1, -0.05]);
    swimming(&mut rig);
    let m = depth_step(&mut rig, 0.3, 30.0, 20.0);
    eprintln!(
        "depth in a current: {:.3} m, heading {:.2}° after 20 s",
        m.late, m.heading
    );
    // Measured 3.2 cm and 0.55° (as in still water: 3.2 cm, 0.25°); the
    // bounds are those of the still-water test, the heading's widened for
    // the cross current.
    assert!(m.late < 0.1, "{:.3} m off the target after 20 s", m.late);
    assert!(m.heading < 5.0, "heading {:.1}° off", m.heading);
    assert_eq!(rig.state().mode, Mode::Swimming as u8);
}

/// A raw 6-axis IMU (no fusion attitude): the accelerometer levels the
/// estimate and the gyro (beside the model) turns it, so roll and pitch stay
/// right; heading has no absolute reference (it starts at 0, the robot's
/// own start) and drifts only by the gyro's bias walk; the hold still works.
#[test]
fn a_raw_imu_levels_by_gravity_and_holds_a_heading() {
    let mut rig = Rig::with_sensor(&config(), 8, [0.0; 3], |s| s.fusion = false);
    let h0 = swimming(&mut rig);
    hold_heading(&mut rig, h0 + 60.0);
    let (mut tilt, mut heading, mut offset) = (0.0f64, 0.0f64, None);
    rig.run(10.0, |r| {
        let t = r.truth();
        let est = r.ctl.nav().expect("a sensor").estimate();
        let truth = true_attitude(&t);
        let up = |q: nalgebra::UnitQuaternion<f64>| q.inverse() * nalgebra::Vector3::z();
        tilt = tilt.max(up(est.attitude).angle(&up(truth)).to_degrees());
        let f = |q: nalgebra::UnitQuaternion<f64>| {
            let v = q * nalgebra::Vector3::x();
            v.y.atan2(v.x).to_degrees()
        };
        let d = angle_diff_deg(f(est.attitude), f(truth));
        let o = *offset.get_or_insert(d);
        heading = heading.max(angle_diff_deg(d, o).abs());
    });
    eprintln!("raw IMU: tilt error up to {tilt:.2}°, heading drift up to {heading:.2}°");
    // Measured 1.26° of tilt and 4.36° of heading drift over the 10 s of
    // a held 60° turn (seeded: the same every run, so the heading bound is
    // close to the figure on purpose: more drift is a regression). A wrong
    // gravity or rate sign is off by tens of degrees within a second.
    assert!(tilt < 5.0, "tilt error up to {tilt:.2}°");
    assert!(heading < 5.0, "heading error up to {heading:.2}°");
    assert_eq!(rig.state().nav.hold, 1);
    assert_eq!(
        SensorHealth::from_code(rig.state().nav.sensor),
        Some(SensorHealth::Ok)
    );
}

/// Every scripted sensor fault, during a held turn: the hold ends, the
/// swim stops smoothly and straight, the cause and the fault are named.
#[test]
fn every_sensor_fault_ends_the_hold_in_the_safe_state() {
    for (fault, expected) in [
        ("sensor silent", SensorHealth::Silent),
        ("sensor stuck", SensorHealth::Stuck),
        ("sensor bias-jump 1.0", SensorHealth::Implausible),
    ] {
        let mut rig = Rig::new(&config(), 5, [0.0; 3]);
        let h0 = swimming(&mut rig);
        hold_heading(&mut rig, h0 + 90.0);
        rig.run(1.0, |_| {});
        rig.scenario_from_now(&format!("0.5 {fault}"));
        let ended = rig.run_until(10.0, |r| r.state().mode == Mode::Ready as u8);
        let s = rig.state();
        assert!(ended, "{fault}: mode {} after 10 s", s.mode);
        assert_eq!(s.cause, Cause::SensorLost.code(), "{fault}");
        assert_eq!(
            SensorHealth::from_code(s.nav.hold_exit),
            Some(expected),
            "{fault}"
        );
        assert_eq!(s.nav.hold, 0, "{fault}: the hold ended");
        assert_eq!(s.gait_actual.turn, 0.0, "{fault}: straight");
        assert_eq!(s.gait_actual.amplitude, 0.0, "{fault}: stopped");
        // A new hold is refused while the sensor is unhealthy, and says why.
        let r = rig.command(Command::Hold(Hold {
            heading: Some(0.0),
            depth: None,
        }));
        assert_eq!(r.accepted, 0, "{fault}");
        assert!(
            r.reason().contains(expected.name()),
            "{fault}: {}",
            r.reason()
        );
    }
}

/// Issue 46, finding 11: CI's `check-heading` failed with "head sensor
/// lost" while fuzzing loaded the machine: the built-in robot's thread (the
/// sensor and the vertebrae alike) went without the CPU for longer than
/// the sensor's 0.1 s timeout, and the daemon, counting silence on its own
/// clock, took a stalled simulation for a silent sensor. A robot that
/// says nothing at all is the drives' liveness watch's to judge
/// (heartbeat-timeout, 0.35 s); the sensor is silent when the bus carries
/// the others' frames and not its own.
#[test]
fn a_stalled_robot_is_not_a_silent_sensor() {
    let mut rig = Rig::new(&config(), 12, [0.0; 3]);
    let h0 = swimming(&mut rig);
    hold_heading(&mut rig, h0 + 30.0);
    rig.run(1.0, |_| {});
    // 0.2 s: twice the sensor's timeout, within the heartbeats'.
    rig.starve_robot(0.2);
    let mut worst = SensorHealth::Ok;
    rig.run(3.0, |r| {
        let h = SensorHealth::from_code(r.state().nav.sensor).expect("a health");
        if h != SensorHealth::Ok {
            worst = h;
        }
    });
    let s = rig.state();
    assert_eq!(s.nav.hold_exit, 0, "the hold was let go: {worst:?}");
    assert_eq!(s.nav.hold, 1, "heading still held");
    assert_eq!(s.mode, Mode::Swimming as u8);
    // The sensor alone silent while the vertebrae talk is still silence.
    rig.scenario_from_now("0.1 sensor silent");
    assert!(rig.run_until(2.0, |r| r.state().nav.hold_exit
        == SensorHealth::Silent as u8));
}

#[test]
fn holds_need_a_sensor_and_control() {
    // No sensor configured.
    let mut cfg = config();
    cfg.sensor.node = 0;
    let mut rig = Rig::new(&cfg, 6, [0.0; 3]);
    rig.swim(1.0);
    let r = rig.command(Command::Hold(Hold {
        heading: Some(10.0),
        depth: None,
    }));
    assert_eq!(r.accepted, 0);
    assert!(r.reason().contains("no head sensor"), "{}", r.reason());
    rig.run(0.1, |_| {});
    assert_eq!(rig.state().mode, Mode::Swimming as u8, "the swim goes on");
    // Manual (nothing held) is always accepted.
    rig.ok(Command::Hold(Hold::MANUAL));
    // Out-of-range depth and a NaN heading are named.
    let mut rig = Rig::new(&config(), 7, [0.0; 3]);
    swimming(&mut rig);
    let r = rig.command(Command::Hold(Hold {
        heading: None,
        depth: Some(-1.0),
    }));
    assert!(r.reason().contains("depth (m) = -1"), "{}", r.reason());
    let r = rig.command(Command::Hold(Hold {
        heading: Some(f64::NAN),
        depth: None,
    }));
    assert!(
        r.reason().contains("heading (deg) is not a finite"),
        "{}",
        r.reason()
    );
}

/// Depth hold on the ballasted body (`[model] ballast`, default 2 cm): a
/// 0.5 m step with the heading held too. The paper's unballasted body rolls
/// over under a pitch curvature instead (docs/autopilot.md).
#[test]
fn depth_hold_reaches_and_keeps_its_target() {
    let mut rig = Rig::new(&config(), 2, [0.0; 3]);
    swimming(&mut rig);
    let m = depth_step(&mut rig, 0.5, 30.0, 20.0);
    // Measured: 90 % in 2.7 s, 8 cm over, within 3 cm after 20 s, the
    // heading within 0.3° (the bench prints them).
    let reached = m.reached.expect("90 % of the step reached");
    assert!(reached < 8.0, "90 % of the step after {reached:.1} s");
    assert!(m.overshoot < 0.2, "overshoot {:.3} m", m.overshoot);
    assert!(m.late < 0.1, "{:.3} m off the target after 20 s", m.late);
    assert!(
        m.heading < 3.0,
        "heading {:.1}° off while diving",
        m.heading
    );
    let s = rig.state();
    assert_eq!(s.mode, Mode::Swimming as u8);
    assert_eq!(s.nav.hold, 3, "heading and depth held");
}

/// Issue 46, finding 1: at amplitude 0.3 a depth hold 0.2 m below the
/// start climbed through the surface (−0.46 m after 30 s here, the
/// curvature at its diving limit all along): so slow a body climbs under a
/// diving curvature, and the law now takes the sign and size of that from
/// the model's dive table.
///
/// Bound: within 15 cm over the last 10 s of 30. Measured 11.7 cm (a slow
/// swing about the target: the body's authority there is 0.03 m/s per
/// 1/m, and its pitch answers a curvature change first in the other
/// sense); the old law ended 1.66 m off.
#[test]
fn depth_hold_holds_at_low_amplitude() {
    let mut rig = Rig::new(&config(), 11, [0.0; 3]);
    rig.swim_at(0.3, 1.0);
    rig.run(4.0, |_| {});
    let target = ORIGIN_DEPTH + 0.2;
    rig.ok(Command::Hold(Hold {
        heading: None,
        depth: Some(target),
    }));
    let mut trace = Vec::new();
    let start = rig.time();
    let mut late = 0.0f64;
    rig.run(30.0, |r| {
        let d = true_depth(&r.truth());
        let t = r.time() - start;
        if trace.len() < (t / 2.0) as usize {
            trace.push(format!("{d:.2}"));
        }
        if t > 20.0 {
            late = late.max((d - target).abs());
        }
    });
    eprintln!("amplitude 0.3, depth {target} m: {}", trace.join(" "));
    assert!(
        late < 0.1,
        "{late:.3} m off the target after 20 s: {}",
        trace.join(" ")
    );
}

/// The operating grid (docs/autopilot.md, "Measured"): amplitude ×
/// frequency × current (none, or 0.1 m/s across the path), a 0.2 m depth
/// step held with the heading, 30 s. Prints one JSON line per point: the
/// settle time (the last time beyond ±5 cm; 30 = never settled), the
/// steady error (the worst over the last 10 s) and the heading's. Long
/// (24 closed loops): run by hand,
/// `cargo test --workspace --all-features --test autopilot -- --ignored depth_hold_grid --nocapture`.
#[test]
#[ignore = "long (24 closed loops of 34 s): the figures of docs/autopilot.md, by hand"]
fn depth_hold_grid() {
    let mut points = Vec::new();
    for current in [0.0, 0.1] {
        for amplitude in [0.2, 0.3, 0.6, 1.0] {
            for frequency in [0.5, 1.0, 1.5] {
                points.push((amplitude, frequency, current));
            }
        }
    }
    let lines: Vec<_> = points
        .into_iter()
        .map(|(a, f, c)| {
            std::thread::spawn(move || {
                let mut rig = Rig::new(&config(), 2, [0.0, c, 0.0]);
                rig.swim_at(a, f);
                rig.run(4.0, |_| {});
                let m = depth_step(&mut rig, 0.2, 30.0, 20.0);
                format!(
                    "{{\"amplitude\":{a},\"frequency_hz\":{f},\"current_mps\":{c},\"settle_5cm_s\":{:.1},\"steady_error_m\":{:.3},\"overshoot_m\":{:.3},\"heading_error_deg\":{:.1},\"max_roll_deg\":{:.0}}}",
                    m.last_outside, m.late, m.overshoot, m.heading, m.roll
                )
            })
        })
        .collect();
    for l in lines {
        println!("{}", l.join().expect("a grid point"));
    }
}

/// Issue 46: the simulated body swam on above the water (a held 1.2 m
/// became −1.6 m). Climbing hard from 1 m (full amplitude, the pitch
/// curvature climbing at 0.26 m/s), the nose reaches the surface and
/// stays on it; the sensor's depth says so too.
#[test]
fn the_simulated_body_cannot_swim_above_the_surface() {
    let mut rig = Rig::new(&config(), 13, [0.0; 3]);
    rig.swim(1.0);
    rig.run(3.0, |_| {});
    rig.ok(Command::Swim(anguilla_ipc::vocabulary::SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: -0.5,
    }));
    let (mut shallowest, mut estimated) = (f64::INFINITY, f64::INFINITY);
    rig.run(12.0, |r| {
        shallowest = shallowest.min(true_depth(&r.truth()));
        estimated = estimated.min(r.state().nav.depth_m as f64);
    });
    assert!(shallowest >= 0.0, "the nose at {shallowest:.3} m");
    assert!(rig.robot.stats().surfaced > 0, "never reached the surface");
    // Pressure noise 20 Pa is 2 mm of water; the filter follows within cm.
    assert!(estimated > -0.05, "estimated {estimated:.3} m");
}

/// The hold states seen (in order, repeats dropped) over `seconds` of the
/// depth hold `target`, and the last snapshot's words.
fn depth_states(rig: &mut Rig, target: f64, seconds: f64) -> (Vec<HoldState>, String) {
    rig.ok(Command::Hold(Hold {
        heading: None,
        depth: Some(target),
    }));
    let mut seen: Vec<HoldState> = Vec::new();
    rig.run(seconds, |r| {
        let h = r.state().nav.depth_state().expect("a known hold state");
        if seen.last() != Some(&h) {
            seen.push(h);
        }
    });
    (seen, rig.state().nav.hold_words().join("; "))
}

/// Issue 46, finding 1: the daemon names how a hold is doing. At full
/// amplitude, 1 Hz, a 0.5 m step converges, then holds (within 0.2 m)
/// and never fails; the heading, not held, is off.
#[test]
fn a_hold_that_reaches_its_target_is_converging_then_holding() {
    let mut rig = Rig::new(&config(), 2, [0.0; 3]);
    swimming(&mut rig);
    let (seen, words) = depth_states(&mut rig, ORIGIN_DEPTH + 0.5, 20.0);
    eprintln!("full amplitude, 1 Hz: {seen:?}; {words}");
    assert_eq!(seen.first(), Some(&HoldState::Converging), "{seen:?}");
    assert_eq!(seen.last(), Some(&HoldState::Holding), "{seen:?}");
    assert!(!seen.iter().any(|h| h.failed()), "{seen:?}");
    assert!(
        words.starts_with("holding: depth ") && words.ends_with(" m for 1.50 m"),
        "{words}"
    );
    assert_eq!(rig.state().nav.heading_state(), Some(HoldState::Off));
    assert_eq!(rig.state().nav.surfaced, 0);
}

/// Issue 46, finding 1: at amplitude 0.6 and 1 Hz the dive table's
/// authority changes sign (−0.030 m/s per 1/m there, +0.032 at 0.8) and
/// a 0.2 m step ends 1.9 m off (docs/autopilot.md, the grid). The daemon
/// says so: within the settle time and a little, the depth hold is a
/// failure (not converging, or cannot), named with its values, and it
/// does not go back to converging.
#[test]
fn a_hold_that_cannot_converge_says_so() {
    let mut rig = Rig::new(&config(), 2, [0.0; 3]);
    rig.swim_at(0.6, 1.0);
    rig.run(4.0, |_| {});
    let (seen, words) = depth_states(&mut rig, ORIGIN_DEPTH + 0.2, 30.0);
    eprintln!("amplitude 0.6, 1 Hz: {seen:?}; {words}");
    let last = *seen.last().expect("a state");
    assert!(last.failed(), "{seen:?}; {words}");
    let first_failure = seen.iter().position(|h| h.failed()).expect("a failure");
    assert!(seen[first_failure..].iter().all(|h| h.failed()), "{seen:?}");
    assert!(words.starts_with(last.name()), "{words}");
    assert!(words.contains("m for 1.20 m"), "{words}");
}
