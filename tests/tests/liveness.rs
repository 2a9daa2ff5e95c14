//! A dead joint is never masked, whoever sends heartbeats for it: a joint's drives are
//! judged alive by the feedback they send each period, not only by their
//! heartbeats, and two senders on one id are told apart by the heartbeat
//! counter.
//!
//! Each attack runs on the built-in robot (the daemon's real loop, the
//! in-process bus with CAN wire time) while the robot swims:
//! - `spoof`: joint 3's drives die and another sender forges their
//!   heartbeats, in the state the other joints report, counters advancing
//!   by one (before this issue the robot swam on with a dead joint);
//! - `twin`: a second node configured to id 3 (anguilla nodes: the only
//!   family whose heartbeats carry a counter).
//!
//! Over SLCAN (separate processes) the same scenarios run in
//! `processes_slcan.rs`.

use std::time::Duration;

use anguilla_ipc::{Command, FaultKind, Mode, SwimParams};
use anguilla_protocol::Family;
use anguilla_sim::scenario::{Action, NodeFault};
use anguilla_system_tests::process::{
    REPLY, connect, ok, poll_until, take_control_and_enable, wait_for,
};
use anguilla_system_tests::{Robot, Watchdog, family_config};

const JOINTS: usize = 6;
const DISABLED: u8 = 1;

/// The robot of `drive`'s family, swimming F1 at full amplitude, and the
/// client that holds control.
fn swimming(drive: Family, name: &str) -> (Robot, anguilla_ipc::Client) {
    let cfg = family_config(drive, JOINTS, "liveness", name);
    let robot = Robot::start_with(cfg).expect("daemon and robot start");
    let mut client = connect(&robot.prefix, name);
    wait_for(&mut client, "every joint alive and disabled", 15.0, |s| {
        s.joints[..JOINTS]
            .iter()
            .all(|j| j.node_alive == 1 && j.node_state == DISABLED)
    });
    take_control_and_enable(&mut client, 5.0);
    ok(
        &mut client,
        Command::Swim(SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        }),
    );
    wait_for(&mut client, "Swimming", 5.0, |s| {
        s.mode == Mode::Swimming as u8
    });
    (robot, client)
}

/// Starts the robot, swims, applies `fault` to joint 3 and waits for the
/// daemon's fault of `kind`, naming joint 3 and not its heartbeats; then
/// checks that reset and enable are refused while the cause lasts.
fn swim_then(drive: Family, name: &str, fault: NodeFault, kind: FaultKind) {
    let _wd = Watchdog::new(name, Duration::from_secs(120));
    let (robot, mut client) = swimming(drive, name);
    robot.inject(Action::Node { id: 3, fault });
    let s = wait_for(&mut client, kind.name(), 5.0, |s| {
        s.fault_kinds & kind as u32 != 0
    });
    assert_eq!(s.fault_nodes, 1 << 3, "{drive}: joint 3 named: {s:?}");
    assert_eq!(
        s.fault_kinds & FaultKind::HeartbeatLost as u32,
        0,
        "{drive}: the heartbeats go on; only what the joint does gives it away"
    );
    let s = wait_for(&mut client, "Fault", 2.0, |s| s.mode == Mode::Fault as u8);
    // The reset is refused while the cause lasts, naming it.
    let r = client.request(Command::Reset, REPLY).expect("reply");
    assert_eq!(
        r.accepted,
        0,
        "{drive}: reset accepted with {}",
        kind.name()
    );
    assert!(
        r.reason().contains(kind.name()) && r.reason().contains("node 3"),
        "{drive}: {}",
        r.reason()
    );
    eprintln!(
        "{drive}: {} of joint 3 found while swimming; mode {}, reset refused: {}",
        kind.name(),
        s.mode,
        r.reason()
    );
    // And enabling again cannot get past it.
    let r = client.request(Command::Enable, REPLY).expect("reply");
    assert_eq!(r.accepted, 0, "{drive}: enable in Fault");
}

#[test]
fn anguilla_a_dead_node_with_forged_heartbeats_faults() {
    swim_then(
        Family::Anguilla,
        "spoof-anguilla",
        NodeFault::Spoof,
        FaultKind::FeedbackLost,
    );
}

#[test]
fn cia402_a_dead_drive_with_forged_heartbeats_faults() {
    swim_then(
        Family::Cia402,
        "spoof-cia402",
        NodeFault::Spoof,
        FaultKind::FeedbackLost,
    );
}

#[test]
fn odrive_a_dead_axis_with_forged_heartbeats_faults() {
    swim_then(
        Family::Odrive,
        "spoof-odrive",
        NodeFault::Spoof,
        FaultKind::FeedbackLost,
    );
}

#[test]
fn anguilla_two_nodes_on_one_id_fault() {
    swim_then(
        Family::Anguilla,
        "twin-anguilla",
        NodeFault::Twin,
        FaultKind::DuplicateNode,
    );
}

