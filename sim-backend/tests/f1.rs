//! Perfect servos fed the setpoints of gait F1 over the bus reproduce the
//! model's own F1 head speed.

mod common;

use std::time::Duration;

use anguilla_model::gait::named_gait;
use anguilla_model::{LawSource, Model, ModelConfig, Workspace, posture, run};
use anguilla_protocol::message::AxisSetpoint;
use anguilla_sim::RobotConfig;
use anguilla_sim::actuator::ActuatorParams;
use anguilla_sim::plant::{JointInput, Plant, PlantConfig};
use common::{Host, MS};

const JOINTS: usize = 12;
const DT: f64 = 0.002;
/// Simulated time of the gait (s): 3 periods of F1.
const DURATION: f64 = 3.0;
/// Averaging window: the last 2 whole periods (s).
const WINDOW: f64 = 2.0;

fn joints(model: &Model, ws: &mut Workspace, src: &LawSource) -> Vec<JointInput> {
    posture(model, ws, src)
        .iter()
        .map(|j| JointInput {
            angle: [j.pitch, j.yaw],
            rate: [j.pitch_rate, j.yaw_rate],
        })
        .collect()
}

fn mean_last(xs: &[f64], n: usize) -> f64 {
    xs[xs.len() - n..].iter().sum::<f64>() / n as f64
}

