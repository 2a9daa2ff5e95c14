//! A robot of ODrive joints on an in-process bus: a test master speaking
//! CANSimple (docs/drives.md, "ODrive") enables it and makes it swim; the
//! scenario language reaches its drives by joint number.

mod common;

use std::f64::consts::TAU;
use std::time::Duration;

use anguilla_drivers::Bus;
use anguilla_protocol::Family;
use anguilla_protocol::message::NodeState;
use anguilla_protocol::odrive::{
    self, AxisState, Body, ControlMode, InputMode, InputPos, Message, NodeId,
};
use anguilla_sim::RobotConfig;
use common::{Host, MS};

const JOINTS: usize = 4;

fn odrive_host() -> Host {
    Host::new(RobotConfig {
        drive: Family::Odrive,
        ..RobotConfig::with_joints(JOINTS)
    })
}

fn send(h: &mut Host, node: u8, body: Body) {
    let f = Message {
        node: NodeId::new(node).unwrap(),
        body,
    }
    .encode()
    .unwrap();
    h.host.send(&f).unwrap();
}

/// Every axis's id, joint 1 pitch first (the defaults 1..=2n).
fn ids(h: &Host) -> Vec<u8> {
    (0..JOINTS)
        .flat_map(|j| h.robot.config().drive_ids(j))
        .collect()
}

/// docs/drives.md's enable sequence to every axis.
fn enable(h: &mut Host) {
    for id in ids(h) {
        send(
            h,
            id,
            Body::SetControllerMode {
                control_mode: ControlMode::PositionControl,
                input_mode: InputMode::Passthrough,
            },
        );
        send(h, id, Body::SetAxisState(AxisState::ClosedLoopControl));
    }
}

/// The yaw of joint `j` (0 = head end) at time `t` (s): a travelling wave,
/// 0.3 rad, 1 Hz, a quarter period between joints.
fn wave(j: usize, t: f64) -> f64 {
    0.3 * (TAU * t - j as f64 * TAU / 4.0).sin()
}

/// Set_Input_Pos to every axis every 10 ms for `d`.
fn swim(h: &mut Host, d: Duration) {
    let end = h.now() + d;
    while h.now() < end {
        let t = h.now().as_secs_f64();
        for j in 0..JOINTS {
            let [p, y] = h.robot.config().drive_ids(j);
            for (id, angle) in [(p, 0.0), (y, wave(j, t))] {
                let input = InputPos {
                    input_pos: (angle / TAU) as f32,
                    vel_ff: 0.0,
                    torque_ff: 0.0,
                };
                send(h, id, Body::SetInputPos(input));
            }
        }
        h.run(10 * MS);
    }
}

/// The CANSimple messages the host heard since `from`.
fn heard_since(h: &Host, from: Duration) -> Vec<Message> {
    h.heard
        .iter()
        .filter(|(t, _)| *t > from)
        .filter_map(|(_, f)| odrive::decode(f).ok())
        .collect()
}

