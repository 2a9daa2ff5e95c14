//! The loop thread: fixed rate on absolute deadlines, and its helpers.
//!
//! [`spawn`] starts the control loop on its own thread (optionally
//! SCHED_FIFO, pinned, with memory locked) and its helper threads. The loop
//! talks to each through bounded crossbeam channels of `Copy` values, with
//! `try_send`/`try_recv` only: it never waits on a helper, and never
//! allocates (iceoryx2 does, so its ports live on the helpers):
//!
//! - the **state** thread (at SCHED_FIFO one below the loop, when the loop
//!   has a priority above 1; so is the command thread) takes each period's [`anguilla_ipc::StateSnapshot`] and
//!   publishes it on iceoryx2, then wakes the clients (when it falls behind,
//!   only the newest snapshot is published; the others are counted);
//! - the **command** thread waits for operator requests (clients announce
//!   them on the `command-ready` event; it also polls every
//!   [`COMMAND_POLL`]), hands them to the loop with the client port each
//!   came on (the client's identity), and sends the loop's answers back.
//!   Its work is bounded however clients behave: a notification that finds no
//!   request is followed by none for [`COMMAND_ROUND_MIN`] (a notification
//!   flood costs little, a real command waits for nothing), a round with
//!   requests waits for the loop's answers (one period), and a round takes
//!   at most [`COMMAND_BATCH`] requests (every client's in-flight
//!   requests, so each client is served every round);
//! - the **E-stop** thread receives on the reserved E-stop socket
//!   ([`anguilla_ipc::estop`]) and raises a flag the loop reads every period;
//! - the **logger** receives [`Event`]s from the loop and writes them with
//!   `tracing` (the loop never logs itself; when the channel is full the
//!   event is dropped and counted); refused commands are summed up in one
//!   line per [`REFUSAL_LOG_INTERVAL`], never one line per request;
//! - the **reaper** scans iceoryx2's node registry every 250 ms and tells
//!   the loop which client nodes are gone — died, or ended without releasing
//!   control (their control is released).
//!
//! Each period the loop sleeps to an absolute deadline
//! (`clock_nanosleep(TIMER_ABSTIME)`), answers the operator commands handed
//! over, runs [`Controller::run_period`], and hands the state over. A period that
//! starts more than a whole period late is an *overrun*: it is counted and
//! the missed periods are skipped, never caught up by bursting frames.
//!
//! With `recording.dir` set, a third helper, the **recorder**, writes every
//! frame in and out and every operator command (see [`crate::record`]).
//!
//! On stop (SIGINT/SIGTERM in the binary), a swim is stopped smoothly (at
//! most `shutdown_grace`), then the actuators are disabled and the loop ends.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use anguilla_drivers::Bus;
use anguilla_protocol::message::ErrorBits;
use crossbeam_channel::{Receiver, Sender, TrySendError};

use crate::config::Config;
use crate::control::{Controller, SetupError};
use crate::rt::{self, RtRequest};
use crate::stats::Window;
use anguilla_ipc::vocabulary::{Cause, FaultSet, Mode, Nanos};
use anguilla_ipc::{CommandReply, Envelope, LoopSnapshot, StateSnapshot};

/// What the loop tells the logger. `Copy`, so sending it never allocates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The mode changed.
    Mode {
        /// Previous mode.
        from: Mode,
        /// New mode.
        to: Mode,
        /// Why it changed.
        cause: Cause,
        /// The faults that put it in Fault or EStop (none otherwise: faults
        /// latched while limp do not explain a later change).
        faults: FaultSet,
    },
    /// A command was refused; the reply carries the reason.
    Refused {
        /// The client port it came on.
        origin: u128,
        /// The answer sent.
        reply: CommandReply,
    },
    /// The client holding control is gone, its control released.
    HolderGone {
        /// Its process was seen dead (else its node left the registry:
        /// the process ended, or died and was cleaned up by another).
        crashed: bool,
    },
    /// The bus changed state (a `BusSnapshot::state` code: 2 bus-off,
    /// 3 adapter gone, 0 back to normal).
    Bus {
        /// The new state's code.
        state: u8,
    },
    /// A drive's notice (configuration done or failed).
    Drive(crate::drive::Notice),
    /// The loop overran (periods skipped).
    Overrun {
        /// Periods skipped this time.
        skipped: u64,
    },
    /// Joints' drives report errors they did not report before (one event
    /// per code: twelve joints latching the same E-stop are one line).
    NodeErrors {
        /// The joints (bit 0 = the head end's).
        joints: u64,
        /// Its family's code (`JointSnapshot::node_errors`): anguilla error
        /// bits, a CiA 402 EMCY code or an ODrive axis error.
        code: u32,
        /// Whether `code` holds anguilla error bits.
        anguilla: bool,
    },
}

/// What went wrong starting the loop.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The controller could not be built from the configuration.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The operator interface could not be created. Its message shows the
    /// cause, so the cause is not also its `source` (an error chain printed
    /// with `{:#}` would say it twice).
    #[error("operator interface: {0}")]
    Ipc(anguilla_ipc::IpcError),
    /// A thread could not be started.
    #[error("cannot start the {0} thread: {1}")]
    Thread(&'static str, std::io::Error),
    /// The loop thread ended before it was ready, without saying why.
    #[error("the control loop ended during start-up")]
    EndedEarly,
    /// The configuration has no control rate the bus can carry (a rate
    /// over `bus.max-load`): the daemon does not run at another one.
    #[error("configuration: {0}")]
    Rate(crate::config::ConfigError),
}

