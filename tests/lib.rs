//! System tests: the daemon and the simulated robot end to end, on each bus.
//!
//! The tests live in `tests/*.rs`; this library holds their shared fixtures:
//! [`Robot`] (the real daemon loop and the simulated robot `anguilla run`
//! drives without a bus: nodes, actuators and swimming body on an
//! in-process bus) and [`Watchdog`].
#![warn(missing_docs)]

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_daemon::run::{self, Running};
use anguilla_drivers::Bus;
use anguilla_sim::builtin::{Builtin, BuiltinConfig};

/// Aborts the test process if it is not dropped within a time limit, so a
/// hung test fails instead of blocking CI.
#[derive(Debug)]
pub struct Watchdog {
    done: Option<std::sync::mpsc::Sender<()>>,
}

impl Watchdog {
    /// Arms the watchdog for `limit` stretched by the patience
    /// ([`anguilla_testkit::patient`]); `name` is printed if it fires.
    pub fn new(name: &str, limit: Duration) -> Self {
        let limit = anguilla_testkit::patient(limit);
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let name = name.to_string();
        std::thread::spawn(move || {
            if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(limit) {
                eprintln!("watchdog: test '{name}' still running after {limit:?}: aborting");
                // An abort runs no destructor: the daemons and tools this
                // process started would outlive it (and load the rest of
                // the run). Kill them first.
                kill_children();
                std::process::abort();
            }
        });
        Self { done: Some(tx) }
    }
}

/// Kills (SIGKILL) every process whose parent is this one, as /proc
/// lists them.
fn kill_children() {
    let me = std::process::id().to_string();
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return;
    };
    for e in dir.flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        // /proc/PID/stat: "pid (comm) state ppid ..."; comm may hold spaces.
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1));
        if ppid == Some(me.as_str()) {
            // SAFETY: kill has no memory effects.
            unsafe { libc::kill(pid, libc::SIGKILL) };
        }
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        if let Some(tx) = self.done.take() {
            let _ = tx.send(());
        }
    }
}

/// The daemon loop and the simulated robot, running in this process. The
/// iceoryx2 services are under [`Robot::prefix`], unique to the test.
pub struct Robot {
    /// The daemon's service prefix.
    pub prefix: String,
    /// The configuration the daemon runs.
    pub config: Config,
    running: Option<Running>,
    sim: Option<Builtin>,
}

impl std::fmt::Debug for Robot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Robot")
            .field("prefix", &self.prefix)
            .finish()
    }
}

impl Robot {
    /// Starts the simulated nodes and the daemon with the default
    /// configuration under a prefix made of `name` and the process id.
    pub fn start(name: &str) -> anyhow::Result<Self> {
        let mut cfg = Config::default();
        cfg.ipc.prefix = format!("anguilla-systest/{name}-{}", std::process::id());
        Self::start_with(cfg)
    }

    /// Starts the simulated nodes and the daemon with `cfg`.
    pub fn start_with(cfg: Config) -> anyhow::Result<Self> {
        Self::start_with_scenario(cfg, "")
    }

    /// Starts the simulated robot, playing the fault `scenario` (the text
    /// of a scenario file), and the daemon with `cfg`.
    pub fn start_with_scenario(cfg: Config, scenario: &str) -> anyhow::Result<Self> {
        let (bus, sim) = start_builtin(&cfg, scenario)?;
        let running = run::spawn(cfg.clone(), bus, Arc::new(AtomicBool::new(false)))?;
        Ok(Self {
            prefix: cfg.ipc.prefix.clone(),
            config: cfg,
            running: Some(running),
            sim: Some(sim),
        })
    }
}

impl Robot {
    /// Fault injection: the daemon's end of the bus goes to `state`.
    pub fn force_daemon_bus(&self, state: anguilla_drivers::BusState) {
        self.sim.as_ref().expect("running").force_host_state(state);
    }

    /// Fault injection on the robot's side, now: a scenario action.
    pub fn inject(&self, action: anguilla_sim::scenario::Action) {
        self.sim.as_ref().expect("running").inject(action);
    }

    /// Another sender on the robot's bus (`cansend`): `frame` goes on the
    /// wire now, heard by the daemon and the robot alike.
    pub fn send_foreign(&self, frame: &anguilla_protocol::frame::Frame) {
        self.sim.as_ref().expect("running").send_foreign(frame);
    }

    /// Stops the daemon (a smooth stop, as on SIGTERM) and the robot;
    /// the daemon's run report.
    pub fn stop(mut self) -> anguilla_daemon::run::RunReport {
        let r = self.running.take().expect("running");
        r.request_stop();
        let report = r.join().expect("the daemon's loop ends cleanly");
        if let Some(sim) = self.sim.take() {
            sim.stop();
        }
        report
    }

