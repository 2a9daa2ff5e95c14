//! The daemon and the simulated robot as two separate processes, joined by a
//! real serial driver: `anguilla sim --slcan-pty` emulates a USB SLCAN adapter
//! on a pseudo-terminal and `anguilla run --bus slcan:/dev/pts/N@1000000`
//! drives it. An operator client enables, swims, stops and E-stops.

use std::io::{BufRead, BufReader};
use std::process::{Command as Proc, Stdio};
use std::time::Duration;

use anguilla_ipc::{Command, Mode};
use anguilla_system_tests::process::{
    F1, Killed, REPLY, anguilla_bin, connect, keep_alive_for, ok, tracking, wait_for,
};

/// The daemon and the simulator share this machine's CPU, as the built-in
/// robot does: its relaxed timeouts (`Config::relax_for_builtin`), so a
/// starved machine does not fault the nodes' watchdogs (an ODrive's fired
/// under stress-ng).
const SHARED_CPU: &str = "[control]\ncommand-timeout = 2\nheartbeat-timeout = 2\nnode-watchdog = 1\nfeedback-timeout = 320\n";

#[test]
fn daemon_and_simulator_processes_over_an_slcan_pty() {
    let bin = anguilla_bin();
    if !bin.exists() {
        panic!("{} not built (cargo build --bin anguilla)", bin.display());
    }
    let (sim, device) = sim_on_pty(&bin);
    let prefix = format!("anguilla-test/slcan-processes-{}", std::process::id());
    let config = std::env::temp_dir().join(format!("anguilla-slcan-{}.toml", std::process::id()));
    std::fs::write(
        &config,
        format!("[ipc]\nprefix = \"{prefix}\"\n\n{SHARED_CPU}"),
    )
    .unwrap();
    let _daemon = run_on_pty(&bin, &device, &config);
    let mut c = connect(&prefix, "slcan-operator");
    wait_for(&mut c, "the daemon's first state", 15.0, |_| true);
    ok(&mut c, Command::TakeControl);
    ok(&mut c, Command::Enable);
    wait_for(&mut c, "ready", 10.0, |s| s.mode == Mode::Ready as u8);
    let swim = F1;
    ok(&mut c, swim);
    wait_for(&mut c, "the tail swinging", 10.0, |s| {
        s.mode == Mode::Swimming as u8 && s.joints[11].commanded_yaw.abs() > 0.15
    });
    // The tail joint follows the command (F1 swings it by ~0.25 rad), at
    // whatever lag the serial link and a busy machine add.
    let (err, lag, n) = tracking(&mut c, 11, 2.0, swim);
    assert!(
        err < 0.08,
        "tail yaw tracking error {err} rad (median) at its best lag {lag} ms ({n} states)"
    );
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

/// The bought families (CiA 402, ODrive, MIT mode) over a pty: `anguilla
/// sim --drive F --slcan-pty` and
/// `anguilla run` with `[robot] drive = F`, as two processes. The daemon
/// configures the CiA 402 drives by SDO through the emulated adapter, the
/// robot swims, stops, and the E-stop turns every drive off.
#[test]
fn bought_drive_families_over_an_slcan_pty() {
    let bin = anguilla_bin();
    assert!(
        bin.exists(),
        "{} not built (cargo build --bin anguilla)",
        bin.display()
    );
    for drive in ["cia402", "odrive", "mit"] {
        // The drives' own watchdog relaxed as the daemon's timeouts are
        // (SHARED_CPU): an ODrive's 100 ms fired under stress-ng.
        let (sim, device) = sim_on_pty_with(
            &bin,
            &["--drive", drive, "--joints", "6", "--drive-watchdog", "1"],
        );
        let prefix = format!("anguilla-test/slcan-{drive}-{}", std::process::id());
        let config = std::env::temp_dir().join(format!(
            "anguilla-slcan-{drive}-{}.toml",
            std::process::id()
        ));
        std::fs::write(
            &config,
            format!(
                "[robot]\njoints = 6\ndrive = \"{drive}\"\n\n[ipc]\nprefix = \"{prefix}\"\n\n{SHARED_CPU}"
            ),
        )
        .unwrap();
        let daemon = run_on_pty(&bin, &device, &config);
        let mut c = connect(&prefix, "slcan-operator");
        wait_for(
            &mut c,
            &format!("{drive}: every joint disabled"),
            20.0,
            |s| {
                s.joints[..6]
                    .iter()
                    .all(|j| j.node_alive == 1 && j.node_state == 1)
            },
        );
        ok(&mut c, Command::TakeControl);
        ok(&mut c, Command::Enable);
        wait_for(&mut c, &format!("{drive}: ready"), 10.0, |s| {
            s.mode == Mode::Ready as u8
        });
        let swim = F1;
        ok(&mut c, swim);
        wait_for(&mut c, &format!("{drive}: the tail swinging"), 10.0, |s| {
            s.mode == Mode::Swimming as u8 && s.joints[5].commanded_yaw.abs() > 0.1
        });
        // As in families.rs: the bound catches a joint that does not follow
        // or a wrong conversion, not the feedback's lag.
        let (err, lag, n) = tracking(&mut c, 5, 2.0, swim);
        assert!(
            err < 0.08,
            "{drive}: tail yaw tracking error {err} rad (median) at its best lag {lag} ms ({n} states)"
        );
        ok(&mut c, Command::Stop);
        wait_for(
            &mut c,
            &format!("{drive}: ready after the stop"),
            20.0,
            |s| s.mode == Mode::Ready as u8,
        );
        ok(&mut c, Command::EStop);
        wait_for(&mut c, &format!("{drive}: every drive off"), 3.0, |s| {
            s.mode == Mode::EStop as u8 && s.joints[..6].iter().all(|j| j.node_state != 2)
        });
        eprintln!(
            "{drive} over an SLCAN pty: enabled, swam (tail error {err:.3} rad), stopped, E-stopped"
        );
        drop(daemon);
        drop(sim);
        let _ = std::fs::remove_file(&config);
    }
}

/// CAN FD over the pty (issue 46, finding 7): `anguilla sim --slcan-pty
/// --fd` and the daemon with `[bus] fd = true` on `slcan:...?fd=1`. The
/// simulated wire's data phase runs at the daemon's `data-bitrate`
/// (`anguilla sim`'s `--data-bitrate`, by default the daemon's default
/// 5 Mbit/s), not at the nominal 1 Mbit/s, which overloaded it and faulted
/// the robot. The robot enables, swims with its tail following, and stops
/// with no fault.
#[test]
fn can_fd_over_an_slcan_pty() {
    let bin = anguilla_bin();
    assert!(bin.exists(), "{} not built", bin.display());
    let (sim, device) = sim_on_pty_with(&bin, &["--fd"]);
    let prefix = format!("anguilla-test/slcan-fd-{}", std::process::id());
    let config =
        std::env::temp_dir().join(format!("anguilla-slcan-fd-{}.toml", std::process::id()));
    std::fs::write(
        &config,
        format!("[bus]\nfd = true\n\n[ipc]\nprefix = \"{prefix}\"\n\n{SHARED_CPU}"),
    )
    .unwrap();
    let _daemon = run_on_pty_spec(&bin, &format!("slcan:{device}@1000000?fd=1"), &config);
    let mut c = connect(&prefix, "slcan-fd-operator");
    wait_for(&mut c, "the daemon's first state", 15.0, |_| true);
    ok(&mut c, Command::TakeControl);
    ok(&mut c, Command::Enable);
    wait_for(&mut c, "ready over CAN FD", 10.0, |s| {
        s.mode == Mode::Ready as u8
    });
    ok(&mut c, F1);
    wait_for(&mut c, "the tail swinging over CAN FD", 10.0, |s| {
        s.mode == Mode::Swimming as u8 && s.joints[11].commanded_yaw.abs() > 0.15
    });
    let (err, lag, n) = tracking(&mut c, 11, 2.0, F1);
    assert!(
        err < 0.08,
        "tail yaw tracking error {err} rad (median) at its best lag {lag} ms ({n} states)"
    );
    ok(&mut c, Command::Stop);
    let s = wait_for(&mut c, "ready after the stop", 20.0, |s| {
        s.mode == Mode::Ready as u8
    });
    assert_eq!(s.fault_kinds, 0, "faults {:#x}", s.fault_kinds);
    let _ = std::fs::remove_file(&config);
    drop(sim);
}

/// `anguilla run --config CONFIG` on the emulated adapter at `device`.
fn run_on_pty(bin: &std::path::Path, device: &str, config: &std::path::Path) -> Killed {
    run_on_pty_spec(bin, &format!("slcan:{device}@1000000"), config)
}

/// `anguilla run --config CONFIG --bus SPEC`.
fn run_on_pty_spec(bin: &std::path::Path, spec: &str, config: &std::path::Path) -> Killed {
    Killed(
        Proc::new(bin)
            .args(["run", "--quiet", "--bus", spec, "--config"])
            .arg(config)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("anguilla run starts"),
    )
}

/// `anguilla sim --slcan-pty`, its device read from its first lines; the
/// rest of its output drained.
fn sim_on_pty(bin: &std::path::Path) -> (Killed, String) {
    sim_on_pty_with(bin, &[])
}

/// `anguilla sim --slcan-pty` with more arguments.
fn sim_on_pty_with(bin: &std::path::Path, args: &[&str]) -> (Killed, String) {
    let mut sim = Killed(
        Proc::new(bin)
            .args(["sim", "--slcan-pty", "--duration", "120"])
            .args(args)
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
    std::thread::spawn(move || for _ in lines {});
    (sim, device)
}

#[test]
fn an_unplugged_adapter_is_a_named_fault_until_it_is_back() {
    let bin = anguilla_bin();
    assert!(bin.exists(), "{} not built", bin.display());
    // The daemon opens a stable link (as /dev/serial/by-id gives one); the
    // adapter behind it is unplugged (the simulator killed) and plugged in
    // again (a new simulator, a new pty, the link moved).
    let tag = std::process::id();
    let link = std::env::temp_dir().join(format!("anguilla-slcan-adapter-{tag}"));
    let (sim, device) = sim_on_pty(&bin);
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&device, &link).unwrap();
    let prefix = format!("anguilla-test/slcan-unplug-{tag}");
    let config = std::env::temp_dir().join(format!("anguilla-slcan-unplug-{tag}.toml"));
    std::fs::write(&config, format!("[ipc]\nprefix = \"{prefix}\"\n")).unwrap();
    let log = std::env::temp_dir().join(format!("anguilla-slcan-unplug-{tag}.log"));
    let spec = format!("slcan:{}@1000000", link.display());
    let mut daemon = Killed(
        Proc::new(&bin)
            .args(["run", "--quiet", "--bus", &spec, "--config"])
            .arg(&config)
            .stdout(Stdio::null())
            .stderr(Stdio::from(std::fs::File::create(&log).unwrap()))
            .spawn()
            .expect("anguilla run starts"),
    );
    let mut c = connect(&prefix, "unplug-operator");
    ok(&mut c, Command::TakeControl);
    ok(&mut c, Command::Enable);
    wait_for(&mut c, "ready", 15.0, |s| s.mode == Mode::Ready as u8);
    drop(sim); // unplugged
    let s = wait_for(&mut c, "adapter gone", 10.0, |s| {
        s.bus.state == 3 && s.mode == Mode::Fault as u8
    });
    assert!(
        s.fault_kinds & anguilla_ipc::FaultKind::AdapterGone as u32 != 0,
        "named as such: {:#x}",
        s.fault_kinds
    );
    let r = c.request(Command::Reset, REPLY).unwrap();
    assert_eq!(r.accepted, 0);
    assert!(r.reason().contains("adapter gone"), "{}", r.reason());
    let (_sim2, device2) = sim_on_pty(&bin);
    std::fs::remove_file(&link).unwrap();
    std::os::unix::fs::symlink(&device2, &link).unwrap();
    wait_for(&mut c, "the adapter back", 15.0, |s| s.bus.state == 0);
    // Once every node's heartbeat is back too, a reset clears the fault.
    let end = anguilla_testkit::Deadline::new(Duration::from_secs(15));
    loop {
        let r = c.request(Command::Reset, REPLY).unwrap();
        if r.accepted == 1 {
            break;
        }
        assert!(!end.passed(), "reset still refused: {}", r.reason());
        keep_alive_for(&mut c, 0.3, |_| {});
    }
    wait_for(&mut c, "idle", 5.0, |s| s.mode == Mode::Idle as u8);
    unsafe { libc::kill(daemon.0.id() as i32, libc::SIGTERM) };
    let _ = daemon.0.wait();
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains(&format!("adapter gone: {spec}")), "{text}");
    let _ = std::fs::remove_file(&link);
    let _ = std::fs::remove_file(&config);
}

