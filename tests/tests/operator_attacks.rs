//! The operator interface against a buggy or hostile local program: a forged holder, a restarted client's E-stop, every
//! slot taken and a flood, a notification flood, a refusal flood, squatted
//! and stale services. The daemon is `anguilla run` as its own process (the
//! built-in simulated robot); the attacker is this test process.

use std::io::Read as _;
use std::process::{Command as Proc, Stdio};
use std::time::{Duration, Instant};

use anguilla_ipc::{Client, Command, CommandRequest, FaultKind, Mode, SwimParams};
use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::{
    Killed, REPLY, anguilla_bin, connect, iceoryx2_sandbox, node_id_segment, ok, poll_until,
    wait_for,
};

const SWIM: SwimParams = SwimParams {
    amplitude: 0.5,
    frequency: 1.0,
    turn: 0.0,
    pitch: 0.0,
};

/// A prefix and a config file naming it, unique to the test.
fn setup(tag: &str) -> (String, std::path::PathBuf) {
    let prefix = format!("anguilla-attack/{tag}-{}", std::process::id());
    let config =
        std::env::temp_dir().join(format!("anguilla-attack-{tag}-{}.toml", std::process::id()));
    std::fs::write(&config, format!("[ipc]\nprefix = \"{prefix}\"\n")).unwrap();
    (prefix, config)
}

/// A log file for the daemon of test `tag`.
fn log_path(tag: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("anguilla-attack-{tag}-{}.log", std::process::id()))
}

/// `anguilla run` on the built-in simulated robot, its stderr to `log`.
fn daemon(config: &std::path::Path, log: Option<&std::path::Path>) -> Killed {
    let bin = anguilla_bin();
    assert!(
        bin.exists(),
        "{} not built (cargo build --bin anguilla)",
        bin.display()
    );
    let stderr = match log {
        Some(p) => Stdio::from(std::fs::File::create(p).unwrap()),
        None => Stdio::null(),
    };
    Killed(
        Proc::new(&bin)
            .args(["run", "--quiet", "--config"])
            .arg(config)
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .expect("anguilla run starts"),
    )
}

/// Takes control, enables, and waits for Ready.
fn enabled(c: &mut Client) {
    ok(c, Command::TakeControl);
    ok(c, Command::Enable);
    wait_for(c, "ready", 30.0, |s| s.mode == Mode::Ready as u8);
}

fn raw(cmd: Command, sequence: u32) -> CommandRequest {
    CommandRequest::new(cmd, sequence)
}

#[test]
fn a_second_client_cannot_forge_its_way_to_control_and_the_holders_estop_goes_through() {
    let _dog = Watchdog::new("forged holder", Duration::from_secs(120));
    let (prefix, config) = setup("forge");
    let _d = daemon(&config, None);
    let mut a = connect(&prefix, "holder");
    let mut b = connect(&prefix, "forger");
    enabled(&mut a);
    ok(&mut a, Command::Swim(SWIM));
    let s = wait_for(&mut a, "swimming", 10.0, |s| s.mode == Mode::Swimming as u8);
    // B sees who holds control (published), and has nothing to forge with:
    // every request it can make, at the top of the sequence range, is
    // refused as not the holder's.
    assert_eq!(s.holder(), Some(a.id()));
    for (i, cmd) in [
        Command::TakeControl,
        Command::Swim(SWIM),
        Command::Stop,
        Command::Disable,
        Command::ReleaseControl,
        Command::KeepAlive,
    ]
    .into_iter()
    .enumerate()
    {
        let seq = u32::MAX - 5 + i as u32;
        let r = b.request_raw(raw(cmd, seq), REPLY).unwrap();
        assert_eq!(r.accepted, 0, "{} from the forger was accepted", cmd.name());
        assert!(r.reason().contains("holds control"), "{}", r.reason());
    }
    // The holder still drives, with its own low sequence numbers...
    let s = wait_for(&mut a, "still swimming", 5.0, |s| {
        s.mode == Mode::Swimming as u8
    });
    assert_eq!(s.holder(), Some(a.id()));
    ok(
        &mut a,
        Command::Swim(SwimParams {
            amplitude: 0.3,
            ..SWIM
        }),
    );
    // ...and its E-stop goes through, even numbered below one it already used.
    let r = a.request_raw(raw(Command::EStop, 1), REPLY).unwrap();
    assert_eq!(r.accepted, 1, "{}", r.reason());
    let s = wait_for(&mut a, "e-stop", 5.0, |s| s.mode == Mode::EStop as u8);
    assert!(s.fault_kinds & FaultKind::OperatorEStop as u32 != 0);
    // The forger cannot reset; the holder can.
    let r = b.request_raw(raw(Command::Reset, u32::MAX), REPLY).unwrap();
    assert_eq!(r.accepted, 0);
    ok(&mut a, Command::Reset);
    wait_for(&mut a, "idle", 5.0, |s| s.mode == Mode::Idle as u8);
}