    /// The simulated robot's ground truth now.
    pub fn truth(&self) -> anguilla_sim::Truth {
        self.sim.as_ref().expect("running").truth()
    }
}

impl Drop for Robot {
    fn drop(&mut self) {
        if let Some(r) = self.running.take() {
            r.request_stop();
            let _ = r.join();
        }
        if let Some(sim) = self.sim.take() {
            sim.stop();
        }
    }
}

/// The robot `anguilla run` drives without a bus (`anguilla_sim::builtin`:
/// nodes, actuators and the swimming body, in real time), on a bus named
/// after the daemon's prefix; returns the daemon's end.
fn start_builtin(cfg: &Config, scenario: &str) -> anyhow::Result<(Box<dyn Bus>, Builtin)> {
    // `anguilla run`'s own wiring, but for the scenario and the priority:
    // a test's daemon runs without SCHED_FIFO, and so does its robot.
    let bc = BuiltinConfig {
        fifo_priority: None,
        scenario: scenario.to_owned(),
        ..anguilla::builtin_sim::builtin_config(cfg, &format!("{}-bus", cfg.ipc.prefix))
    };
    Ok(Builtin::start(&bc)?)
}

/// The configuration of a system test's daemon: `joints` joints of drive
/// family `drive`, on its own prefix `anguilla-<group>/<name>-<pid>`.
pub fn family_config(
    drive: anguilla_protocol::Family,
    joints: usize,
    group: &str,
    name: &str,
) -> Config {
    let mut cfg = Config::default();
    cfg.robot.joints = joints;
    cfg.robot.drive = drive;
    cfg.ipc.prefix = format!("anguilla-{group}/{name}-{}", std::process::id());
    // The simulated robot runs in this process, beside the daemon, as
    // `anguilla run`'s built-in one does: its timeouts, as there (a starved
    // machine stalls both; 0.35 s heartbeats and 100-period feedback
    // faulted every joint under stress-ng). A test about a timeout sets
    // its own after this.
    cfg.relax_for_builtin();
    cfg.validate().expect("valid configuration");
    cfg
}

/// Fixtures for tests that run `anguilla` as separate processes and talk to
/// the daemon as an operator.
pub mod process {
    use std::path::PathBuf;
    use std::process::Child;
    use std::time::{Duration, Instant};

    use anguilla_ipc::Command;
    use anguilla_ipc::{Client, StateSnapshot};

