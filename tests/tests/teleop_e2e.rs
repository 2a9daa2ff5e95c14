//! The operator tools end to end: a scripted keyboard client (the
//! `anguilla teleop` logic, without a terminal) drives the real daemon loop
//! and the simulated robot through a whole session, and a second client is
//! kept out of control but can E-stop.
//!
//! Every wait is bounded, and a watchdog aborts a test that hangs.

use std::time::{Duration, Instant};

use anguilla_ipc::StateSnapshot;
use anguilla_ipc::{Command, FaultKind, Mode};
use anguilla_system_tests::{Robot, Watchdog};
use anguilla_teleop::app::{Action, Intent, Limits};
use anguilla_teleop::operator::{Driver, Operator};

use anguilla_system_tests::process::REPLY;

/// Pumps `driver` (its steady 10 Hz sender included) until `cond` holds for
/// the newest state and the states of the last `window`, or fails after
/// `timeout` naming `what`. Returns the newest state.
fn wait_for(
    driver: &mut Driver,
    what: &str,
    timeout: Duration,
    window: Duration,
    mut cond: impl FnMut(&StateSnapshot, &[StateSnapshot]) -> bool,
) -> StateSnapshot {
    let deadline = anguilla_testkit::Deadline::new(timeout);
    let mut recent: Vec<(Instant, StateSnapshot)> = vec![];
    loop {
        driver.pump(Instant::now()).expect("ipc");
        let s = driver
            .op
            .wait_state(Duration::from_millis(10))
            .expect("ipc")
            .copied();
        if let Some(s) = s {
            let now = Instant::now();
            if recent.last().is_none_or(|(_, l)| l.sequence != s.sequence) {
                recent.push((now, s));
            }
            recent.retain(|(t, _)| now.duration_since(*t) <= window);
            let full = recent
                .first()
                .is_some_and(|(t, _)| now.duration_since(*t) >= window.mul_f64(0.9));
            let states: Vec<StateSnapshot> = recent.iter().map(|(_, s)| *s).collect();
            if (window.is_zero() || full) && cond(&s, &states) {
                return s;
            }
        }
        if deadline.passed() {
            let last = recent.last().map(|(_, s)| s);
            panic!(
                "timed out after {timeout:?} waiting for {what}; last mode {:?} (faults {:#x} at \
                 nodes {:#x}), gait {:?}, refused {:?}",
                last.map(|s| s.mode),
                last.map_or(0, |s| s.fault_kinds),
                last.map_or(0, |s| s.fault_nodes),
                last.map(|s| s.gait_actual),
                driver.op.last_refused()
            );
        }
    }
}

fn mode_is(m: Mode) -> impl FnMut(&StateSnapshot, &[StateSnapshot]) -> bool {
    move |s, _| s.mode == m as u8
}

fn joints(s: &StateSnapshot) -> &[anguilla_ipc::JointSnapshot] {
    &s.joints[..s.joint_count as usize]
}

