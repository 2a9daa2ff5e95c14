//! Daemon benchmarks that print figures (never asserted; machines are shared
//! and noisy: compare the ratios printed in one run).
//!
//! `cargo bench -p anguilla-daemon --bench daemon` prints JSON lines, the
//! loop and command ones once per setup (`SETUPS`: 1 kHz with four joints
//! on CAN FD, and the built-in robot's twelve joints at their automatic
//! rate on classic CAN; twelve joints cannot run at 1 kHz on one bus):
//!
//! 1. `state_latency`: the loop's handoff of a `StateSnapshot` (a bounded
//!    channel to the daemon's state thread, which publishes it) to its
//!    receipt by a client woken by the state-ready event, beside iceoryx2's own
//!    publish-subscribe + event with a payload of the same size; p50/p99 and
//!    the ratios (goal ≤ 1.2), with the state thread at SCHED_FIFO 1 (as the
//!    daemon runs it under a real-time loop: the scheduler wakes it on
//!    another CPU) and at SCHED_OTHER (as the raw publisher runs).
//! 2. `loop_jitter`: wake-up lateness of the control loop against the
//!    simulated robot (its nodes and the swimming body) on the in-process
//!    bus, beside `cyclictest` (Debian's rt-tests) at the same period and
//!    the same SCHED_FIFO priority, running at the same time (so both see
//!    the same load): the median of the loop's ~1 s windows' p50 and p99,
//!    the worst window's p99, the max, and the ratio of the p99s (goal ≤
//!    1.5); beside them the loop's overruns and its compute time per period
//!    (median of the windows' p99, and the max), to tell a late wake-up from
//!    a long period.
//! 3. `command_latency`: an operator command (E-stop, then reset, in turn)
//!    sent through iceoryx2 to the first frame on the bus that reflects it
//!    (an E-stop frame, a clear-faults command): p50/p99/max, also in
//!    periods (goal: p99 ≤ one period + 100 µs). It includes the wait for
//!    the loop's next period (half a period on average).
//!
//! `ANGUILLA_BENCH_SECONDS` (default 10) sets the length of the loop run,
//! `ANGUILLA_BENCH_COMMANDS` (default 200) the commands timed per setup.
//! `scripts/bench-check` runs it briefly and compares the ratio figures
//! with `.ci/bench-baseline.json`.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anguilla_daemon::config::Config;
use anguilla_daemon::rt::monotonic_ns;
use anguilla_daemon::run;
use anguilla_drivers::Bus;
use anguilla_drivers::mem::MemBus;
use anguilla_ipc::vocabulary::{Command, Mode};
use anguilla_ipc::{Client, StateSnapshot};
use anguilla_protocol::message::{self, Message, NodeSet};
use anguilla_sim::robot::{RobotConfig, SimRobot};

