//! Every drive family end to end: the daemon's real-time loop and the
//! simulated robot whose joints are anguilla vertebra nodes, CiA 402
//! drives, ODrive axes or MIT-mode drives (`[robot] drive`), on the in-process bus with CAN
//! wire time. The same operator session and the same faults, whatever the
//! family: the supervisor, the modes and the watchdogs do not change.
//!
//! Over SLCAN ptys (separate processes) the families are run by
//! `processes_slcan.rs`, on vcan in the VM by `vcan_daemon.rs`.

use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_ipc::{Command, FaultKind, Mode};
use anguilla_protocol::Family;
use anguilla_system_tests::Robot;
use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::{F1, connect, keep_alive_for, ok, tracking, wait_for};

const JOINTS: usize = 6;

fn config(drive: Family, name: &str) -> Config {
    anguilla_system_tests::family_config(drive, JOINTS, "families", name)
}

/// Node state codes of the snapshot (protocol `NodeState`).
const DISABLED: u8 = 1;
const ENABLED: u8 = 2;

fn swims_stops_and_estops(drive: Family, name: &str) {
    let _wd = Watchdog::new(name, Duration::from_secs(120));
    let cfg = config(drive, name);
    let robot = Robot::start_with(cfg.clone()).expect("daemon and robot start");
    let mut client = connect(&robot.prefix, name);
    // Every joint's drives booted (CiA 402: configured by SDO) and report
    // Disabled.
    wait_for(&mut client, "every joint alive and disabled", 15.0, |s| {
        s.joints[..JOINTS]
            .iter()
            .all(|j| j.node_alive == 1 && j.node_state == DISABLED)
    });
    anguilla_system_tests::process::take_control_and_enable(&mut client, 5.0);
    let forward = F1;
    ok(&mut client, forward);
    keep_alive_for(&mut client, 3.0, |_| {});
    // The joints follow their setpoints, and the measured angles the
    // family's master reports are the simulated joints' angles: the tail's
    // measured yaw against its command at the lag that fits best (a CiA
    // 402 position comes from the TPDO sampled at the previous SYNC, one
    // period behind; a starved machine adds more). The bound is about a
    // third of the tail's swing (F1 bends it by ~0.25 rad): a joint that
    // does not follow or a wrong conversion (a sign, a gear) exceeds it.
    let (worst, lag, n) = tracking(&mut client, JOINTS - 1, 2.0, forward);
    assert!(
        worst < 0.08,
        "{drive:?}: tail yaw tracking error {worst} rad (median) at its best lag {lag} ms ({n} states)"
    );
    let s = wait_for(&mut client, "a state", 5.0, |_| true);
    assert_eq!(s.mode, Mode::Swimming as u8, "{drive:?}");
    let truth = robot.truth();
    // At rest the speed is 0; every family measured 0.55-0.56 m/s here
    // (0.553 predicted). The bound says "swims head first", the printed
    // figure says how fast.
    assert!(
        truth.forward_speed > 0.05,
        "{drive:?}: simulated speed {} m/s after 5 s of F1",
        truth.forward_speed
    );
    assert!(
        s.joints[..JOINTS]
            .iter()
            .all(|j| j.node_state == ENABLED && j.node_alive == 1)
    );
    eprintln!(
        "{drive:?}: after 5 s of F1 the simulated robot swims at {:.3} m/s (predicted {:.3}), \
         tail yaw tracking {worst:.3} rad (median) at {lag} ms",
        truth.forward_speed, s.predicted_head_speed
    );
    // A smooth stop back to Ready.
    ok(&mut client, Command::Stop);
    wait_for(&mut client, "Ready after stop", 15.0, |s| {
        s.mode == Mode::Ready as u8
    });
    // E-stop: latched, every drive stops being enabled.
    ok(&mut client, Command::EStop);
    let s = wait_for(&mut client, "drives off after the E-stop", 3.0, |s| {
        s.mode == Mode::EStop as u8 && s.joints[..JOINTS].iter().all(|j| j.node_state != ENABLED)
    });
    assert_eq!(s.mode, Mode::EStop as u8);
    keep_alive_for(&mut client, 0.5, |s| {
        assert_eq!(s.mode, Mode::EStop as u8, "the E-stop stays latched");
    });
}

