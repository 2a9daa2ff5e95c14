//! The ODrive joint driven by frames made with the CANSimple codec, on
//! simulated time (no bus, no daemon).

use anguilla_protocol::frame::Id;
use anguilla_protocol::odrive::{Cmd, arbitration_id, decode};

use super::*;
use crate::device::JointDevice;

const MS: Nanos = Nanos::from_millis(1);
/// Pitch and yaw node ids of the joint under test (joint 2's defaults).
const P: u8 = 3;
const Y: u8 = 4;
const BOOT: Nanos = Nanos::from_millis(20);

fn config() -> OdriveJointConfig {
    OdriveJointConfig {
        ids: [P, Y],
        axes: [ActuatorParams::default(); 2],
        boot_time: BOOT,
        seed: 7,
        watchdog: Nanos::from_millis(100),
    }
}

struct Bench {
    joint: OdriveJoint,
    /// What the joint sent, with the time it was sent (1 ms resolution).
    out: Vec<(Nanos, Frame)>,
    now: Nanos,
}

impl Bench {
    /// A joint just powered on at time zero.
    fn powered_on() -> Self {
        Self {
            joint: OdriveJoint::new(config(), Nanos::ZERO).unwrap(),
            out: Vec::new(),
            now: Nanos::ZERO,
        }
    }

    /// A booted joint (IDLE), nothing heard yet.
    fn new() -> Self {
        let mut b = Self::powered_on();
        b.wait(30 * MS);
        assert_eq!(b.joint.state(), NodeState::Disabled);
        b.out.clear();
        b
    }

    /// Advances by `dt` in 1 ms steps.
    fn wait(&mut self, dt: Nanos) {
        let end = self.now + dt;
        while self.now < end {
            self.now = (self.now + MS).min(end);
            let (out, now) = (&mut self.out, self.now);
            self.joint.advance(now, &mut |f| out.push((now, f)));
        }
    }

    fn send_frame(&mut self, f: &Frame) {
        let (out, now) = (&mut self.out, self.now);
        self.joint.receive(now, f, &mut |fr| out.push((now, fr)));
    }

    fn send(&mut self, node: u8, body: Body) {
        let f = Message {
            node: NodeId::new(node).unwrap(),
            body,
        }
        .encode()
        .unwrap();
        self.send_frame(&f);
    }

    fn both(&mut self, body: Body) {
        self.send(P, body);
        self.send(Y, body);
    }

    /// The documented enable sequence (docs/drives.md) to both axes.
    fn enable(&mut self) {
        self.both(Body::SetControllerMode {
            control_mode: ControlMode::PositionControl,
            input_mode: InputMode::Passthrough,
        });
        self.both(Body::SetAxisState(AxisState::ClosedLoopControl));
    }

    fn input_pos(&mut self, turns: f32) {
        self.both(Body::SetInputPos(InputPos {
            input_pos: turns,
            vel_ff: 0.0,
            torque_ff: 0.0,
        }));
    }

    /// Set_Input_Pos every 10 ms for `d`.
    fn swim_at(&mut self, turns: f32, d: Nanos) {
        let end = self.now + d;
        while self.now < end {
            self.input_pos(turns);
            self.wait(10 * MS);
        }
    }

    /// Every message sent so far, with its time; empties the record.
    fn messages(&mut self) -> Vec<(Nanos, Message)> {
        self.out
            .drain(..)
            .map(|(t, f)| (t, decode(&f).expect("the joint sends only valid frames")))
            .collect()
    }

    /// The heartbeats of `node` sent so far (empties the record).
    fn heartbeats(&mut self, node: u8) -> Vec<(Nanos, Heartbeat)> {
        self.messages()
            .into_iter()
            .filter_map(|(t, m)| match m.body {
                Body::Heartbeat(h) if m.node.get() == node => Some((t, h)),
                _ => None,
            })
            .collect()
    }
}

/// The times (ms) at which `node` sent `cmd`.
fn times_of(msgs: &[(Nanos, Message)], node: u8, cmd: Cmd) -> Vec<u64> {
    msgs.iter()
        .filter(|(_, m)| m.node.get() == node && m.body.cmd() == cmd)
        .map(|(t, _)| t.as_nanos() / 1_000_000)
        .collect()
}

