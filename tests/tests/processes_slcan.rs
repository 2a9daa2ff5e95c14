//! The daemon and the simulated robot as two separate processes, joined by a
//! real serial driver: `anguilla sim --slcan-pty` emulates a USB SLCAN adapter
//! on a pseudo-terminal and `anguilla run --bus slcan:/dev/pts/N@1000000`
//! drives it. An operator client enables, swims, stops and E-stops.

use std::io::{BufRead, BufReader};
use std::process::{Command as Proc, Stdio};
use std::time::{Duration, Instant};

use anguilla_ipc::Client;
use anguilla_ipc::{Command, Mode, SwimParams};
use anguilla_system_tests::process::{Killed, anguilla_bin, ok, wait_for};

#[test]
fn daemon_and_simulator_processes_over_an_slcan_pty() {
    let bin = anguilla_bin();
    if !bin.exists() {
        panic!("{} not built (cargo build --bin anguilla)", bin.display());
    }
    let mut sim = Killed(
        Proc::new(&bin)
            .args(["sim", "--slcan-pty", "--duration", "120"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("anguilla sim starts"),
    );
    let mut lines = BufReader::new(sim.0.stdout.take().unwrap()).lines();
    let device = lines
        .by_ref()
        .take(20)
        .filter_map(|l| l.ok())
        .find_map(|l| {
            l.split_whitespace()
                .find(|w| w.starts_with("/dev/"))
                .map(str::to_string)
        })
        .expect("the simulator prints its device");
    // Keep draining its status lines so it never blocks on a full pipe.
    std::thread::spawn(move || for _ in lines {});
    let prefix = format!("anguilla-test/slcan-processes-{}", std::process::id());
    let config = std::env::temp_dir().join(format!("anguilla-slcan-{}.toml", std::process::id()));
    std::fs::write(&config, format!("[ipc]\nprefix = \"{prefix}\"\n")).unwrap();
    let _daemon = Killed(
        Proc::new(&bin)
            .args([
                "run",
                "--quiet",
                "--bus",
                &format!("slcan:{device}@1000000"),
                "--config",
            ])
            .arg(&config)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("anguilla run starts"),
    );
    let mut c = {
        let end = Instant::now() + Duration::from_secs(10);
        loop {
            if let Ok(c) = Client::new(&prefix, "slcan-operator") {
                break c;
            }
            assert!(Instant::now() < end, "no operator interface");
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    wait_for(&mut c, "the daemon's first state", 15.0, |_| true);
    ok(&mut c, Command::TakeControl);
    ok(&mut c, Command::Enable);
    wait_for(&mut c, "ready", 10.0, |s| s.mode == Mode::Ready as u8);
    ok(
        &mut c,
        Command::Swim(SwimParams {
            amplitude: 1.0,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        }),
    );
    // The tail joint swings and its measured angle follows the command.
    let s = wait_for(&mut c, "the tail swinging", 10.0, |s| {
        s.mode == Mode::Swimming as u8 && s.joints[11].commanded_yaw.abs() > 0.15
    });
    let err = (s.joints[11].measured_yaw - s.joints[11].commanded_yaw).abs();
    assert!(err < 0.08, "tail yaw tracking error {err} rad");
    ok(&mut c, Command::Stop);
    wait_for(&mut c, "ready after the stop", 20.0, |s| {
        s.mode == Mode::Ready as u8
    });
    ok(&mut c, Command::EStop);
    let s = wait_for(&mut c, "e-stop", 3.0, |s| {
        s.mode == Mode::EStop as u8 && s.joints[..12].iter().all(|j| j.node_state == 4)
    });
    assert_eq!(s.joints[0].node_state, 4, "nodes latched in EStop");
    ok(&mut c, Command::Reset);
    wait_for(&mut c, "idle after reset", 5.0, |s| {
        s.mode == Mode::Idle as u8
    });
    let _ = std::fs::remove_file(&config);
    drop(sim);
}
