//! A tool's session with a remote daemon, through `anguilla link`: the
//! [`Session`] of `--connect ENDPOINT`.
//!
//! The session draws a secret 128-bit token and sends its commands as
//! queries on `P/command/<token>`; the link forwards them on the token's
//! own iceoryx2 client, so this tool is one client for the daemon, with its
//! own authority. A hello (an empty query) opens the link's session, and
//! one every 2 s keeps it open and learns the client id the daemon knows
//! it by (after a link restart, a new one) and the link's epoch and clock.
//! Each command carries that epoch and the tool's estimate of the link's
//! clock (a 16-byte attachment), so the link drops a command that a stall
//! made stale. The state arrives on `P/state`.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use anguilla_ipc::{CommandReply, CommandRequest, IpcError, Raw as _, Session, StateSnapshot};
use zenoh::Wait as _;
use zenoh::qos::{CongestionControl, Priority};

use crate::wire::{Hello, Stamp};
use crate::{Endpoint, Tls};

/// How long a command query waits for the link's reply.
const QUERY_TIMEOUT: Duration = Duration::from_secs(2);
/// How long opening a session waits for the link's first answer.
const HELLO_TIMEOUT: Duration = Duration::from_secs(3);
/// How often the session says hello (well within the link's idle timeout).
const HELLO_PERIOD: Duration = Duration::from_secs(2);
/// How long the session waits before another hello when one failed.
const RETRY_PAUSE: Duration = Duration::from_millis(200);

#[derive(Default)]
struct Inner {
    state: Option<StateSnapshot>,
    /// States received so far: a reader knows a state is new by the count
    /// it last took.
    states: u64,
    state_at: Option<Instant>,
    replies: VecDeque<CommandReply>,
    id: u128,
    /// The last hello's answer: the link's clock, and when the answer came
    /// (this tool's clock).
    sync: Option<(Stamp, Instant)>,
    /// The link asked for a hello (it restarted, or closed the session).
    need_hello: bool,
    /// The session is dropped: the hello thread ends.
    stop: bool,
}

/// Most commands awaiting a reply that a session tracks.
const MAX_PENDING: usize = 64;

#[derive(Default)]
struct Shared {
    inner: Mutex<Inner>,
    cv: Condvar,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Waits up to `timeout` while `waiting` holds (woken by each state,
    /// reply, or change); returns the lock either way.
    fn wait_while(
        &self,
        timeout: Duration,
        mut waiting: impl FnMut(&mut Inner) -> bool,
    ) -> std::sync::MutexGuard<'_, Inner> {
        self.cv
            .wait_timeout_while(self.lock(), timeout, |i| waiting(i))
            .map(|(g, _)| g)
            .unwrap_or_else(|p| p.into_inner().0)
    }
}

