//! `anguilla joy`'s session end to end with a scripted gamepad (this machine
//! has no /dev/input): the deadman takes control and drives the real daemon
//! and simulated robot; unplugging sends one stop; the E-stop button works.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;
use std::time::Duration;

use anguilla_ipc::StateSnapshot;
use anguilla_ipc::{Cause, Mode};
use anguilla_system_tests::{Robot, Watchdog};
use anguilla_teleop::app::Limits;
use anguilla_teleop::joy::{AxisRange, Joy, JoyInput, JoyMapping};
use anguilla_teleop::operator::Operator;
use anguilla_teleop::pad::{JoyNotice, JoySession, NoPad, PadGone, PadSource};
use evdev::{AbsoluteAxisCode, KeyCode};

#[derive(Default)]
struct PadState {
    plugged: bool,
    open: bool,
    queue: VecDeque<JoyInput>,
}

/// A pad the test plugs, unplugs and presses.
#[derive(Clone, Default)]
struct ScriptedPad(Rc<RefCell<PadState>>);

impl ScriptedPad {
    fn plug(&self, on: bool) {
        self.0.borrow_mut().plugged = on;
    }
    fn press(&self, code: KeyCode, pressed: bool) {
        self.0
            .borrow_mut()
            .queue
            .push_back(JoyInput::Button { code, pressed });
    }
    fn axis(&self, code: AbsoluteAxisCode, value: i32) {
        self.0
            .borrow_mut()
            .queue
            .push_back(JoyInput::Axis { code, value });
    }
}

impl PadSource for ScriptedPad {
    fn open(&mut self) -> Result<String, NoPad> {
        let mut s = self.0.borrow_mut();
        s.open = s.plugged;
        if s.plugged {
            Ok("scripted pad".to_string())
        } else {
            Err(NoPad::NotFound {
                deadman: KeyCode::BTN_TL,
                speed: AbsoluteAxisCode::ABS_Y,
            })
        }
    }
    fn ranges(&self) -> Vec<(AbsoluteAxisCode, AxisRange)> {
        vec![]
    }
    /// Like evdev: what was queued before the unplug is read first, then
    /// the pad is gone.
    fn read(&mut self, _timeout: Duration, out: &mut Vec<JoyInput>) -> Result<(), PadGone> {
        let mut s = self.0.borrow_mut();
        if !s.plugged && s.queue.is_empty() {
            s.open = false;
            return Err(PadGone);
        }
        out.extend(s.queue.drain(..));
        Ok(())
    }
}

type Session = JoySession<ScriptedPad>;

/// Steps the session until `cond` holds for the newest state (bounded).
fn wait_for(
    s: &mut Session,
    notices: &mut Vec<JoyNotice>,
    what: &str,
    timeout: Duration,
    mut cond: impl FnMut(&StateSnapshot) -> bool,
) -> StateSnapshot {
    let deadline = anguilla_testkit::Deadline::new(timeout);
    loop {
        s.step(|n| notices.push(n)).expect("ipc");
        if let Some(st) = s.op.state()
            && cond(st)
        {
            return *st;
        }
        assert!(
            !deadline.passed(),
            "timed out after {timeout:?} waiting for {what}; mode {:?}, notices {notices:?}",
            s.op.state().map(|x| x.mode)
        );
    }
}