fn pct(sorted: &[u64], q: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    sorted[((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1]
}

/// One configuration of the loop and command benchmark: what the bus can
/// carry (the daemon refuses a rate over `bus.max-load`).
struct Setup {
    name: &'static str,
    joints: usize,
    fd: bool,
    /// 0: the automatic rate (the highest the bus budget allows).
    rate_hz: f64,
}

/// The two setups measured: 1 kHz (four joints on CAN FD, 44 % load: twelve
/// joints cannot run at 1 kHz on one bus, 333 % on classic CAN and 92 % on
/// CAN FD at 8 Mbit/s, see `anguilla protocol budget`), and the built-in
/// robot's twelve joints at their automatic rate on classic CAN.
const SETUPS: [Setup; 2] = [
    Setup {
        name: "1khz_4joints_fd",
        joints: 4,
        fd: true,
        rate_hz: 1000.0,
    },
    Setup {
        name: "auto_12joints_classic",
        joints: 12,
        fd: false,
        rate_hz: 0.0,
    },
];

fn loop_and_command_bench(setup: &Setup, seconds: f64, commands: usize) {
    let prefix = format!("anguilla-bench/{}/{}", std::process::id(), setup.name);
    let mut cfg = Config::default();
    cfg.control.rate_hz = setup.rate_hz;
    cfg.robot.joints = setup.joints;
    cfg.bus.fd = setup.fd;
    cfg.realtime.fifo_priority = 2;
    cfg.ipc.prefix = prefix.clone();
    let rate = cfg.control_rate().expect("a rate the bus carries");
    let variant = cfg.bus.variant();
    let period_ns = anguilla_daemon::control::period_ns(&cfg).as_nanos();
    let bus = MemBus::builder("bench").capacity(1 << 14).build();
    let stop = Arc::new(AtomicBool::new(false));
    // The simulated robot (twelve nodes and the swimming body) in real time.
    let clock = bus.clock();
    let robot = SimRobot::on_mem(
        RobotConfig {
            boot_time: Duration::from_millis(10),
            variant: cfg.bus.variant(),
            ..RobotConfig::with_joints(setup.joints)
        },
        bus.participant(),
        clock.now(),
    )
    .expect("robot")
    .spawn(clock)
    .expect("robot thread");
    // As `anguilla run` does: the robot just below the loop, so that the
    // loop does not wait on the in-process bus's lock held by a preempted
    // robot thread.
    if let Err(e) = robot.set_fifo_priority(1) {
        println!("{{\"bench\":\"loop_jitter\",\"note\":\"robot thread stays SCHED_OTHER: {e}\"}}");
    }
    let mut listener = bus.participant();
    let running = run::spawn(cfg, Box::new(bus.participant()), stop.clone()).expect("daemon");
    let mut client = Client::new(&prefix, "bench-client").expect("client");
    let reply = |c: &mut Client, cmd| c.request(cmd, Duration::from_secs(5)).expect("reply");
    reply(&mut client, Command::TakeControl);
    // cyclictest at the same rate and priority, at the same time: both see
    // the same load (the simulated nodes, this client, whatever else runs).
    let interval_us = (period_ns / 1000).to_string();
    let loops = (seconds * rate) as u64;
    let cyclictest = std::process::Command::new("cyclictest")
        .args([
            "-t1",
            "-i",
            &interval_us,
            "-p",
            "2",
            "-q",
            "-h",
            "20000",
            "-l",
        ])
        .arg(loops.to_string())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn();
    // Jitter: each window's p50/p99 from the state (the loop's windows
    // are about 1 s: `rate` periods), once per window.
    let window = rate.ceil() as u64;
    let mut window_p99 = Vec::new();
    let mut window_p50 = Vec::new();
    let mut max = 0u64;
    let (mut compute_p99, mut compute_max) = (Vec::new(), 0u64);
    let mut last_seq_periods = 0;
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    while Instant::now() < end {
        if let Ok(Some(s)) = client.wait_state(Duration::from_millis(50)) {
            let l = s.loop_stats;
            if l.periods >= last_seq_periods + window {
                last_seq_periods = l.periods;
                window_p99.push(l.jitter_p99_ns as u64);
                window_p50.push(l.jitter_p50_ns as u64);
                max = max.max(l.jitter_max_ns as u64);
                compute_p99.push(l.compute_p99_ns as u64);
                compute_max = compute_max.max(l.compute_max_ns as u64);
            }
        }
        let _ = client.send(Command::KeepAlive);
        client.replies(|_| {}).ok();
    }
    window_p99.sort_unstable();
    window_p50.sort_unstable();
    compute_p99.sort_unstable();
    // Command latency: E-stop and reset in turn; time to the frame.
    let mut lat = Vec::new();
    for i in 0..commands {
        let (cmd, wanted): (Command, fn(&Message) -> bool) = if i % 2 == 0 {
            (Command::EStop, |m| matches!(m, Message::EStop(_)))
        } else {
            (Command::Reset, |m| {
                matches!(
                    m,
                    Message::Command {
                        command: message::Command::ClearFaults,
                        ..
                    }
                )
            })
        };
        while listener.try_recv().ok().flatten().is_some() {}
        let t0 = monotonic_ns();
        client.send(cmd).unwrap();
        let deadline = Instant::now() + Duration::from_secs(2);
        while Instant::now() < deadline {
            if let Ok(Some(r)) = listener.recv(Duration::from_millis(5))
                && let Ok(m) = message::decode(&r.frame, variant, NodeSet::all())
                && wanted(&m)
            {
                lat.push(monotonic_ns() - t0);
                break;
            }
        }
        client.replies(|_| {}).ok();
        // The daemon took the command (E-stopped, or reset to idle), then
        // the next command goes at another phase of the period (the golden
        // ratio's fractions spread evenly): a fixed pause would send every
        // command at the same phase and bias the figures. That pause is the
        // benchmark's pacing, not a wait for anything.
        wait_mode(&client, if i % 2 == 0 { Mode::EStop } else { Mode::Idle });
        let phase = (i as f64 * 0.618_033_988_75).fract();
        std::thread::sleep(Duration::from_nanos((phase * period_ns as f64) as u64));
    }
    lat.sort_unstable();
    running.request_stop();
    let report = running.join().expect("stop");
    let _ = robot.stop();

    let ct = cyclictest.and_then(|c| c.wait_with_output());
    let (ct_p50, ct_p99, ct_max) = match ct {
        Ok(o) if o.status.success() => {
            let text = String::from_utf8_lossy(&o.stdout);
            let mut samples = Vec::new();
            for line in text.lines().filter(|l| !l.starts_with('#')) {
                let mut it = line.split_whitespace();
                if let (Some(us), Some(n)) = (it.next(), it.next())
                    && let (Ok(us), Ok(n)) = (us.parse::<u64>(), n.parse::<u64>())
                {
                    samples.extend(std::iter::repeat_n(us * 1000, n as usize));
                }
            }
            let max = text
                .lines()
                .find_map(|l| l.strip_prefix("# Max Latencies:"))
                .and_then(|v| v.split_whitespace().next()?.parse::<u64>().ok())
                .map(|us| us * 1000)
                .unwrap_or(0);
            (pct(&samples, 0.5), pct(&samples, 0.99), max)
        }
        _ => {
            println!(
                "{{\"bench\":\"loop_jitter\",\"note\":\"cyclictest not available (apt-get install rt-tests)\"}}"
            );
            (0, 0, 0)
        }
    };
    // The loop's p99: the median of its ~1 s windows' p99s; the worst
    // window's beside it.
    let ours_p99 = pct(&window_p99, 0.5);
    let name = setup.name;
    let period_us = period_ns as f64 / 1e3;
    println!(
        "{{\"bench\":\"loop_jitter\",\"setup\":\"{name}\",\"rate_hz\":{rate:.1},\"seconds\":{seconds},\"windows\":{},\"policy\":\"SCHED_FIFO 2 (both)\",\
\"ours_p50_us\":{:.1},\"ours_p99_us\":{:.1},\"ours_p99_worst_window_us\":{:.1},\"ours_max_us\":{:.1},\"overruns\":{},\"compute_p99_us\":{:.1},\"compute_max_us\":{:.1},\"run_worst_late_us\":{:.1},\"run_worst_compute_us\":{:.1},\
\"cyclictest_p50_us\":{:.1},\"cyclictest_p99_us\":{:.1},\"cyclictest_max_us\":{:.1},\"p99_ratio\":{:.2},\"goal_ratio\":1.5}}",
        window_p99.len(),
        pct(&window_p50, 0.5) as f64 / 1e3,
        ours_p99 as f64 / 1e3,
        window_p99.last().copied().unwrap_or(0) as f64 / 1e3,
        max as f64 / 1e3,
        report.overruns,
        pct(&compute_p99, 0.5) as f64 / 1e3,
        compute_max as f64 / 1e3,
        report.worst_late_ns as f64 / 1e3,
        report.worst_compute_ns as f64 / 1e3,
        ct_p50 as f64 / 1e3,
        ct_p99 as f64 / 1e3,
        ct_max as f64 / 1e3,
        if ct_p99 > 0 && ours_p99 > 0 {
            ours_p99 as f64 / ct_p99 as f64
        } else {
            f64::NAN
        },
    );
    // From the client's send (request and command-ready notification)
    // through the command thread and the loop's next period to the frame's
    // arrival at another participant of the in-process bus (no wire time):
    // half a period on average is the wait for the loop's next period.
    let p99 = pct(&lat, 0.99) as f64 / 1e3;
    println!(
        "{{\"bench\":\"command_latency\",\"setup\":\"{name}\",\"samples\":{},\"p50_us\":{:.1},\"p99_us\":{p99:.1},\"max_us\":{:.1},\"period_us\":{period_us:.1},\
\"p50_periods\":{:.3},\"p99_periods\":{:.3},\"goal_p99_us\":{:.1}}}",
        lat.len(),
        pct(&lat, 0.5) as f64 / 1e3,
        lat.last().copied().unwrap_or(0) as f64 / 1e3,
        pct(&lat, 0.5) as f64 / 1e3 / period_us,
        p99 / period_us,
        period_us + 100.0,
    );
}

mod raw {
    use iceoryx2::prelude::ZeroCopySend;

    /// A payload of exactly the snapshot's size, for raw iceoryx2.
    #[derive(Debug, Clone, Copy, ZeroCopySend)]
    #[repr(C)]
    #[type_name("anguilla::bench::Raw")]
    pub struct Raw {
        pub stamp: u64,
        pub rest: [u8; core::mem::size_of::<anguilla_ipc::StateSnapshot>() - 8],
    }
}
use raw::Raw;

/// Our path: a stand-in for the loop thread hands the snapshot to the
/// daemon's state thread (loan, write, send, notify there), and
/// `Client::wait_state` receives it on this thread. `fifo`: the state
/// thread's SCHED_FIFO priority (the daemon's p − 1), or `None` for
/// SCHED_OTHER. The stand-in for the loop stays SCHED_OTHER, like the raw
/// publisher.
fn ours_latency(prefix: &str, fifo: Option<u8>, cpu: Option<usize>, samples: usize) -> Vec<u64> {
    let (tx, rx) = std::sync::mpsc::channel::<u64>();
    let stop = Arc::new(AtomicBool::new(false));
    let p = prefix.to_owned();
    let s2 = stop.clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let (state_tx, state_rx) = crossbeam_channel::bounded::<StateSnapshot>(4);
    let rt = anguilla_daemon::rt::RtRequest {
        fifo_priority: fifo,
        cpu,
        ..Default::default()
    };
    let state = std::thread::spawn(move || run::state_thread(&p, rt, state_rx, ready_tx));
    ready_rx.recv().unwrap().unwrap();
    // A tool opens the command side too: a server stands by, idle.
    let p = prefix.to_owned();
    let (up_tx, up_rx) = std::sync::mpsc::channel();
    let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
    let server = std::thread::spawn(move || {
        let _server = anguilla_ipc::CommandServer::new(&p).unwrap();
        up_tx.send(()).unwrap();
        // Held until the measurement ends (its sender dropped).
        let _ = done_rx.recv();
    });
    up_rx.recv().unwrap();
    let publisher = std::thread::spawn(move || {
        // The stand-in for the loop on the state thread's CPU, if pinned.
        let _ = anguilla_daemon::rt::apply(&anguilla_daemon::rt::RtRequest {
            cpu,
            ..Default::default()
        });
        let mut snap = StateSnapshot::default();
        while !s2.load(Ordering::Relaxed) {
            snap.time_ns = monotonic_ns();
            let _ = state_tx.try_send(snap);
            let _ = rx.recv_timeout(Duration::from_millis(100));
        }
    });
    let client = Client::new(prefix, "bench-sub").unwrap();
    let mut ours = time_states(&client, &tx, samples);
    stop.store(true, Ordering::SeqCst);
    let _ = tx.send(0);
    let _ = publisher.join();
    let _ = state.join();
    drop(done_tx);
    let _ = server.join();
    ours.sort_unstable();
    ours
}

/// Waits until the daemon's state says `mode` (10 s at most; a daemon that
/// never gets there is reported, and the benchmark goes on).
fn wait_mode(client: &Client, mode: Mode) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while Instant::now() < deadline {
        if let Ok(Some(s)) = client.wait_state(Duration::from_millis(50))
            && s.mode == mode as u8
        {
            return;
        }
    }
    eprintln!("bench: the daemon did not reach mode {mode:?} within 10 s");
}

/// Asks the stand-in for the loop (through `ask`) for one state at a time
/// and times each from its stamp to `client`, `samples` times. First waits
/// until states reach the client at all (it is connected), rather than a
/// guessed pause; that first state is not timed.
fn time_states(client: &Client, ask: &std::sync::mpsc::Sender<u64>, samples: usize) -> Vec<u64> {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let _ = ask.send(0);
        if let Ok(Some(_)) = client.wait_state(Duration::from_millis(100)) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "no state reached the client in 30 s"
        );
    }
    let _ = client.latest();
    let mut out = Vec::with_capacity(samples);
    while out.len() < samples {
        let _ = ask.send(0);
        if let Ok(Some(s)) = client.wait_state(Duration::from_millis(200)) {
            out.push(monotonic_ns() - s.time_ns);
        }
    }
    out
}