/// Heartbeat loss and a drive fault from the robot's side, bus-off on the
/// daemon's: the daemon faults with the right kinds and names the joints.
fn faults_are_reported(drive: Family, name: &str) {
    let _wd = Watchdog::new(name, Duration::from_secs(120));
    let mut cfg = config(drive, name);
    // Joint 2's drives fall silent for 4 s (a CiA 402 drive also misses
    // the master's heartbeat meanwhile, and faults: EMCY 0x8130); joint 4's
    // drives fault. A heartbeat timeout of 1.5 s (not 0.35): on a starved
    // machine the simulated robot's thread can stall long enough for every
    // joint to look lost, and the test is about naming joint 2 alone.
    cfg.control.heartbeat_timeout = 1.5;
    let scenario = "2.0 node 2 silent 4.0\n6.5 node 4 fault\n";
    let robot = Robot::start_with_scenario(cfg, scenario).expect("daemon and robot start");
    let mut client = connect(&robot.prefix, name);
    wait_for(&mut client, "every joint alive and disabled", 15.0, |s| {
        s.joints[..JOINTS]
            .iter()
            .all(|j| j.node_alive == 1 && j.node_state == DISABLED)
    });
    let lost = wait_for(&mut client, "heartbeat loss of joint 2", 10.0, |s| {
        s.fault_kinds & FaultKind::HeartbeatLost as u32 != 0
    });
    // (In Idle the fault is latched and reported; there is nothing to stop.)
    assert_eq!(lost.fault_nodes, 1 << 2, "{drive:?}: joint 2 named");
    assert_eq!(lost.joints[1].node_alive, 0);
    let fault = wait_for(&mut client, "drive fault of joint 4", 10.0, |s| {
        s.fault_kinds & FaultKind::NodeFault as u32 != 0 && s.joints[3].node_state == 3
    });
    assert_ne!(fault.fault_nodes & 1 << 4, 0, "{drive:?}: joint 4 named");
    assert_eq!(fault.joints[3].node_state, 3, "{drive:?}: joint 4 in Fault");
    assert_ne!(
        fault.joints[3].node_errors, 0,
        "{drive:?}: the drive's code"
    );
    robot.force_daemon_bus(anguilla_drivers::BusState::BusOff);
    let off = wait_for(&mut client, "bus-off", 10.0, |s| {
        s.fault_kinds & FaultKind::BusOff as u32 != 0
    });
    assert_eq!(
        off.mode,
        Mode::Fault as u8,
        "{drive:?}: bus-off faults even in Idle"
    );
    robot.force_daemon_bus(anguilla_drivers::BusState::ErrorActive);
    eprintln!(
        "{drive:?}: heartbeat loss, drive fault (code {:#x}) and bus-off reported",
        fault.joints[3].node_errors
    );
}

#[test]
fn anguilla_nodes_swim_stop_and_estop() {
    swims_stops_and_estops(Family::Anguilla, "swim-anguilla");
}

#[test]
fn cia402_drives_swim_stop_and_estop() {
    swims_stops_and_estops(Family::Cia402, "swim-cia402");
}

#[test]
fn odrive_axes_swim_stop_and_estop() {
    swims_stops_and_estops(Family::Odrive, "swim-odrive");
}

#[test]
fn mit_drives_swim_stop_and_estop() {
    swims_stops_and_estops(Family::Mit, "swim-mit");
}

#[test]
fn anguilla_faults_are_reported() {
    faults_are_reported(Family::Anguilla, "faults-anguilla");
}

#[test]
fn cia402_faults_are_reported() {
    faults_are_reported(Family::Cia402, "faults-cia402");
}

#[test]
fn odrive_faults_are_reported() {
    faults_are_reported(Family::Odrive, "faults-odrive");
}

#[test]
fn mit_faults_are_reported() {
    faults_are_reported(Family::Mit, "faults-mit");
}

/// Every family has its two tests above: a new family without them fails
/// here.
#[test]
fn every_family_is_tested() {
    let this = include_str!("families.rs");
    for f in Family::ALL {
        for test in ["_swim_stop_and_estop() {", "_faults_are_reported() {"] {
            let name = f.name();
            assert!(
                this.lines()
                    .any(|l| l.starts_with("fn ") && l.contains(name) && l.ends_with(test)),
                "no test named fn {name}…{test} for {f}"
            );
        }
    }
}