impl From<anguilla_ipc::IpcError> for RunError {
    fn from(e: anguilla_ipc::IpcError) -> Self {
        Self::Ipc(e)
    }
}

/// Figures of a finished run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunReport {
    /// Periods run.
    pub periods: u64,
    /// Overruns.
    pub overruns: u64,
    /// Wake-up lateness of the last window (ns): p50, p99, max.
    pub jitter: crate::stats::Summary,
    /// Compute time of the last window (ns).
    pub compute: crate::stats::Summary,
    /// Latest wake-up of the whole run (ns). An overrun with
    /// `worst_compute_ns` below the period was the OS waking the loop late,
    /// not a period computing too long.
    pub worst_late_ns: u64,
    /// Longest period of the whole run (ns), from wake-up to hand-over.
    pub worst_compute_ns: u64,
    /// Events the logger channel dropped.
    pub events_dropped: u64,
    /// Records the recorder channel dropped (recording fell behind).
    pub records_dropped: u64,
    /// Snapshots the state thread skipped (it fell behind; the newest one
    /// is always published).
    pub states_dropped: u64,
    /// The mode at the end.
    pub final_mode: Mode,
}

/// A running daemon loop.
pub struct Running {
    stop: Arc<AtomicBool>,
    /// Ends the E-stop thread and the reaper, once the loop has ended: a
    /// swim being stopped at shutdown can still be E-stopped.
    helpers_stop: Arc<AtomicBool>,
    loop_thread: JoinHandle<Result<RunReport, RunError>>,
    helpers: Vec<JoinHandle<()>>,
    ground_truth: Option<crossbeam_channel::Sender<(u64, crate::truth::GroundTruth)>>,
}

impl Running {
    /// Where a simulated robot's ground truth goes, `(daemon time ns,
    /// truth)`, while recording (`None` otherwise): the recorder writes it
    /// to the session's MCAP file. Use `try_send`: a full channel drops the
    /// sample, nothing waits.
    pub fn ground_truth(
        &self,
    ) -> Option<&crossbeam_channel::Sender<(u64, crate::truth::GroundTruth)>> {
        self.ground_truth.as_ref()
    }

    /// Asks the loop to stop (smoothly) without waiting.
    pub fn request_stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Whether the loop thread has ended.
    pub fn is_finished(&self) -> bool {
        self.loop_thread.is_finished()
    }

    /// Waits for the loop to end and returns its report.
    pub fn join(self) -> Result<RunReport, RunError> {
        let r = self
            .loop_thread
            .join()
            .unwrap_or_else(|_| panic!("the control loop thread panicked"));
        self.stop.store(true, Ordering::SeqCst);
        self.helpers_stop.store(true, Ordering::SeqCst);
        for h in self.helpers {
            let _ = h.join();
        }
        r
    }
}

/// How long a smooth stop may take at shutdown before the actuators are
/// disabled anyway.
const SHUTDOWN_GRACE: Nanos = Nanos::from_millis(3_000);