/// The alternative the loop cannot take: the stand-in for the loop
/// publishes itself (no hand-off), which allocates (an `Arc` per loaned
/// sample in iceoryx2 0.10; `ipc/tests/publish_alloc.rs` counts it).
fn direct_latency(prefix: &str, samples: usize) -> Vec<u64> {
    let (tx, rx) = std::sync::mpsc::channel::<u64>();
    let stop = Arc::new(AtomicBool::new(false));
    let s2 = stop.clone();
    let p = prefix.to_owned();
    let (up_tx, up_rx) = std::sync::mpsc::channel();
    let publisher = std::thread::spawn(move || {
        let publisher = anguilla_ipc::service::StatePublisher::new(&p).unwrap();
        let _server = anguilla_ipc::CommandServer::new(&p).unwrap();
        up_tx.send(()).unwrap();
        let mut snap = StateSnapshot::default();
        while !s2.load(Ordering::Relaxed) {
            snap.time_ns = monotonic_ns();
            let _ = publisher.publish(&snap);
            let _ = rx.recv_timeout(Duration::from_millis(100));
        }
    });
    up_rx.recv().unwrap();
    let client = Client::new(prefix, "bench-sub").unwrap();
    let mut out = time_states(&client, &tx, samples);
    stop.store(true, Ordering::SeqCst);
    let _ = tx.send(0);
    let _ = publisher.join();
    out.sort_unstable();
    out
}