fn random_token() -> Result<String, IpcError> {
    let b: [u8; 16] = crate::urandom()
        .map_err(|e| IpcError::Remote(format!("drawing a session token from /dev/urandom: {e}")))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

fn open_session(endpoint: &Endpoint, tls: Option<&Tls>) -> Result<zenoh::Session, IpcError> {
    let config = crate::zenoh_config("client", std::slice::from_ref(endpoint), false, tls)
        .map_err(|e| IpcError::Remote(e.to_string()))?;
    zenoh::open(config).wait().map_err(|e| {
        let why = match tls {
            // Zenoh says only that it could not connect: a handshake of
            // our own names the cause.
            Some(t) if endpoint.tls => crate::diagnose::tls_failure(endpoint, t),
            _ => format!(
                "{} (is `anguilla link --listen {}` running there?)",
                crate::diagnose::without_source_paths(&e.to_string()),
                endpoint.text
            ),
        };
        IpcError::Remote(format!("cannot reach a link at {}: {why}", endpoint.text))
    })
}

/// A command's stamp: the link's epoch and its clock now, as estimated
/// from the last hello (none before the first).
fn stamp(sync: Option<(Stamp, Instant)>) -> Option<Vec<u8>> {
    let (clock, at) = sync?;
    let since = i64::try_from(at.elapsed().as_millis()).unwrap_or(i64::MAX);
    Some(
        Stamp {
            link_ms: clock.link_ms.saturating_add(since),
            ..clock
        }
        .encode(),
    )
}

/// The daemon prefix the link on `session` serves, if it answers within
/// `INFO_TIMEOUT` (1 s; older links do not answer).
pub fn served_prefix(session: &zenoh::Session) -> Option<String> {
    let replies = session
        .get(crate::INFO_KEY)
        .timeout(INFO_TIMEOUT)
        .wait()
        .ok()?;
    let reply = replies.recv().ok()?;
    let sample = reply.result().ok()?;
    String::from_utf8(sample.payload().to_bytes().into_owned()).ok()
}

/// Asks the link at `endpoint` which daemon prefix it serves (`None`: it
/// did not answer in time; an older link does not).
pub fn ask_prefix(endpoint: &Endpoint, tls: Option<&Tls>) -> Result<Option<String>, IpcError> {
    let session = open_session(endpoint, tls)?;
    let served = served_prefix(&session);
    let _ = session.close().wait();
    Ok(served)
}

/// How long a tool waits for the link to say which prefix it serves.
const INFO_TIMEOUT: Duration = Duration::from_secs(1);

/// Who runs this tool, for the link to show as the holder (`link:NAME`):
/// `$USER`, else `$LOGNAME`, else `uid` and the real uid.
fn operator() -> String {
    ["USER", "LOGNAME"]
        .iter()
        .find_map(|v| std::env::var(v).ok().filter(|s| !s.is_empty()))
        .unwrap_or_else(|| {
            let uid = std::fs::read_to_string("/proc/self/status")
                .ok()
                .and_then(|s| {
                    s.lines()
                        .find_map(|l| l.strip_prefix("Uid:"))
                        .and_then(|l| l.split_whitespace().next().map(str::to_string))
                })
                .unwrap_or_else(|| "unknown".into());
            format!("uid{uid}")
        })
}

/// Says hello on `key`, waits for the answer, and records the client id
/// and the link's epoch and clock in `shared`.
fn hello(session: &zenoh::Session, key: &str, shared: &Shared) -> Result<(), String> {
    let replies = session
        .get(key)
        .attachment(operator().into_bytes())
        .timeout(HELLO_TIMEOUT)
        .wait()
        .map_err(|e| e.to_string())?;
    let reply = replies.recv().map_err(|_| {
        let prefix = key.split("/command/").next().unwrap_or(key);
        match served_prefix(session) {
            Some(served) if served != prefix => format!(
                "this link serves the daemon at prefix '{served}', not '{prefix}' \
                 (give --prefix {served})"
            ),
            Some(_) => format!(
                "the link did not answer the hello within {HELLO_TIMEOUT:?} (does it \
                 accept commands? `[link] commands`)"
            ),
            None => format!("no anguilla link answered within {HELLO_TIMEOUT:?}"),
        }
    })?;
    let b = match reply.result() {
        Ok(sample) => sample.payload().to_bytes().into_owned(),
        Err(e) => return Err(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned()),
    };
    let h = Hello::decode(&b).ok_or_else(|| {
        format!(
            "the link's hello reply has {} bytes, not {} (another version?)",
            b.len(),
            Hello::LEN
        )
    })?;
    let mut i = shared.lock();
    i.id = h.id;
    i.sync = Some((h.clock, Instant::now()));
    i.need_hello = false;
    Ok(())
}

/// A tool's session with a daemon through `anguilla link`.
pub struct RemoteClient {
    session: zenoh::Session,
    prefix: String,
    endpoint: String,
    key: String,
    shared: Arc<Shared>,
    _state: Option<zenoh::pubsub::Subscriber<()>>,
    sequence: u32,
    pending: Vec<(u32, Instant)>,
    /// The state count at the last wait_any, and at the last state taken.
    seen_states: u64,
    taken_states: u64,
    keepalive: Option<std::thread::JoinHandle<()>>,
}

impl std::fmt::Debug for RemoteClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteClient")
            .field("endpoint", &self.endpoint)
            .field("prefix", &self.prefix)
            .finish()
    }
}

