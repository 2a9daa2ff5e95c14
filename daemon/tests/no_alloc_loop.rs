//! The running control loop thread allocates nothing, operator interface
//! included (the E-stop socket too): a counting allocator counts the allocations made on the thread
//! named `anguilla-loop` (and on no other), while a client drives the
//! simulated robot through iceoryx2 — swim, turn, dive, stop, a refused
//! command, an E-stop and a reset — and reads the state every period.
//!
//! iceoryx2 0.10 allocates when it loans a sample or answers a request, so
//! its ports live on the daemon's state and command threads; this test is
//! what keeps them there.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anguilla_daemon::config::Config;
use anguilla_daemon::run;
use anguilla_drivers::mem::MemBus;
use anguilla_ipc::vocabulary::{Command, Mode, SwimParams};
use anguilla_ipc::{Client, StateSnapshot};
use anguilla_sim::robot::{RobotConfig, SimRobot};

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

/// The kernel thread id of this process's thread named `name`.
fn thread_named(name: &str) -> Option<i32> {
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let task = task.ok()?;
        let comm = std::fs::read_to_string(task.path().join("comm")).unwrap_or_default();
        if comm.trim_end() == name {
            return task.file_name().to_str()?.parse().ok();
        }
    }
    None
}

fn swim(turn: f64, pitch: f64) -> Command {
    Command::Swim(SwimParams {
        amplitude: 1.0,
        frequency: 1.0,
        turn,
        pitch,
    })
}

/// Reads states for `secs`, sending keep-alives as the holder must; returns
/// the newest state and how many were read.
fn hold(client: &mut Client, secs: f64) -> (StateSnapshot, usize) {
    let end = Instant::now() + Duration::from_secs_f64(secs);
    let (mut last, mut n) = (StateSnapshot::default(), 0);
    let mut keep_alive = Instant::now();
    while Instant::now() < end {
        if let Ok(Some(s)) = client.wait_state(Duration::from_millis(50)) {
            last = s;
            n += 1;
        }
        if keep_alive.elapsed() > Duration::from_millis(100) {
            client.send(Command::KeepAlive).expect("keep-alive sent");
            keep_alive = Instant::now();
        }
        client.replies(|_| {}).expect("replies read");
    }
    (last, n)
}

fn accepted(client: &mut Client, cmd: Command) {
    let r = client
        .request(cmd, Duration::from_secs(5))
        .expect("the daemon answers");
    assert_eq!(r.accepted, 1, "'{}' refused: {}", cmd.name(), r.reason());
}

fn wait_mode(client: &mut Client, want: Mode, secs: f64) {
    let end = Instant::now() + Duration::from_secs_f64(secs);
    let mut mode = Mode::Idle;
    while Instant::now() < end {
        let (s, _) = hold(client, 0.05);
        mode = Mode::from_code(s.mode).unwrap_or(Mode::Idle);
        if mode == want {
            return;
        }
    }
    panic!("still {mode} after {secs} s, expected {want}");
}

#[test]
fn the_running_loop_thread_allocates_nothing() {
    let prefix = format!("anguilla-test/no-alloc-loop-{}", std::process::id());
    let mut cfg = Config::default();
    cfg.ipc.prefix = prefix.clone();
    let bus = MemBus::builder("no-alloc-loop").capacity(1 << 14).build();
    let clock = bus.clock();
    let robot = SimRobot::on_mem(
        RobotConfig {
            node_ids: cfg.node_ids(),
            boot_time: Duration::from_millis(10),
            ..RobotConfig::with_joints(cfg.robot.joints)
        },
        bus.participant(),
        clock.now(),
    )
    .expect("simulated robot");
    let sim = robot.spawn(clock).expect("simulated robot thread");
    let stop = Arc::new(AtomicBool::new(false));
    let running = run::spawn(cfg, Box::new(bus.participant()), stop).expect("daemon starts");
    let mut client = Client::new(&prefix, "no-alloc-client").expect("client");
    let mut observer = Client::new(&prefix, "no-alloc-observer").expect("observer");

    // Warm-up, not counted: control taken, actuators enabled.
    accepted(&mut client, Command::TakeControl);
    accepted(&mut client, Command::Enable);
    wait_mode(&mut client, Mode::Ready, 10.0);
    let loop_tid = thread_named("anguilla-loop").expect("the loop thread is named");

    anguilla_testkit::watch_thread(loop_tid);
    let (first, _) = hold(&mut client, 0.05);
    accepted(&mut client, swim(0.0, 0.0));
    hold(&mut client, 1.0);
    accepted(&mut client, swim(1.5, 0.0));
    hold(&mut client, 0.5);
    accepted(&mut client, swim(0.0, 0.8));
    // A refused command: the observer does not hold control.
    let r = observer
        .request(Command::Stop, Duration::from_secs(5))
        .expect("answer");
    assert_eq!(r.accepted, 0);
    let (swimming, _) = hold(&mut client, 0.5);
    assert_eq!(Mode::from_code(swimming.mode), Some(Mode::Swimming));
    accepted(&mut client, Command::Stop);
    wait_mode(&mut client, Mode::Ready, 10.0);
    // E-stop from the observer (anyone may), then reset and enable again.
    accepted(&mut observer, Command::EStop);
    wait_mode(&mut client, Mode::EStop, 5.0);
    accepted(&mut client, Command::TakeControl);
    accepted(&mut client, Command::Reset);
    accepted(&mut client, Command::Enable);
    wait_mode(&mut client, Mode::Ready, 10.0);
    // An E-stop on the reserved socket, then reset again.
    anguilla_ipc::estop::send(&prefix).expect("e-stop socket");
    wait_mode(&mut client, Mode::EStop, 5.0);
    let (stopped, _) = hold(&mut client, 0.1);
    assert_eq!(stopped.socket_estops, 1, "taken on the reserved path");
    accepted(&mut client, Command::Reset);
    accepted(&mut client, Command::Enable);
    wait_mode(&mut client, Mode::Ready, 10.0);
    let (last, read) = hold(&mut client, 0.2);
    anguilla_testkit::watch_thread(0);
    let n = anguilla_testkit::watched_calls();

    let periods = last.sequence - first.sequence;
    running.request_stop();
    let report = running.join().expect("clean stop");
    let _ = sim.stop();
    assert!(periods > 500, "only {periods} periods counted");
    assert!(read > 0);
    assert_eq!(
        n, 0,
        "{n} allocator calls on the loop thread in {periods} periods (overruns {})",
        report.overruns
    );
}
