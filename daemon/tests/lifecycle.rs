//! The controller drives twelve simulated vertebra nodes through the whole
//! lifecycle and the safety reactions that involve only the bus and nodes.

mod rig;

use anguilla_daemon::config::Config;
use anguilla_ipc::vocabulary::{Command, FaultKind, Mode, SwimParams};
use anguilla_protocol::message::NodeState;
use rig::Rig;

fn swim(amplitude: f64, frequency: f64) -> Command {
    Command::Swim(SwimParams {
        amplitude,
        frequency,
        turn: 0.0,
        pitch: 0.0,
    })
}

/// A rig with control taken by client 1 and the actuators enabled.
fn ready(name: &str) -> Rig {
    let mut r = Rig::new(name, &Config::default());
    r.run_for(0.1); // nodes boot
    assert_eq!(r.command(1, Command::TakeControl).accepted, 1);
    assert_eq!(r.command(1, Command::Enable).accepted, 1);
    r.run_for(0.3);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
    r
}

#[test]
fn enable_swim_stop_and_the_joints_follow() {
    let mut r = ready("lifecycle-swim");
    assert!(r.nodes.iter().all(|n| n.state() == NodeState::Enabled));
    assert_eq!(r.command(1, swim(1.0, 1.0)).accepted, 1);
    let mut max_err = 0.0f64;
    let mut max_angle = 0.0f64;
    for i in 0..(4.0e9 / r.ctl.period_ns().as_nanos() as f64) as usize {
        r.step();
        if r.now.as_nanos() > 3_000_000_000 {
            for (j, n) in r.nodes.iter().enumerate() {
                let cmd = n.active_setpoint()[1].position as f64;
                let (th, _, _) = n.kinematics(1);
                max_err = max_err.max((th - cmd).abs());
                max_angle = max_angle.max(r.ctl.setpoints()[j][1].position.abs() as f64);
            }
        }
        if i % 20 == 0 {
            // The holder keeps sending (command timeout 0.5 s).
            r.command(1, Command::KeepAlive);
        }
    }
    assert_eq!(r.ctl.supervisor().mode(), Mode::Swimming);
    // Full amplitude F1 curvature (up to 3.5 /m over 1/13 m) bends the tail
    // joints by about 0.25 rad; the servos track within a few degrees.
    assert!(max_angle > 0.15, "yaw setpoints reach {max_angle} rad");
    assert!(max_err < 0.06, "tracking error {max_err} rad");
    assert!(
        r.ctl.report().forward_speed > 0.1,
        "model predicts forward swimming"
    );
    assert_eq!(r.command(1, Command::Stop).accepted, 1);
    r.run_for(0.2);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Stopping);
    for _ in 0..20 {
        r.command(1, Command::KeepAlive);
        r.run_for(0.25);
    }
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
    let straight = r
        .ctl
        .setpoints()
        .iter()
        .flatten()
        .all(|s| s.position.abs() < 1e-3);
    assert!(straight, "holding straight after the stop");
}

#[test]
fn operator_silence_stops_the_swim_smoothly() {
    let mut r = ready("lifecycle-silent");
    r.command(1, swim(1.0, 1.0));
    r.run_for(1.0);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Stopping);
    // Smoothly: amplitude ramps down rather than jumping to straight.
    assert!(r.ctl.snapshot().gait_actual.amplitude > 0.1);
    assert!(r.nodes.iter().all(|n| n.state() == NodeState::Enabled));
    r.run_for(6.0);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
}

#[test]
fn estop_from_any_client_disables_every_node_and_latches() {
    let mut r = ready("lifecycle-estop");
    r.command(1, swim(0.5, 1.0));
    r.run_for(0.3);
    // Client 2 does not hold control but can E-stop.
    assert_eq!(r.command(2, Command::Stop).accepted, 0);
    assert_eq!(r.command(2, Command::EStop).accepted, 1);
    r.run_for(0.05);
    assert_eq!(r.ctl.supervisor().mode(), Mode::EStop);
    assert!(r.nodes.iter().all(|n| n.state() == NodeState::EStop));
    assert_eq!(r.command(1, Command::Enable).accepted, 0, "latched");
    assert_eq!(r.command(1, Command::Reset).accepted, 1);
    r.run_for(0.5);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Idle);
    assert!(r.nodes.iter().all(|n| n.state() == NodeState::Disabled));
    assert_eq!(r.command(1, Command::Enable).accepted, 1);
    r.run_for(0.3);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
}