#[test]
fn a_restarted_client_is_a_new_client_and_its_estop_is_never_refused() {
    let _dog = Watchdog::new("restarted client", Duration::from_secs(120));
    let (prefix, config) = setup("restart");
    let _d = daemon(&config, None);
    let first_id;
    {
        // A tool with a fixed numbering sends the highest sequence number,
        // then "restarts" (a new process would be a new client port too).
        let mut c = connect(&prefix, "fixed-tool");
        first_id = c.id();
        let r = c
            .request_raw(raw(Command::TakeControl, u32::MAX), REPLY)
            .unwrap();
        assert_eq!(r.accepted, 1, "{}", r.reason());
        let r = c
            .request_raw(raw(Command::Enable, u32::MAX), REPLY)
            .unwrap();
        assert_eq!(r.accepted, 0, "a duplicate number is refused");
        assert!(r.reason().contains("sequence number"), "{}", r.reason());
    }
    let mut c = connect(&prefix, "fixed-tool");
    assert_ne!(c.id(), first_id, "a restarted tool is a new client");
    for seq in [0, 1, 1, u32::MAX, 0] {
        let r = c.request_raw(raw(Command::EStop, seq), REPLY).unwrap();
        assert_eq!(
            r.accepted,
            1,
            "e-stop numbered {seq} refused: {}",
            r.reason()
        );
    }
    wait_for(&mut c, "e-stop", 5.0, |s| s.mode == Mode::EStop as u8);
}

/// Opens clients until the daemon's services refuse one; returns them.
fn take_every_slot(prefix: &str) -> Vec<Client> {
    let mut hogs = Vec::new();
    for i in 0..4 * anguilla_ipc::MAX_TOOLS {
        match Client::new(prefix, &format!("hog-{i}")) {
            Ok(c) => hogs.push(c),
            Err(_) => return hogs,
        }
    }
    panic!("{} clients and the services still accept more", hogs.len());
}