/// What a drive family owes the tests beyond the two above, by file (from
/// the workspace's root): a property test of its codec, a fuzz target of
/// its decoder (built and run by CI), and a test that a simulated robot of
/// its joints allocates nothing in steady state. The match is exhaustive:
/// a new family does not compile until it names its own, and
/// `every_family_owes_a_proptest_a_fuzz_target_and_a_no_allocation_test`
/// checks that they are there and what they claim.
struct Owed {
    /// The file with the codec's `proptest!`.
    codec_proptest: &'static str,
    /// The fuzz target's name (`fuzz/fuzz_targets/<name>.rs`).
    fuzz_target: &'static str,
    /// The simulator's counting-allocator test.
    sim_no_alloc: &'static str,
    /// What that test counts: a robot of the family's joints, or one joint.
    sim_subject: &'static str,
}

fn owed(f: Family) -> Owed {
    match f {
        Family::Anguilla => Owed {
            codec_proptest: "protocol/tests/codec.rs",
            fuzz_target: "decode",
            sim_no_alloc: "sim-backend/tests/no_alloc.rs",
            sim_subject: "SimRobot::on_mem",
        },
        Family::Cia402 => Owed {
            codec_proptest: "protocol/src/canopen/tests.rs",
            fuzz_target: "canopen",
            sim_no_alloc: "sim-backend/tests/cia402_no_alloc.rs",
            sim_subject: "Cia402Joint::new",
        },
        Family::Odrive => Owed {
            codec_proptest: "protocol/src/odrive/tests.rs",
            fuzz_target: "odrive",
            sim_no_alloc: "sim-backend/tests/odrive_no_alloc.rs",
            sim_subject: "Family::Odrive",
        },
        Family::Mit => Owed {
            codec_proptest: "protocol/src/mit/tests.rs",
            fuzz_target: "mit",
            sim_no_alloc: "sim-backend/tests/mit_no_alloc.rs",
            sim_subject: "Family::Mit",
        },
    }
}

#[test]
fn every_family_owes_a_proptest_a_fuzz_target_and_a_no_allocation_test() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let read = |path: &str| {
        std::fs::read_to_string(root.join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
    };
    let fuzz_manifest = read("fuzz/Cargo.toml");
    let ci = read(".ci/run");
    let ci_targets = ci
        .lines()
        .find_map(|l| l.trim().strip_prefix("for target in "))
        .expect(".ci/run lists the fuzz targets it runs (`for target in …`)");
    for f in Family::ALL {
        let o = owed(f);
        let proptest = read(o.codec_proptest);
        assert!(
            proptest.contains("proptest!") && proptest.contains("decode("),
            "{f}: {} has no proptest! of its decoder",
            o.codec_proptest
        );
        let target = format!("fuzz/fuzz_targets/{}.rs", o.fuzz_target);
        assert!(
            read(&target).contains("fuzz_target!"),
            "{f}: {target} is no fuzz target"
        );
        assert!(
            fuzz_manifest.contains(&format!("name = \"{}\"", o.fuzz_target)),
            "{f}: fuzz/Cargo.toml has no [[bin]] {}",
            o.fuzz_target
        );
        assert!(
            ci_targets.split_whitespace().any(|t| t == o.fuzz_target),
            "{f}: .ci/run does not fuzz {} ({ci_targets})",
            o.fuzz_target
        );
        let seeds = root.join("fuzz/seeds").join(o.fuzz_target);
        assert!(
            std::fs::read_dir(&seeds).is_ok_and(|mut d| d.next().is_some()),
            "{f}: no seed in {}",
            seeds.display()
        );
        let no_alloc = read(o.sim_no_alloc);
        assert!(
            no_alloc.contains("anguilla_testkit::count(")
                && no_alloc.contains("CountingAlloc")
                && no_alloc.contains(o.sim_subject),
            "{f}: {} counts no allocations of {}",
            o.sim_no_alloc,
            o.sim_subject
        );
    }
}
