//! The robot in real time: behind an emulated SLCAN adapter on a
//! pseudo-terminal (as `anguilla sim --slcan-pty` runs it), a host opens the
//! device, enables the nodes and hears them answer.

use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::slcan::emulator::{EmulatorConfig, SlcanEmulator};
use anguilla_drivers::{Bus, open};
use anguilla_protocol::message::{self, Command, Message, NodeSet, NodeState, Target, Variant};
use anguilla_sim::{RobotConfig, SimRobot};

/// Waits (real time, bounded: the watchdog of this test, `limit` times the
/// patience) until `f` holds; `f` waits on the bus itself.
fn wait_for(what: &str, limit: Duration, mut f: impl FnMut() -> bool) {
    let deadline = anguilla_testkit::Deadline::new(limit);
    while !f() {
        assert!(
            !deadline.passed(),
            "timed out waiting for {what} ({:?})",
            deadline.limit()
        );
    }
}

#[test]
fn robot_behind_an_slcan_pty_answers_a_host() {
    let bus = MemBus::builder("sim-realtime-slcan")
        .bitrate(1_000_000)
        .build();
    let emu =
        SlcanEmulator::on_pty(Box::new(bus.participant()), EmulatorConfig::default()).expect("pty");
    let clock = bus.clock();
    let robot =
        SimRobot::on_mem(RobotConfig::with_joints(3), bus.participant(), clock.now()).unwrap();
    let running = robot.spawn(clock).unwrap();
    let spec = format!("slcan:{}@1000000", emu.path().unwrap());
    let mut host = open(&spec).unwrap();

    let mut states = [None; 3];
    let listen = |host: &mut Box<dyn Bus>, states: &mut [Option<NodeState>; 3]| {
        if let Ok(Some(r)) = host.recv(Duration::from_millis(20))
            && let Ok(Message::Heartbeat(hb)) =
                message::decode(&r.frame, Variant::Classic, NodeSet::all())
        {
            states[hb.node.get() as usize - 1] = Some(hb.state);
        }
    };
    wait_for("Disabled heartbeats", Duration::from_secs(20), || {
        listen(&mut host, &mut states);
        states.iter().all(|s| *s == Some(NodeState::Disabled))
    });
    let enable = Message::Command {
        target: Target::All,
        command: Command::Enable,
    }
    .encode(Variant::Classic)
    .unwrap();
    host.send(&enable).unwrap();
    wait_for("Enabled heartbeats", Duration::from_secs(20), || {
        listen(&mut host, &mut states);
        states.iter().all(|s| *s == Some(NodeState::Enabled))
    });
    // The heartbeats leave as the nodes change state; the status is taken
    // at the end of the robot's tick, a moment later: wait for it (a busy
    // machine can put the host's read in between), listening to the bus
    // meanwhile (each try waits for its next frame, at most 20 ms).
    wait_for(
        "the status showing 3 nodes enabled",
        Duration::from_secs(20),
        || {
            listen(&mut host, &mut states);
            running.status().states[2] == 3
        },
    );
    let robot = running.stop().expect("the simulation thread returns");
    assert!(robot.stats().frames_in >= 1);
    assert_eq!(robot.stats().model_errors, 0);
}