#[test]
fn with_every_slot_taken_and_a_flood_ctl_estop_still_stops_the_robot() {
    let _dog = Watchdog::new("exhausted slots", Duration::from_secs(180));
    let (prefix, config) = setup("slots");
    let _d = daemon(&config, None);
    let mut a = connect(&prefix, "operator");
    enabled(&mut a);
    ok(&mut a, Command::Swim(SWIM));
    wait_for(&mut a, "swimming", 10.0, |s| s.mode == Mode::Swimming as u8);
    // The hostile program: every slot, then a flood from each of its clients.
    let (full_tx, full_rx) = std::sync::mpsc::channel();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flood_stop = stop.clone();
    let p = prefix.clone();
    let hog = std::thread::spawn(move || {
        let mut hogs = take_every_slot(&p);
        full_tx.send(hogs.len()).unwrap();
        let mut seq = 0u32;
        while !flood_stop.load(std::sync::atomic::Ordering::Relaxed) {
            for h in hogs.iter_mut() {
                seq = seq.wrapping_add(1);
                let _ = h.send_request(raw(Command::Swim(SWIM), seq));
                let _ = h.replies(|_| {});
            }
        }
    });
    let hogs = full_rx
        .recv_timeout(anguilla_testkit::patient(Duration::from_secs(60)))
        .expect("slots taken");
    println!("the hostile program holds {hogs} clients, and floods");
    // No new tool gets in: `ctl status` cannot connect.
    let bin = anguilla_bin();
    let status = Proc::new(&bin)
        .args(["ctl", "--prefix", &prefix, "status"])
        .output()
        .unwrap();
    assert_eq!(
        status.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    // The E-stop does.
    let estop = Proc::new(&bin)
        .args(["ctl", "--prefix", &prefix, "estop"])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&estop.stdout);
    assert_eq!(
        estop.status.code(),
        Some(0),
        "{said} {}",
        String::from_utf8_lossy(&estop.stderr)
    );
    assert!(said.contains("e-stop socket"), "{said}");
    let s = wait_for(&mut a, "e-stop", 5.0, |s| s.mode == Mode::EStop as u8);
    assert!(s.socket_estops >= 1, "taken on the reserved path");
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    hog.join().unwrap();
}

/// CPU seconds a thread of `pid` named `comm` has used (utime + stime).
fn thread_cpu(pid: u32, comm: &str) -> f64 {
    let tick = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    for t in std::fs::read_dir(format!("/proc/{pid}/task"))
        .unwrap()
        .flatten()
    {
        let name = std::fs::read_to_string(t.path().join("comm")).unwrap_or_default();
        if name.trim() != comm {
            continue;
        }
        let stat = std::fs::read_to_string(t.path().join("stat")).unwrap();
        // Fields after the ")" of the command name: state is field 3, utime 14, stime 15.
        let rest = &stat[stat.rfind(')').unwrap() + 2..];
        let f: Vec<&str> = rest.split_whitespace().collect();
        let (u, s): (f64, f64) = (f[11].parse().unwrap(), f[12].parse().unwrap());
        return (u + s) / tick;
    }
    panic!("no thread {comm} in process {pid}");
}

#[test]
fn a_notification_and_refusal_flood_costs_bounded_cpu_and_log_lines() {
    let _dog = Watchdog::new("floods", Duration::from_secs(180));
    let (prefix, config) = setup("flood");
    let log = log_path("flood");
    let mut d = daemon(&config, Some(&log));
    let pid = d.0.id();
    let mut a = connect(&prefix, "operator");
    enabled(&mut a);
    let mut b = connect(&prefix, "flooder");
    // 1. A notification flood on command-ready (no requests), 3 s.
    let secs = 3.0;
    let before = thread_cpu(pid, "anguilla-comman");
    let start = Instant::now();
    let mut notified = 0u64;
    while start.elapsed().as_secs_f64() < secs {
        for _ in 0..100 {
            b.notify_command_ready().unwrap();
        }
        notified += 100;
    }
    let wall = start.elapsed().as_secs_f64();
    let used = thread_cpu(pid, "anguilla-comman") - before;
    println!(
        "notification flood: {notified} notifications in {wall:.1} s; the command thread used \
         {used:.2} CPU s ({:.0} % of one core; ~97 % before the command thread's round limit)",
        100.0 * used / wall
    );
    // The bound is a resource bound, not a speed goal: one round a ms costs
    // a few % of a core; an unbounded thread takes it all. Noise only lowers it.
    assert!(
        used / wall < 0.5,
        "command thread at {:.0} % of a core",
        100.0 * used / wall
    );
    // 2. A refusal flood: B holds no control; 3000 swims, three in flight.
    let mut refused = 0u64;
    let mut seq = 0u32;
    while refused < 3000 {
        for _ in 0..3 {
            seq += 1;
            b.send_request(raw(Command::Swim(SWIM), seq)).unwrap();
        }
        let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(5));
        let mut got = 0;
        while got < 3 && !deadline.passed() {
            b.replies(|r| {
                got += 1;
                refused += u64::from(r.accepted == 0);
            })
            .unwrap();
            let _ = b.wait_state(Duration::from_millis(1));
        }
        assert_eq!(got, 3, "every request answered");
    }
    let s = wait_for(&mut a, "the refusals counted", 5.0, |s| {
        s.refused_commands >= 3000
    });
    assert!(s.refused_commands >= 3000);
    let flood_secs = start.elapsed().as_secs_f64() - wall;
    // SIGTERM: a clean stop flushes the log summary.
    unsafe { libc::kill(pid as i32, libc::SIGTERM) };
    let _ = d.0.wait();
    let mut text = String::new();
    std::fs::File::open(&log)
        .unwrap()
        .read_to_string(&mut text)
        .unwrap();
    let lines = text.lines().filter(|l| l.contains("refused")).count();
    println!("refusal flood: {refused} refusals in {flood_secs:.1} s logged as {lines} line(s)");
    // One whole line and one summary per second at most, plus the last.
    let bound = 2 * (flood_secs.ceil() as usize + 1) + 2;
    assert!(
        lines <= bound,
        "{lines} refusal lines (bound {bound}):\n{text}"
    );
    assert!(text.contains("more command(s)"), "a summary line:\n{text}");
}