/// A dead joint is never masked, over a real serial driver: node 3 dies at once and a
/// forger sends its heartbeats (state and counter as a healthy node's);
/// node 5 gets a twin on its id. The daemon names both while idle, and an
/// enable ends in Fault, never in Ready: no swim with a dead joint.
#[test]
fn a_forged_heartbeat_and_a_twin_node_do_not_mask_a_dead_joint_over_slcan() {
    let bin = anguilla_bin();
    assert!(bin.exists(), "{} not built", bin.display());
    let tag = std::process::id();
    let scenario = std::env::temp_dir().join(format!("anguilla-slcan-spoof-{tag}.txt"));
    std::fs::write(&scenario, "0.0 node 3 spoof\n1.0 node 5 twin\n").unwrap();
    let (sim, device) = sim_on_pty_with(&bin, &["--scenario", scenario.to_str().unwrap()]);
    let prefix = format!("anguilla-test/slcan-spoof-{tag}");
    let config = std::env::temp_dir().join(format!("anguilla-slcan-spoof-{tag}.toml"));
    std::fs::write(
        &config,
        format!("[ipc]\nprefix = \"{prefix}\"\n\n{SHARED_CPU}"),
    )
    .unwrap();
    let _daemon = run_on_pty(&bin, &device, &config);
    let mut c = connect(&prefix, "slcan-operator");
    let no_feedback = anguilla_ipc::FaultKind::FeedbackLost as u32;
    let duplicate = anguilla_ipc::FaultKind::DuplicateNode as u32;
    let s = wait_for(&mut c, "no feedback (3) and duplicate (5)", 20.0, |s| {
        s.fault_kinds & no_feedback != 0 && s.fault_kinds & duplicate != 0
    });
    assert_eq!(s.fault_nodes, 1 << 3 | 1 << 5, "{s:?}");
    assert_eq!(
        s.fault_kinds & anguilla_ipc::FaultKind::HeartbeatLost as u32,
        0,
        "node 3's forged heartbeats keep it 'alive'"
    );
    assert_eq!(s.joints[2].node_alive, 1, "forged heartbeats");
    ok(&mut c, Command::TakeControl);
    ok(&mut c, Command::Enable);
    let s = wait_for(&mut c, "Fault (or Ready, wrongly)", 10.0, |s| {
        s.mode == Mode::Fault as u8 || s.mode == Mode::Ready as u8
    });
    assert_eq!(s.mode, Mode::Fault as u8, "enabled with a dead joint");
    let _ = std::fs::remove_file(&config);
    let _ = std::fs::remove_file(&scenario);
    drop(sim);
}
