//! Each fault of the scenario language does what it says; the same scenario
//! and seed give the same frames.

mod common;

use std::time::Duration;

use anguilla_drivers::{Bus, BusState};
use anguilla_protocol::Frame;
use anguilla_protocol::message::{
    Direction, ErrorBits, FIRST_UNUSED_ID, Function, Message, NodeState, Variant, definition,
};
use anguilla_sim::actuator::ActuatorParams;
use anguilla_sim::{RobotConfig, SimError};
use common::{Host, MS};

fn cfg() -> RobotConfig {
    RobotConfig::with_joints(4)
}

fn host(scenario: &str) -> Host {
    let mut h = Host::new(cfg());
    h.robot.load_scenario(scenario).unwrap();
    h.enable_all();
    h
}

fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s)
}

#[test]
fn silent_node_sends_nothing_then_speaks_again() {
    let mut h = host("0.1 node 3 silent 0.3");
    h.hold(0.0, secs(0.6) - h.now());
    // Window strictly inside the silence (frames sent just before 0.1 may
    // be taken by the host in the same millisecond).
    let during: Vec<_> = h
        .heard
        .iter()
        .filter(|(t, _)| *t > secs(0.101) && *t < secs(0.4))
        .collect();
    let from3 = |f: &Frame| {
        matches!(f.id().as_standard().and_then(Function::split_id), Some((f, 3))
            if definition(Variant::Classic, f).is_some_and(|d| d.direction == Direction::NodeToHost))
    };
    assert!(!during.is_empty(), "the other nodes keep talking");
    assert!(!during.iter().any(|(_, f)| from3(f)), "node 3 was silent");
    assert!(h.node_spoke_since(3, secs(0.4)), "node 3 speaks again");
    // Deaf during the silence, its watchdog then expires as firmware would.
    assert_eq!(h.state_of(3), NodeState::Fault);
    assert_eq!(h.state_of(2), NodeState::Enabled);
}

#[test]
fn rebooted_node_boots_again_and_comes_back_disabled() {
    let mut h = host("0.2 node 2 reboot");
    h.hold(0.0, secs(0.5) - h.now());
    assert_eq!(h.state_of(2), NodeState::Disabled);
    assert_eq!(h.state_of(1), NodeState::Enabled);
    let boot_hb = h.messages_since(secs(0.2)).into_iter().any(|m| {
        matches!(m, Message::Heartbeat(hb) if hb.node.get() == 2 && hb.state == NodeState::Disabled)
    });
    assert!(boot_hb, "a Disabled heartbeat from node 2 after the reboot");
}

#[test]
fn stuck_joint_does_not_move() {
    let mut h = host("0.1 joint 4 yaw stuck");
    h.hold(0.0, secs(0.15) - h.now());
    let before = h.robot.node(4).unwrap().kinematics(1).0;
    h.hold(0.3, secs(0.6));
    let yaw4 = h.robot.node(4).unwrap().kinematics(1).0;
    let pitch4 = h.robot.node(4).unwrap().kinematics(0).0;
    let yaw3 = h.robot.node(3).unwrap().kinematics(1).0;
    assert_eq!(yaw4, before, "stuck yaw stays where it was");
    // The free axes reach the 0.3 rad setpoint within the load's
    // steady-state error (kp = 40 N·m/rad, loads ~0.1 N·m: ~3 mrad).
    assert!((pitch4 - 0.3).abs() < 0.02, "{pitch4}");
    assert!((yaw3 - 0.3).abs() < 0.02, "{yaw3}");
    let fb = h.last_feedback(4).unwrap();
    assert!(
        (fb[1] as f64 - before).abs() < 0.01,
        "feedback reports it: {fb:?}"
    );
}