fn remote(node: u8, cmd: Cmd) -> Frame {
    let id = Id::Standard(arbitration_id(NodeId::new(node).unwrap(), cmd));
    Frame::new_remote(id, 8).unwrap()
}

#[test]
fn boots_silent_then_sends_heartbeats_every_100_ms_and_estimates_every_10_ms() {
    let mut b = Bench::powered_on();
    b.wait(1000 * MS);
    let msgs = b.messages();
    for node in [P, Y] {
        let hb = times_of(&msgs, node, Cmd::Heartbeat);
        assert_eq!(
            hb,
            (20..1000).step_by(100).collect::<Vec<_>>(),
            "node {node}"
        );
        let enc = times_of(&msgs, node, Cmd::GetEncoderEstimates);
        assert_eq!(
            enc,
            (20..=1000).step_by(10).collect::<Vec<_>>(),
            "node {node}"
        );
    }
    assert_eq!(msgs.len(), 2 * (10 + 99), "nothing else: {msgs:?}");
    // Booted: IDLE without error; the joint at rest reads zero.
    let Body::Heartbeat(h) = msgs[0].1.body else {
        panic!("{:?}", msgs[0])
    };
    assert_eq!(h.axis_state, AxisState::Idle);
    assert_eq!(h.axis_error, 0);
    assert!(msgs.iter().all(|(_, m)| match m.body {
        Body::EncoderEstimates(e) => e.pos == 0.0 && e.vel == 0.0,
        _ => true,
    }));
}

#[test]
fn while_booting_it_hears_nothing_and_its_state_is_boot() {
    let mut b = Bench::powered_on();
    b.wait(10 * MS);
    assert_eq!(b.joint.state(), NodeState::Boot);
    assert_eq!(b.joint.axis_state(0), AxisState::Undefined);
    b.enable();
    b.send_frame(&remote(P, Cmd::Heartbeat));
    assert!(b.out.is_empty(), "{:?}", b.out);
    b.wait(20 * MS);
    assert_eq!(
        b.joint.state(),
        NodeState::Disabled,
        "the enable was not heard"
    );
}

#[test]
fn remote_frames_are_answered_at_once() {
    let mut b = Bench::new();
    b.wait(5 * MS);
    b.out.clear();
    for (node, cmd) in [(P, Cmd::Heartbeat), (Y, Cmd::GetEncoderEstimates)] {
        b.send_frame(&remote(node, cmd));
        let msgs = b.messages();
        assert_eq!(msgs.len(), 1, "{msgs:?}");
        assert_eq!(msgs[0].1.node.get(), node);
        assert_eq!(msgs[0].1.body.cmd(), cmd);
    }
}

#[test]
fn closed_loop_needs_position_control_with_passthrough_and_idle_disarms() {
    let mut b = Bench::new();
    // No controller mode yet: refused, reported in procedure_result.
    b.both(Body::SetAxisState(AxisState::ClosedLoopControl));
    assert_eq!(b.joint.state(), NodeState::Disabled);
    let hb = b.heartbeats(P);
    assert_eq!(hb.len(), 1, "a heartbeat at once: {hb:?}");
    assert_eq!(hb[0].1.axis_state, AxisState::Idle);
    assert_eq!(hb[0].1.procedure_result, procedure_result::INVALID_STATE);
    // Another mode: refused too.
    b.both(Body::SetControllerMode {
        control_mode: ControlMode::VelocityControl,
        input_mode: InputMode::Passthrough,
    });
    b.both(Body::SetAxisState(AxisState::ClosedLoopControl));
    assert_eq!(b.joint.axis_state(1), AxisState::Idle);
    // The documented sequence: closed loop, both axes.
    b.enable();
    assert_eq!(b.joint.axis_state(0), AxisState::ClosedLoopControl);
    assert_eq!(b.joint.state(), NodeState::Enabled);
    let hb = b.heartbeats(Y);
    let last = hb.last().unwrap().1;
    assert_eq!(last.axis_state, AxisState::ClosedLoopControl);
    assert_eq!(last.procedure_result, procedure_result::SUCCESS);
    // One axis idle: the joint is Disabled, that axis limp, the other
    // still holding its input.
    b.swim_at(0.05, 200 * MS);
    b.send(Y, Body::SetAxisState(AxisState::Idle));
    assert_eq!(b.joint.state(), NodeState::Disabled);
    b.input_pos(0.05);
    b.wait(MS);
    assert_eq!(b.joint.motor_torque(1), 0.0);
    assert!(
        b.joint.kinematics(0).0 > 0.25,
        "{:?}",
        b.joint.kinematics(0)
    );
    // A state this emulation does not run: refused, state unchanged.
    b.send(P, Body::SetAxisState(AxisState::FullCalibrationSequence));
    assert_eq!(b.joint.axis_state(0), AxisState::ClosedLoopControl);
    assert_eq!(b.joint.procedure_result(0), procedure_result::INVALID_STATE);
}

