use super::*;
use crate::device::JointDevice;

const MS: Nanos = Nanos::from_millis(1);

fn joint() -> MitJoint {
    MitJoint::new(
        MitJointConfig {
            ids: [3, 4],
            axes: [ActuatorParams::default(); 2],
            boot_time: 50 * MS,
            seed: 7,
            timeout: CAN_TIMEOUT,
        },
        Nanos::ZERO,
    )
    .unwrap()
}

fn frame(node: u8, body: Body) -> Frame {
    Message {
        node: NodeId::new(node).unwrap(),
        body,
    }
    .encode(&DEFAULT_RANGES)
    .unwrap()
}

/// Sends `body` to drive `node` at `t`; the replies.
fn ask(j: &mut MitJoint, t: Nanos, node: u8, body: Body) -> Vec<Message> {
    let mut out = Vec::new();
    j.receive(t, &frame(node, body), &mut |f| out.push(f));
    out.iter()
        .map(|f| mit::decode(f, &DEFAULT_RANGES).unwrap())
        .collect()
}

fn hold(position: f32) -> Body {
    Body::Command(Command {
        position,
        velocity: 0.0,
        kp: 40.0,
        kd: 1.2,
        torque: 0.0,
    })
}

fn reply(m: &[Message]) -> Reply {
    match m {
        [
            Message {
                body: Body::Reply(r),
                ..
            },
        ] => *r,
        _ => panic!("expected one reply, got {m:?}"),
    }
}

#[test]
fn boots_deaf_then_answers_every_frame_and_nothing_unasked() {
    let mut j = joint();
    assert!(ask(&mut j, 10 * MS, 3, Body::ExitMotorMode).is_empty());
    assert_eq!(j.state(), NodeState::Boot);
    let mut unasked = 0;
    j.advance(60 * MS, &mut |_| unasked += 1);
    assert_eq!(unasked, 0);
    assert_eq!(j.state(), NodeState::Disabled);
    let r = ask(&mut j, 61 * MS, 4, Body::ExitMotorMode);
    assert_eq!(r[0].node.get(), 4);
    assert_eq!(
        reply(&r).status,
        Some(Status {
            temperature: TEMPERATURE,
            error: 0
        })
    );
    // Another drive's id: not ours.
    assert!(ask(&mut j, 62 * MS, 5, Body::ExitMotorMode).is_empty());
    // Junk on our id: counted, not answered.
    let mut out = 0;
    j.receive(
        63 * MS,
        &Frame::new_standard(3, &[1, 2]).unwrap(),
        &mut |_| out += 1,
    );
    assert_eq!((out, j.counters().bad_frames), (0, 1));
}

#[test]
fn motor_mode_servos_to_the_command_and_exit_goes_limp() {
    let mut j = joint();
    j.advance(60 * MS, &mut |_| {});
    // Out of motor mode a command is answered and ignored.
    assert_eq!(ask(&mut j, 61 * MS, 3, hold(0.3)).len(), 1);
    assert_eq!(j.counters().applied, 0);
    ask(&mut j, 62 * MS, 3, Body::EnterMotorMode);
    assert!(j.motor_mode(0) && !j.motor_mode(1));
    assert_eq!(j.state(), NodeState::Disabled, "the worse of the two");
    ask(&mut j, 62 * MS, 4, Body::EnterMotorMode);
    assert_eq!(j.state(), NodeState::Enabled);
    let mut t = 62 * MS;
    let mut last = Vec::new();
    for _ in 0..100 {
        t += 10 * MS;
        last = ask(&mut j, t, 3, hold(0.3));
        ask(&mut j, t, 4, hold(-0.2));
    }
    let (p, _, _) = j.kinematics(0);
    assert!((p - 0.3).abs() < 0.01, "pitch at {p}");
    assert!((j.kinematics(1).0 + 0.2).abs() < 0.01);
    let rep = reply(&last);
    assert!((rep.position - 0.3).abs() < 0.01, "{rep:?}");
    ask(&mut j, t, 3, Body::ExitMotorMode);
    assert!(!j.motor_mode(0));
    // Set zero: the present position reads 0 from now on.
    let rep = reply(&ask(&mut j, t, 4, Body::SetZero));
    assert!(rep.position.abs() < 0.01, "{rep:?}");
}

#[test]
fn the_can_timeout_ends_motor_mode() {
    let mut j = joint();
    j.advance(60 * MS, &mut |_| {});
    ask(&mut j, 61 * MS, 3, Body::EnterMotorMode);
    j.advance(61 * MS + CAN_TIMEOUT - MS, &mut |_| {});
    assert!(j.motor_mode(0));
    j.advance(61 * MS + CAN_TIMEOUT + 2 * MS, &mut |_| {});
    assert!(!j.motor_mode(0));
    assert_eq!(j.counters().watchdog_expiries, 1);
}

#[test]
fn an_injected_fault_refuses_motor_mode_until_its_cause_is_gone() {
    let mut j = joint();
    j.advance(60 * MS, &mut |_| {});
    ask(&mut j, 61 * MS, 3, Body::EnterMotorMode);
    j.inject_fault(ErrorBits::OVER_TEMPERATURE, 62 * MS, &mut |_| {});
    assert!(!j.motor_mode(0));
    assert_eq!(j.state(), NodeState::Fault);
    let rep = reply(&ask(&mut j, 63 * MS, 3, Body::EnterMotorMode));
    assert_eq!(rep.status.unwrap().error, error_code::OVER_TEMPERATURE);
    assert!(!j.motor_mode(0));
    // Exit clears an error whose cause is gone, not before.
    ask(&mut j, 64 * MS, 3, Body::ExitMotorMode);
    assert_eq!(j.error(0), error_code::OVER_TEMPERATURE);
    j.clear_injected_fault();
    ask(&mut j, 65 * MS, 3, Body::ExitMotorMode);
    assert_eq!(j.error(0), 0);
    ask(&mut j, 66 * MS, 3, Body::EnterMotorMode);
    assert!(j.motor_mode(0));
}

#[test]
fn silent_and_rebooted_drives() {
    let mut j = joint();
    j.advance(60 * MS, &mut |_| {});
    ask(&mut j, 61 * MS, 3, Body::EnterMotorMode);
    j.set_silent(true);
    assert!(ask(&mut j, 62 * MS, 3, Body::ExitMotorMode).is_empty());
    assert!(j.motor_mode(0), "a silent drive hears nothing");
    j.reboot(70 * MS);
    assert!(!j.motor_mode(0));
    assert_eq!(j.state(), NodeState::Boot);
    assert!(ask(&mut j, 100 * MS, 3, Body::ExitMotorMode).is_empty());
    assert_eq!(ask(&mut j, 130 * MS, 3, Body::ExitMotorMode).len(), 1);
}

#[test]
fn bad_configurations_name_the_field() {
    let cfg = MitJointConfig {
        ids: [3, 3],
        axes: [ActuatorParams::default(); 2],
        boot_time: MS,
        seed: 1,
        timeout: CAN_TIMEOUT,
    };
    let e = MitJoint::new(cfg, Nanos::ZERO).unwrap_err().to_string();
    assert!(e.contains("share the drive id 3"), "{e}");
    let e = MitJoint::new(MitJointConfig { ids: [0, 1], ..cfg }, Nanos::ZERO)
        .unwrap_err()
        .to_string();
    assert!(e.contains("MIT drive id 0 outside 1..=127"), "{e}");
}
