//! A mixed robot on one bus (issue 49, first part): the simulated robot
//! plays ten vertebrae and swims with the measured motion of the other
//! two, which another simulated robot on the same bus plays as real
//! vertebrae would (`anguilla sim --skip 1,2`). The daemon drives all
//! twelve as ever; the body swims as an all-simulated one does (within
//! 1 % of its speed), its observed joints a period behind the "real"
//! ones. The body's load on an observed joint is printed beside its
//! all-simulated twin's, not checked: the measured rates' steps (classic
//! CAN's 0.08 rad/s) make its acceleration, and so its load, noisy.

use anguilla_ipc::vocabulary::Mode;
use anguilla_testkit::lockstep::{self, Rig};

/// Mean forward speed (m/s) over `seconds` of `rig`'s swim, from the
/// truth's positions.
fn mean_speed(rig: &mut Rig, seconds: f64) -> f64 {
    let a = rig.truth().position;
    rig.run(seconds, |_| {});
    let b = rig.truth().position;
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt() / seconds
}

/// The rig's control period (s).
fn period_s(rig: &Rig) -> f64 {
    rig.ctl.period_ns().as_nanos() as f64 * 1e-9
}

#[test]
fn a_mixed_robot_swims_with_its_real_joints_measured_motion() {
    let cfg = lockstep::config();
    let mut mixed = Rig::mixed(&cfg, 5, &[1, 2], |_| {});
    mixed.swim(1.0);
    mixed.run(10.0, |_| {});
    // Played a feedback interval late (a control period) from a frame that
    // is itself up to a period old: within two periods' motion of the real
    // joints at their fastest.
    let period = period_s(&mixed);
    let mut fastest: f64 = 0.0;
    let mut worst: f64 = 0.0;
    let mut load_sq = 0.0;
    let mut n = 0.0;
    mixed.run(4.0, |r| {
        let real = r.real.as_ref().expect("the real vertebrae");
        for (j, node) in real.nodes().iter().enumerate() {
            for axis in 0..2 {
                let seen = r.robot.nodes()[j].kinematics(axis).0;
                let (angle, rate, _) = node.kinematics(axis);
                worst = worst.max((seen - angle).abs());
                fastest = fastest.max(rate.abs());
            }
        }
        load_sq += r.robot.loads()[0][1].powi(2);
        n += 1.0;
    });
    assert_eq!(mixed.state().mode, Mode::Swimming as u8, "no fault");
    let load_rms = (load_sq / n).sqrt();
    eprintln!(
        "observed joints within {worst:.4} rad of the real ones; joint 1 yaw load RMS {load_rms:.4} N·m"
    );
    let bound = 2.0 * period * fastest;
    eprintln!("bound: two periods of {period:.5} s at {fastest:.3} rad/s = {bound:.4} rad");
    assert!(
        worst < bound,
        "the observed joints lag the real ones by {worst} rad (bound {bound})"
    );
    let mixed_speed = mean_speed(&mut mixed, 10.0);
    let mut all = Rig::new(&cfg, 5, [0.0; 3]);
    all.swim(1.0);
    all.run(10.0, |_| {});
    let mut all_sq = 0.0;
    all.run(4.0, |r| all_sq += r.robot.loads()[0][1].powi(2));
    let all_rms = (all_sq / n).sqrt();
    let all_speed = mean_speed(&mut all, 10.0);
    eprintln!(
        "mean speed: mixed {mixed_speed:.4} m/s, all simulated {all_speed:.4} m/s; joint 1 yaw \
         load RMS all simulated {all_rms:.4} N·m"
    );
    assert!(
        (mixed_speed - all_speed).abs() < 0.01 * all_speed,
        "{mixed_speed} against {all_speed}"
    );
}

/// A node the robot does not have, a bought family, or a node named twice
/// cannot be real.
#[test]
fn bad_real_joints_are_refused_by_name() {
    use anguilla_sim::{RobotConfig, SimRobot};
    let bus = anguilla_drivers::mem::MemBus::builder("mixed-bad").build();
    for (observed, drive, says) in [
        (
            vec![13],
            anguilla_protocol::Family::Anguilla,
            "node 13 is not one of the robot's",
        ),
        (
            vec![2, 2],
            anguilla_protocol::Family::Anguilla,
            "node 2 named twice",
        ),
        (
            vec![1],
            anguilla_protocol::Family::Odrive,
            "drives are all simulated",
        ),
    ] {
        let cfg = RobotConfig {
            observed,
            drive,
            ..RobotConfig::with_joints(12)
        };
        let e = SimRobot::on_mem(cfg, bus.participant(), std::time::Duration::ZERO)
            .expect_err("refused")
            .to_string();
        assert!(e.contains("observed") && e.contains(says), "{e}");
    }
    // Nor can a scenario fault a real vertebra, by node or by joint.
    let cfg = RobotConfig {
        observed: vec![2],
        ..RobotConfig::with_joints(12)
    };
    let mut robot = SimRobot::on_mem(cfg, bus.participant(), std::time::Duration::ZERO).unwrap();
    for text in ["1.0 node 2 silent\n", "1.0 joint 2 yaw stuck\n"] {
        let e = robot.load_scenario(text).expect_err(text).to_string();
        assert!(
            e.contains("line 1 scripts a fault of node 2, a real vertebra"),
            "{e}"
        );
    }
    robot
        .load_scenario("1.0 node 3 silent\n")
        .expect("a simulated one");
}