#[test]
fn set_input_pos_moves_the_joint_and_the_estimates_follow() {
    let mut b = Bench::new();
    // Ignored while idle.
    b.input_pos(0.1);
    b.wait(200 * MS);
    assert_eq!(b.joint.kinematics(0).0, 0.0);
    assert_eq!(b.joint.counters().applied, 0);
    b.enable();
    b.swim_at(0.05, 1000 * MS);
    assert_eq!(b.joint.counters().applied, 2 * 100);
    // 0.05 turns = 0.314 rad. The default servo (kp 40 N·m/rad) without
    // load settles to within an encoder count (1.5 mrad) in far less than
    // the second given; 5 mrad leaves room for what is left of the motion.
    let target = 0.05 * TURN;
    for axis in 0..2 {
        let (th, w, _) = b.joint.kinematics(axis);
        assert!((th - target).abs() < 5e-3, "axis {axis}: {th} rad");
        assert!(w.abs() < 0.05, "axis {axis}: {w} rad/s");
    }
    let msgs = b.messages();
    let last = msgs
        .iter()
        .rev()
        .find_map(|(_, m)| match m.body {
            Body::EncoderEstimates(e) if m.node.get() == P => Some(e),
            _ => None,
        })
        .unwrap();
    // In turns: 0.05 within an encoder count (1/4096 turn) and the settling.
    assert!((last.pos - 0.05).abs() < 1e-3, "{last:?}");
    // The torque feedforward reaches the servo: without load the joint
    // settles where the position loop cancels it, torque_ff / kp =
    // 0.5 / 40 = 12.5 mrad beyond the input (±3 mrad: an encoder count
    // and what is left of the settling after 0.3 s, ζ ≈ 0.7, ω ≈ 45 rad/s).
    for _ in 0..30 {
        b.send(
            P,
            Body::SetInputPos(InputPos {
                input_pos: 0.05,
                vel_ff: 0.0,
                torque_ff: 0.5,
            }),
        );
        b.send(Y, Body::Request(Cmd::Heartbeat));
        b.wait(10 * MS);
    }
    let offset = b.joint.kinematics(0).0 - target;
    assert!((offset - 0.0125).abs() < 3e-3, "{offset} rad");
}

#[test]
fn the_watchdog_disarms_an_axis_left_without_messages_in_closed_loop() {
    let mut b = Bench::new();
    b.enable();
    b.swim_at(0.02, 300 * MS);
    // 90 ms without a message from the master: still closed loop.
    b.wait(90 * MS);
    assert_eq!(b.joint.state(), NodeState::Enabled);
    b.out.clear();
    b.wait(20 * MS);
    assert_eq!(b.joint.state(), NodeState::Fault);
    for axis in 0..2 {
        assert_eq!(b.joint.axis_error(axis), axis_error::WATCHDOG_TIMER_EXPIRED);
        assert_eq!(b.joint.axis_state(axis), AxisState::Idle);
        assert_eq!(b.joint.motor_torque(axis), 0.0, "limp");
    }
    assert_eq!(b.joint.counters().watchdog_expiries, 2);
    let hb = b.heartbeats(P);
    assert_eq!(hb[0].1.axis_error, axis_error::WATCHDOG_TIMER_EXPIRED);
    assert_eq!(hb[0].1.procedure_result, procedure_result::DISARMED);
    // Idle axes have no watchdog; Clear_Errors makes them Disabled.
    b.wait(500 * MS);
    assert_eq!(b.joint.counters().watchdog_expiries, 2);
    b.both(Body::ClearErrors { identify: false });
    assert_eq!(b.joint.state(), NodeState::Disabled);
    b.enable();
    assert_eq!(b.joint.state(), NodeState::Enabled);
}