#[test]
fn torque_limit_caps_the_motor_torque_and_is_reported() {
    let mut h = host("0.1 joint 2 pitch torque-limit 0.05");
    h.hold(0.0, secs(0.15) - h.now());
    let from = h.now();
    let (mut max2, mut max3) = (0.0f64, 0.0f64);
    let end = h.now() + secs(0.3);
    while h.now() < end {
        let n = h.robot.nodes().len();
        let sp = anguilla_protocol::message::AxisSetpoint {
            position: 0.5,
            velocity: 0.0,
            torque: 0.0,
        };
        h.counter = h.counter.wrapping_add(1);
        let c = h.counter;
        let host = &mut h.host;
        anguilla_protocol::message::encode_setpoints(
            h.variant,
            c,
            anguilla_protocol::message::from_node_one(&vec![[sp, sp]; n]),
            |f| host.send(&f).unwrap(),
        )
        .unwrap();
        h.send(Message::Sync { counter: c });
        for _ in 0..10 {
            h.run(MS);
            max2 = max2.max(h.robot.node(2).unwrap().motor_torque(0).abs());
            max3 = max3.max(h.robot.node(3).unwrap().motor_torque(0).abs());
        }
    }
    assert!(max2 <= 0.05 + 1e-12, "capped: {max2}");
    assert!(
        max3 > 0.5,
        "an uncapped joint uses more torque for the step: {max3}"
    );
    let warned = h.messages_since(from).into_iter().any(|m| {
        matches!(m, Message::Heartbeat(hb) if hb.node.get() == 2 && hb.errors.any(ErrorBits::TORQUE_LIMIT))
    });
    assert!(warned, "TORQUE_LIMIT reported by node 2");
}

fn feedback_positions(h: &Host, id: u8, axis: usize, from: Duration) -> Vec<f64> {
    h.messages_since(from)
        .into_iter()
        .filter_map(|m| match m {
            Message::Feedback(f) if f.node.get() == id => Some(f.axes[axis].position as f64),
            _ => None,
        })
        .collect()
}

fn std_dev(xs: &[f64]) -> f64 {
    let m = xs.iter().sum::<f64>() / xs.len() as f64;
    (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / xs.len() as f64).sqrt()
}

#[test]
fn encoder_noise_shows_in_the_feedback_of_that_axis_only() {
    let mut h = host("0.1 joint 2 pitch noise 0.05");
    h.hold(0.0, secs(0.1) - h.now());
    h.hold(0.0, secs(1.0));
    let noisy = feedback_positions(&h, 2, 0, secs(0.11));
    let quiet = feedback_positions(&h, 3, 0, secs(0.11));
    assert!(noisy.len() >= 80, "{}", noisy.len());
    let (sn, sq) = (std_dev(&noisy), std_dev(&quiet));
    // 90 samples: the sample std of N(0, 0.05) is within 0.035..0.065 far
    // beyond 3 sigma (its standard error is 0.05/sqrt(180) = 0.004).
    assert!((0.035..0.065).contains(&sn), "{sn}");
    assert!(sq < 0.005, "{sq}");
}

#[test]
fn encoder_spike_offsets_one_reading() {
    let mut h = host("0.3 joint 2 yaw spike 0.4");
    h.hold(0.0, secs(0.6) - h.now());
    let ys = feedback_positions(&h, 2, 1, secs(0.1));
    let spikes = ys.iter().filter(|y| (**y - 0.4).abs() < 0.05).count();
    let quiet = ys.iter().filter(|y| y.abs() < 0.01).count();
    assert_eq!(spikes, 1, "{ys:?}");
    assert_eq!(quiet, ys.len() - 1, "{ys:?}");
}

#[test]
fn bus_drop_and_drop_fraction_lose_frames() {
    let mut h = host("0.1 bus drop 5\n0.3 bus drop-fraction 0.5\n0.5 bus drop-fraction 0");
    h.hold(0.0, secs(0.2) - h.now());
    assert_eq!(h.bus.fault_stats().dropped, 5);
    h.hold(0.0, secs(0.5) - h.now());
    let dropped = h.bus.fault_stats().dropped;
    // 20 cycles x (4 setpoints + SYNC + 4 feedback) + heartbeats ~ 200
    // frames at p = 0.5: about 100 lost, certainly more than 30.
    assert!(dropped > 35, "{dropped}");
    h.hold(0.0, secs(0.2));
    assert_eq!(
        h.bus.fault_stats().dropped,
        dropped,
        "no more drops after 0"
    );
}

