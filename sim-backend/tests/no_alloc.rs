//! In steady state `SimRobot::step_until` allocates nothing, so an
//! in-process robot does not disturb the daemon's allocation-free control
//! period (nor its counting-allocator tests).

use std::sync::Arc;
use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::{Bus, Clock, ManualClock};
use anguilla_protocol::message::{self, AxisSetpoint, Command, Message, Target, Variant};
use anguilla_sim::{RobotConfig, SimRobot};

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

#[test]
fn step_until_allocates_nothing_in_steady_state() {
    let clock = ManualClock::new();
    let bus = MemBus::builder("sim-no-alloc")
        .clock(Arc::new(clock.clone()))
        .build();
    let mut host = bus.participant();
    let mut robot = SimRobot::on_mem(
        RobotConfig::with_joints(12),
        bus.participant(),
        Duration::ZERO,
    )
    .unwrap();
    // the water changes twice inside the counted periods (0.6-1.6 s)
    robot
        .load_scenario("0.7 water current 0.1 0\n1.2 water current 0 -0.1 0.02")
        .unwrap();
    let enable = Message::Command {
        target: Target::All,
        command: Command::Enable,
    }
    .encode(Variant::Classic)
    .unwrap();
    let mut setpoints = [[AxisSetpoint::default(); 2]; 12];
    let mut cycle =
        |k: u16, robot: &mut SimRobot, host: &mut anguilla_drivers::mem::MemParticipant| {
            for (j, sp) in setpoints.iter_mut().enumerate() {
                sp[1].position = 0.2 * ((k as f32) * 0.01 + j as f32).sin();
            }
            message::encode_setpoints(
                Variant::Classic,
                k,
                message::from_node_one(&setpoints),
                |f| host.send(&f).unwrap(),
            )
            .unwrap();
            let sync = Message::Sync { counter: k }
                .encode(Variant::Classic)
                .unwrap();
            host.send(&sync).unwrap();
            clock.advance(Duration::from_millis(2));
            robot.step_until(clock.now());
            host.drain(&mut |_| {}).unwrap();
        };
    for k in 0..20 {
        if k == 10 {
            host.send(&enable).unwrap();
        }
        cycle(k, &mut robot, &mut host);
    }
    // Warm up (first heartbeats, queues reach their working size).
    for k in 20..300 {
        cycle(k, &mut robot, &mut host);
    }
    assert_eq!(robot.state_counts()[2], 12);
    let ((), n) = anguilla_testkit::count(|| {
        for k in 300..800 {
            cycle(k, &mut robot, &mut host);
        }
    });
    assert_eq!(n, 0, "{n} allocator calls in 500 control periods (1 s)");
    assert_eq!(
        robot.current(),
        anguilla_model::Current::steady([0.0, -0.1, 0.02]).unwrap(),
        "the scenario's currents were applied"
    );
}

#[test]
fn a_robot_with_a_head_sensor_allocates_nothing_in_steady_state() {
    let clock = ManualClock::new();
    let bus = MemBus::builder("sim-no-alloc-sensor")
        .clock(Arc::new(clock.clone()))
        .build();
    let mut host = bus.participant();
    for (variant, latency) in [(Variant::Classic, 4), (Variant::Fd, 0)] {
        let mut robot = SimRobot::on_mem(
            RobotConfig {
                variant,
                head_sensor: Some(anguilla_sim::sensor::SensorConfig {
                    latency_samples: latency,
                    ..anguilla_sim::sensor::SensorConfig::typical(40)
                }),
                ..RobotConfig::with_joints(12)
            },
            bus.participant(),
            clock.now(),
        )
        .unwrap();
        robot
            .load_scenario("0.3 sensor stuck\n0.35 sensor ok\n0.4 sensor bias-jump 0.1\n")
            .unwrap();
        let mut frames = 0usize;
        let mut step = |robot: &mut SimRobot, frames: &mut usize| {
            clock.advance(Duration::from_millis(2));
            robot.step_until(clock.now());
            host.drain(&mut |_| *frames += 1).unwrap();
        };
        // Warm-up: buffers reach their steady size.
        for _ in 0..100 {
            step(&mut robot, &mut frames);
        }
        // Samples, latency ring, heartbeats and the scripted faults.
        let ((), calls) = anguilla_testkit::count(|| {
            for _ in 0..250 {
                step(&mut robot, &mut frames);
            }
        });
        assert_eq!(calls, 0, "{variant}: the sensor's period allocated");
        assert!(robot.head_sensor().unwrap().samples_sent() >= 40);
        assert!(frames > 0);
    }
}