#[test]
fn perfect_servos_fed_f1_reproduce_the_models_head_speed() {
    let gait = named_gait("F1").unwrap();
    let steps = (DURATION / DT).round() as usize;
    let window = (WINDOW / DT).round() as usize;
    let pcfg = PlantConfig {
        joints: JOINTS,
        dt: DT,
        ..PlantConfig::default()
    };
    let model = Model::new(ModelConfig {
        nodes: pcfg.nodes,
        dt: DT,
        joints: JOINTS,
        ..ModelConfig::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);

    // 1. The model's own discrete robot: the body driven directly by F1's
    //    joint motion (no bus, no servos).
    let mut reference = Plant::new(pcfg).unwrap();
    let mut src = LawSource::new(gait.law);
    let mut ref_speed = Vec::with_capacity(steps);
    for k in 0..steps {
        src.t = k as f64 * DT;
        let input = joints(&model, &mut ws, &src);
        reference.step(&input).unwrap();
        if k == 0 {
            // Same initial condition as the robot below: the head at rest
            // with the body already moving.
            reference.reset_head(anguilla_model::HeadState::launch(0.0));
        }
        ref_speed.push(-reference.head().v1());
    }

    // 2. The simulated robot with ideal servos, fed F1's joint angles and
    //    rates as setpoints + SYNC every 2 ms over the in-process bus.
    let cfg = RobotConfig {
        actuator: ActuatorParams {
            ideal: true,
            ..ActuatorParams::default()
        },
        tick: Duration::from_secs_f64(DT),
        ..RobotConfig::with_joints(JOINTS)
    };
    let mut h = Host::new(cfg);
    h.enable_all();
    // Align the host's SYNCs with the robot's ticks.
    while !h.now().as_millis().is_multiple_of(2) {
        h.run(MS);
    }
    let mut sim_speed = Vec::with_capacity(steps);
    let period = Duration::from_secs_f64(DT);
    for k in 0..steps {
        src.t = k as f64 * DT;
        let sp: Vec<[AxisSetpoint; 2]> = joints(&model, &mut ws, &src)
            .iter()
            .map(|j| {
                [0, 1].map(|a| AxisSetpoint {
                    position: j.angle[a] as f32,
                    velocity: j.rate[a] as f32,
                    torque: 0.0,
                })
            })
            .collect();
        h.cycle(&sp, period);
        if k == 0 {
            h.robot.reset_head();
        }
        sim_speed.push(h.robot.truth().forward_speed);
    }
    assert_eq!(h.robot.stats().model_errors, 0);
    assert_eq!(h.robot.state_counts()[2], JOINTS, "all nodes still Enabled");

    // 3. The continuous body of the paper (run_gait) at the same grid, for
    //    the report: the chain of 12 joints differs from the beam.
    let mut beam_speed = Vec::with_capacity(steps);
    run::run_gait(&model, &gait, DURATION, |_, _, after, _, _| {
        beam_speed.push(-after.v1())
    })
    .unwrap();

    let sim = mean_last(&sim_speed, window);
    let chain = mean_last(&ref_speed, window);
    let beam = mean_last(&beam_speed, window);
    let e = (sim - chain).abs() / chain.abs();
    eprintln!(
        "F1, {JOINTS} joints, dt {DT} s, mean forward speed over t in ({}, {DURATION}] s: \
         simulated robot {sim:.5} m/s, model's discrete robot {chain:.5} m/s ({:.3} %), \
         model's continuous body (run_gait) {beam:.5} m/s",
        DURATION - WINDOW,
        100.0 * e
    );
    assert!(sim > 0.05, "the robot swims head first: {sim}");
    // 1 %: the tolerance. The only differences are the setpoints'
    // quantization on the wire (0.2 mrad, 1 mrad/s) and one tick of delay,
    // common to every joint, which shifts the motion in time uniformly.
    assert!(e < 0.01, "sim {sim} vs model {chain}: {:.2} %", 100.0 * e);
    // And against the paper's continuous body: measured 0.7 %, the chain of
    // 12 joints (curvature lumped at the joints) being the only difference.
    let e_beam = (sim - beam).abs() / beam.abs();
    assert!(
        e_beam < 0.01,
        "sim {sim} vs run_gait {beam}: {:.2} %",
        100.0 * e_beam
    );
}

/// F1 over the bus to servos with dynamics, with or without the model's
/// torques as feedforward: (mean forward speed, largest yaw tracking error).
fn servo_run(with_feedforward: bool) -> (f64, f64) {
    // The same host loop with the default servos (dynamics, torque limits,
    // encoder quantization, body load coupled implicitly) and, as the daemon
    // does, the model's joint torques as feedforward: the joints lag their
    // setpoints a little, and the robot swims head first close to the
    // model's speed.
    let gait = named_gait("F1").unwrap();
    let steps = (DURATION / DT).round() as usize;
    let window = (WINDOW / DT).round() as usize;
    let pcfg = PlantConfig {
        joints: JOINTS,
        dt: DT,
        ..PlantConfig::default()
    };
    let model = Model::new(ModelConfig {
        nodes: pcfg.nodes,
        dt: DT,
        joints: JOINTS,
        ..ModelConfig::default()
    })
    .unwrap();
    let mut ws = Workspace::new(&model);
    let mut src = LawSource::new(gait.law);
    // The model in lockstep gives the feedforward torques (its loads).
    let mut feedforward = Plant::new(pcfg).unwrap();
    let mut h = Host::new(RobotConfig::with_joints(JOINTS));
    h.enable_all();
    while !h.now().as_millis().is_multiple_of(2) {
        h.run(MS);
    }
    let mut speed = Vec::with_capacity(steps);
    let mut max_err = 0.0f64;
    for k in 0..steps {
        src.t = k as f64 * DT;
        let js = joints(&model, &mut ws, &src);
        let ff = feedforward.step(&js).unwrap().to_vec();
        if k == 0 {
            feedforward.reset_head(anguilla_model::HeadState::launch(0.0));
        }
        let sp: Vec<[AxisSetpoint; 2]> = js
            .iter()
            .zip(&ff)
            .map(|(j, t)| {
                [0, 1].map(|a| AxisSetpoint {
                    position: j.angle[a] as f32,
                    velocity: j.rate[a] as f32,
                    torque: if with_feedforward { t[a] as f32 } else { 0.0 },
                })
            })
            .collect();
        h.cycle(&sp, Duration::from_secs_f64(DT));
        if k == 0 {
            h.robot.reset_head();
        }
        if k > steps / 3 {
            for (n, j) in h.robot.nodes().iter().zip(&js) {
                max_err = max_err.max((n.kinematics(1).0 - j.angle[1]).abs());
            }
        }
        speed.push(h.robot.truth().forward_speed);
    }
    assert_eq!(h.robot.stats().model_errors, 0);
    (mean_last(&speed, window), max_err)
}

#[test]
fn default_servos_fed_f1_with_torque_feedforward_swim_close_to_the_model() {
    let (v, max_err) = servo_run(true);
    let (v0, max_err0) = servo_run(false);
    eprintln!(
        "F1 with default servos: with torque feedforward {v:.5} m/s, largest yaw tracking \
         error {max_err:.4} rad; without {v0:.5} m/s, {max_err0:.4} rad"
    );
    // Setpoints are one 2 ms period old when applied and the gait moves at
    // up to 2 rad/s: a few hundredths of a radian of tracking error.
    assert!(max_err < 0.05, "{max_err}");
    // Tracking errors of that size change the mean speed by a few percent
    // at most: 10 % is a loose bound around the model's 0.374 m/s.
    assert!((v - 0.374).abs() < 0.0374, "{v}");
    // Without the feedforward the servos (kp = 40 N·m/rad) track the load
    // only through their position error: measured 2.7 times the error (and
    // tail amplitudes off enough to change the speed by 16 %).
    assert!(max_err0 > 2.0 * max_err, "{max_err0} vs {max_err}");
}