    /// The `anguilla` binary: `$ANGUILLA_BIN` (set in the vcan VM), else the
    /// workspace's debug build (which `cargo test --workspace --all-features` builds, `link` and
    /// `foxglove` included).
    pub fn anguilla_bin() -> PathBuf {
        std::env::var_os("ANGUILLA_BIN")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/debug/anguilla")
            })
    }

    /// How well joint `joint`'s measured yaw follows its command while the
    /// robot swims: the states read for `seconds` (resending `keep` every
    /// 100 ms so the swim goes on), then the median of |measured(t) −
    /// commanded(t − L)| at the lag L (0..=250 ms) that fits best, pairing
    /// states by their own clocks. Returns (median rad, lag ms, pairs). A
    /// lag (a busy machine, a slow serial link) does not count, nor do the
    /// few states of a stall; at 1 Hz a joint that does not move gives
    /// ≈ 0.7 × its swing, a sign error ≥ its swing (the lag window stops
    /// well short of the half period that would mimic one).
    pub fn tracking(
        client: &mut Client,
        joint: usize,
        seconds: f64,
        keep: Command,
    ) -> (f32, u64, usize) {
        let mut samples: Vec<(u64, f32, f32)> = Vec::new();
        let end = Instant::now() + Duration::from_secs_f64(seconds);
        let mut next_send = Instant::now();
        while Instant::now() < end {
            if Instant::now() >= next_send {
                let _ = client.send(keep);
                next_send += Duration::from_millis(100);
            }
            if let Ok(Some(s)) = client.wait_state(Duration::from_millis(20)) {
                let j = &s.joints[joint];
                if samples.last().is_none_or(|l| l.0 != s.time_ns) {
                    samples.push((s.time_ns, j.commanded_yaw, j.measured_yaw));
                }
            }
            let _ = client.replies(|_| {});
        }
        let mut best = (f32::INFINITY, 0, 0);
        let mut errors: Vec<f32> = Vec::with_capacity(samples.len());
        for lag_ms in (0..=250u64).step_by(5) {
            let lag = lag_ms * 1_000_000;
            errors.clear();
            let mut k = 0;
            for &(t, _, measured) in &samples {
                let Some(want) = t.checked_sub(lag) else {
                    continue;
                };
                // The sample nearest `want` (samples are in time order).
                while k + 1 < samples.len()
                    && samples[k + 1].0.abs_diff(want) <= samples[k].0.abs_diff(want)
                {
                    k += 1;
                }
                if samples[k].0.abs_diff(want) <= 10_000_000 {
                    errors.push((measured - samples[k].1).abs());
                }
            }
            if errors.len() >= 20 {
                errors.sort_by(f32::total_cmp);
                let median = errors[errors.len() / 2];
                if median < best.0 {
                    best = (median, lag_ms, errors.len());
                }
            }
        }
        assert!(
            best.0.is_finite(),
            "too few states to judge the tracking: {} in {seconds} s",
            samples.len()
        );
        best
    }

    /// Polls `f` until it gives a value, for at most `timeout` stretched
    /// by the patience; panics naming `what` otherwise. For conditions no
    /// event announces (a process starting, a file appearing); the state
    /// has `wait_for`. The one helper of every crate:
    /// [`anguilla_testkit::poll_until`].
    pub use anguilla_testkit::poll_until;

    /// Raw CAN sockets that receive every frame on `ifname`, as the kernel
    /// lists them (`/proc/net/can/rcvlist_all`, one line per receiver:
    /// device, id, mask, function, data, matches, `raw`); `None` without
    /// that file (no can-raw module, or no CAN in this kernel).
    pub fn can_receivers(ifname: &str) -> Option<usize> {
        let text = std::fs::read_to_string("/proc/net/can/rcvlist_all").ok()?;
        Some(
            text.lines()
                .filter(|l| {
                    let mut w = l.split_whitespace();
                    w.next() == Some(ifname) && l.trim_end().ends_with(" raw")
                })
                .count(),
        )
    }

    /// Starts `cmd` (a can-utils program such as `candump` listening on
    /// `ifname` without filters) and returns once the kernel lists one more
    /// receiver on `ifname` than before: its socket is bound, so it sees
    /// every frame sent from now on. The readiness signal can-utils does not
    /// print. Test binaries on vcan run one test at a time, so no other
    /// socket appears meanwhile.
    pub fn spawn_listening(cmd: &mut std::process::Command, ifname: &str) -> Child {
        let before = can_receivers(ifname)
            .expect("/proc/net/can/rcvlist_all: the kernel's CAN receive lists (can-raw loaded)");
        let mut child = cmd.spawn().expect("the CAN listener starts");
        poll_until(
            &format!("{cmd:?} listening on {ifname}"),
            Duration::from_secs(10),
            || {
                if let Ok(Some(status)) = child.try_wait() {
                    panic!("{cmd:?} exited before listening: {status}");
                }
                (can_receivers(ifname)? > before).then_some(())
            },
        );
        child
    }

    /// Makes `dir` with an iceoryx2 configuration of its own in
    /// `dir/config/iceoryx2.toml` (iceoryx2 reads ./config/iceoryx2.toml
    /// first, so a process started in `dir` uses it): root-path
    /// `dir/iox2/`, prefix `iox_prefix`. Keeps a test's iceoryx2 files
    /// (and the damage it does to them) apart from the other tests'.
    pub fn iceoryx2_sandbox(dir: &std::path::Path, iox_prefix: &str) {
        let _ = std::fs::remove_dir_all(dir);
        std::fs::create_dir_all(dir.join("config")).unwrap();
        std::fs::write(
            dir.join("config/iceoryx2.toml"),
            format!(
                "[global]\nroot-path = \"{}/iox2/\"\nprefix = \"{iox_prefix}\"\n",
                dir.display()
            ),
        )
        .unwrap();
    }

    /// iceoryx2's node-id segment in /dev/shm for the iceoryx2 prefix
    /// `iox_prefix`, once a node made it.
    pub fn node_id_segment(iox_prefix: &str) -> Option<PathBuf> {
        std::fs::read_dir(anguilla_ipc::guard::SHM_DIR)
            .ok()?
            .filter_map(|e| e.ok())
            .map(|e| e.path())
            .find(|p| {
                let n = p.file_name().unwrap_or_default().to_string_lossy();
                n.starts_with(iox_prefix) && n.ends_with(".global_mgmt")
            })
    }

    /// The paper's gait F1 (full amplitude, 1 Hz), straight ahead.
    pub const F1: Command = Command::Swim(anguilla_ipc::SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn: 0.0,
        pitch: 0.0,
    });

    /// The deadline of a command's reply: only a daemon that hangs reaches
    /// it (a starved machine has taken over 5 s to answer).
    pub const REPLY: Duration = Duration::from_secs(30);

    /// How much longer than on a quiet machine a condition may take
    /// (`ANGUILLA_TEST_PATIENCE`): [`anguilla_testkit::patience`], which
    /// every crate's test deadlines use.
    pub use anguilla_testkit::patience;

    /// Takes control and enables, and waits for Ready.
    pub fn take_control_and_enable(client: &mut Client, timeout: f64) {
        ok(client, Command::TakeControl);
        ok(client, Command::Enable);
        wait_for(client, "Ready", timeout, |s| {
            s.mode == anguilla_ipc::Mode::Ready as u8
        });
    }

    /// A client of the daemon at `prefix`, once its services are up.
    pub fn connect(prefix: &str, name: &str) -> Client {
        poll_until(
            &format!("the daemon at {prefix} serving"),
            Duration::from_secs(20),
            || Client::new(prefix, name).ok(),
        )
    }

    /// `anguilla run` (the built-in robot) serving `prefix`, with more
    /// configuration (`extra`, TOML after `[ipc]`), once `ctl status`
    /// answers; `tag` names its temporary configuration file.
    pub fn daemon_with(prefix: &str, tag: &str, extra: &str) -> Killed {
        let config =
            std::env::temp_dir().join(format!("anguilla-{tag}-{}.toml", std::process::id()));
        std::fs::write(&config, format!("[ipc]\nprefix = \"{prefix}\"\n{extra}")).unwrap();
        let d = Killed(
            std::process::Command::new(anguilla_bin())
                .args(["run", "--quiet", "--config"])
                .arg(&config)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .spawn()
                .unwrap(),
        );
        poll_until("the daemon up", Duration::from_secs(20), || {
            let o = std::process::Command::new(anguilla_bin())
                .args(["ctl", "--prefix", prefix, "status"])
                .output()
                .ok()?;
            (o.status.code() == Some(0)).then_some(())
        });
        let _ = std::fs::remove_file(&config);
        d
    }

    /// A finished process's status, stdout and stderr, for assertion messages.
    pub fn output_text(o: &std::process::Output) -> String {
        format!(
            "status {:?}; stdout {}; stderr {}",
            o.status.code(),
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    }

    /// A child process killed (and reaped) when dropped.
    #[derive(Debug)]
    pub struct Killed(pub Child);

    impl Drop for Killed {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }

    /// Sends `cmd` and asserts it is accepted (the reason otherwise).
    pub fn ok(client: &mut Client, cmd: Command) {
        let r = client.request(cmd, REPLY).expect("reply");
        assert_eq!(r.accepted, 1, "{} refused: {}", cmd.name(), r.reason());
    }

    /// Keeps control alive for `seconds`, handing every state to `each`.
    pub fn keep_alive_for(client: &mut Client, seconds: f64, mut each: impl FnMut(&StateSnapshot)) {
        let _ = keep_alive_until(client, seconds, |s| {
            each(s);
            false
        });
    }

    /// Sends keep-alives and takes states for up to `timeout` seconds until
    /// one satisfies `f`: `(true, that state)`, else `(false, the last one)`.
    fn keep_alive_until(
        client: &mut Client,
        timeout: f64,
        mut f: impl FnMut(&StateSnapshot) -> bool,
    ) -> (bool, Option<StateSnapshot>) {
        let end = Instant::now() + Duration::from_secs_f64(timeout);
        let mut last = None;
        while Instant::now() < end {
            let _ = client.send(Command::KeepAlive);
            if let Ok(Some(s)) = client.wait_state(Duration::from_millis(100)) {
                let found = f(&s);
                last = Some(s);
                if found {
                    return (true, last);
                }
            }
            let _ = client.replies(|_| {});
        }
        (false, last)
    }

    /// Keeps control alive and waits up to `timeout` seconds for a state
    /// satisfying `f`; panics naming `what` and the last state otherwise.
    pub fn wait_for(
        client: &mut Client,
        what: &str,
        timeout: f64,
        f: impl Fn(&StateSnapshot) -> bool,
    ) -> StateSnapshot {
        let (found, last) = keep_alive_until(client, timeout * patience(), f);
        if let (true, Some(s)) = (found, last) {
            return s;
        }
        let detail = last.map(|s| {
            format!(
                "mode {}, faults {:#x}, node 1 state {} errors {:#x}, bus malformed {} tx {} rx {}",
                s.mode,
                s.fault_kinds,
                s.joints[0].node_state,
                s.joints[0].node_errors,
                s.bus.malformed,
                s.bus.tx_frames,
                s.bus.rx_frames
            )
        });
        panic!("{what} not reached within {timeout} s; last state: {detail:?}");
    }
}