#[test]
fn an_estop_frame_on_the_bus_latches_the_daemon() {
    let mut r = ready("lifecycle-bus-estop");
    r.bus
        .inject(&anguilla_protocol::Frame::new_standard(0x000, &[]).unwrap());
    r.run_for(0.05);
    assert_eq!(r.ctl.supervisor().mode(), Mode::EStop);
    assert!(r.ctl.supervisor().faults().contains(FaultKind::BusEStop));
}

#[test]
fn a_silent_node_is_a_fault_naming_it() {
    let mut r = ready("lifecycle-heartbeat");
    r.command(1, swim(0.5, 1.0));
    r.run_for(0.3);
    r.nodes[6].set_silent(true);
    r.run_for(0.6);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault);
    let f = r.ctl.supervisor().faults();
    assert!(f.contains(FaultKind::HeartbeatLost));
    assert_eq!(f.nodes, 1 << 7, "node 7 is joint 7");
    // A reset is refused while it stays silent.
    assert_eq!(r.command(1, Command::Reset).accepted, 0);
}

#[test]
fn malformed_frames_are_counted_never_fatal() {
    let mut r = ready("lifecycle-malformed");
    for i in 0..50u16 {
        r.bus.inject(
            &anguilla_protocol::Frame::new_standard(0x7F0 + (i % 8), &[i as u8; 3]).unwrap(),
        );
    }
    r.run_for(0.1);
    assert_eq!(r.ctl.drives().counters().malformed, 50);
    assert_eq!(r.ctl.snapshot().bus.malformed, 50);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
}

#[test]
fn bus_off_is_a_fault_and_no_setpoints_are_sent_meanwhile() {
    use anguilla_drivers::{Bus, BusState};
    let mut r = ready("lifecycle-bus-off");
    r.command(1, swim(0.5, 1.0));
    r.run_for(0.3);
    let id = r.host.id();
    r.bus.force_state(id, BusState::BusOff);
    r.run_for(0.05);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault);
    assert!(r.ctl.supervisor().faults().contains(FaultKind::BusOff));
    let tx_before = r.host.counters().tx;
    r.run_for(0.1);
    assert_eq!(
        r.host.counters().tx,
        tx_before,
        "nothing sent while bus-off"
    );
    assert_eq!(
        r.command(1, Command::Reset).accepted,
        0,
        "refused while bus-off"
    );
    r.bus.force_state(id, BusState::ErrorActive);
    r.run_for(0.05);
    assert_eq!(r.command(1, Command::Reset).accepted, 1);
    r.run_for(0.5);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Idle);
}

#[test]
fn an_actuator_fault_stops_the_swim_and_names_the_node() {
    use anguilla_protocol::message::ErrorBits;
    let mut r = ready("lifecycle-node-fault");
    r.command(1, swim(0.5, 1.0));
    r.run_for(0.3);
    let mut out = Vec::new();
    let now = r.now;
    r.nodes[3].inject_fault(ErrorBits::OVER_TEMPERATURE, now, &mut |f| out.push(f));
    // The node's heartbeat reaches the bus with the rig's next step.
    for f in out {
        let _ = anguilla_drivers::Bus::send(&mut r.bus.participant(), &f);
    }
    r.run_for(0.2);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault);
    let f = r.ctl.supervisor().faults();
    assert!(f.contains(FaultKind::NodeFault));
    assert_eq!(f.nodes, 1 << 4, "node 4 is joint 4");
    // Default policy: the others hold (still enabled), gait ramps to rest.
    assert!(
        r.nodes
            .iter()
            .filter(|n| n.state() == NodeState::Enabled)
            .count()
            == 11
    );
    assert_eq!(r.ctl.snapshot().gait_target.amplitude, 0.0);
}