#[test]
fn a_gamepad_drives_and_unplugging_it_stops_the_robot() {
    let _dog = Watchdog::new("joy e2e", Duration::from_secs(180));
    let robot = Robot::start("joy-session").expect("daemon and robot start");
    let pad = ScriptedPad::default();
    let mut op = Operator::connect(&robot.prefix, "systest-joy").unwrap();
    let first = *op
        .wait_state(Duration::from_secs(20))
        .unwrap()
        .expect("first state");
    let limits = Limits::from_snapshot(&first.limits);
    let mut s = JoySession::new(op, Joy::new(JoyMapping::default(), limits), pad.clone());
    let mut notices = vec![];
    // Bounds, not speed goals: generous for a loaded 2-core CI machine.
    let t = Duration::from_secs(60);

    // No pad: said once, nothing sent.
    wait_for(&mut s, &mut notices, "the first state", t, |_| true);
    assert_eq!(
        notices
            .iter()
            .filter(|n| matches!(n, JoyNotice::Waiting(_)))
            .count(),
        1,
        "said once: {notices:?}"
    );
    assert!(!s.connected());

    // Plugged: found within its 1 s look-up period.
    pad.plug(true);
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(15));
    while !s.connected() && !deadline.passed() {
        s.step(|n| notices.push(n)).unwrap();
    }
    assert!(s.connected(), "{notices:?}");

    // Sticks without the deadman do nothing.
    pad.axis(AbsoluteAxisCode::ABS_Y, -32768);
    pad.press(KeyCode::BTN_START, true);
    let st = wait_for(&mut s, &mut notices, "a few states", t, |_| true);
    assert_eq!(st.holder(), None, "no control taken without the deadman");

    // Deadman: control; start: enable; the stick (still forward) swims.
    pad.axis(AbsoluteAxisCode::ABS_Y, 0);
    pad.press(KeyCode::BTN_TL, true);
    let id = s.op.id();
    wait_for(&mut s, &mut notices, "control", t, |st| {
        st.holder() == Some(id)
    });
    pad.press(KeyCode::BTN_START, true);
    pad.press(KeyCode::BTN_START, false);
    wait_for(&mut s, &mut notices, "ready", t, |st| {
        st.mode == Mode::Ready as u8
    });
    pad.axis(AbsoluteAxisCode::ABS_Y, -32768);
    pad.axis(AbsoluteAxisCode::ABS_RX, -32768);
    let st = wait_for(&mut s, &mut notices, "swimming, turning left", t, |st| {
        st.mode == Mode::Swimming as u8 && st.gait_actual.turn > 1.5
    });
    assert_eq!(st.gait_target.amplitude, 1.0);
    assert_eq!(st.gait_target.turn, limits.max_turn as f32);

    // Unplugged while driving: one stop (a command, not the daemon's
    // silence timeout), then the robot comes to ready. Here the pad goes
    // with the deadman held (a device that fails); a real kernel releases
    // held buttons first, which tests/tests/gamepad_uinput.rs covers.
    pad.plug(false);
    let st = wait_for(&mut s, &mut notices, "stopping", t, |st| {
        st.mode == Mode::Stopping as u8
    });
    assert!(notices.contains(&JoyNotice::Disconnected { stop_sent: true }));
    assert_eq!(
        Cause::from_code(st.cause),
        Some(Cause::Command),
        "stopped by a command (the one stop)"
    );
    assert_eq!(st.operator_silent_stops, 0);
    wait_for(
        &mut s,
        &mut notices,
        "ready after the stop",
        Duration::from_secs(60),
        |st| st.mode == Mode::Ready as u8,
    );

    // Replugged: the old stick position is forgotten; the deadman again
    // keeps control alive without swimming.
    pad.plug(true);
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(15));
    while !s.connected() && !deadline.passed() {
        s.step(|n| notices.push(n)).unwrap();
    }
    assert!(s.connected());
    pad.press(KeyCode::BTN_TL, true);
    pad.axis(AbsoluteAxisCode::ABS_Y, -32768);
    wait_for(&mut s, &mut notices, "swimming again", t, |st| {
        st.mode == Mode::Swimming as u8
    });

    // E-stop button: latched.
    pad.press(KeyCode::BTN_EAST, true);
    wait_for(&mut s, &mut notices, "e-stop", t, |st| {
        st.mode == Mode::EStop as u8
    });
    assert!(
        notices
            .iter()
            .any(|n| matches!(n, JoyNotice::Mode(m) if *m == Mode::EStop as u8))
    );

    // Reset (deadman held), then quit releases control.
    pad.axis(AbsoluteAxisCode::ABS_Y, 0);
    pad.press(KeyCode::BTN_SELECT, true);
    wait_for(&mut s, &mut notices, "idle after reset", t, |st| {
        st.mode == Mode::Idle as u8
    });
    s.quit(Duration::from_secs(5)).unwrap();
    wait_for(&mut s, &mut notices, "control released", t, |st| {
        st.holder().is_none()
    });
}
