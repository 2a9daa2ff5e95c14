//! A robot of ODrive joints allocates nothing in steady state either: the
//! ODrive emulation's receive and advance (and the robot around them) are
//! as allocation-free as the vertebra node's.

mod common;

use std::time::Duration;

use anguilla_drivers::{Bus, Clock};
use anguilla_protocol::Family;
use anguilla_protocol::frame::Frame;
use anguilla_protocol::odrive::{
    AxisState, Body, Cmd, ControlMode, InputMode, InputPos, Message, NodeId, arbitration_id,
};
use anguilla_sim::RobotConfig;
use common::Host;

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

const JOINTS: usize = 6;

fn frame(node: u8, body: Body) -> Frame {
    Message {
        node: NodeId::new(node).unwrap(),
        body,
    }
    .encode()
    .unwrap()
}

#[test]
fn an_odrive_robot_allocates_nothing_in_steady_state() {
    let cfg = RobotConfig {
        drive: Family::Odrive,
        ..RobotConfig::with_joints(JOINTS)
    };
    let ids: Vec<u8> = (0..JOINTS).flat_map(|j| cfg.drive_ids(j)).collect();
    let Host {
        clock,
        mut host,
        mut robot,
        ..
    } = Host::new(cfg);
    let period = |k: u32,
                  robot: &mut anguilla_sim::SimRobot,
                  host: &mut anguilla_drivers::mem::MemParticipant| {
        for (i, &id) in ids.iter().enumerate() {
            let angle = 0.03 * ((k as f32) * 0.02 + i as f32).sin();
            let input = InputPos {
                input_pos: angle,
                vel_ff: 0.0,
                torque_ff: 0.0,
            };
            host.send(&frame(id, Body::SetInputPos(input))).unwrap();
        }
        // A request and a junk frame too: answers and bad frames are on
        // the path measured.
        let hb = arbitration_id(NodeId::new(ids[0]).unwrap(), Cmd::Heartbeat);
        host.send(&Frame::new_remote(hb.into(), 8).unwrap())
            .unwrap();
        let junk = u16::from(ids[1]) << 5 | u16::from(Cmd::SetInputPos.id());
        host.send(&Frame::new_standard(junk, &[1, 2]).unwrap())
            .unwrap();
        clock.advance(Duration::from_millis(2));
        robot.step_until(clock.now());
        host.drain(&mut |_| {}).unwrap();
    };
    for k in 0..40 {
        if k == 30 {
            for &id in &ids {
                let mode = Body::SetControllerMode {
                    control_mode: ControlMode::PositionControl,
                    input_mode: InputMode::Passthrough,
                };
                host.send(&frame(id, mode)).unwrap();
                let closed = Body::SetAxisState(AxisState::ClosedLoopControl);
                host.send(&frame(id, closed)).unwrap();
            }
        }
        period(k, &mut robot, &mut host);
    }
    // Warm up (queues reach their working size).
    for k in 40..300 {
        period(k, &mut robot, &mut host);
    }
    assert_eq!(robot.state_counts()[2], JOINTS);
    let ((), n) = anguilla_testkit::count(|| {
        for k in 300..800 {
            period(k, &mut robot, &mut host);
        }
    });
    assert_eq!(n, 0, "{n} allocator calls in 500 periods (1 s)");
    assert_eq!(robot.state_counts()[2], JOINTS, "still enabled");
    // One junk frame a period, heard from the end of the boot (20 ms).
    let bad = robot.nodes()[0].counters().bad_frames;
    assert!((780..=800).contains(&bad), "{bad} bad frames counted");
}