/// Joint 3's drives reboot mid-swim (issue 45: the robot swam on with the
/// joint limp, its state shown as Boot or Disabled and no fault): a fault
/// naming joint 3 and what it reported. Not a lasting cause: once the
/// drives answer again, the reset goes through and the robot enables.
fn reboot_mid_swim(drive: Family, name: &str) {
    let _wd = Watchdog::new(name, Duration::from_secs(120));
    let (robot, mut client) = swimming(drive, name);
    robot.inject(Action::Node {
        id: 3,
        fault: NodeFault::Reboot,
    });
    let limp = FaultKind::NodeRebooted as u32 | FaultKind::NodeDisabled as u32;
    let s = wait_for(&mut client, "a fault for a limp joint", 5.0, |s| {
        s.fault_kinds & limp != 0
    });
    assert_eq!(s.fault_nodes, 1 << 3, "{drive}: joint 3 named: {s:?}");
    assert_eq!(
        s.fault_kinds & !limp,
        0,
        "{drive}: nothing but the limp joint: {s:?}"
    );
    wait_for(&mut client, "Fault", 2.0, |s| s.mode == Mode::Fault as u8);
    // Refused while the drives still boot ("heartbeat lost" for a
    // moment, on a busy machine); accepted once they answer.
    poll_until("the reset accepted", Duration::from_secs(5), || {
        let r = client.request(Command::Reset, REPLY).expect("reply");
        (r.accepted == 1).then_some(())
    });
    take_control_and_enable(&mut client, 5.0);
    eprintln!(
        "{drive}: joint 3 rebooted mid-swim: fault {}, reset and enabled again",
        anguilla_ipc::FaultSet {
            kinds: s.fault_kinds,
            nodes: s.fault_nodes
        }
    );
}

#[test]
fn anguilla_a_node_rebooting_mid_swim_faults() {
    reboot_mid_swim(Family::Anguilla, "reboot-anguilla");
}

#[test]
fn cia402_a_drive_rebooting_mid_swim_faults() {
    reboot_mid_swim(Family::Cia402, "reboot-cia402");
}

#[test]
fn odrive_an_axis_rebooting_mid_swim_faults() {
    reboot_mid_swim(Family::Odrive, "reboot-odrive");
}

/// One foreign frame, `cansend can0 083#02` (Command to node 3: Disable),
/// mid-swim: node 3 obeys it and goes limp; before issue 45 the daemon only
/// counted it and the robot swam on. Now an E-stop from the bus, naming
/// node 3 (the other families' commands: `daemon/tests/limp.rs`).
#[test]
fn anguilla_a_foreign_one_byte_disable_mid_swim_estops() {
    let name = "foreign-disable-anguilla";
    let _wd = Watchdog::new(name, Duration::from_secs(120));
    let (robot, mut client) = swimming(Family::Anguilla, name);
    let disable = anguilla_protocol::frame::Frame::new_standard(0x083, &[0x02]).unwrap();
    robot.send_foreign(&disable);
    let s = wait_for(&mut client, "E-stop", 5.0, |s| s.mode == Mode::EStop as u8);
    let faults = anguilla_ipc::FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    // Node 3 says it is disabled at once: when its heartbeat arrives in
    // the frame's period, "actuator disabled" is latched with it.
    let expected = FaultKind::ForeignCommand as u32 | FaultKind::NodeDisabled as u32;
    assert!(
        faults.contains(FaultKind::ForeignCommand) && s.fault_kinds & !expected == 0,
        "{faults}"
    );
    assert_eq!(s.fault_nodes, 1 << 3, "node 3 named: {faults}");
    let s = wait_for(&mut client, "every node off", 3.0, |s| {
        s.joints[..JOINTS].iter().all(|j| j.node_state != 2)
    });
    assert_eq!(s.mode, Mode::EStop as u8, "latched");
}

/// The false-positive check of the second line (`anguilla_daemon::tracking`)
/// and the figure its band is set from: every family's built-in robot (the
/// swimming body's loads, the family's servo) swims at full amplitude and
/// the largest frequency, turn and pitch the configuration accepts, then
/// stops; no fault, and the worst tracking error the loop measured on
/// fresh feedback is printed (set `TRACKING_BAND` from it) and must stay
/// under three quarters of the band (CiA 402 measured 0.182 rad of 0.3).
#[test]
fn healthy_tracking_error_of_every_family() {
    use anguilla_daemon::tracking::TRACKING_BAND;
    let _wd = Watchdog::new("healthy-tracking", Duration::from_secs(300));
    for drive in Family::ALL {
        let name = format!("healthy-tracking-{}", drive.name());
        let (robot, mut client) = swimming(drive, &name);
        let g = &robot.config.gait;
        let gaits = [
            (g.max_frequency, 0.0, 0.0),
            (g.max_frequency, g.max_turn, 0.0),
            (g.max_frequency, -g.max_turn, g.max_pitch),
            (1.0, 0.0, -g.max_pitch),
        ];
        for (frequency, turn, pitch) in gaits {
            ok(
                &mut client,
                Command::Swim(SwimParams {
                    amplitude: 1.0,
                    frequency,
                    turn,
                    pitch,
                }),
            );
            anguilla_system_tests::process::keep_alive_for(&mut client, 2.0, |s| {
                assert_eq!(
                    s.fault_kinds,
                    0,
                    "{drive}: {}",
                    anguilla_ipc::FaultSet {
                        kinds: s.fault_kinds,
                        nodes: s.fault_nodes
                    }
                );
            });
        }
        ok(&mut client, Command::Stop);
        wait_for(&mut client, "Ready after the stop", 15.0, |s| {
            s.mode == Mode::Ready as u8 && s.fault_kinds == 0
        });
        drop(client);
        let report = robot.stop();
        let worst = report.worst_tracking_error;
        eprintln!("{drive}: worst tracking error {worst:.3} rad (band {TRACKING_BAND} rad)");
        assert!(worst > 0.0, "{drive}: judged");
        // Well inside the band. CiA 402's interpolated position mode lags
        // the most, and more on a loaded machine (the built-in robot is
        // not real-time here): 0.18 rad under stress-ng's two CPU hogs,
        // 0.245 under CI's builds, 0.06 to 0.08 for the others.
        assert!(worst < 0.9 * TRACKING_BAND, "{drive}: {worst} rad");
    }
}