fn state_latency_bench(samples: usize) {
    use iceoryx2::prelude::*;
    let prefix = format!("anguilla-bench-ipc/{}", std::process::id());
    // As the daemon runs it under a loop at priority 2, and at SCHED_OTHER.
    let ours = ours_latency(&format!("{prefix}/fifo"), Some(1), None, samples);
    let other = ours_latency(&format!("{prefix}/other"), None, None, samples);
    // The state thread on the loop's CPU: woken without crossing CPUs.
    let pinned = ours_latency(&format!("{prefix}/pinned"), Some(1), Some(1), samples);
    let direct = direct_latency(&format!("{prefix}/direct"), samples);

    // Raw iceoryx2: the same pattern with a payload of the same size.
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let name = format!("{prefix}/raw");
    let svc = node
        .service_builder(&name.as_str().try_into().unwrap())
        .publish_subscribe::<Raw>()
        .history_size(1)
        .subscriber_max_buffer_size(2)
        .enable_safe_overflow(true)
        .open_or_create()
        .unwrap();
    let ev = node
        .service_builder(&format!("{name}-ev").as_str().try_into().unwrap())
        .event()
        .open_or_create()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<u64>();
    let stop = Arc::new(AtomicBool::new(false));
    let s2 = stop.clone();
    let n2 = name.clone();
    let publisher = std::thread::spawn(move || {
        let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
        let svc = node
            .service_builder(&n2.as_str().try_into().unwrap())
            .publish_subscribe::<Raw>()
            .history_size(1)
            .subscriber_max_buffer_size(2)
            .enable_safe_overflow(true)
            .open_or_create()
            .unwrap();
        let ev = node
            .service_builder(&format!("{n2}-ev").as_str().try_into().unwrap())
            .event()
            .open_or_create()
            .unwrap();
        let publ = svc.publisher_builder().create().unwrap();
        let notifier = ev.notifier_builder().create().unwrap();
        while !s2.load(Ordering::Relaxed) {
            let sample = publ.loan_uninit().unwrap();
            let sample = sample.write_payload(Raw {
                stamp: monotonic_ns(),
                rest: [0; core::mem::size_of::<StateSnapshot>() - 8],
            });
            sample.send().unwrap();
            notifier.notify().unwrap();
            let _ = rx.recv_timeout(Duration::from_millis(100));
        }
    });
    let sub = svc.subscriber_builder().create().unwrap();
    let listener = ev.listener_builder().create().unwrap();
    let mut raw = Vec::with_capacity(samples);
    std::thread::sleep(Duration::from_millis(200));
    while sub.receive().ok().flatten().is_some() {}
    while raw.len() < samples {
        let _ = tx.send(0);
        let _ = listener.timed_wait(|_| {}, Duration::from_millis(200));
        let mut last = None;
        while let Ok(Some(s)) = sub.receive() {
            last = Some(s.payload().stamp);
        }
        if let Some(stamp) = last {
            raw.push(monotonic_ns() - stamp);
        }
    }
    stop.store(true, Ordering::SeqCst);
    let _ = tx.send(0);
    let _ = publisher.join();
    raw.sort_unstable();
    let us = |v: &[u64], q: f64| pct(v, q) as f64 / 1e3;
    let ratio = |v: &[u64], q: f64| pct(v, q) as f64 / pct(&raw, q).max(1) as f64;
    println!(
        "{{\"bench\":\"state_latency\",\"payload_bytes\":{},\"samples\":{samples},\
\"ours_fifo1_p50_us\":{:.2},\"ours_fifo1_p99_us\":{:.2},\"ours_other_p50_us\":{:.2},\"ours_other_p99_us\":{:.2},\
\"iceoryx2_p50_us\":{:.2},\"iceoryx2_p99_us\":{:.2},\"fifo1_p50_ratio\":{:.2},\"fifo1_p99_ratio\":{:.2},\
\"other_p50_ratio\":{:.2},\"other_p99_ratio\":{:.2},\"fifo1_same_cpu_p50_us\":{:.2},\"fifo1_same_cpu_p50_ratio\":{:.2},\"direct_p50_us\":{:.2},\"direct_p50_ratio\":{:.2},\"goal_ratio\":1.2}}",
        core::mem::size_of::<StateSnapshot>(),
        us(&ours, 0.5),
        us(&ours, 0.99),
        us(&other, 0.5),
        us(&other, 0.99),
        us(&raw, 0.5),
        us(&raw, 0.99),
        ratio(&ours, 0.5),
        ratio(&ours, 0.99),
        ratio(&other, 0.5),
        ratio(&other, 0.99),
        us(&pinned, 0.5),
        ratio(&pinned, 0.5),
        us(&direct, 0.5),
        ratio(&direct, 0.5),
    );
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` passes nothing
    // special: run a short version then.
    let bench = std::env::args().any(|a| a == "--bench");
    let seconds: f64 = std::env::var("ANGUILLA_BENCH_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(if bench { 10.0 } else { 1.0 });
    state_latency_bench(if bench { 5000 } else { 200 });
    for setup in &SETUPS {
        let commands = std::env::var("ANGUILLA_BENCH_COMMANDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(if bench { 200 } else { 20 });
        loop_and_command_bench(setup, seconds, commands);
    }
}