#[test]
fn bus_delay_makes_frames_late() {
    let mut h = host("0.1 bus delay 2ms");
    // Only heartbeats on the bus from 0.1 s on (4 every 100 ms).
    h.run(secs(0.2) - h.now());
    let start = h.now();
    h.heard.clear();
    h.cycle(&[Default::default(); 4], 40 * MS);
    let first_fb = h
        .heard
        .iter()
        .find(|(_, f)| f.id().as_standard().and_then(Function::from_id) == Some(Function::Feedback))
        .map(|(t, _)| *t)
        .expect("feedback");
    // 4 setpoints and the SYNC take 2 ms each on the wire, then the first
    // feedback 2 ms more (without the delay: within the same millisecond).
    assert!(first_fb - start >= 12 * MS, "{:?}", first_fb - start);
}

#[test]
fn bus_corrupt_flips_bits_in_the_next_frames() {
    let mut h = host("0.1 bus corrupt 3");
    h.hold(0.0, secs(0.3) - h.now());
    assert_eq!(h.bus.fault_stats().corrupted, 3);
}

#[test]
fn bus_off_delivers_nothing_during_the_window() {
    let mut h = host("0.2 bus bus-off 0.2");
    h.hold(0.0, secs(0.6) - h.now());
    let during = h
        .heard
        .iter()
        .filter(|(t, _)| *t > secs(0.201) && *t < secs(0.4))
        .count();
    assert_eq!(during, 0, "nothing from the robot while it is bus-off");
    assert!(h.robot.stats().send_errors > 0);
    assert_eq!(h.robot.bus().state(), BusState::ErrorActive);
    assert!(h.node_spoke_since(1, secs(0.41)), "back after the window");
    // Deaf for 200 ms, the nodes' 50 ms watchdogs expired.
    assert_eq!(h.robot.state_counts()[3], 4);
}

#[test]
fn flood_of_unknown_frames_leaves_nodes_unaffected() {
    let mut h = host("0.1 bus flood 1000");
    h.hold(0.0, secs(0.4) - h.now());
    let unknown = h
        .heard
        .iter()
        .filter(|(_, f)| f.id().as_standard().is_some_and(|r| r >= FIRST_UNUSED_ID))
        .count();
    assert_eq!(unknown, 1000, "the host heard the whole flood");
    assert_eq!(h.robot.stats().flood_frames, 1000);
    assert_eq!(h.robot.state_counts()[2], 4, "all still Enabled");
    for n in h.robot.nodes() {
        assert_eq!(n.counters().bad_frames, 0, "no BAD_FRAME for unknown ids");
    }
}

#[test]
fn scripted_errors_name_the_line() {
    let mut h = Host::new(cfg());
    let e = h
        .robot
        .load_scenario("0.1 node 1 reboot\n0.2 node 7 reboot\n")
        .unwrap_err();
    assert!(
        e.to_string().contains("line 2") && e.to_string().contains("node 7 does not exist"),
        "{e}"
    );
}

/// A bus without fault hooks (delegates to a mem participant).
struct Plain(anguilla_drivers::mem::MemParticipant);

impl Bus for Plain {
    fn send(&mut self, f: &Frame) -> anguilla_drivers::Result<()> {
        self.0.send(f)
    }
    fn recv(
        &mut self,
        t: Duration,
    ) -> anguilla_drivers::Result<Option<anguilla_drivers::Received>> {
        self.0.recv(t)
    }
    fn state(&self) -> BusState {
        self.0.state()
    }
    fn counters(&self) -> anguilla_drivers::BusCounters {
        self.0.counters()
    }
    fn capabilities(&self) -> anguilla_drivers::Capabilities {
        self.0.capabilities()
    }
    fn flush_tx(&mut self) -> anguilla_drivers::Result<()> {
        self.0.flush_tx()
    }
    fn reopen(&mut self) -> anguilla_drivers::OpenResult<()> {
        self.0.reopen()
    }
    fn spec(&self) -> &str {
        "plain:test"
    }
}