/// A program that creates `<prefix>/state` before the daemon, with the
/// documented settings but room for `max_publishers`, and (with
/// `publish`) publishes a fake state on it.
struct Squatter {
    _node: iceoryx2::prelude::Node<iceoryx2::prelude::ipc::Service>,
    _service: iceoryx2::service::port_factory::publish_subscribe::PortFactory<
        iceoryx2::prelude::ipc::Service,
        anguilla_ipc::StateSnapshot,
        (),
    >,
    _publisher: Option<
        iceoryx2::port::publisher::Publisher<
            iceoryx2::prelude::ipc::Service,
            anguilla_ipc::StateSnapshot,
            (),
        >,
    >,
}

impl Squatter {
    fn state(prefix: &str, max_publishers: usize, publish: bool) -> Self {
        use iceoryx2::prelude::*;
        let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
        let name = ServiceName::new(&format!("{prefix}/state")).unwrap();
        let service = node
            .service_builder(&name)
            .publish_subscribe::<anguilla_ipc::StateSnapshot>()
            .history_size(1)
            .subscriber_max_buffer_size(2)
            .enable_safe_overflow(true)
            .max_subscribers(anguilla_ipc::MAX_TOOLS)
            .max_publishers(max_publishers)
            .max_nodes(anguilla_ipc::MAX_NODES)
            .create()
            .unwrap();
        let publisher = publish.then(|| {
            let p = service.publisher_builder().create().unwrap();
            let fake = anguilla_ipc::StateSnapshot {
                mode: Mode::Ready as u8,
                ..Default::default()
            };
            p.send_copy(fake).unwrap();
            p
        });
        Self {
            _node: node,
            _service: service,
            _publisher: publisher,
        }
    }
}

