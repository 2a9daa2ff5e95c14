//! `anguilla run --scenario FILE`: faults scripted on the built-in
//! simulated robot, in the scenario language `anguilla sim --scenario`
//! plays (sim-backend/README.md), snags included.

use std::process::{Command as Proc, Stdio};
use std::time::Duration;

use anguilla_ipc::vocabulary::{Command, SwimParams};
use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::{
    Killed, anguilla_bin, connect, ok, take_control_and_enable, wait_for,
};

/// A snag on joint 5's yaw from the robot's start, scripted on `anguilla
/// run`: once the robot swims, joint 5's yaw residual alarm is raised, and
/// when it is, no other axis's is (issue 46, findings 5 and 7: a snag was
/// scriptable only on `anguilla sim`).
#[test]
fn a_snag_scripted_on_the_built_in_robot_alarms_its_joint() {
    let _dog = Watchdog::new("run --scenario", Duration::from_secs(180));
    let id = std::process::id();
    let prefix = format!("anguilla-scenario/snag-{id}");
    let dir = std::env::temp_dir().join(format!("anguilla-scenario-{id}"));
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("anguilla.toml");
    std::fs::write(&config, format!("[ipc]\nprefix = \"{prefix}\"\n")).unwrap();
    let scenario = dir.join("snag.txt");
    std::fs::write(&scenario, "# a weed on joint 5\n0 joint 5 yaw snag 0.5\n").unwrap();
    let _daemon = Killed(
        Proc::new(anguilla_bin())
            .args(["run", "--quiet", "--config"])
            .arg(&config)
            .arg("--scenario")
            .arg(&scenario)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let mut client = connect(&prefix, "scenario-test");
    take_control_and_enable(&mut client, 20.0);
    ok(
        &mut client,
        Command::Swim(SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        }),
    );
    // The residual is judged while swimming: the alarm follows the swim's
    // start by its low-pass and hold (about a second in lockstep).
    let s = wait_for(&mut client, "joint 5's yaw residual alarm", 20.0, |s| {
        s.residual_alarms().any(|(j, a, _)| (j, a) == (5, "yaw"))
    });
    let alarms: Vec<_> = s.residual_alarms().collect();
    assert_eq!(alarms.len(), 1, "other joints alarmed too: {alarms:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