#[test]
fn bus_faults_on_a_bus_without_hooks_are_refused_with_the_line() {
    let bus = anguilla_drivers::mem::MemBus::builder("sim-plain").build();
    let mut robot =
        anguilla_sim::SimRobot::new(cfg(), Box::new(Plain(bus.participant())), Duration::ZERO)
            .unwrap();
    // Node faults and floods are fine anywhere.
    robot
        .load_scenario("0.1 node 1 silent\n0.2 bus flood 10")
        .unwrap();
    let e = robot
        .load_scenario("0.1 node 1 silent\n0.2 bus drop 3")
        .unwrap_err();
    assert!(
        matches!(e, SimError::BusFaultNeedsMemBus { line: 2, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("mem:NAME"), "{e}");
}

fn scripted_run(seed: u64) -> Vec<(Duration, Frame)> {
    let mut h = Host::new(RobotConfig {
        seed,
        actuator: ActuatorParams {
            encoder_noise: 0.01,
            ..ActuatorParams::default()
        },
        ..cfg()
    });
    h.robot
        .load_scenario(
            "0.1 bus drop-fraction 0.2\n0.15 joint 1 pitch spike 0.2\n0.2 bus flood 50\n\
             0.25 node 2 reboot\n0.3 bus corrupt 2\n0.35 bus drop-fraction 0",
        )
        .unwrap();
    h.enable_all();
    h.hold(0.2, secs(0.5) - h.now());
    h.heard
}

#[test]
fn same_scenario_and_seed_give_the_same_frames() {
    let a = scripted_run(7);
    let b = scripted_run(7);
    assert!(a.len() > 200, "{}", a.len());
    assert!(a == b, "byte-identical frame sequences");
    let c = scripted_run(8);
    assert!(a != c, "another seed gives other noise");
}

#[test]
fn a_water_current_event_carries_the_robot_along() {
    // The robot holds its joints straight; at 0.5 s the water starts to flow
    // sideways at 0.1 m/s. Broadside, the body catches up with the water
    // within seconds (model/README.md "Currents": the relative speed decays
    // as 1 / (1 + t / tau), tau ~ 0.8 s).
    let u = 0.1;
    let mut h = host("0.5 water current 0 0.1");
    h.hold(0.0, secs(0.5) - h.now());
    let before = h.robot.truth();
    h.hold(0.0, secs(20.5) - h.now());
    let after = h.robot.truth();
    eprintln!(
        "held straight, cross current {u} m/s from 0.5 s: velocity at 0.5 s {:?}, at 20.5 s {:?}, yaw {:.4} rad",
        before.velocity, after.velocity, after.yaw
    );
    assert!(
        before.velocity.iter().all(|v| v.abs() < 1e-3),
        "still water until 0.5 s: {:?}",
        before.velocity
    );
    assert_eq!(
        h.robot.current(),
        anguilla_model::Current::steady([0.0, u, 0.0]).unwrap()
    );
    // 20 s after the onset the 1 / (1 + t / tau) law leaves ~4 % of U
    // sideways (measured 5.5 %): within 10 %. The start-up cross flow also
    // turns the body (0.11 rad measured), which leaves a relative flow along
    // its axis that only skin friction damps, slowly (model/README.md,
    // "Currents"): 0.013 m/s measured along e1, accepted below 0.2 U.
    assert!(
        (after.velocity[1] - u).abs() < 0.1 * u,
        "carried sideways: {:?}",
        after.velocity
    );
    assert!(after.velocity[0].abs() < 0.2 * u, "{:?}", after.velocity);
}

#[test]
fn the_configured_current_flows_from_the_start() {
    let c = anguilla_model::Current::steady([0.1, 0.0, 0.0]).unwrap();
    let mut h = Host::new(RobotConfig {
        current: c,
        ..cfg()
    });
    h.enable_all();
    assert_eq!(h.robot.current(), c);
    h.hold(0.0, secs(2.0) - h.now());
    let t = h.robot.truth();
    // Along the body only skin friction acts: after 2 s the body has picked
    // up a few mm/s downstream, and nothing sideways.
    eprintln!(
        "held straight, axial current 0.1 m/s, 2 s: velocity {:?}",
        t.velocity
    );
    assert!(t.velocity[0] > 1e-3, "{:?}", t.velocity);
    assert!(
        t.velocity[1].abs() < 0.1 * t.velocity[0],
        "{:?}",
        t.velocity
    );
}

/// A snag is a torque on its joint's axis: the joint's drive supplies it,
/// and a body held in its pose does not pass it on to the other joints
/// (what the snag takes of the motor's torque never reaches the body).
/// Held straight in still water, every load is near zero; after the
/// snag's 0.5 N·m on joint 2's yaw the drive there supplies 0.5 N·m
/// (within 5 %), and no other axis more than 0.025 N·m (5 % of the snag).
/// Before the snag was taken off the body's torque, joint 2's drive
/// supplied 1.19 N·m (2.4 times the snag) and the body passed a share of
/// it to every other joint.
#[test]
fn a_snag_loads_its_own_joint_and_no_other() {
    let mut h = host("0.3 joint 2 yaw snag 0.5");
    h.hold(0.0, secs(0.25) - h.now());
    h.hold(0.0, secs(1.5));
    let torque = |h: &Host, j: u8, a: usize| h.robot.node(j).unwrap().motor_torque(a);
    let snagged = torque(&h, 2, 1);
    assert!((snagged - 0.5).abs() < 0.025, "joint 2 yaw: {snagged} N·m");
    for j in 1..=4u8 {
        for a in 0..2 {
            if (j, a) != (2, 1) {
                let t = torque(&h, j, a);
                assert!(t.abs() < 0.025, "joint {j} axis {a}: {t} N·m");
            }
        }
    }
}

/// A snag on a joint nobody servos (the robot idle, its drives limp)
/// pulls the joint to its end stop, where it rests; the body stays whole
/// and the joint comes back once servoed. With a 0.5 N·m snag on joint
/// 5's yaw from the start, the 12-joint robot's joint turned on without
/// bound before the actuators had end stops (-4.91 rad after 1 s, the
/// body folded through itself), the body model failed at every step from
/// 1.05 s on (973 failed steps by 3 s) and the limp joints spun to
/// thousands of radians: the daemon that enabled it saw frozen feedback
/// and every torque at its limit.
#[test]
fn a_snag_on_a_limp_joint_pulls_it_to_its_stop_and_no_further() {
    let mut h = Host::new(RobotConfig::with_joints(12));
    h.robot.load_scenario("0 joint 5 yaw snag 0.5").unwrap();
    h.run(secs(3.0));
    assert_eq!(h.robot.state_counts()[1], 12, "every node disabled");
    let travel = ActuatorParams::default().travel;
    let angle = |h: &Host, j: u8, a: usize| h.robot.node(j).unwrap().kinematics(a).0;
    assert_eq!(h.robot.stats().model_errors, 0, "the body model failed");
    let yaw5 = angle(&h, 5, 1);
    assert!(
        (yaw5 + travel).abs() < 0.01,
        "joint 5 yaw at {yaw5} rad, its stop at -{travel}"
    );
    for j in 1..=12u8 {
        for a in 0..2 {
            let q = angle(&h, j, a);
            if (j, a) != (5, 1) {
                assert!(q.abs() < travel, "joint {j} axis {a} at {q} rad");
            }
        }
    }
    // enabled and held straight: back within the servo's error, the drive
    // supplying the snag
    h.enable_all();
    h.hold(0.0, secs(2.0));
    assert_eq!(h.robot.stats().model_errors, 0, "the body model failed");
    for j in 1..=12u8 {
        for a in 0..2 {
            let q = angle(&h, j, a);
            assert!(q.abs() < 0.05, "joint {j} axis {a} at {q} rad");
        }
    }
    let t5 = h.robot.node(5).unwrap().motor_torque(1);
    assert!((t5 - 0.5).abs() < 0.05, "joint 5 yaw supplies {t5} N·m");
}
