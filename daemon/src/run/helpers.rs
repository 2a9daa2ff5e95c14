//! The loop's helper threads that talk to the operators: the E-stop
//! socket, the reaper of dead clients, the state publisher and the command
//! thread.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};

use crate::rt::{self, RtRequest};
use anguilla_ipc::{CommandReply, Envelope, StateSnapshot};

use super::log::ErrorLog;

/// Receives on the E-stop socket until `stop`; each datagram is an E-stop
/// the loop takes next period. Logs at most one line per second.
pub(super) fn estop_thread(
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

pub(super) fn reaper(watch_rx: Receiver<u128>, tx: Sender<(u128, bool)>, stop: Arc<AtomicBool>) {
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
pub(super) const STATE_QUEUE: usize = 4;
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
                if let Some(l) = failing.succeeded(std::time::Instant::now(), "state publication") {
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
pub(super) struct CommandLinks {
    pub(super) to_loop: Sender<Envelope>,
    pub(super) from_loop: Receiver<(u128, CommandReply)>,
    pub(super) estops: Arc<AtomicU64>,
    /// Sends once the loop runs (dropped unsent if its setup failed):
    /// requests are taken from then on. Taken before, they waited for the
    /// loop's setup (the model's, over a second in a debug build): the
    /// reply wait ran out, the loop then carried them out, and their
    /// clients never heard.
    pub(super) loop_up: Receiver<()>,
}

/// Takes operator requests from iceoryx2, hands them to the loop and sends
/// back the loop's answers.
pub(super) fn command_thread(
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
        loop_up,
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
    // Requests wait in iceoryx2 (their clients' timeouts run) until the
    // loop can answer them; a loop that never came up has nothing to serve.
    if loop_up.recv().is_err() {
        return;
    }
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
                    if let Some(l) =
                        failing.succeeded(std::time::Instant::now(), "taking operator commands")
                    {
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