impl RemoteClient {
    /// Connects through the link at `endpoint` to the daemon at `prefix`.
    /// With `commands`, opens a command session with the link (and fails
    /// when no link answers); without, only reads the state (a monitor).
    pub fn connect(
        prefix: &str,
        endpoint: &Endpoint,
        tls: Option<&Tls>,
        commands: bool,
    ) -> Result<Self, IpcError> {
        if !anguilla_ipc::valid_prefix(prefix) {
            return Err(IpcError::BadPrefix(prefix.to_string()));
        }
        let session = open_session(endpoint, tls)?;
        // A link serving another daemon prefix says so: name both.
        if let Some(served) = served_prefix(&session)
            && served != prefix
        {
            return Err(IpcError::Remote(format!(
                "the link at {} serves the daemon at prefix '{served}', not '{prefix}' \
                 (give --prefix {served})",
                endpoint.text
            )));
        }
        let shared = Arc::new(Shared::default());
        let sh = shared.clone();
        let state = session
            .declare_subscriber(crate::state_key(prefix))
            .callback(move |sample| {
                let b = sample.payload().to_bytes();
                // A payload of another size (another layout) is not a state.
                if let Some(s) = StateSnapshot::from_bytes(&b) {
                    let mut i = sh.lock();
                    i.state = Some(s);
                    i.states += 1;
                    i.state_at = Some(Instant::now());
                    drop(i);
                    sh.cv.notify_all();
                }
            })
            .wait()
            .map_err(|e| IpcError::Remote(format!("subscribing to the state: {e}")))?;
        let token = random_token()?;
        let key = crate::command_key(prefix, &token);
        let mut keepalive = None;
        if commands {
            hello(&session, &key, &shared).map_err(|e| {
                IpcError::Remote(format!(
                    "the link at {} (prefix '{prefix}'): {e}",
                    endpoint.text
                ))
            })?;
            let (s, k, sh) = (session.clone(), key.clone(), shared.clone());
            keepalive = Some(std::thread::spawn(move || {
                loop {
                    // Until the period ends, the link asks, or the session ends.
                    let due = Instant::now() + HELLO_PERIOD;
                    let stop = sh
                        .wait_while(HELLO_PERIOD, |i| {
                            !i.stop && !i.need_hello && Instant::now() < due
                        })
                        .stop;
                    if stop {
                        return;
                    }
                    if hello(&s, &k, &sh).is_err() {
                        // No link: ask again after a pause a stop cuts short.
                        if sh.wait_while(RETRY_PAUSE, |i| !i.stop).stop {
                            return;
                        }
                    }
                }
            }));
        }
        Ok(Self {
            session,
            prefix: prefix.to_string(),
            endpoint: endpoint.text.clone(),
            key,
            shared,
            _state: Some(state),
            sequence: 0,
            pending: Vec::new(),
            seen_states: 0,
            taken_states: 0,
            keepalive,
        })
    }
}

impl Drop for RemoteClient {
    fn drop(&mut self) {
        self.shared.lock().stop = true;
        self.shared.cv.notify_all();
        if let Some(k) = self.keepalive.take() {
            let _ = k.join();
        }
    }
}

/// Sends an E-stop through the link's E-stop key and waits for the link to
/// say it relayed it to the daemon's E-stop socket.
pub fn estop_through(session: &zenoh::Session, prefix: &str) -> Result<(), IpcError> {
    let replies = estop_query(session, prefix)
        .timeout(Duration::from_secs(1))
        .wait()
        .map_err(|e| IpcError::Remote(format!("e-stop query: {e}")))?;
    match replies.recv() {
        Ok(r) => match r.result() {
            Ok(_) => Ok(()),
            Err(e) => Err(IpcError::Remote(
                String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
            )),
        },
        Err(_) => Err(IpcError::Remote(
            "no link relayed the e-stop within 1 s".into(),
        )),
    }
}

fn estop_query<'a>(
    session: &'a zenoh::Session,
    prefix: &str,
) -> zenoh::session::SessionGetBuilder<'a, 'static, zenoh::handlers::DefaultHandler> {
    session
        .get(crate::estop_key(prefix))
        .payload(b"estop".to_vec())
        .priority(Priority::RealTime)
}

/// An E-stop through the link at `endpoint` on its own Zenoh session: the
/// path no session limit blocks (`ctl estop --connect`).
pub fn remote_estop(prefix: &str, endpoint: &Endpoint, tls: Option<&Tls>) -> Result<(), IpcError> {
    let session = open_session(endpoint, tls)?;
    estop_through(&session, prefix)
}

impl Session for RemoteClient {
    fn id(&self) -> u128 {
        self.shared.lock().id
    }

    fn describe(&self) -> String {
        format!(
            "prefix '{}' through the link at {}",
            self.prefix, self.endpoint
        )
    }

    fn silence_hint(&self) -> String {
        // The link is this session's router: none connected means the
        // link went away (or the network), not the daemon behind it.
        let routers = self.session.info().routers_zid().wait().count();
        if routers == 0 {
            format!(
                "the link at {} stopped or cannot be reached (is `anguilla link` running?)",
                self.endpoint
            )
        } else {
            "the link is up: is the daemon behind it running?".into()
        }
    }