#[test]
fn a_diverging_model_drops_the_feedforward_and_faults() {
    let mut cfg = Config::default();
    // A gait far beyond anything physical: 20 /m curvature at 10 Hz.
    cfg.gait.amplitude_polynomial = [20.0, 20.0, 20.0];
    cfg.gait.max_frequency = 10.0;
    cfg.gait.amplitude_rate = 1000.0;
    cfg.gait.amplitude_accel = 1000.0;
    cfg.gait.frequency_rate = 1000.0;
    cfg.gait.frequency_accel = 1000.0;
    let mut r = Rig::new("lifecycle-model", &cfg);
    r.run_for(0.1);
    r.command(1, Command::TakeControl);
    r.command(1, Command::Enable);
    r.run_for(0.3);
    r.command(1, swim(1.0, 10.0));
    for _ in 0..30 {
        r.run_for(0.1);
        r.command(1, Command::KeepAlive);
        if r.ctl.supervisor().mode() == Mode::Fault {
            break;
        }
    }
    assert!(r.ctl.counters().model_failures > 0, "{:?}", r.ctl.report());
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault);
    assert!(
        r.ctl
            .supervisor()
            .faults()
            .contains(FaultKind::ModelDiverged)
    );
    r.run_for(0.1);
    assert!(r.ctl.snapshot().feedforward_dropped == 1);
    assert!(r.ctl.setpoints().iter().flatten().all(|s| s.torque == 0.0));
    assert!(
        r.ctl
            .setpoints()
            .iter()
            .flatten()
            .all(|s| s.position.is_finite())
    );
}

#[test]
fn setpoints_beyond_joint_limits_are_clamped_and_counted() {
    let mut cfg = Config::default();
    cfg.limits.angle = 0.05;
    cfg.limits.torque = 0.01;
    let mut r = Rig::new("lifecycle-limits", &cfg);
    r.run_for(0.1);
    r.command(1, Command::TakeControl);
    r.command(1, Command::Enable);
    r.run_for(0.3);
    assert_eq!(r.command(1, swim(1.0, 1.0)).accepted, 1);
    for _ in 0..10 {
        r.run_for(0.2);
        r.command(1, Command::KeepAlive);
        for s in r.ctl.setpoints().iter().flatten() {
            assert!(s.position.abs() <= 0.05 + 1e-6, "{s:?}");
            assert!(s.torque.abs() <= 0.01 + 1e-6, "{s:?}");
        }
    }
    let clamped = r.ctl.snapshot().clamped_setpoints;
    assert!(clamped > 100, "only {clamped} clamped");
    assert_eq!(
        r.ctl.supervisor().mode(),
        Mode::Swimming,
        "clamping is not a fault"
    );
    // The nodes apply what they were sent (within their own, wider limits).
    let worst = r
        .nodes
        .iter()
        .map(|n| n.active_setpoint()[1].position.abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 0.05 + 1e-3, "{worst}");
}

/// Setpoint frames seen by `spy` since the last call, per node id.
fn setpoints_seen(spy: &mut anguilla_drivers::mem::MemParticipant) -> [u32; 64] {
    use anguilla_drivers::Bus;
    use anguilla_protocol::message::{Message, NodeSet, Variant, decode};
    let mut seen = [0u32; 64];
    while let Ok(Some(r)) = spy.try_recv() {
        if let Ok(Message::Setpoint(s)) = decode(&r.frame, Variant::Classic, NodeSet::all()) {
            seen[s.node.get() as usize] += 1;
        }
    }
    seen
}