#[test]
fn a_squatter_is_named_and_a_dead_daemons_services_are_taken_over() {
    let _dog = Watchdog::new("squatting", Duration::from_secs(120));
    let bin = anguilla_bin();
    let (prefix, config) = setup("squat");
    let run_for_a_second = || {
        Proc::new(&bin)
            .args(["run", "--quiet", "--duration", "1", "--config"])
            .arg(&config)
            .stdout(Stdio::null())
            .output()
            .unwrap()
    };
    {
        // This process creates the state service and publishes fake state.
        let squatter = Squatter::state(&prefix, 1, true);
        let out = run_for_a_second();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "the daemon ran beside a squatter");
        let want = format!(
            "service '{prefix}/state' is held by a live process (pid {}",
            std::process::id()
        );
        assert!(err.contains(&want), "{err}");
        drop(squatter);
    }
    {
        // Room for a second publisher, held with no port: the daemon would
        // open it (iceoryx2 opens a service with at least the capacities
        // asked for) and the program publish beside it later.
        let _squatter = Squatter::state(&prefix, 2, false);
        let out = run_for_a_second();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "the daemon shared its state service");
        assert!(
            err.contains("max publishers 2, expected 1")
                && err.contains(&format!("pid {}", std::process::id())),
            "{err}"
        );
    }
    {
        // A careless tool: open_or_create with iceoryx2's default settings,
        // before the daemon. It publishes nothing, but the settings differ.
        use iceoryx2::prelude::*;
        let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
        let name = ServiceName::new(&format!("{prefix}/command")).unwrap();
        let _svc = node
            .service_builder(&name)
            .request_response::<anguilla_ipc::CommandRequest, anguilla_ipc::CommandReply>()
            .open_or_create()
            .unwrap();
        let out = run_for_a_second();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success(),
            "the daemon ran on a mis-made service"
        );
        let want = format!("pid {}", std::process::id());
        assert!(
            err.contains(&format!("service '{prefix}/command'")) && err.contains(&want),
            "names the service and the process: {err}"
        );
    }
    // A daemon killed outright leaves its services and its E-stop socket.
    let mut d = daemon(&config, None);
    let mut c = connect(&prefix, "watcher");
    wait_for(&mut c, "first state", 10.0, |_| true);
    unsafe { libc::kill(d.0.id() as i32, libc::SIGKILL) };
    let _ = d.0.wait();
    // The watcher still holds the services open; the new daemon takes them over.
    let out = run_for_a_second();
    assert!(
        out.status.success(),
        "after a dead daemon: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    drop(c);
}

#[test]
fn a_second_daemon_on_a_prefix_is_told_another_daemon_serves_it() {
    let _dog = Watchdog::new("second daemon", Duration::from_secs(120));
    let (prefix, config) = setup("second");
    let _first = daemon(&config, None);
    let mut c = connect(&prefix, "watcher");
    wait_for(&mut c, "first state", 10.0, |_| true);
    let out = Proc::new(anguilla_bin())
        .args(["run", "--quiet", "--duration", "1", "--config"])
        .arg(&config)
        .stdout(Stdio::null())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "the second daemon ran: {err}");
    // The operator's words, once, and none of iceoryx2's.
    let want = "another anguilla daemon serves this prefix";
    assert_eq!(err.matches(want).count(), 1, "{err}");
    for name in [
        "iceoryx2",
        "Error::",
        "OpenOrCreate",
        "AlreadyExists",
        "InUse",
    ] {
        assert!(!err.contains(name), "'{name}' in: {err}");
    }
    // The first daemon serves on, undisturbed.
    let before = wait_for(&mut c, "state", 10.0, |_| true).loop_stats.periods;
    wait_for(&mut c, "the first daemon still running", 10.0, |s| {
        s.loop_stats.periods > before
    });
}