#[test]
fn a_master_enables_an_odrive_robot_and_makes_it_swim() {
    let mut h = odrive_host();
    h.run(60 * MS);
    assert_eq!(h.robot.state_counts(), [0, JOINTS, 0, 0, 0], "booted");
    // Every axis heartbeats and sends its estimates.
    let heard = heard_since(&h, Duration::ZERO);
    for id in ids(&h) {
        assert!(heard.iter().any(|m| m.node.get() == id
            && matches!(m.body, Body::Heartbeat(hb) if hb.axis_state == AxisState::Idle)));
        assert!(
            heard
                .iter()
                .any(|m| m.node.get() == id && matches!(m.body, Body::EncoderEstimates(_)))
        );
    }
    enable(&mut h);
    h.run(MS);
    assert_eq!(h.robot.state_counts(), [0, 0, JOINTS, 0, 0], "enabled");
    let start = h.robot.truth();
    swim(&mut h, Duration::from_secs(3));
    assert_eq!(h.robot.state_counts()[2], JOINTS, "still enabled");
    let end = h.robot.truth();
    // The joints follow the wave. Tolerance: the default servo under the
    // water's load lags its input; 0.1 rad is a third of the amplitude,
    // far below what a joint left limp or at zero would show (0.3 rad).
    let t = end.time.as_secs_f64();
    let mut worst: f64 = 0.0;
    for (j, angles) in end.joints.iter().enumerate() {
        assert!(
            angles[0].abs() < 0.05,
            "joint {} pitch {}",
            j + 1,
            angles[0]
        );
        worst = worst.max((angles[1] - wave(j, t)).abs());
    }
    assert!(worst < 0.1, "worst yaw error {worst} rad");
    // It swims: the wave runs head to tail, so the body goes head first
    // (0.4 m in 3 s here; the sway alone, without thrust, is millimetres).
    let moved = (0..3)
        .map(|i| (end.position[i] - start.position[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(moved > 0.1, "the nose moved {moved} m");
    assert!(end.forward_speed > 0.05, "{} m/s", end.forward_speed);
    // The estimates the master hears are the truth in turns.
    let last = heard_since(&h, h.now() - 20 * MS);
    let [_, yaw1] = h.robot.config().drive_ids(0);
    let est = last
        .iter()
        .rev()
        .find_map(|m| match m.body {
            Body::EncoderEstimates(e) if m.node.get() == yaw1 => Some(e),
            _ => None,
        })
        .expect("joint 1 yaw's estimates");
    // Within what the joint moves in the 10 ms between estimates (0.3 rad
    // · 2π · 1 Hz · 10 ms ≈ 0.02 rad ≈ 0.003 turns) and an encoder count.
    let truth_turns = end.joints[0][1] / TAU;
    assert!(
        (f64::from(est.pos) - truth_turns).abs() < 0.005,
        "{est:?} vs {truth_turns} turns"
    );
    // The master stops: every axis's watchdog fires, the joints fault.
    h.run(200 * MS);
    assert_eq!(h.robot.state_counts(), [0, 0, 0, JOINTS, 0], "watchdog");
}

#[test]
fn scenario_node_faults_name_the_joint_of_a_bought_family() {
    let mut h = odrive_host();
    h.robot.load_scenario("0.1 node 2 silent 0.2").unwrap();
    h.run(150 * MS);
    let [p, y] = h.robot.config().drive_ids(1);
    let quiet_from = h.now() - 40 * MS;
    let heard = heard_since(&h, quiet_from);
    assert!(
        !heard.iter().any(|m| m.node.get() == p || m.node.get() == y),
        "joint 2's drives ({p}, {y}) are silent"
    );
    assert!(heard.iter().any(|m| m.node.get() == 1), "joint 1 speaks");
    h.run(200 * MS);
    let heard = heard_since(&h, h.now() - 40 * MS);
    assert!(heard.iter().any(|m| m.node.get() == p), "speaks again");
    assert_eq!(h.state_of(2), NodeState::Disabled);
}

#[test]
fn a_flood_avoids_the_drives_ids() {
    let mut h = Host::new(RobotConfig {
        drive: Family::Odrive,
        // Joint 1 on the highest ids: a flood of "unused" anguilla ids
        // (0x240..=0x7FF, ODrive nodes 18..=63) would hit it.
        axis_ids: vec![[62, 63], [3, 4], [5, 6], [20, 21]],
        ..RobotConfig::with_joints(JOINTS)
    });
    h.robot.load_scenario("0.1 bus flood 2000 0.2").unwrap();
    h.run(60 * MS);
    enable(&mut h);
    swim(&mut h, Duration::from_millis(400));
    assert_eq!(h.robot.stats().flood_frames, 2000);
    assert_eq!(
        h.robot.state_counts()[2],
        JOINTS,
        "no Estop, no junk acted on"
    );
    for (j, n) in h.robot.nodes().iter().enumerate() {
        assert_eq!(n.counters().bad_frames, 0, "joint {}", j + 1);
    }
    let ours = ids(&h);
    let flooded = h
        .heard
        .iter()
        .filter_map(|(_, f)| f.id().as_standard())
        .filter(|&id| !ours.contains(&odrive::split_id(id).0))
        .count();
    assert_eq!(flooded, 2000, "the host heard the whole flood");
}

#[test]
fn the_builtin_robot_takes_the_family_and_numbers_bought_joints_from_one() {
    use anguilla_sim::builtin::{Builtin, BuiltinConfig};
    let (mut host, running) = Builtin::start(&BuiltinConfig {
        bus_name: format!("sim-odrive-builtin-{}", std::process::id()),
        bitrate: 1_000_000,
        data_bitrate: None,
        drive: Family::Odrive,
        // The daemon's node ids: only their number counts for bought drives.
        node_ids: vec![7, 9],
        axis_ids: vec![[10, 11], [20, 21]],
        variant: anguilla_protocol::message::Variant::Classic,
        fifo_priority: None,
        scenario: String::new(),
        head_sensor: None,
        tail_sensor: None,
        body: anguilla_model::Body::paper(),
        off_bus: Vec::new(),
    })
    .unwrap();
    // Real time: wait (bounded, a watchdog against a hang, not a speed
    // requirement) for joint 2's yaw heartbeat.
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(20));
    let mut seen = false;
    while !seen && !deadline.passed() {
        if let Ok(Some(r)) = host.recv(Duration::from_millis(100)) {
            seen = matches!(odrive::decode(&r.frame),
                Ok(Message { node, body: Body::Heartbeat(hb) })
                    if node.get() == 21 && hb.axis_state == AxisState::Idle);
        }
    }
    running.stop();
    assert!(seen, "no heartbeat from node 21");
}