/// Starts the daemon on `bus` with `cfg`; `stop` ends it (smoothly).
pub fn spawn(cfg: Config, bus: Box<dyn Bus>, stop: Arc<AtomicBool>) -> Result<Running, RunError> {
    // A configuration that was never validated may ask for a rate the bus
    // cannot carry: refused here, never run at another rate.
    cfg.control_rate().map_err(RunError::Rate)?;
    let (ev_tx, ev_rx) = crossbeam_channel::bounded::<Event>(1024);
    let (dead_tx, dead_rx) = crossbeam_channel::bounded::<(u128, bool)>(64);
    let (watch_tx, watch_rx) = crossbeam_channel::bounded::<u128>(64);
    let (state_tx, state_rx) = crossbeam_channel::bounded::<StateSnapshot>(STATE_QUEUE);
    // The loop keeps a receiver too: when the state thread falls behind, the
    // loop drops the oldest snapshot queued instead of the newest.
    let state_rx_loop = state_rx.clone();
    let (req_tx, req_rx) = crossbeam_channel::bounded::<Envelope>(COMMAND_BATCH);
    let (reply_tx, reply_rx) = crossbeam_channel::bounded::<(u128, CommandReply)>(COMMAND_BATCH);
    // E-stops taken out of band (the E-stop socket, or an operator E-stop
    // the command queue had no room for): the loop handles them next period.
    let estops = Arc::new(AtomicU64::new(0));
    let mut helpers = Vec::new();
    // The E-stop socket first: a live daemon on the same prefix is found
    // here, before any iceoryx2 service is touched.
    let estop_listener = anguilla_ipc::estop::EStopListener::bind(&cfg.ipc.prefix)?;
    // iceoryx2's directory and node-id segment: another user's are refused
    // before any node is made (anguilla_ipc::guard).
    anguilla_ipc::guard::check()?;
    // The iceoryx2 helpers first: their setup errors (a bad prefix, a
    // second daemon on the same services) are reported by `spawn`.
    let (ipc_ready_tx, ipc_ready_rx) =
        std::sync::mpsc::channel::<Result<(), anguilla_ipc::IpcError>>();
    // With the loop at SCHED_FIFO p, the two iceoryx2 helpers run at p - 1:
    // above ordinary threads, so clients see the state and the loop sees
    // commands without waiting for a busy CPU, and never above the loop.
    let helper_rt = RtRequest {
        fifo_priority: (cfg.realtime.fifo_priority > 1).then(|| cfg.realtime.fifo_priority - 1),
        ..RtRequest::default()
    };
    let (prefix, ready) = (cfg.ipc.prefix.clone(), ipc_ready_tx.clone());
    helpers.push(
        std::thread::Builder::new()
            .name("anguilla-state".into())
            .spawn(move || state_thread(&prefix, helper_rt, state_rx, ready))
            .map_err(|e| RunError::Thread("state", e))?,
    );
    let prefix = cfg.ipc.prefix.clone();
    let cmd_estops = estops.clone();
    // Ten periods, and a second to spare for a loop that overruns: past
    // that the loop is stalled and the clients' own timeouts report it.
    let reply_wait = Duration::from_secs(1) + 10 * Duration::from(crate::control::period_ns(&cfg));
    helpers.push(
        std::thread::Builder::new()
            .name("anguilla-command".into())
            .spawn(move || {
                command_thread(
                    &prefix,
                    helper_rt,
                    CommandLinks {
                        to_loop: req_tx,
                        from_loop: reply_rx,
                        estops: cmd_estops,
                    },
                    reply_wait,
                    ipc_ready_tx,
                )
            })
            .map_err(|e| RunError::Thread("command", e))?,
    );
    for _ in 0..2 {
        let r = ipc_ready_rx
            .recv()
            .unwrap_or(Err(anguilla_ipc::IpcError::Iceoryx(
                "an operator-interface thread ended during start-up".into(),
            )));
        if let Err(e) = r {
            stop.store(true, Ordering::SeqCst);
            // The helpers end when the loop's ends of their channels go.
            drop((state_tx, state_rx_loop, req_rx, reply_tx));
            for h in helpers {
                let _ = h.join();
            }
            return Err(e.into());
        }
    }
    // The node-id segment the daemon's nodes made or opened: its user's
    // only from now on (iceoryx2 makes it 0666).
    match anguilla_ipc::guard::restrict() {
        Ok(changed) => {
            for s in changed {
                tracing::info!("{} restricted to this user (mode 0600)", s.display());
            }
        }
        Err(e) => tracing::warn!("{e}"),
    }
    let helpers_stop = Arc::new(AtomicBool::new(false));
    let (sock_estops, estop_stop) = (estops.clone(), helpers_stop.clone());
    helpers.push(
        std::thread::Builder::new()
            .name("anguilla-estop".into())
            .spawn(move || {
                for w in rt::apply(&helper_rt) {
                    tracing::warn!("e-stop thread: {w}");
                }
                estop_thread(estop_listener, sock_estops, estop_stop)
            })
            .map_err(|e| RunError::Thread("e-stop", e))?,
    );
    let bus_spec = bus.spec().to_string();
    helpers.push(
        std::thread::Builder::new()
            .name("anguilla-log".into())
            .spawn(move || logger(ev_rx, bus_spec))
            .map_err(|e| RunError::Thread("logger", e))?,
    );
    let reaper_stop = helpers_stop.clone();
    helpers.push(
        std::thread::Builder::new()
            .name("anguilla-reaper".into())
            .spawn(move || reaper(watch_rx, dead_tx, reaper_stop))
            .map_err(|e| RunError::Thread("reaper", e))?,
    );
    let mut ground_truth = None;
    let recording = if cfg.recording.dir.is_empty() {
        None
    } else {
        let secs = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        let dir = std::path::Path::new(&cfg.recording.dir).join(format!("session-{secs}"));
        let (rec_tx, rec_rx) = crossbeam_channel::bounded(1 << 16);
        let (st_tx, st_rx) = crossbeam_channel::bounded(256);
        let (truth_tx, truth_rx) = crossbeam_channel::bounded(64);
        ground_truth = Some(truth_tx);
        let rcfg = cfg.clone();
        let shown = dir.display().to_string();
        helpers.push(
            std::thread::Builder::new()
                .name("anguilla-rec".into())
                .spawn(move || {
                    if let Err(e) = crate::record::recorder(dir, rcfg, rec_rx, st_rx, truth_rx) {
                        tracing::error!("recording to {shown} failed: {e}");
                    }
                })
                .map_err(|e| RunError::Thread("recorder", e))?,
        );
        Some((rec_tx, st_tx))
    };
    let loop_stop = stop.clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let loop_thread = std::thread::Builder::new()
        .name("anguilla-loop".into())
        .spawn(move || {
            let links = Links {
                events: ev_tx,
                dead: dead_rx,
                watch: watch_tx,
                ready: ready_tx,
                states: (state_tx, state_rx_loop),
                requests: req_rx,
                replies: reply_tx,
                estops,
            };
            control_loop(cfg, bus, loop_stop, links, recording)
        })
        .map_err(|e| RunError::Thread("control loop", e))?;
    // Setup errors (IPC, model) surface here rather than in a log line.
    match ready_rx.recv() {
        Ok(()) => Ok(Running {
            stop,
            helpers_stop,
            loop_thread,
            helpers,
            ground_truth,
        }),
        Err(_) => {
            stop.store(true, Ordering::SeqCst);
            helpers_stop.store(true, Ordering::SeqCst);
            let r = loop_thread
                .join()
                .unwrap_or_else(|_| panic!("the control loop thread panicked"));
            for h in helpers {
                let _ = h.join();
            }
            Err(r.err().unwrap_or(RunError::EndedEarly))
        }
    }
}

/// Refused commands are logged as one summary line per interval at most.
pub const REFUSAL_LOG_INTERVAL: Duration = Duration::from_secs(1);

/// A helper thread's repeated failure (publishing the state, taking
/// commands): every failure counted, logged at most once per
/// [`REFUSAL_LOG_INTERVAL`] for as long as it lasts, with the count since
/// the last line, and its end logged once.
#[derive(Debug, Default)]
pub struct ErrorLog {
    last_line: Option<std::time::Instant>,
    since_line: u64,
    total: u64,
}