#[test]
fn estop_disarms_with_estop_requested_until_clear_errors() {
    let mut b = Bench::new();
    b.enable();
    b.swim_at(0.02, 100 * MS);
    b.out.clear();
    b.send(P, Body::Estop);
    assert_eq!(b.joint.axis_error(0), axis_error::ESTOP_REQUESTED);
    assert_eq!(b.joint.axis_state(0), AxisState::Idle);
    assert_eq!(b.joint.axis_state(1), AxisState::ClosedLoopControl);
    assert_eq!(b.joint.state(), NodeState::EStop, "the worse of the two");
    let hb = b.heartbeats(P);
    assert_eq!(hb.len(), 1, "at once");
    assert_eq!(hb[0].1.axis_error, axis_error::ESTOP_REQUESTED);
    // Closed loop is refused while the error is active.
    b.send(P, Body::SetAxisState(AxisState::ClosedLoopControl));
    assert_eq!(b.joint.axis_state(0), AxisState::Idle);
    assert_eq!(b.joint.procedure_result(0), procedure_result::DISARMED);
    // Yaw's watchdog fires (the master went quiet), then yaw is E-stopped
    // too: pitch has ESTOP_REQUESTED alone, yaw more.
    b.wait(200 * MS);
    assert_eq!(b.joint.axis_error(1), axis_error::WATCHDOG_TIMER_EXPIRED);
    b.send(Y, Body::Estop);
    assert_eq!(b.joint.state(), NodeState::EStop, "pitch's E-stop first");
    b.send(P, Body::ClearErrors { identify: true });
    assert_eq!(b.joint.state(), NodeState::Fault, "yaw: watchdog + estop");
    b.send(Y, Body::ClearErrors { identify: false });
    assert_eq!(b.joint.state(), NodeState::Disabled);
    assert_eq!(b.joint.axis_error(1), 0);
    b.enable();
    assert_eq!(b.joint.state(), NodeState::Enabled);
}

#[test]
fn an_injected_fault_survives_clear_errors_until_its_cause_is_removed() {
    assert_eq!(
        injected_error(ErrorBits::OVER_TEMPERATURE),
        axis_error::MOTOR_OVER_TEMP
    );
    assert_eq!(
        injected_error(ErrorBits::UNDER_VOLTAGE),
        axis_error::DC_BUS_UNDER_VOLTAGE
    );
    assert_eq!(injected_error(ErrorBits::ENCODER), axis_error::DRV_FAULT);
    let mut b = Bench::new();
    b.enable();
    b.swim_at(0.02, 50 * MS);
    b.out.clear();
    let (out, now) = (&mut b.out, b.now);
    b.joint
        .inject_fault(ErrorBits::OVER_TEMPERATURE, now, &mut |f| {
            out.push((now, f))
        });
    assert_eq!(b.joint.state(), NodeState::Fault);
    let msgs = b.messages();
    for node in [P, Y] {
        let hb: Vec<_> = msgs
            .iter()
            .filter_map(|(_, m)| match m.body {
                Body::Heartbeat(h) if m.node.get() == node => Some(h),
                _ => None,
            })
            .collect();
        assert_eq!(hb.len(), 1, "at once: {msgs:?}");
        assert_eq!(hb[0].axis_error, axis_error::MOTOR_OVER_TEMP);
        assert_eq!(hb[0].axis_state, AxisState::Idle);
    }
    b.both(Body::ClearErrors { identify: false });
    assert_eq!(b.joint.state(), NodeState::Fault, "the cause persists");
    assert_eq!(b.joint.axis_error(0), axis_error::MOTOR_OVER_TEMP);
    // A power cycle does not remove the cause either.
    let now = b.now;
    b.joint.reboot(now);
    b.wait(30 * MS);
    assert_eq!(b.joint.state(), NodeState::Fault, "after the reboot");
    assert_eq!(b.joint.axis_error(1), axis_error::MOTOR_OVER_TEMP);
    b.joint.clear_injected_fault();
    b.both(Body::ClearErrors { identify: false });
    assert_eq!(b.joint.state(), NodeState::Disabled);
}