/// In Fault under the "hold" policy the daemon keeps only the nodes that
/// still answer busy: a silent node gets no setpoints (they would be load
/// on a bus that may be why it is silent), and with every node silent it
/// sends nothing but SYNC and Disable, so the heartbeats can come back and
/// a reset succeeds (a saturated bus once kept every node lost and the
/// reset refused forever).
#[test]
fn in_fault_the_daemon_does_not_fill_the_bus() {
    let mut r = ready("lifecycle-fault-traffic");
    let mut spy = r.bus.participant();
    r.command(1, swim(0.5, 1.0));
    r.run_for(0.3);
    r.nodes[6].set_silent(true);
    r.run_for(0.6);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Fault);
    setpoints_seen(&mut spy);
    r.run_for(0.2);
    let seen = setpoints_seen(&mut spy);
    assert_eq!(seen[7], 0, "the silent node gets no setpoints");
    for id in (1..=12).filter(|&i| i != 7) {
        assert!(
            seen[id] >= 15,
            "node {id} still held: {} setpoints",
            seen[id]
        );
    }
    // Every node silent: no setpoints at all.
    for n in &mut r.nodes {
        n.set_silent(true);
    }
    r.run_for(0.6);
    setpoints_seen(&mut spy);
    r.run_for(0.3);
    assert_eq!(setpoints_seen(&mut spy), [0; 64], "nothing to hold");
    assert_eq!(r.command(1, Command::Reset).accepted, 0, "still silent");
    // They answer again: the reset is accepted and the daemon is idle.
    for n in &mut r.nodes {
        n.set_silent(false);
    }
    r.run_for(0.3);
    assert_eq!(r.command(1, Command::Reset).accepted, 1);
    r.run_for(0.5);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Idle);
}

/// Sparse node ids on CAN FD: the daemon drives every node
/// through the setpoint group of its id, and the automatic rate is budgeted
/// for the group frames it actually sends (eleven for these twelve ids, not
/// the two that twelve contiguous ids take), so the bus stays within
/// `bus.max-load`.
#[test]
fn sparse_fd_ids_are_driven_and_budgeted_by_the_frames_sent() {
    use anguilla_drivers::Bus;
    use anguilla_protocol::budget::{Cadence, budget, control_traffic};
    use anguilla_protocol::message::{Message, NodeSet, Variant, decode};
    let mut cfg = Config::default();
    cfg.bus.fd = true;
    cfg.robot.node_ids = vec![1, 7, 13, 19, 25, 31, 37, 43, 49, 55, 60, 63];
    let rate = cfg.control_rate().expect("a rate within the budget");
    let nodes = cfg.node_set();
    assert!(budget(nodes, rate, cfg.bitrates()).unwrap().load <= cfg.bus.max_load + 1e-9);
    let Cadence::PerPeriod(budgeted) = control_traffic(Variant::Fd, nodes)[0].cadence else {
        panic!("setpoints are per period")
    };
    let mut r = Rig::new("lifecycle-sparse-fd", &cfg);
    let mut spy = r.bus.participant();
    r.run_for(0.1);
    assert_eq!(r.command(1, Command::TakeControl).accepted, 1);
    assert_eq!(r.command(1, Command::Enable).accepted, 1);
    r.run_for(0.3);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Ready);
    assert_eq!(r.command(1, swim(0.5, 1.0)).accepted, 1);
    r.run_for(0.5);
    assert_eq!(r.ctl.supervisor().mode(), Mode::Swimming);
    assert!(r.nodes.iter().all(|n| n.state() == NodeState::Enabled));
    while let Ok(Some(_)) = spy.try_recv() {}
    let (mut groups, mut syncs) = (0u32, 0u32);
    for _ in 0..10 {
        r.step();
    }
    while let Ok(Some(f)) = spy.try_recv() {
        match decode(&f.frame, Variant::Fd, NodeSet::all()) {
            Ok(Message::SetpointGroup(_)) => groups += 1,
            Ok(Message::Sync { .. }) => syncs += 1,
            _ => {}
        }
    }
    assert_eq!(syncs, 10);
    assert_eq!(groups, 10 * 11, "one frame per group of an id");
    assert_eq!(budgeted, 11, "the budget counts the frames sent");
}