#[test]
fn an_estop_while_shutdown_stops_a_swim_still_goes_through() {
    let _dog = Watchdog::new("e-stop at shutdown", Duration::from_secs(120));
    let (prefix, config) = setup("shutdown-estop");
    let bin = anguilla_bin();
    let mut d = Killed(
        Proc::new(&bin)
            .args(["run", "--config"])
            .arg(&config)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let mut a = connect(&prefix, "operator");
    enabled(&mut a);
    ok(
        &mut a,
        Command::Swim(SwimParams {
            amplitude: 1.0,
            ..SWIM
        }),
    );
    // Well into the swim: its ramp-down then takes a while.
    wait_for(&mut a, "swimming hard", 10.0, |s| {
        s.mode == Mode::Swimming as u8 && s.gait_actual.amplitude > 0.5
    });
    // SIGTERM starts the smooth stop (up to 3 s); the E-stop socket must
    // stay open until the loop has ended.
    unsafe { libc::kill(d.0.id() as i32, libc::SIGTERM) };
    wait_for(&mut a, "the shutdown's smooth stop", 5.0, |s| {
        s.mode == Mode::Stopping as u8
    });
    anguilla_ipc::estop::send(&prefix).expect("the e-stop socket is open during the stop");
    let status = d.0.wait().unwrap();
    let mut out = String::new();
    d.0.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    assert!(status.success(), "{out}");
    assert!(out.contains("stopped in mode e-stop"), "{out}");
}

#[test]
fn a_holder_that_leaves_without_releasing_is_not_called_dead() {
    let _dog = Watchdog::new("holder leaves", Duration::from_secs(120));
    let (prefix, config) = setup("leaves");
    // Control is released by the departure alone: the silent holder's
    // timeout (3 s by default) would release it too, without the line, on
    // a machine so loaded that the departure is seen later (CI,
    // 2026-12-06: the log had no such line because there was none).
    let text = std::fs::read_to_string(&config).unwrap();
    std::fs::write(
        &config,
        format!("{text}[control]\ncontrol-release-timeout = 600\n"),
    )
    .unwrap();
    let log = log_path("leaves");
    let mut d = daemon(&config, Some(&log));
    let watcher = connect(&prefix, "watcher");
    {
        let mut c = connect(&prefix, "leaving-tool");
        ok(&mut c, Command::TakeControl);
        // Dropped here: its node ends cleanly, control still held.
    }
    let end = anguilla_testkit::Deadline::new(Duration::from_secs(20));
    loop {
        if let Ok(Some(s)) = watcher.wait_state(Duration::from_millis(100))
            && s.holder().is_none()
        {
            break;
        }
        assert!(!end.passed(), "control never released");
    }
    // The log's line may follow the state that shows control released
    // (the logger writes on its own thread): wait for it, not for time.
    let read = || std::fs::read_to_string(&log).unwrap_or_default();
    poll_until(
        "the log says the holder left without releasing",
        Duration::from_secs(20),
        || read().contains("left without releasing it").then_some(()),
    );
    unsafe { libc::kill(d.0.id() as i32, libc::SIGTERM) };
    let _ = d.0.wait();
    let text = read();
    assert!(text.contains("left without releasing it"), "{text}");
    assert!(!text.contains("died"), "{text}");
}

/// No tool hangs for ever: iceoryx2's node-id segment truncated (by a program
/// of the daemon's own user: others can no longer write it) made every new
/// tool hang for ever, deaf to SIGTERM. Now a tool ends within 2 s of
/// SIGTERM while it waits, and gives up by itself after the open limit,
/// naming the files to check.
#[test]
fn a_damaged_node_id_segment_hangs_no_tool() {
    let _dog = Watchdog::new("damaged-segment", Duration::from_secs(120));
    let tag = std::process::id();
    // The damage stays in this test's own iceoryx2 files.
    let dir = std::env::temp_dir().join(format!("anguilla-attack-segment-{tag}"));
    let iox_prefix = format!("ih{tag}_");
    iceoryx2_sandbox(&dir, &iox_prefix);
    let ctl = || {
        let mut p = Proc::new(anguilla_bin());
        p.args([
            "ctl",
            "--prefix",
            &format!("anguilla-attack-seg-{tag}"),
            "status",
        ])
        .current_dir(&dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
        p
    };
    // A first tool makes the segment (and finds no daemon).
    let o = ctl().output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let seg = node_id_segment(&iox_prefix).expect("the node-id segment");
    std::fs::OpenOptions::new()
        .write(true)
        .open(&seg)
        .unwrap()
        .set_len(0)
        .unwrap();
    // SIGTERM while it waits inside iceoryx2 (its open-limit thread,
    // "anguilla-open-limit", lives exactly as long as such a call): gone
    // within 2 s, the bound.
    let mut child = ctl().spawn().unwrap();
    let pid = child.id() as i32;
    poll_until(
        "the tool waiting in iceoryx2",
        Duration::from_secs(10),
        || {
            std::fs::read_dir(format!("/proc/{pid}/task"))
                .ok()?
                .filter_map(|t| t.ok())
                .any(|t| {
                    std::fs::read_to_string(t.path().join("comm"))
                        .is_ok_and(|c| c.starts_with("anguilla-open-l"))
                })
                .then_some(())
        },
    );
    let (done_tx, done) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = done_tx.send(child.wait());
    });
    let sent = Instant::now();
    unsafe { libc::kill(pid, libc::SIGTERM) };
    let ended = done.recv_timeout(anguilla_testkit::patient(Duration::from_secs(5)));
    let took = sent.elapsed();
    if ended.is_err() {
        unsafe { libc::kill(pid, libc::SIGKILL) };
        panic!("the tool still runs 5 s (times the patience) after SIGTERM");
    }
    assert!(
        took < anguilla_testkit::patient(Duration::from_secs(2)),
        "ended {took:?} after SIGTERM"
    );
    // Left alone, it gives up by itself, naming what to check.
    let start = Instant::now();
    let o = ctl().output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    // The limit, plus the tool's own start and the first node's creation
    // (which made the segment, above) on a busy machine: it catches a
    // tool that waits for ever, not a slow one.
    assert!(
        start.elapsed()
            < anguilla_ipc::guard::OPEN_LIMIT + anguilla_testkit::patient(Duration::from_secs(10)),
        "{:?}",
        start.elapsed()
    );
    assert!(
        err.contains("global_mgmt") || err.contains("iceoryx2"),
        "{err}"
    );
    eprintln!(
        "damaged segment: SIGTERM ended the tool in {took:?}; alone it gave up in {:?}: {}",
        start.elapsed(),
        err.lines().last().unwrap_or("")
    );
    let _ = std::fs::remove_file(&seg);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 45: a signal's stop was logged as an operator's command ("mode
/// swimming -> stopping: by an operator's command", cause 1). It has its
/// own cause, shutdown, in the state (and so in the recording's states)
/// and in the log.
#[test]
fn a_signals_stop_is_the_daemons_shutdown_not_an_operators_command() {
    let _dog = Watchdog::new("signal's stop", Duration::from_secs(120));
    let (prefix, config) = setup("signal-stop");
    let log = log_path("signal-stop");
    let mut d = daemon(&config, Some(&log));
    let mut a = connect(&prefix, "operator");
    enabled(&mut a);
    ok(
        &mut a,
        Command::Swim(SwimParams {
            amplitude: 1.0,
            ..SWIM
        }),
    );
    // Well into the swim: its ramp-down then takes a while.
    wait_for(&mut a, "swimming hard", 10.0, |s| {
        s.mode == Mode::Swimming as u8 && s.gait_actual.amplitude > 0.5
    });
    unsafe { libc::kill(d.0.id() as i32, libc::SIGTERM) };
    let s = wait_for(&mut a, "the shutdown's smooth stop", 5.0, |s| {
        s.mode == Mode::Stopping as u8
    });
    assert_eq!(
        anguilla_ipc::Cause::from_code(s.cause),
        Some(anguilla_ipc::Cause::Shutdown),
        "cause {}",
        s.cause
    );
    let _ = d.0.wait();
    let mut text = String::new();
    std::fs::File::open(&log)
        .unwrap()
        .read_to_string(&mut text)
        .unwrap();
    assert!(
        text.contains("mode swimming -> stopping: the daemon is shutting down"),
        "{text}"
    );
    assert!(
        !text.contains("-> stopping: by an operator's command"),
        "{text}"
    );
}