#[test]
fn a_silent_joint_neither_sends_nor_hears_and_a_reboot_loses_the_mode() {
    let mut b = Bench::new();
    b.enable();
    b.swim_at(0.02, 50 * MS);
    b.joint.set_silent(true);
    b.out.clear();
    b.both(Body::SetAxisState(AxisState::Idle));
    b.wait(300 * MS);
    assert!(b.out.is_empty(), "a silent joint sends nothing");
    assert_eq!(b.joint.state(), NodeState::Enabled, "and hears nothing");
    b.joint.set_silent(false);
    b.wait(100 * MS);
    assert!(!b.heartbeats(P).is_empty(), "speaks again");
    // Power cycle: boots again (quiet meanwhile), the mode lost.
    let now = b.now;
    b.joint.reboot(now);
    assert_eq!(b.joint.state(), NodeState::Boot);
    b.wait(10 * MS);
    assert!(b.out.is_empty());
    b.wait(20 * MS);
    assert_eq!(b.joint.state(), NodeState::Disabled);
    b.both(Body::SetAxisState(AxisState::ClosedLoopControl));
    assert_eq!(b.joint.state(), NodeState::Disabled, "no controller mode");
    b.enable();
    assert_eq!(b.joint.state(), NodeState::Enabled);
}

#[test]
fn junk_on_its_ids_is_counted_other_frames_are_ignored() {
    let mut b = Bench::new();
    b.enable();
    let id = |node: u8, cmd: u8| (u16::from(node) << 5) | u16::from(cmd);
    let junk = [
        // Set_Input_Pos too short.
        Frame::new_standard(id(P, 0x0C), &[0; 4]).unwrap(),
        // A NaN position.
        Frame::new_standard(id(Y, 0x0C), &[0, 0, 0xC0, 0x7F, 0, 0, 0, 0]).unwrap(),
        // An axis state beyond the DBC's table.
        Frame::new_standard(id(P, 0x07), &[99, 0, 0, 0]).unwrap(),
        // A command this emulation does not implement (Get_Version).
        Frame::new_standard(id(P, 0x00), &[]).unwrap(),
        // A remote frame on a command that is not requestable (Estop).
        Frame::new_remote(Id::standard(id(Y, 0x02)).unwrap(), 0).unwrap(),
        // CAN FD on an own id.
        Frame::new_fd(Id::standard(id(P, 0x0C)).unwrap(), &[0; 8], false).unwrap(),
        // Clear_Errors with identify 2.
        Frame::new_standard(id(Y, 0x18), &[2]).unwrap(),
    ];
    for f in &junk {
        b.send_frame(f);
    }
    assert_eq!(b.joint.counters().bad_frames, junk.len() as u64);
    assert_eq!(b.joint.state(), NodeState::Enabled, "nothing acted on");
    let ignored = [
        // Another node's Estop and junk.
        Frame::new_standard(id(P + 2, 0x02), &[]).unwrap(),
        Frame::new_standard(id(0, 0x0C), &[1]).unwrap(),
        // An extended id whose low bits are an own Estop.
        Frame::new(Id::extended(u32::from(id(P, 0x02))).unwrap(), &[]).unwrap(),
        // Drive-to-host messages on an own id (another device's).
        Message {
            node: NodeId::new(P).unwrap(),
            body: Body::Heartbeat(Heartbeat {
                axis_error: 1,
                axis_state: AxisState::Idle,
                procedure_result: 0,
                trajectory_done: true,
            }),
        }
        .encode()
        .unwrap(),
    ];
    b.out.clear();
    for f in &ignored {
        b.send_frame(f);
    }
    assert_eq!(b.joint.counters().bad_frames, junk.len() as u64);
    assert_eq!(b.joint.state(), NodeState::Enabled);
    assert!(b.out.is_empty(), "{:?}", b.out);
}

#[test]
fn bad_configurations_name_the_field() {
    let e = OdriveJoint::new(
        OdriveJointConfig {
            ids: [3, 64],
            ..config()
        },
        Nanos::ZERO,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("ids") && e.contains("0..=63"), "{e}");
    let e = OdriveJoint::new(
        OdriveJointConfig {
            ids: [5, 5],
            ..config()
        },
        Nanos::ZERO,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("share the node id 5"), "{e}");
    let e = OdriveJoint::new(
        OdriveJointConfig {
            watchdog: Nanos::ZERO,
            ..config()
        },
        Nanos::ZERO,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("watchdog"), "{e}");
}