impl ErrorLog {
    /// A failure at `now`: returns the line to log, if one is due.
    pub fn failed(
        &mut self,
        now: std::time::Instant,
        what: &str,
        e: &dyn std::fmt::Display,
    ) -> Option<String> {
        self.total += 1;
        self.since_line += 1;
        match self.last_line {
            Some(t) if now.duration_since(t) < REFUSAL_LOG_INTERVAL => None,
            _ => {
                let n = core::mem::take(&mut self.since_line);
                self.last_line = Some(now);
                Some(if n > 1 {
                    format!("{what} failed {n} times since the last report: {e}")
                } else {
                    format!("{what} failed: {e}")
                })
            }
        }
    }

    /// A success: returns the line that says the failures ended, if any.
    pub fn succeeded(&mut self, what: &str) -> Option<String> {
        if self.total == 0 {
            return None;
        }
        let line = format!("{what} works again after {} failure(s)", self.total);
        *self = Self::default();
        Some(line)
    }
}

/// Sums up refusals: the first of an interval is logged whole, the rest
/// are counted and reported in one line when the interval ends.
#[derive(Debug, Default)]
struct RefusalLog {
    since: Option<std::time::Instant>,
    suppressed: u64,
    latest: Option<(u128, CommandReply)>,
}

impl RefusalLog {
    fn refused(&mut self, now: std::time::Instant, origin: u128, reply: CommandReply) {
        match self.since {
            Some(t) if now.duration_since(t) < REFUSAL_LOG_INTERVAL => {
                self.suppressed += 1;
                self.latest = Some((origin, reply));
            }
            _ => {
                self.flush(now);
                self.since = Some(now);
                tracing::info!(
                    "refused command {} from client {origin:032x}: {}",
                    reply.sequence,
                    reply.reason()
                );
            }
        }
    }

    fn flush(&mut self, now: std::time::Instant) {
        if self.suppressed > 0
            && let Some((origin, reply)) = self.latest
        {
            tracing::info!(
                "refused {} more command(s) in {:.1} s; latest from client {origin:032x}: {}",
                self.suppressed,
                self.since
                    .map_or(0.0, |t| now.duration_since(t).as_secs_f64()),
                reply.reason()
            );
        }
        self.suppressed = 0;
        self.latest = None;
        self.since = None;
    }

    fn due(&self, now: std::time::Instant) -> bool {
        self.since
            .is_some_and(|t| now.duration_since(t) >= REFUSAL_LOG_INTERVAL)
    }
}

/// "joint 3", "joints 1–12", "joints 2, 5": 1-based, runs as ranges.
fn joint_list(joints: u64) -> String {
    let ids: Vec<u32> = (0..64)
        .filter(|j| joints & (1 << j) != 0)
        .map(|j| j + 1)
        .collect();
    let mut runs: Vec<String> = Vec::new();
    let mut i = 0;
    while i < ids.len() {
        let mut k = i;
        while k + 1 < ids.len() && ids[k + 1] == ids[k] + 1 {
            k += 1;
        }
        runs.push(match k - i {
            0 => ids[i].to_string(),
            1 => format!("{}, {}", ids[i], ids[k]),
            _ => format!("{}–{}", ids[i], ids[k]),
        });
        i = k + 1;
    }
    let plural = if ids.len() == 1 { "joint" } else { "joints" };
    format!("{plural} {}", runs.join(", "))
}

fn report(joints: u64) -> &'static str {
    if joints.count_ones() == 1 {
        "reports"
    } else {
        "report"
    }
}

/// Overruns, told to the operator as an overloaded machine: the first at
/// once, with what to do; then a count every [`OVERLOAD_LOG_INTERVAL`]
/// while they last.
#[derive(Debug, Default)]
struct OverloadLog {
    /// When the last line was logged.
    last_line: Option<std::time::Instant>,
    /// Periods missed since then.
    missed: u64,
    /// Overruns since then.
    overruns: u64,
}

impl OverloadLog {
    /// An overrun that skipped `skipped` periods at `now`: the line to
    /// log, if one is due.
    fn overran(&mut self, now: std::time::Instant, skipped: u64) -> Option<String> {
        self.missed += skipped;
        self.overruns += 1;
        if self.last_line.is_none() {
            self.last_line = Some(now);
            (self.missed, self.overruns) = (0, 0);
            Some(format!(
                "machine overloaded: the control loop missed {skipped} period(s); \
                 other work is taking its CPU (on a robot, give the loop a core and \
                 a real-time priority: [realtime] cpu, fifo-priority)"
            ))
        } else {
            self.tick(now)
        }
    }

    /// Time passing: the summary line, if one is due.
    fn tick(&mut self, now: std::time::Instant) -> Option<String> {
        let t = self.last_line?;
        if now.duration_since(t) < OVERLOAD_LOG_INTERVAL {
            return None;
        }
        let line = (self.overruns > 0).then(|| {
            format!(
                "machine overloaded: the control loop missed {} period(s) in {} overrun(s) \
                 in the last {:.0} s",
                self.missed,
                self.overruns,
                now.duration_since(t).as_secs_f64()
            )
        });
        // A quiet interval makes the next overrun news again.
        self.last_line = line.is_some().then_some(now);
        (self.missed, self.overruns) = (0, 0);
        line
    }
}

/// How often an overloaded machine is reported while it lasts.
pub const OVERLOAD_LOG_INTERVAL: Duration = Duration::from_secs(5);

