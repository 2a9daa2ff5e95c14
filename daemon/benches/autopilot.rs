//! Heading and depth hold on the simulated robot, measured. Prints JSON
//! lines; nothing is asserted (the tests in
//! `tests/autopilot.rs` assert bounds).
//!
//! `cargo bench -p anguilla-daemon --bench autopilot`
//!
//! The rig is `anguilla_testkit::lockstep`: the controller and the simulated
//! robot (twelve vertebra nodes, the swimming body, a typical fusion IMU
//! and pressure sensor with noise and bias walk) in lockstep on simulated
//! time, default configuration plus `[sensor] node = 20`, gait at full
//! amplitude and 1 Hz. Headings are the body's true heading: the head's,
//! averaged over one gait period (which removes the tail beat's swing).
//!
//! 1. `heading_step`: +60° then −120° held: rise time (10 → 90 % of the
//!    step), overshoot, settling time to ±5°, and the model's predicted turn
//!    time at the largest turn rate the autopilot asks for.
//! 2. `open_loop_baseline`: an operator's fixed turn curvature, held for the
//!    time the model predicts for +60°, then straight: the final error.
//! 3. `cross_current`: 0.1 m/s across the path, heading held: the mean and
//!    largest error over the last 6 s of 20 s.
//! 4. `estimate`: the head's attitude and depth estimate against the truth.
//! 5. `depth_step`: +0.5 m held with the heading, on the ballasted body
//!    (`[model] ballast`, default 2 cm) and on the paper's unballasted one,
//!    which rolls over under pitch curvature (docs/autopilot.md): rise time,
//!    overshoot, settling to ±5 cm, the worst error and heading error over
//!    the last 10 s of 30, the largest roll; and on the ballasted body in a
//!    current of 0.1 m/s across and 0.05 m/s down.

use anguilla_testkit::lockstep;

use anguilla_ipc::Hold;
use anguilla_ipc::vocabulary::{Command, Mode, SwimParams};
use lockstep::*;

fn per_gait_period(rig: &Rig) -> usize {
    (1e9 / rig.ctl.period_ns().as_nanos() as f64).round() as usize
}

fn swimming(rig: &mut Rig) -> f64 {
    rig.swim(1.0);
    rig.run(4.0, |_| {});
    rig.state().nav.heading_deg as f64
}

struct Step {
    rise: Option<f64>,
    overshoot: f64,
    settle: Option<f64>,
    final_error: f64,
}

