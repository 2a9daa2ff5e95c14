//! The plant swims, turns and dives as the joints actually move; CAN FD
//! nodes work the same way.

mod common;

use std::time::Duration;

use anguilla_model::gait::named_gait;
use anguilla_model::{LawSource, Model, ModelConfig, Workspace, posture};
use anguilla_protocol::message::{AxisSetpoint, Variant};
use anguilla_sim::RobotConfig;
use anguilla_sim::actuator::ActuatorParams;
use anguilla_sim::plant::PlantConfig;
use common::{Host, MS};

const JOINTS: usize = 6;
const DT: f64 = 0.002;

/// F1 with `bias` (rad) added to every joint's `[pitch, yaw]`, ideal servos,
/// for `seconds`; returns the final truth and the mean forward speed over
/// the last half second.
fn swim(bias: [f64; 2], seconds: f64, variant: Variant) -> (anguilla_sim::Truth, f64) {
    let model = Model::new(ModelConfig {
        nodes: PlantConfig::default().nodes,
        dt: DT,
        joints: JOINTS,
        ..ModelConfig::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut src = LawSource::new(named_gait("F1").unwrap().law);
    let mut h = Host::new(RobotConfig {
        variant,
        actuator: ActuatorParams {
            ideal: true,
            ..ActuatorParams::default()
        },
        ..RobotConfig::with_joints(JOINTS)
    });
    h.enable_all();
    while !h.now().as_millis().is_multiple_of(2) {
        h.run(MS);
    }
    let steps = (seconds / DT).round() as usize;
    let last = (0.5 / DT).round() as usize;
    let mut mean = 0.0;
    for k in 0..steps {
        src.t = k as f64 * DT;
        let sp: Vec<[AxisSetpoint; 2]> = posture(&model, &mut ws, &src)
            .iter()
            .map(|j| {
                [
                    AxisSetpoint {
                        position: (j.pitch + bias[0]) as f32,
                        velocity: j.pitch_rate as f32,
                        torque: 0.0,
                    },
                    AxisSetpoint {
                        position: (j.yaw + bias[1]) as f32,
                        velocity: j.yaw_rate as f32,
                        torque: 0.0,
                    },
                ]
            })
            .collect();
        h.cycle(&sp, Duration::from_secs_f64(DT));
        if k == 0 {
            h.robot.reset_head();
        }
        if k >= steps - last {
            mean += h.robot.truth().forward_speed / last as f64;
        }
    }
    assert_eq!(h.robot.stats().model_errors, 0);
    (h.robot.truth(), mean)
}

#[test]
fn the_robot_turns_and_dives_as_its_joints_bend() {
    let (straight, _) = swim([0.0; 2], 2.0, Variant::Classic);
    let (turn, _) = swim([0.0, 0.15], 2.0, Variant::Classic);
    let (dive, _) = swim([0.15, 0.0], 2.0, Variant::Classic);
    let dyaw = (turn.yaw - straight.yaw).to_degrees();
    let dz = dive.position[2] - straight.position[2];
    eprintln!(
        "after 2 s of F1: straight yaw {:.1} deg z {:.4} m; yaw bias 0.15 rad: yaw change {:+.1} deg; \
         pitch bias 0.15 rad: depth change {:+.4} m",
        straight.yaw.to_degrees(),
        straight.position[2],
        dyaw,
        dz
    );
    // F1 alone swims straight and level.
    assert!(
        straight.position[2].abs() < 1e-6,
        "{}",
        straight.position[2]
    );
    // A lateral bend of 0.9 rad in all (6 x 0.15) turns the head by
    // tens of degrees in 2 s; a vertical bend moves it out of the plane.
    assert!(dyaw.abs() > 10.0, "turn: {dyaw} deg");
    assert!(dz.abs() > 0.02, "dive: {dz} m");
}

#[test]
fn fd_nodes_swim_like_classic_ones() {
    let (_, classic) = swim([0.0; 2], 1.5, Variant::Classic);
    let (_, fd) = swim([0.0; 2], 1.5, Variant::Fd);
    eprintln!("mean forward speed over (1, 1.5] s: classic {classic:.5} m/s, FD {fd:.5} m/s");
    // The same setpoints; classic CAN carries velocities in 0.08 rad/s steps
    // (FD: 0.005), which the ideal servos pass on to the body: a difference
    // of a few per mille in the mean speed, bounded here by 2 %.
    assert!(fd > 0.05, "{fd}");
    assert!((classic - fd).abs() < 0.02 * fd, "{classic} vs {fd}");
}