fn logger(rx: Receiver<Event>, bus_spec: String) {
    let mut refusals = RefusalLog::default();
    let mut overload = OverloadLog::default();
    loop {
        let ev = match rx.recv_timeout(REFUSAL_LOG_INTERVAL / 4) {
            Ok(ev) => Some(ev),
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => None,
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
        };
        let now = std::time::Instant::now();
        if refusals.due(now) {
            refusals.flush(now);
        }
        if let Some(line) = overload.tick(now) {
            tracing::warn!("{line}");
        }
        match ev {
            None => {}
            Some(Event::Mode {
                from,
                to,
                cause,
                faults,
            }) if faults.is_empty() => {
                tracing::info!("mode {from} -> {to}: {}", cause.words())
            }
            Some(Event::Mode {
                from,
                to,
                cause,
                faults,
            }) => tracing::warn!("mode {from} -> {to}: {} ({faults})", cause.words()),
            Some(Event::Refused { origin, reply }) => refusals.refused(now, origin, reply),
            Some(Event::HolderGone { crashed: true }) => {
                tracing::warn!("the client holding control died; control released")
            }
            Some(Event::HolderGone { crashed: false }) => tracing::warn!(
                "the client holding control left without releasing it; control released"
            ),
            Some(Event::Bus { state: 3 }) => tracing::error!(
                "adapter gone: {bus_spec}; nothing is sent until it is back (reconnecting)"
            ),
            Some(Event::Bus { state }) => {
                tracing::warn!("bus {bus_spec}: {}", anguilla_ipc::bus_state_name(state))
            }
            Some(Event::Overrun { skipped }) => {
                if let Some(line) = overload.overran(now, skipped) {
                    tracing::warn!("{line}")
                }
            }
            Some(Event::NodeErrors {
                joints,
                code,
                anguilla: true,
            }) => tracing::warn!(
                "{} {}: {}",
                joint_list(joints),
                report(joints),
                ErrorBits(code as u16)
            ),
            Some(Event::NodeErrors { joints, code, .. }) => tracing::warn!(
                "{} {} error code {code:#010x} (docs/drives.md)",
                joint_list(joints),
                report(joints)
            ),
            Some(Event::Drive(n @ crate::drive::Notice::Configured { .. })) => {
                tracing::info!("{n}")
            }
            Some(Event::Drive(n)) => tracing::error!("{n}"),
        }
    }
    refusals.flush(std::time::Instant::now());
}