    fn provenance_problem(&self) -> Option<String> {
        let at = self.shared.lock().state_at;
        match at {
            Some(t) if t.elapsed() > Duration::from_secs(2) => Some(format!(
                "no state through the link at {} for {:.1} s",
                self.endpoint,
                t.elapsed().as_secs_f64()
            )),
            _ => None,
        }
    }

    fn send_request(&mut self, req: CommandRequest) -> Result<u32, IpcError> {
        let sh = self.shared.clone();
        let stamp = stamp(self.shared.lock().sync);
        let mut get = self
            .session
            .get(&self.key)
            .payload(req.as_bytes().to_vec())
            // A late command is useless, and the link's reply must never
            // wait on this tool's connection: drop, never block.
            .congestion_control(CongestionControl::Drop)
            .priority(Priority::InteractiveHigh)
            .timeout(QUERY_TIMEOUT);
        if let Some(b) = stamp {
            get = get.attachment(b);
        }
        get.callback(move |reply| {
            let mut i = sh.lock();
            let mode = i.state.map_or(0, |s| s.mode);
            let r = match reply.result() {
                Ok(sample) => {
                    let b = sample.payload().to_bytes();
                    match crate::wire::decode_reply(&b) {
                        Some((id, r)) => {
                            i.id = id;
                            r
                        }
                        None => CommandReply::refused(
                            &req,
                            mode,
                            &format!("the link's reply has {} bytes (another version?)", b.len()),
                        ),
                    }
                }
                Err(e) => {
                    let text = String::from_utf8_lossy(&e.payload().to_bytes()).into_owned();
                    if text.contains("hello") {
                        i.need_hello = true;
                    }
                    CommandReply::refused(&req, mode, &format!("link: {text}"))
                }
            };
            i.replies.push_back(r);
            drop(i);
            sh.cv.notify_all();
        })
        .wait()
        .map_err(|e| IpcError::Remote(format!("sending through {}: {e}", self.endpoint)))?;
        self.pending.retain(|(_, t)| t.elapsed() < QUERY_TIMEOUT);
        if self.pending.len() >= MAX_PENDING {
            self.pending.remove(0);
        }
        self.pending.push((req.sequence, Instant::now()));
        Ok(req.sequence)
    }

    fn replies(&mut self, f: &mut dyn FnMut(&CommandReply)) -> Result<(), IpcError> {
        let got: Vec<CommandReply> = self.shared.lock().replies.drain(..).collect();
        for r in &got {
            if let Some(i) = self.pending.iter().position(|(s, _)| *s == r.sequence) {
                self.pending.swap_remove(i);
            }
            f(r);
        }
        Ok(())
    }

    fn awaiting(&self) -> usize {
        self.pending
            .iter()
            .filter(|(_, t)| t.elapsed() < QUERY_TIMEOUT)
            .count()
    }

    fn wait_any(&mut self, timeout: Duration) -> Result<(), IpcError> {
        self.pending.retain(|(_, t)| t.elapsed() < QUERY_TIMEOUT);
        // Returns on a reply, or a state newer than the last wait saw.
        let seen = self.seen_states;
        let i = self
            .shared
            .wait_while(timeout, |i| i.replies.is_empty() && i.states == seen);
        self.seen_states = i.states;
        Ok(())
    }

    fn latest(&mut self) -> Result<Option<StateSnapshot>, IpcError> {
        self.wait_state(Duration::ZERO)
    }

    fn wait_state(&mut self, timeout: Duration) -> Result<Option<StateSnapshot>, IpcError> {
        let taken = self.taken_states;
        let i = self.shared.wait_while(timeout, |i| i.states == taken);
        if i.states == taken {
            return Ok(None);
        }
        self.taken_states = i.states;
        Ok(i.state)
    }

    fn estop_out_of_band(&mut self) -> Result<(), IpcError> {
        // Sent, not awaited: a tool's loop must not stall on it (the
        // command and the state confirm it).
        estop_query(&self.session, &self.prefix)
            .timeout(Duration::from_secs(1))
            .callback(|_| {})
            .wait()
            .map_err(|e| IpcError::Remote(format!("e-stop query: {e}")))
    }

    fn next_sequence(&mut self) -> u32 {
        self.sequence = self.sequence.wrapping_add(1);
        self.sequence
    }
}
