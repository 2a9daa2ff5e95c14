//! How much faster than real time the simulated robot runs.
//!
//! `cargo run --release -p anguilla-sim --example speed [JOINTS] [SECONDS]`
//!
//! A host on a ManualClock sends gait F1's joint angles and rates as
//! setpoints + SYNC every 2 ms to the robot (servos with dynamics, default
//! 12 joints) for SECONDS (default 10) of simulated time; only the robot's
//! `step_until` is timed. Prints one JSON line.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::{Bus, Clock, ManualClock};
use anguilla_model::gait::named_gait;
use anguilla_model::{LawSource, Model, ModelConfig, Workspace, posture};
use anguilla_protocol::message::{self, AxisSetpoint, Command, Message, Target, Variant};
use anguilla_sim::{RobotConfig, SimRobot};

fn main() {
    let mut args = std::env::args().skip(1);
    let joints: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(12);
    let seconds: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(10.0);
    let period = Duration::from_millis(2);
    let clock = ManualClock::new();
    let bus = MemBus::builder("speed")
        .clock(Arc::new(clock.clone()))
        .build();
    let mut host = bus.participant();
    let cfg = RobotConfig::with_joints(joints);
    let mut robot = SimRobot::on_mem(cfg.clone(), bus.participant(), Duration::ZERO).unwrap();
    let model = Model::new(ModelConfig {
        joints,
        dt: period.as_secs_f64(),
        nodes: cfg.model_nodes,
        ..ModelConfig::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut src = LawSource::new(named_gait("F1").unwrap().law);

    let mut busy = Duration::ZERO;
    let mut step = |robot: &mut SimRobot, clock: &ManualClock| {
        clock.advance(period);
        let t0 = Instant::now();
        robot.step_until(clock.now());
        busy += t0.elapsed();
    };
    for _ in 0..20 {
        step(&mut robot, &clock);
    }
    let enable = Message::Command {
        target: Target::All,
        command: Command::Enable,
    };
    host.send(&enable.encode(Variant::Classic).unwrap())
        .unwrap();
    let steps = (seconds / period.as_secs_f64()) as usize;
    let mut frames = 0usize;
    for k in 0..steps {
        src.t = k as f64 * period.as_secs_f64();
        let sp: Vec<[AxisSetpoint; 2]> = posture(&model, &mut ws, &src)
            .iter()
            .map(|j| {
                [
                    AxisSetpoint {
                        position: j.pitch as f32,
                        velocity: j.pitch_rate as f32,
                        torque: 0.0,
                    },
                    AxisSetpoint {
                        position: j.yaw as f32,
                        velocity: j.yaw_rate as f32,
                        torque: 0.0,
                    },
                ]
            })
            .collect();
        let counter = k as u16;
        message::encode_setpoints(
            Variant::Classic,
            counter,
            message::from_node_one(&sp),
            |f| host.send(&f).unwrap(),
        )
        .unwrap();
        host.send(&Message::Sync { counter }.encode(Variant::Classic).unwrap())
            .unwrap();
        step(&mut robot, &clock);
        frames += host.drain(&mut |_| {}).unwrap();
    }
    let simulated = clock.now().as_secs_f64();
    let t = robot.truth();
    println!(
        "{{\"joints\":{joints},\"simulated_s\":{simulated:.3},\"robot_cpu_s\":{:.3},\"faster_than_real_time\":{:.1},\"tick_ms\":{},\"frames_to_host\":{frames},\"forward_speed\":{:.4},\"model_errors\":{}}}",
        busy.as_secs_f64(),
        simulated / busy.as_secs_f64(),
        cfg.tick.as_secs_f64() * 1e3,
        t.forward_speed,
        robot.stats().model_errors
    );
}