/// Mean over the window and over the joints of a measured angle: the
/// undulation averages out over whole periods (1 Hz gait, 2 s window),
/// leaving the turn's or the dive's bias.
fn mean_angle(states: &[StateSnapshot], f: impl Fn(&anguilla_ipc::JointSnapshot) -> f32) -> f64 {
    let mut sum = 0.0;
    let mut n = 0usize;
    for s in states {
        for j in joints(s) {
            sum += f(j) as f64;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// Spread (max - min) over the window of the tail joint's measured yaw.
fn tail_swing(states: &[StateSnapshot]) -> f64 {
    let ys: Vec<f64> = states
        .iter()
        .map(|s| joints(s).last().map_or(0.0, |j| j.measured_yaw as f64))
        .collect();
    let max = ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let min = ys.iter().cloned().fold(f64::INFINITY, f64::min);
    max - min
}

/// The limits the daemon publishes: its configuration's, and the tools'
/// defaults are the default configuration's.
fn published_limits(op: &mut Operator, cfg: &anguilla_daemon::config::Config) -> Limits {
    let s = *op
        .wait_state(Duration::from_secs(20))
        .unwrap()
        .expect("the daemon's first state");
    let l = Limits::from_snapshot(&s.limits);
    assert_eq!(l.max_frequency, cfg.gait.max_frequency as f32 as f64);
    assert_eq!(l.max_turn, cfg.gait.max_turn as f32 as f64);
    assert_eq!(l.max_pitch, cfg.gait.max_pitch as f32 as f64);
    assert_eq!(
        s.limits.daemon_pid,
        std::process::id(),
        "an in-process daemon"
    );
    let d = anguilla_daemon::config::Config::default().gait;
    assert_eq!(
        Limits::default(),
        Limits {
            max_frequency: d.max_frequency,
            max_turn: d.max_turn,
            max_pitch: d.max_pitch,
        }
    );
    l
}

#[test]
fn a_scripted_operator_drives_a_whole_session() {
    let _dog = Watchdog::new("teleop e2e session", Duration::from_secs(240));
    let robot = Robot::start("teleop-session").expect("daemon and robot start");
    let mut op = Operator::connect(&robot.prefix, "systest-teleop").expect("connect");
    let limits = published_limits(&mut op, &robot.config);
    let mut d = Driver::new(op, Intent::new(limits));
    let no_window = Duration::ZERO;
    let window = Duration::from_secs(2);

    // The daemon is heard; nobody holds control.
    let s = wait_for(
        &mut d,
        "the first state",
        Duration::from_secs(20),
        no_window,
        |_, _| true,
    );
    assert_eq!(s.mode, Mode::Idle as u8);
    assert_eq!(s.holder(), None);

    // Enable → ready.
    assert_eq!(
        d.op.request(Command::TakeControl, REPLY).unwrap().accepted,
        1
    );
    assert_eq!(d.act(Action::Enable).unwrap(), Some(Command::Enable));
    let s = wait_for(
        &mut d,
        "ready",
        Duration::from_secs(20),
        no_window,
        mode_is(Mode::Ready),
    );
    assert_eq!(s.holder(), Some(d.op.id()), "we hold control");
    assert!(d.op.holds_control());

    // Swim: six steps faster → amplitude 0.6 at 1 Hz; the tail swings.
    for _ in 0..6 {
        d.act(Action::Faster).unwrap();
    }
    wait_for(
        &mut d,
        "swimming",
        Duration::from_secs(10),
        no_window,
        mode_is(Mode::Swimming),
    );
    // At 0.6 of the F1 amplitude the tail joint swings by about ±0.15 rad
    // (0.25 rad at full amplitude, daemon/tests/lifecycle.rs); 0.1 rad peak
    // to peak cannot be noise of a joint held straight (< 0.01 rad).
    // Straight: over two whole periods the yaw angles average out (0.02
    // rad, against the 0.077 rad of the turn below).
    let s = wait_for(
        &mut d,
        "the tail swinging, unbiased, while swimming straight",
        Duration::from_secs(60),
        window,
        |s, w| {
            s.mode == Mode::Swimming as u8
                && tail_swing(w) > 0.1
                && mean_angle(w, |j| j.measured_yaw).abs() < 0.02
        },
    );
    assert!(
        s.predicted_head_speed > 0.0,
        "the model predicts forward motion"
    );

    // Turn left: four steps → 1 /m. A left turn (positive yaw rate about
    // e3, which points up) is a negative K_c3 (the paper's T1, K_c3 = +2,
    // turns right to -88°), so each of the 13 segments (1/13 m) bends by
    // about -1/13 rad ≈ -0.077 rad on average; -0.03 rad over a 2 s window
    // (two whole periods) is well clear of a straight swim's mean.
    for _ in 0..4 {
        d.act(Action::TurnLeft).unwrap();
    }
    let s = wait_for(
        &mut d,
        "the yaw angles biased to the left",
        Duration::from_secs(60),
        window,
        |s, w| s.gait_actual.turn > 0.9 && mean_angle(w, |j| j.measured_yaw) < -0.03,
    );
    assert_eq!(s.mode, Mode::Swimming as u8);

    // Dive: straighten, then four steps → 1 /m of pitch curvature (the
    // daemon's maximum); the pitch angles bias the same way, the yaw mean
    // comes back towards zero.
    d.act(Action::Straighten).unwrap();
    for _ in 0..4 {
        d.act(Action::Dive).unwrap();
    }
    let s = wait_for(
        &mut d,
        "the pitch angles biased (diving)",
        Duration::from_secs(60),
        window,
        |s, w| {
            s.gait_actual.pitch > 0.9
                && s.gait_actual.turn.abs() < 0.05
                && mean_angle(w, |j| j.measured_pitch) > 0.03
                && mean_angle(w, |j| j.measured_yaw).abs() < 0.03
        },
    );
    assert_eq!(s.mode, Mode::Swimming as u8);

    // Stop → stopping → ready, every joint back near straight (0.02 rad:
    // servo tracking error of a joint held still is a few mrad).
    assert_eq!(d.act(Action::Stop).unwrap(), Some(Command::Stop));
    let s = wait_for(
        &mut d,
        "ready and straight after the stop",
        Duration::from_secs(60),
        no_window,
        |s, _| {
            s.mode == Mode::Ready as u8
                && joints(s)
                    .iter()
                    .all(|j| j.measured_yaw.abs() < 0.02 && j.measured_pitch.abs() < 0.02)
        },
    );
    assert_eq!(
        s.holder(),
        Some(d.op.id()),
        "still in control (keep-alives at 10 Hz)"
    );

    // E-stop: latched, named as an operator e-stop.
    d.act(Action::Faster).unwrap();
    wait_for(
        &mut d,
        "swimming again",
        Duration::from_secs(10),
        no_window,
        mode_is(Mode::Swimming),
    );
    assert_eq!(d.act(Action::EStop).unwrap(), Some(Command::EStop));
    let s = wait_for(
        &mut d,
        "e-stop",
        Duration::from_secs(10),
        no_window,
        mode_is(Mode::EStop),
    );
    assert_ne!(s.fault_kinds & FaultKind::OperatorEStop as u32, 0);
    assert!(!d.intent.swimming());
    // Latched: enable is refused, with the daemon's reason remembered.
    let r = d.op.request(Command::Enable, REPLY).unwrap();
    assert_eq!(r.accepted, 0);
    assert!(
        d.op.last_refused().unwrap().reason.contains("reset"),
        "{:?}",
        d.op.last_refused()
    );

    // Reset → idle; the steady sender does not restart anything by itself.
    assert_eq!(d.act(Action::Reset).unwrap(), Some(Command::Reset));
    wait_for(
        &mut d,
        "idle after the reset",
        Duration::from_secs(10),
        no_window,
        mode_is(Mode::Idle),
    );
    d.act(Action::Enable).unwrap();
    let s = wait_for(
        &mut d,
        "ready again",
        Duration::from_secs(20),
        window,
        |s, w| s.mode == Mode::Ready as u8 && w.iter().all(|x| x.mode == Mode::Ready as u8),
    );
    assert_eq!(s.fault_kinds, 0);

    // The steady 10 Hz sender kept every swim alive: the daemon never had
    // to stop one for the operator's silence.
    assert_eq!(s.operator_silent_stops, 0);

    // Quit: stop and release control.
    d.quit(REPLY).unwrap();
    wait_for(
        &mut d,
        "control released",
        Duration::from_secs(10),
        no_window,
        |s, _| s.holder().is_none(),
    );
}

#[test]
fn a_second_client_cannot_take_control_but_can_estop() {
    let _dog = Watchdog::new("teleop e2e authority", Duration::from_secs(180));
    let robot = Robot::start("teleop-authority").expect("daemon and robot start");
    let mut op_a = Operator::connect(&robot.prefix, "systest-a").unwrap();
    let limits = published_limits(&mut op_a, &robot.config);
    let mut a = Driver::new(op_a, Intent::new(limits));
    let mut b = Driver::new(
        Operator::connect(&robot.prefix, "systest-b").unwrap(),
        Intent::new(limits),
    );
    assert_ne!(a.op.id(), b.op.id());
    let none = Duration::ZERO;

    wait_for(
        &mut a,
        "the first state",
        Duration::from_secs(20),
        none,
        |_, _| true,
    );
    assert_eq!(
        a.op.request(Command::TakeControl, REPLY).unwrap().accepted,
        1
    );
    a.act(Action::Enable).unwrap();
    wait_for(
        &mut a,
        "ready",
        Duration::from_secs(20),
        none,
        mode_is(Mode::Ready),
    );

    // B is refused control and every driving command, with the reason.
    let r = b.op.request(Command::TakeControl, REPLY).unwrap();
    assert_eq!(r.accepted, 0);
    assert!(r.reason().contains("holds control"), "{}", r.reason());
    for cmd in [Command::Stop, Command::Disable, Command::ReleaseControl] {
        assert_eq!(b.op.request(cmd, REPLY).unwrap().accepted, 0, "{cmd:?}");
    }
    assert!(b.op.last_refused().is_some());

    // B's swim is refused (no control), and B's intent forgets it, so it
    // would not start swimming if B took control later.
    assert!(matches!(
        b.act(Action::Faster).unwrap(),
        Some(Command::Swim(_))
    ));
    assert!(b.intent.swimming());
    let deadline = anguilla_testkit::Deadline::new(REPLY);
    while b.intent.swimming() && !deadline.passed() {
        b.pump(Instant::now()).unwrap();
        b.op.wait_state(Duration::from_millis(10)).unwrap();
    }
    assert!(!b.intent.swimming(), "refused swim forgotten");
    assert_eq!(
        b.op.last_refused().unwrap().kind,
        Some(anguilla_ipc::CommandKind::Swim)
    );

    // A swims; B, watching, sees A as the holder and sends nothing steady.
    for _ in 0..5 {
        a.act(Action::Faster).unwrap();
    }
    wait_for(
        &mut a,
        "swimming",
        Duration::from_secs(10),
        none,
        mode_is(Mode::Swimming),
    );
    let s = wait_for(
        &mut b,
        "B sees the swim",
        Duration::from_secs(10),
        none,
        mode_is(Mode::Swimming),
    );
    assert_eq!(s.holder(), Some(a.op.id()));
    assert!(!b.op.holds_control());

    // B's E-stop works.
    assert_eq!(b.op.request(Command::EStop, REPLY).unwrap().accepted, 1);
    wait_for(
        &mut b,
        "e-stop from B",
        Duration::from_secs(10),
        none,
        mode_is(Mode::EStop),
    );
    // A's intent follows: its steady sender sends keep-alives, not swims.
    wait_for(
        &mut a,
        "A sees the e-stop",
        Duration::from_secs(10),
        none,
        mode_is(Mode::EStop),
    );
    assert!(!a.intent.swimming());
    assert_eq!(a.intent.steady(), Command::KeepAlive);
    // Only the holder can reset.
    assert_eq!(b.op.request(Command::Reset, REPLY).unwrap().accepted, 0);
    assert_eq!(a.op.request(Command::Reset, REPLY).unwrap().accepted, 1);
    wait_for(
        &mut a,
        "idle",
        Duration::from_secs(10),
        none,
        mode_is(Mode::Idle),
    );
    a.quit(REPLY).unwrap();
    // Released: now B can take control.
    wait_for(
        &mut b,
        "control released",
        Duration::from_secs(10),
        none,
        |s, _| s.holder().is_none(),
    );
    assert_eq!(
        b.op.request(Command::TakeControl, REPLY).unwrap().accepted,
        1
    );
}

/// The keyboard client follows a path (issue 48): `f` loads the
/// `--path` file and starts it, `f` again pauses it (the operator takes
/// over, swimming on straight), `f` once more resumes it on its leg, and
/// space stops the swim (the path interrupted).
#[test]
fn the_keyboard_client_follows_pauses_and_resumes_a_path() {
    use anguilla_ipc::GuideState;
    let _dog = Watchdog::new("teleop path", Duration::from_secs(240));
    let mut cfg = anguilla_system_tests::family_config(
        anguilla_protocol::Family::Anguilla,
        12,
        "tpath",
        "tp",
    );
    cfg.sensor.node = 20;
    cfg.validate().expect("valid");
    let robot = Robot::start_with(cfg.clone()).expect("daemon and robot start");
    let mut op = Operator::connect(&robot.prefix, "systest-teleop-path").expect("connect");
    let limits = published_limits(&mut op, &robot.config);
    let mut d = Driver::new(op, Intent::new(limits));
    let text =
        "{\"waypoints\": [{\"x\": 0, \"y\": 0}, {\"x\": 20, \"y\": 0}, {\"x\": 20, \"y\": 10}]}";
    d.path = Some(anguilla_teleop::path::PathFile::parse(text).expect("a path"));
    let none = Duration::ZERO;
    let guide = |s: &StateSnapshot| s.guide.guide_state();
    wait_for(
        &mut d,
        "the estimate",
        Duration::from_secs(20),
        none,
        |s, _| s.nav.samples > 0,
    );
    assert_eq!(
        d.op.request(Command::TakeControl, REPLY).unwrap().accepted,
        1
    );
    d.act(Action::Enable).unwrap();
    wait_for(
        &mut d,
        "ready",
        Duration::from_secs(20),
        none,
        mode_is(Mode::Ready),
    );
    // Follow.
    assert!(matches!(
        d.act(Action::Follow).unwrap(),
        Some(Command::Follow(_))
    ));
    let s = wait_for(
        &mut d,
        "following",
        Duration::from_secs(10),
        none,
        |s, _| guide(s) == Some(GuideState::Following) && s.mode == Mode::Swimming as u8,
    );
    assert_eq!((s.guide.leg, s.guide.waypoints), (1, 3));
    // The steady sender keeps the path alive (a keep-alive, not a swim
    // that would end it): still following 3 s on.
    let start = Instant::now();
    let s = wait_for(
        &mut d,
        "3 s of the path",
        Duration::from_secs(20),
        none,
        |_, _| start.elapsed() >= Duration::from_secs(3),
    );
    assert_eq!(guide(&s), Some(GuideState::Following), "{:?}", s.guide);
    // Pause: the operator swims on, straight.
    assert!(matches!(
        d.act(Action::Follow).unwrap(),
        Some(Command::Swim(_))
    ));
    let s = wait_for(&mut d, "paused", Duration::from_secs(10), none, |s, _| {
        guide(s) == Some(GuideState::Interrupted)
    });
    assert_eq!(s.mode, Mode::Swimming as u8, "swimming on");
    // Resume on the same leg.
    assert!(matches!(
        d.act(Action::Follow).unwrap(),
        Some(Command::Follow(f)) if f.resume
    ));
    let s = wait_for(&mut d, "resumed", Duration::from_secs(10), none, |s, _| {
        guide(s) == Some(GuideState::Following)
    });
    assert_eq!(s.guide.leg, 1, "the leg it was on");
    // Space: stop; the path is interrupted and the robot comes to rest.
    d.act(Action::Stop).unwrap();
    let s = wait_for(
        &mut d,
        "ready",
        Duration::from_secs(30),
        none,
        mode_is(Mode::Ready),
    );
    assert_eq!(guide(&s), Some(GuideState::Interrupted));
    assert_eq!(s.refused_commands, 0, "nothing refused");
}