/// Receives on the E-stop socket until `stop`; each datagram is an E-stop
/// the loop takes next period. Logs at most one line per second.
fn estop_thread(
    listener: anguilla_ipc::estop::EStopListener,
    estops: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
) {
    let mut last_log: Option<std::time::Instant> = None;
    let mut unlogged = 0u64;
    while !stop.load(Ordering::Relaxed) {
        match listener.wait(Duration::from_millis(50), 1024) {
            Ok(0) => {}
            Ok(n) => {
                estops.fetch_add(n as u64, Ordering::AcqRel);
                unlogged += n as u64;
                let now = std::time::Instant::now();
                if last_log.is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1)) {
                    tracing::warn!(
                        "e-stop: {unlogged} datagram(s) on {}",
                        listener.path().display()
                    );
                    last_log = Some(now);
                    unlogged = 0;
                }
            }
            Err(e) => {
                tracing::error!("e-stop socket {}: {e}", listener.path().display());
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}

fn reaper(watch_rx: Receiver<u128>, tx: Sender<(u128, bool)>, stop: Arc<AtomicBool>) {
    let mut watch = anguilla_ipc::NodeWatch::default();
    while !stop.load(Ordering::Relaxed) {
        for id in watch_rx.try_iter() {
            watch.watch(id);
        }
        if let Some((alive, dead)) = anguilla_ipc::scan_nodes() {
            for gone in watch.update(&alive, &dead) {
                let _ = tx.try_send(gone);
            }
        }
        // Poll the stop flag often; scan every 250 ms.
        for _ in 0..5 {
            if stop.load(Ordering::Relaxed) {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Snapshots the state channel holds (the state thread publishes the newest).
const STATE_QUEUE: usize = 4;
/// Most operator requests handed to the loop in one round: every client's
/// requests in flight (iceoryx2 lets a client have no more), so one round
/// serves every client.
pub const COMMAND_BATCH: usize = anguilla_ipc::MAX_TOOLS * anguilla_ipc::MAX_REQUESTS_PER_CLIENT;
/// Shortest time between a round of the command thread that found no
/// request and the next: a client that floods `command-ready` without
/// requests wakes it at most this often.
pub const COMMAND_ROUND_MIN: Duration = Duration::from_millis(1);
/// How often the command thread looks for requests that no client announced
/// on `command-ready`.
pub const COMMAND_POLL: Duration = Duration::from_millis(10);

/// The state thread's body: publishes on iceoryx2 what the loop hands over
/// through `rx` (the newest when behind) until the loop drops its sender.
/// Applies `rt` to itself first. Reports on `ready` whether the services
/// could be opened. Public for the benchmark, which measures the loop's
/// handoff to a client's receipt.
pub fn state_thread(
    prefix: &str,
    rt: RtRequest,
    rx: Receiver<StateSnapshot>,
    ready: std::sync::mpsc::Sender<Result<(), anguilla_ipc::IpcError>>,
) {
    for w in rt::apply(&rt) {
        tracing::warn!("state thread: {w}");
    }
    let publisher = match anguilla_ipc::StatePublisher::new(prefix) {
        Ok(p) => {
            let _ = ready.send(Ok(()));
            p
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    drop(ready);
    let mut failing = ErrorLog::default();
    // Ends when the loop drops its sender.
    while let Ok(mut snap) = rx.recv() {
        for newer in rx.try_iter() {
            snap = newer;
        }
        match publisher.publish(&snap) {
            Ok(()) => {
                if let Some(l) = failing.succeeded("state publication") {
                    tracing::info!("{l}");
                }
            }
            Err(e) => {
                if let Some(l) = failing.failed(std::time::Instant::now(), "state publication", &e)
                {
                    tracing::warn!("{l}");
                }
            }
        }
    }
}

/// The command thread's channels to the loop.
struct CommandLinks {
    to_loop: Sender<Envelope>,
    from_loop: Receiver<(u128, CommandReply)>,
    estops: Arc<AtomicU64>,
}

/// Takes operator requests from iceoryx2, hands them to the loop and sends
/// back the loop's answers.
fn command_thread(
    prefix: &str,
    rt: RtRequest,
    links: CommandLinks,
    reply_wait: Duration,
    ready: std::sync::mpsc::Sender<Result<(), anguilla_ipc::IpcError>>,
) {
    use crossbeam_channel::{RecvTimeoutError, TryRecvError};
    let CommandLinks {
        to_loop,
        from_loop,
        estops,
    } = links;
    for w in rt::apply(&rt) {
        tracing::warn!("command thread: {w}");
    }
    let mut server = match anguilla_ipc::CommandServer::new(prefix) {
        Ok(s) => {
            let _ = ready.send(Ok(()));
            s
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    drop(ready);
    let mut waiting: Vec<(Envelope, anguilla_ipc::ActiveRequest)> =
        Vec::with_capacity(COMMAND_BATCH);
    let mut failing = ErrorLog::default();
    let mut last_round = std::time::Instant::now();
    let mut last_round_empty = false;
    loop {
        // Serve until the loop has gone (it still answers while it stops a
        // swim at shutdown). Nothing is awaited here, so replies found are
        // late ones to an abandoned batch: drop them all, or they would
        // crowd out the next batch's.
        loop {
            match from_loop.try_recv() {
                Ok(_) => continue,
                Err(TryRecvError::Disconnected) => return,
                Err(TryRecvError::Empty) => break,
            }
        }
        // Bounded wake-ups: after a round that a notification woke and that
        // found nothing, a flood of notifications costs one round per
        // COMMAND_ROUND_MIN, each draining all of them at once. A round
        // with requests already waited for the loop's answers, and a round
        // that the poll's timeout ended was no flood: neither delays the
        // next request (after a timeout, one command in ten would wait up to 1 ms).
        let since = last_round.elapsed();
        if last_round_empty && since < COMMAND_ROUND_MIN {
            std::thread::sleep(COMMAND_ROUND_MIN - since);
        }
        let notified = server.wait(COMMAND_POLL).unwrap_or(true);
        last_round = std::time::Instant::now();
        last_round_empty = notified;
        while waiting.len() < COMMAND_BATCH {
            match server.take() {
                Ok(Some((env, request))) => {
                    if to_loop.try_send(env).is_err() {
                        // The loop is stalled or gone: an E-stop still
                        // goes through, the rest wait for the client's retry.
                        if env.request.is_estop() {
                            estops.fetch_add(1, Ordering::AcqRel);
                        }
                        break;
                    }
                    waiting.push((env, request));
                    last_round_empty = false;
                }
                Ok(None) => {
                    if let Some(l) = failing.succeeded("taking operator commands") {
                        tracing::info!("{l}");
                    }
                    break;
                }
                Err(e) => {
                    let what = "taking operator commands";
                    if let Some(l) = failing.failed(std::time::Instant::now(), what, &e) {
                        tracing::warn!("{l}");
                    }
                    break;
                }
            }
        }
        // Answer in the loop's order; a reply is matched by client port and
        // sequence so that a late answer to an abandoned batch is dropped.
        while !waiting.is_empty() {
            match from_loop.recv_timeout(reply_wait) {
                Ok((origin, reply)) => {
                    let at = waiting.iter().position(|(env, _)| {
                        env.origin == origin && env.request.sequence == reply.sequence
                    });
                    if let Some(at) = at {
                        anguilla_ipc::CommandServer::reply(waiting.remove(at).1, reply);
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    // The loop is stalled: the clients' own timeouts report it.
                    waiting.clear();
                }
                Err(RecvTimeoutError::Disconnected) => return,
            }
        }
    }
}

/// The loop thread's channels to its helpers.
struct Links {
    events: Sender<Event>,
    dead: Receiver<(u128, bool)>,
    watch: Sender<u128>,
    ready: std::sync::mpsc::Sender<()>,
    states: (Sender<StateSnapshot>, Receiver<StateSnapshot>),
    requests: Receiver<Envelope>,
    replies: Sender<(u128, CommandReply)>,
    estops: Arc<AtomicU64>,
}

fn control_loop(
    cfg: Config,
    mut bus: Box<dyn Bus>,
    stop: Arc<AtomicBool>,
    links: Links,
    recording: Option<(
        Sender<crate::session::Record>,
        Sender<anguilla_ipc::StateSnapshot>,
    )>,
) -> Result<RunReport, RunError> {
    let rt_req = RtRequest {
        fifo_priority: (cfg.realtime.fifo_priority > 0).then_some(cfg.realtime.fifo_priority),
        cpu: (cfg.realtime.cpu >= 0).then_some(cfg.realtime.cpu as usize),
        lock_memory: cfg.realtime.lock_memory,
    };
    let Links {
        events,
        dead,
        watch,
        ready,
        states: (to_publish, unpublished),
        requests,
        replies,
        estops,
    } = links;
    let mut estops_seen = 0u64;
    for w in rt::apply(&rt_req) {
        tracing::warn!("{w}");
    }
    let mut ctl = Controller::new(&cfg, Nanos::from_nanos(rt::monotonic_ns()))?;
    let joints = cfg.robot.joints.min(anguilla_ipc::MAX_JOINTS);
    let anguilla = cfg.robot.drive == anguilla_protocol::Family::Anguilla;
    let states = recording.map(|(records, states)| {
        ctl.set_tap(records);
        states
    });
    // The loop's clock arithmetic is in raw nanoseconds, as `rt` reads them.
    let period = ctl.period_ns().as_nanos();
    tracing::info!(
        "control loop at {:.1} Hz ({} joints, bus {})",
        1e9 / period as f64,
        cfg.robot.joints,
        bus.spec()
    );
    let _ = ready.send(());
    let window = (1e9 / period as f64).ceil() as u64; // about one second
    let mut jitter = Window::new(window);
    let mut compute = Window::new(window);
    let (mut periods, mut overruns, mut dropped) = (0u64, 0u64, 0u64);
    let mut states_dropped = 0u64;
    let (mut worst_late, mut worst_compute) = (0u64, 0u64);
    let emit = |ev: Event, dropped: &mut u64| {
        if let Err(TrySendError::Full(_)) = events.try_send(ev) {
            *dropped += 1;
        }
    };
    let mut deadline = rt::monotonic_ns() + period;
    let mut mode = ctl.supervisor().mode();
    let mut bus_state = 0u8;
    let mut node_errors = [0u32; anguilla_ipc::MAX_JOINTS];
    let mut stopping_since: Option<Nanos> = None;
    loop {
        rt::sleep_until_ns(deadline);
        let wake = rt::monotonic_ns();
        let late = wake.saturating_sub(deadline);
        jitter.record(late);
        worst_late = worst_late.max(late);
        if late >= period {
            let skipped = late / period;
            overruns += 1;
            deadline += skipped * period;
            emit(Event::Overrun { skipped }, &mut dropped);
        }
        let now = Nanos::from_nanos(wake);
        // Out-of-band E-stops first, then operator commands, then dead
        // clients, then the period itself.
        let estops_now = estops.load(Ordering::Acquire);
        if estops_now != estops_seen {
            estops_seen = estops_now;
            ctl.socket_estop(now, estops_now);
        }
        while let Ok(env) = requests.try_recv() {
            let reply = ctl.command(now, &env);
            if reply.accepted == 0 {
                emit(
                    Event::Refused {
                        origin: env.origin,
                        reply,
                    },
                    &mut dropped,
                );
            }
            // Room for every request handed over: the channels are the same size.
            let _ = replies.try_send((env.origin, reply));
        }
        if let Some(node) = ctl.take_new_holder_node() {
            let _ = watch.try_send(node);
        }
        while let Ok((node, crashed)) = dead.try_recv() {
            if ctl.node_died(now, node) {
                emit(Event::HolderGone { crashed }, &mut dropped);
            }
        }
        if stop.load(Ordering::Relaxed) {
            let since = *stopping_since.get_or_insert(now);
            ctl.begin_shutdown(now);
            let m = ctl.supervisor().mode();
            let settled = !matches!(m, Mode::Swimming | Mode::Stopping);
            if settled || now.saturating_sub(since) > SHUTDOWN_GRACE {
                ctl.disable_all(bus.as_mut());
                break;
            }
        }
        ctl.run_period(now, bus.as_mut());
        periods += 1;
        while let Some(n) = ctl.take_drive_notice() {
            emit(Event::Drive(n), &mut dropped);
        }
        // Joints with news, grouped by code (fixed room: no allocation).
        let mut news = [(0u32, 0u64); anguilla_ipc::MAX_JOINTS];
        let mut groups = 0;
        for (j, (js, seen)) in ctl
            .snapshot()
            .joints
            .iter()
            .zip(node_errors.iter_mut())
            .enumerate()
            .take(joints)
        {
            // anguilla: new bits; a bought drive: a new code.
            let code = js.node_errors;
            let new = if anguilla {
                code & !*seen != 0
            } else {
                code != *seen && code != 0
            };
            *seen = code;
            if !new {
                continue;
            }
            match news[..groups].iter_mut().find(|(c, _)| *c == code) {
                Some((_, mask)) => *mask |= 1 << j,
                None => {
                    news[groups] = (code, 1 << j);
                    groups += 1;
                }
            }
        }
        for &(code, joints) in &news[..groups] {
            emit(
                Event::NodeErrors {
                    joints,
                    code,
                    anguilla,
                },
                &mut dropped,
            );
        }
        let now_bus = ctl.snapshot().bus.state;
        if now_bus != bus_state {
            emit(Event::Bus { state: now_bus }, &mut dropped);
            bus_state = now_bus;
        }
        let new_mode = ctl.supervisor().mode();
        if new_mode != mode {
            emit(
                Event::Mode {
                    from: mode,
                    to: new_mode,
                    cause: ctl.supervisor().cause(),
                    faults: if matches!(new_mode, Mode::Fault | Mode::EStop) {
                        ctl.supervisor().faults()
                    } else {
                        FaultSet::default()
                    },
                },
                &mut dropped,
            );
            mode = new_mode;
        }
        let spent = rt::monotonic_ns().saturating_sub(wake);
        compute.record(spent);
        worst_compute = worst_compute.max(spent);
        let (j, c) = (jitter.summary(), compute.summary());
        ctl.set_loop_stats(LoopSnapshot {
            period_ns: period as u32,
            jitter_p50_ns: j.p50.min(u32::MAX as u64) as u32,
            jitter_p99_ns: j.p99.min(u32::MAX as u64) as u32,
            jitter_max_ns: j.max.min(u32::MAX as u64) as u32,
            compute_p50_ns: c.p50.min(u32::MAX as u64) as u32,
            compute_p99_ns: c.p99.min(u32::MAX as u64) as u32,
            compute_max_ns: c.max.min(u32::MAX as u64) as u32,
            reserved: 0,
            periods,
            overruns,
        });
        if let Err(TrySendError::Full(snap)) = to_publish.try_send(*ctl.snapshot()) {
            states_dropped += unpublished.try_recv().is_ok() as u64;
            let _ = to_publish.try_send(snap);
        }
        if let Some(st) = &states
            && periods % 10 == 0
        {
            let _ = st.try_send(*ctl.snapshot());
        }
        deadline += period;
    }
    drop(events);
    let records_dropped = ctl.tap_dropped();
    let final_mode = ctl.supervisor().mode();
    // Dropping the controller and the state sender ends the recording.
    drop(ctl);
    drop(states);
    Ok(RunReport {
        worst_late_ns: worst_late,
        worst_compute_ns: worst_compute,
        records_dropped,
        states_dropped,
        periods,
        overruns,
        jitter: jitter.summary(),
        compute: compute.summary(),
        events_dropped: dropped,
        final_mode,
    })
}

#[cfg(test)]
mod tests {
    /// The first overrun is told at once with what to do, the next ones
    /// counted every 5 s while they last; after a quiet interval an
    /// overrun is news again.
    #[test]
    fn an_overloaded_machine_is_told_once_then_counted() {
        let t0 = std::time::Instant::now();
        let s = |secs: f64| t0 + std::time::Duration::from_secs_f64(secs);
        let mut log = super::OverloadLog::default();
        let first = log.overran(s(0.0), 3).expect("the first is told");
        assert!(
            first.starts_with("machine overloaded: the control loop missed 3 period(s)"),
            "{first}"
        );
        assert!(first.contains("[realtime] cpu, fifo-priority"), "{first}");
        assert_eq!(log.overran(s(1.0), 2), None);
        assert_eq!(log.overran(s(2.0), 4), None);
        assert_eq!(log.tick(s(4.0)), None);
        let summary = log.tick(s(5.5)).expect("a summary after 5 s");
        assert_eq!(
            summary,
            "machine overloaded: the control loop missed 6 period(s) in 2 overrun(s) in the last 6 s"
        );
        // Quiet for 5 s: nothing, and the next overrun is news.
        assert_eq!(log.tick(s(11.0)), None);
        let again = log.overran(s(12.0), 1).expect("news again");
        assert!(again.contains("other work is taking its CPU"), "{again}");
    }

    #[test]
    fn joints_are_listed_as_ranges() {
        assert_eq!(super::joint_list(1 << 2), "joint 3");
        assert_eq!(super::joint_list((1 << 12) - 1), "joints 1–12");
        assert_eq!(super::joint_list(0b1_0010), "joints 2, 5");
        assert_eq!(super::joint_list(0b1110_0011), "joints 1, 2, 6–8");
        assert_eq!(super::report(1 << 4), "reports");
    }

    use super::*;

    /// A failure must be heard for as long as it lasts (the command thread
    /// once logged its first error and then nothing for ever): a failure that lasts is reported once
    /// a second with its count, and its end once.
    #[test]
    fn a_lasting_failure_is_reported_once_a_second_with_its_count() {
        let t0 = std::time::Instant::now();
        let mut log = ErrorLog::default();
        let mut lines = Vec::new();
        // A failure every 100 ms for 2.5 s.
        for i in 0..25u64 {
            let now = t0 + Duration::from_millis(100 * i);
            lines.extend(log.failed(now, "taking operator commands", &"closed"));
        }
        assert_eq!(
            lines,
            [
                "taking operator commands failed: closed",
                "taking operator commands failed 10 times since the last report: closed",
                "taking operator commands failed 10 times since the last report: closed",
            ]
        );
        assert_eq!(
            log.succeeded("taking operator commands").as_deref(),
            Some("taking operator commands works again after 25 failure(s)")
        );
        assert_eq!(log.succeeded("taking operator commands"), None);
        // A new failure after the recovery is logged at once.
        assert!(log.failed(t0, "x", &"again").is_some());
    }
}

#[cfg(test)]
mod rate_tests {
    use super::*;

    /// A benchmark once asked for 1 kHz with twelve joints on classic
    /// CAN (333 % bus load); the daemon ran at 100 Hz without a word, and
    /// every command seemed to wait for a 10 ms poll. Now it is refused.
    #[test]
    fn a_rate_the_bus_cannot_carry_is_refused_not_replaced() {
        let mut cfg = Config::default();
        cfg.control.rate_hz = 1000.0;
        cfg.ipc.prefix = format!("anguilla-rate-test/{}", std::process::id());
        let bus = anguilla_drivers::mem::MemBus::builder("rate-test").build();
        let stop = Arc::new(AtomicBool::new(false));
        let err = match spawn(cfg, Box::new(bus.participant()), stop) {
            Ok(_) => panic!("spawned at a rate the bus cannot carry"),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains("control.rate-hz = 1000") && err.contains("bus.max-load"),
            "{err}"
        );
    }
}