/// Runs `seconds` from a step of `step` degrees from `from` (the hold
/// already set), timing the true body heading.
fn measure(rig: &mut Rig, from: f64, step: f64, seconds: f64) -> Step {
    let target = from + step;
    let mut body = BodyHeading::new(per_gait_period(rig));
    let start = rig.time();
    let (mut t10, mut t90, mut over, mut outside, mut last) = (None, None, 0.0f64, start, 0.0);
    rig.run(seconds, |r| {
        let h = body.push(&r.truth());
        let done = angle_diff_deg(h, from) * step.signum();
        let t = r.time() - start;
        if t10.is_none() && done >= 0.1 * step.abs() {
            t10 = Some(t);
        }
        if t90.is_none() && done >= 0.9 * step.abs() {
            t90 = Some(t);
        }
        let e = angle_diff_deg(h, target);
        over = over.max(e * step.signum());
        if e.abs() > 5.0 {
            outside = r.time();
        }
        last = e;
    });
    Step {
        rise: t10.zip(t90).map(|(a, b)| b - a),
        overshoot: over,
        settle: (outside < start + seconds - 2.0).then_some(outside - start),
        final_error: last,
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or("null".into(), |v| format!("{v:.2}"))
}

fn main() {
    let cfg = config();
    // 1. Heading steps.
    let mut rig = Rig::new(&cfg, 1, [0.0; 3]);
    let h0 = swimming(&mut rig);
    let gains = rig.ctl.autopilot().expect("autopilot").gains();
    let speed = rig.ctl.report().forward_speed;
    let max_rate = cfg.autopilot.max_turn_rate;
    for (from, step) in [(h0, 60.0), (h0 + 60.0, -120.0)] {
        rig.ok(Command::Hold(Hold {
            heading: Some(from + step),
            depth: None,
        }));
        let m = measure(&mut rig, from, step, 15.0);
        let predicted = step.abs() / max_rate;
        println!(
            "{{\"bench\":\"heading_step\",\"step_deg\":{step},\"rise_s\":{},\"overshoot_deg\":{:.2},\"overshoot_pct\":{:.1},\"settling_s\":{},\"final_error_deg\":{:.2},\"predicted_turn_s\":{predicted:.2},\"settling_over_predicted_gait_periods\":{},\"turn_gain\":{:.3},\"speed_mps\":{speed:.3}}}",
            opt(m.rise),
            m.overshoot,
            100.0 * m.overshoot / step.abs(),
            opt(m.settle),
            m.final_error,
            opt(m.settle.map(|s| s - predicted)),
            gains.turn
        );
    }
    // 2. Open-loop baseline: the operator turns at the curvature giving
    // the same largest rate, for the predicted time, then goes straight.
    let mut rig = Rig::new(&cfg, 1, [0.0; 3]);
    let h0 = swimming(&mut rig);
    let rate = max_rate.to_radians();
    let turn = (rate / (gains.turn * speed)).min(cfg.gait.max_turn);
    let duration = 60f64.to_radians() / (gains.turn * speed * turn);
    let swim = |turn| {
        Command::Swim(SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn,
            pitch: 0.0,
        })
    };
    rig.ok(swim(turn));
    rig.run(duration, |_| {});
    rig.ok(swim(0.0));
    let m = measure(&mut rig, h0, 60.0, 15.0 - duration);
    println!(
        "{{\"bench\":\"open_loop_baseline\",\"step_deg\":60,\"turn_curvature\":{turn:.3},\"turn_time_s\":{duration:.2},\"final_error_deg\":{:.2},\"overshoot_deg\":{:.2}}}",
        m.final_error, m.overshoot
    );
    // 3. Cross current.
    let mut rig = Rig::new(&cfg, 3, [0.0, 0.1, 0.0]);
    let h0 = swimming(&mut rig);
    rig.ok(Command::Hold(Hold {
        heading: Some(h0),
        depth: None,
    }));
    let mut body = BodyHeading::new(per_gait_period(&rig));
    let (mut sum, mut n, mut worst) = (0.0, 0, 0.0f64);
    let start = rig.time();
    rig.run(20.0, |r| {
        let e = angle_diff_deg(body.push(&r.truth()), h0);
        if r.time() - start > 14.0 {
            sum += e;
            n += 1;
            worst = worst.max(e.abs());
        }
    });
    let drift = rig.truth().position[1];
    println!(
        "{{\"bench\":\"cross_current\",\"current_mps\":0.1,\"mean_error_deg\":{:.2},\"worst_error_deg\":{worst:.2},\"lateral_drift_m\":{drift:.2}}}",
        sum / n as f64
    );
    // 4. The estimate against the truth during a held 90° turn.
    let mut rig = Rig::new(&cfg, 4, [0.0; 3]);
    let h0 = swimming(&mut rig);
    rig.ok(Command::Hold(Hold {
        heading: Some(h0 + 90.0),
        depth: None,
    }));
    let (mut att, mut att_sum, mut depth, mut n) = (0.0f64, 0.0, 0.0f64, 0);
    rig.run(10.0, |r| {
        let t = r.truth();
        let est = r.ctl.nav().expect("sensor").estimate();
        let a = est.attitude.angle_to(&true_attitude(&t)).to_degrees();
        att = att.max(a);
        att_sum += a;
        n += 1;
        depth = depth.max((est.depth - true_depth(&t)).abs());
    });
    let s = rig.state();
    println!(
        "{{\"bench\":\"estimate\",\"attitude_error_mean_deg\":{:.2},\"attitude_error_max_deg\":{att:.2},\"depth_error_max_m\":{depth:.4},\"rate_innovation\":{:.3},\"samples\":{},\"lost_samples\":{}}}",
        att_sum / n as f64,
        s.nav.rate_innovation,
        s.nav.samples,
        s.nav.lost_samples
    );
    // 5. Depth step, on the ballasted body (the default) and the paper's,
    // and on the ballasted one in a current (0.1 m/s across, 0.05 down).
    for (ballast, current) in [
        (cfg.model.ballast, [0.0; 3]),
        (0.0, [0.0; 3]),
        (cfg.model.ballast, [0.0, 0.1, -0.05]),
    ] {
        let mut cfg = cfg.clone();
        cfg.model.ballast = ballast;
        let mut rig = Rig::new(&cfg, 2, current);
        swimming(&mut rig);
        let m = depth_step(&mut rig, 0.5, 30.0, 20.0);
        let s = rig.state();
        println!(
            "{{\"bench\":\"depth_step\",\"ballast_m\":{ballast},\"current_mps\":{current:?},\"step_m\":0.5,\"rise_90pct_s\":{},\"overshoot_m\":{:.3},\"settling_5cm_s\":{},\"worst_error_last_10s_m\":{:.3},\"heading_error_last_10s_deg\":{:.2},\"max_roll_deg\":{:.1},\"still_swimming\":{},\"hold_exit\":{}}}",
            opt(m.reached),
            m.overshoot,
            opt((m.last_outside < 28.0).then_some(m.last_outside)),
            m.late,
            m.heading,
            m.roll,
            s.mode == Mode::Swimming as u8,
            s.nav.hold_exit
        );
    }
}
