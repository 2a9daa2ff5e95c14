//! A robot of MIT-mode joints allocates nothing in steady state either:
//! the MIT emulation's receive and advance (and the robot around them) are
//! as allocation-free as the vertebra node's.

mod common;

use std::time::Duration;

use anguilla_drivers::{Bus, Clock};
use anguilla_protocol::Family;
use anguilla_protocol::frame::Frame;
use anguilla_protocol::mit::{Body, Command, DEFAULT_RANGES, Message, NodeId};
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
    .encode(&DEFAULT_RANGES)
    .unwrap()
}

#[test]
fn an_mit_robot_allocates_nothing_in_steady_state() {
    let cfg = RobotConfig {
        drive: Family::Mit,
        ..RobotConfig::with_joints(JOINTS)
    };
    let ids: Vec<u8> = (0..JOINTS).flat_map(|j| cfg.drive_ids(j)).collect();
    let Host {
        clock,
        mut host,
        mut robot,
        ..
    } = Host::new(cfg);
    let mut replies = 0u64;
    let mut period = |k: u32,
                      robot: &mut anguilla_sim::SimRobot,
                      host: &mut anguilla_drivers::mem::MemParticipant| {
        for (i, &id) in ids.iter().enumerate() {
            let angle = 0.03 * ((k as f32) * 0.02 + i as f32).sin();
            let c = Command {
                position: angle,
                velocity: 0.0,
                kp: 40.0,
                kd: 1.2,
                torque: 0.0,
            };
            host.send(&frame(id, Body::Command(c))).unwrap();
        }
        // A junk frame on a drive's id too (a command of 2 bytes): bad
        // frames are on the path measured.
        host.send(&Frame::new_standard(u16::from(ids[1]), &[1, 2]).unwrap())
            .unwrap();
        clock.advance(Duration::from_millis(2));
        robot.step_until(clock.now());
        host.drain(&mut |_| replies += 1).unwrap();
    };
    for k in 0..40 {
        if k == 30 {
            for &id in &ids {
                host.send(&frame(id, Body::EnterMotorMode)).unwrap();
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
    // Every drive answers each command: 12 replies a period at least.
    assert!(
        replies >= 800 * 2 * JOINTS as u64 - 40 * 12,
        "{replies} replies"
    );
    // One junk frame a period, heard from the end of the boot.
    let bad = robot.nodes()[0].counters().bad_frames;
    assert!((700..=800).contains(&bad), "{bad} bad frames counted");
}
