//! The link process's bridge: the daemon's state out to Zenoh, remote
//! commands and E-stops in.
//!
//! - **State**: read over iceoryx2 like any tool, put on `P/state` at most
//!   [`LinkSettings::state_rate`] times a second, and at once when the
//!   mode, the cause or the holder changes (an E-stop shows without wait).
//! - **Commands**: a query on `P/command/<token>`. Each token gets its own
//!   iceoryx2 client (its own node and client port), created at its first
//!   query, up to [`LinkSettings::max_clients`]; the daemon sees one client
//!   per remote tool. A session silent for [`LinkSettings::idle_timeout`]
//!   is closed (its node leaves, and the daemon releases its control).
//!   Nothing is kept alive on a remote tool's behalf: a link that stalls or
//!   dies is a silent operator, and the daemon's deadman stops the swim.
//! - **Stale commands**: a session is opened only by a hello, whose reply
//!   carries the link's epoch (random per link process) and clock. A tool
//!   stamps each command with that epoch and its estimate of the link's
//!   clock (the clock in the last hello reply plus the time since, on the
//!   tool's own clock; 16-byte attachment), so the link judges a command's
//!   age on its own clock and drops one older than the daemon's command
//!   timeout: a link or network that stalled delivers no old command when
//!   it resumes, and the tools re-sync every hello (no drift, no suspend).
//!   A command for an unknown token, or stamped with another link's epoch,
//!   is refused: the tool says hello again.
//! - **E-stop**: a query on `P/estop` is relayed to the daemon's E-stop
//!   socket from Zenoh's own thread at once, whatever the command queue
//!   holds and however many sessions exist.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::time::{Duration, Instant};

use anguilla_ipc::{Client, CommandReply, CommandRequest, Raw as _, StateSnapshot};
use zenoh::Wait as _;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::query::Query;

use crate::ros2::node::{Ros2Node, Ros2Settings};
use crate::wire::{Hello, Stamp, token_of};
use crate::{Endpoint, LinkError, Tls, zenoh_err};

/// How far ahead of the link's clock a command's stamp may be (ms): a
/// tool's estimate lags the clock, so this only absorbs the two clocks'
/// rates over a hello's 2 s.
pub const MAX_STAMP_AHEAD_MS: i64 = 250;

/// Queries waiting for the bridge's loop; beyond, a query is answered
/// "busy" at once.
const QUERY_QUEUE: usize = 256;
/// Replies one session may await: as many as its iceoryx2 client keeps
/// (beyond, the oldest is answered "outcome unknown").
const SESSION_PENDING: usize = anguilla_ipc::MAX_REQUESTS_PER_CLIENT - 1;
/// A forwarded command whose reply has not come within this is answered
/// with an error.
const REPLY_TIMEOUT: Duration = Duration::from_secs(2);

/// How the link runs (from `[link]` and the command line).
#[derive(Debug, Clone)]
pub struct LinkSettings {
    /// The daemon's iceoryx2 prefix, also the Zenoh key prefix.
    pub prefix: String,
    /// Endpoints to listen on (checked).
    pub listen: Vec<Endpoint>,
    /// TLS files, for `tls/` endpoints.
    pub tls: Option<Tls>,
    /// Most states a second.
    pub state_rate: f64,
    /// Most remote sessions at once.
    pub max_clients: usize,
    /// A silent session is closed after this.
    pub idle_timeout: Duration,
    /// Remote clients may send commands.
    pub allow_command: bool,
    /// Remote clients may send E-stops.
    pub allow_estop: bool,
    /// The state is published.
    pub publish_state: bool,
    /// The robot as a ROS 2 node ([`crate::ros2`]), when set.
    pub ros2: Option<Ros2Settings>,
}

/// The bridge's counters (shared with the E-stop callback).
#[derive(Debug, Default)]
pub struct BridgeStats {
    /// States put on the link.
    pub states: AtomicU64,
    /// Their payload bytes.
    pub state_bytes: AtomicU64,
    /// Commands forwarded to the daemon.
    pub commands: AtomicU64,
    /// Commands answered with an error by the link (malformed, stale, busy, full).
    pub rejected: AtomicU64,
    /// E-stops relayed.
    pub estops: AtomicU64,
}

struct Pending {
    sequence: u32,
    query: Query,
    since: Instant,
}

struct RemoteSession {
    client: Client,
    last_seen: Instant,
    pending: Vec<Pending>,
}

/// The running bridge.
pub struct Bridge {
    settings: LinkSettings,
    session: zenoh::Session,
    publisher: Option<zenoh::pubsub::Publisher<'static>>,
    reader: Client,
    queries: Receiver<Query>,
    _command_queryable: Option<zenoh::query::Queryable<()>>,
    _estop_queryable: Option<zenoh::query::Queryable<()>>,
    _info_queryable: zenoh::query::Queryable<()>,
    sessions: HashMap<String, RemoteSession>,
    stats: Arc<BridgeStats>,
    started: Instant,
    last_state: Option<StateSnapshot>,
    last_put: Option<Instant>,
    command_timeout: Duration,
    next_node: u64,
    epoch: u64,
    ros2: Option<Ros2Node>,
}

/// The access-control list of the link's router: remote clients may do
/// exactly what the allowlist says, and nothing else (no queryable, no
/// publication, no subscription elsewhere).
fn access_control(s: &LinkSettings) -> String {
    let p = &s.prefix;
    let mut rules = Vec::new();
    let mut rule = |id: &str, msg: &str, flow: &str, key: String| {
        rules.push(serde_json::json!({
            "id": id, "messages": [msg], "flows": [flow], "permission": "allow", "key_exprs": [key],
        }));
    };
    // Which prefix this link serves: a tool given another says so.
    rule("prefix-query", "query", "ingress", crate::INFO_KEY.into());
    rule("prefix-reply", "reply", "egress", crate::INFO_KEY.into());
    if s.allow_command {
        rule(
            "command-query",
            "query",
            "ingress",
            format!("{p}/command/*"),
        );
        rule("command-reply", "reply", "egress", format!("{p}/command/*"));
    }
    if s.allow_estop {
        rule("estop-query", "query", "ingress", format!("{p}/estop"));
        rule("estop-reply", "reply", "egress", format!("{p}/estop"));
    }
    if s.publish_state {
        rule(
            "state-subscribe",
            "declare_subscriber",
            "ingress",
            format!("{p}/state"),
        );
        rule("state-put", "put", "egress", format!("{p}/state"));
    }
    if let Some(r) = &s.ros2 {
        crate::ros2::acl::rules(r, &mut rule);
    }
    let ids: Vec<_> = rules.iter().map(|r| r["id"].clone()).collect();
    let policies = if ids.is_empty() {
        serde_json::json!([])
    } else {
        serde_json::json!([{ "id": "remote", "rules": ids, "subjects": ["everyone"] }])
    };
    serde_json::json!({
        "enabled": true,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [{ "id": "everyone" }],
        "policies": policies,
    })
    .to_string()
}

fn monotonic_ms(started: Instant) -> i64 {
    i64::try_from(started.elapsed().as_millis()).unwrap_or(i64::MAX)
}

/// This link process's epoch: random, so a tool can tell a restarted link.
fn random_epoch() -> u64 {
    match crate::urandom() {
        Ok(b) => u64::from_le_bytes(b),
        // Not secret: only distinct; the time and pid do.
        Err(_) => {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos() as u64)
                ^ u64::from(std::process::id())
        }
    }
}

fn reply_err(q: &Query, text: &str) {
    if let Err(e) = q.reply_err(text.to_string()).wait() {
        tracing::debug!("reply to {}: {e}", q.key_expr());
    }
}

impl Bridge {
    /// Opens the daemon's interface (waits for nothing: fails with
    /// [`anguilla_ipc::IpcError::NoDaemon`] when no daemon serves the prefix)
    /// and the Zenoh router on the endpoints.
    pub fn open(settings: LinkSettings) -> Result<Self, LinkError> {
        let reader = Client::new(
            &settings.prefix,
            &format!("anguilla-link-{}", std::process::id()),
        )?;
        let mut config =
            crate::zenoh_config("router", &settings.listen, true, settings.tls.as_ref())?;
        let acl = access_control(&settings);
        config
            .insert_json5("access_control", &acl)
            .map_err(|e| LinkError::Zenoh(format!("access control {acl}: {e}")))?;
        let session = zenoh::open(config).wait().map_err(|e| {
            LinkError::Zenoh(format!(
                "listening on {}: {e}",
                settings
                    .listen
                    .iter()
                    .map(|e| e.text.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?;
        let p = settings.prefix.clone();
        let publisher = if settings.publish_state {
            Some(
                session
                    .declare_publisher(crate::state_key(&p))
                    .congestion_control(CongestionControl::Drop)
                    .priority(Priority::DataHigh)
                    .wait()
                    .map_err(zenoh_err("state publisher"))?,
            )
        } else {
            None
        };
        let stats = Arc::new(BridgeStats::default());
        let (tx, queries): (SyncSender<Query>, _) = std::sync::mpsc::sync_channel(QUERY_QUEUE);
        let command_queryable = if settings.allow_command {
            let st = stats.clone();
            Some(
                session
                    .declare_queryable(format!("{p}/command/*"))
                    .callback(move |q| match tx.try_send(q) {
                        Ok(()) => {}
                        Err(TrySendError::Full(q) | TrySendError::Disconnected(q)) => {
                            st.rejected.fetch_add(1, Ordering::Relaxed);
                            reply_err(&q, "the link is busy: command dropped");
                        }
                    })
                    .wait()
                    .map_err(zenoh_err("command queryable"))?,
            )
        } else {
            None
        };
        let estop_queryable = if settings.allow_estop {
            let st = stats.clone();
            let prefix = p.clone();
            Some(
                session
                    .declare_queryable(crate::estop_key(&p))
                    .callback(move |q| {
                        let text = match anguilla_ipc::estop::send(&prefix) {
                            Ok(()) => {
                                st.estops.fetch_add(1, Ordering::Relaxed);
                                "e-stop relayed to the daemon's e-stop socket".to_string()
                            }
                            Err(e) => format!("e-stop NOT relayed: {e}"),
                        };
                        tracing::warn!("remote e-stop: {text}");
                        let r = if text.starts_with("e-stop relayed") {
                            q.reply(q.key_expr().clone(), text).wait()
                        } else {
                            q.reply_err(text).wait()
                        };
                        if let Err(e) = r {
                            tracing::debug!("e-stop reply: {e}");
                        }
                    })
                    .wait()
                    .map_err(zenoh_err("e-stop queryable"))?,
            )
        } else {
            None
        };
        let served = p.clone();
        let info_queryable = session
            .declare_queryable(crate::INFO_KEY)
            .callback(move |q| {
                if let Err(e) = q.reply(crate::INFO_KEY, served.clone()).wait() {
                    tracing::debug!("prefix reply: {e}");
                }
            })
            .wait()
            .map_err(zenoh_err("prefix queryable"))?;
        let ros2 = match settings.ros2.clone() {
            Some(r) => Some(Ros2Node::open(&session, &p, r)?),
            None => None,
        };
        Ok(Self {
            settings,
            session,
            publisher,
            reader,
            queries,
            _command_queryable: command_queryable,
            _estop_queryable: estop_queryable,
            _info_queryable: info_queryable,
            sessions: HashMap::new(),
            stats,
            started: Instant::now(),
            last_state: None,
            last_put: None,
            command_timeout: Duration::from_millis(500),
            next_node: 0,
            epoch: random_epoch(),
            ros2,
        })
    }

    /// The counters.
    pub fn stats(&self) -> &BridgeStats {
        &self.stats
    }

    /// The ROS 2 node, when `[link] ros2` is on.
    pub fn ros2(&self) -> Option<&Ros2Node> {
        self.ros2.as_ref()
    }

    /// Remote sessions open.
    pub fn sessions(&self) -> usize {
        self.sessions.len()
    }

    /// The Zenoh session (its id, for messages).
    pub fn zenoh(&self) -> &zenoh::Session {
        &self.session
    }

    /// One turn: waits up to `wait` for a query, then forwards queries,
    /// collects the daemon's replies, publishes the state when due and
    /// closes idle sessions.
    pub fn step(&mut self, wait: Duration) -> Result<(), LinkError> {
        if let Ok(q) = self.queries.recv_timeout(wait) {
            self.handle(q);
            while let Ok(q) = self.queries.try_recv() {
                self.handle(q);
            }
        }
        self.collect()?;
        if let Some(n) = &mut self.ros2 {
            n.serve()?;
        }
        self.publish_state()?;
        self.expire();
        Ok(())
    }

    fn publish_state(&mut self) -> Result<(), LinkError> {
        let Some(s) = self.reader.latest()? else {
            return Ok(());
        };
        self.command_timeout = Duration::from_millis(u64::from(s.limits.command_timeout_ms.max(1)));
        let changed = self
            .last_state
            .is_none_or(|l| l.mode != s.mode || l.cause != s.cause || l.holder() != s.holder());
        self.last_state = Some(s);
        if let Some(n) = &mut self.ros2 {
            n.publish(&s)?;
        }
        let due = self
            .last_put
            .is_none_or(|t| t.elapsed().as_secs_f64() >= 1.0 / self.settings.state_rate);
        if let Some(p) = &self.publisher
            && (changed || due)
        {
            p.put(s.as_bytes().to_vec())
                .wait()
                .map_err(zenoh_err("put state"))?;
            self.last_put = Some(Instant::now());
            self.stats.states.fetch_add(1, Ordering::Relaxed);
            self.stats
                .state_bytes
                .fetch_add(s.as_bytes().len() as u64, Ordering::Relaxed);
        }
        Ok(())
    }

    fn reject(&self, q: &Query, why: &str) {
        self.stats.rejected.fetch_add(1, Ordering::Relaxed);
        reply_err(q, why);
    }

    fn handle(&mut self, q: Query) {
        let key = q.key_expr().as_str().to_string();
        let Some(token) = token_of(&self.settings.prefix, &key) else {
            self.reject(
                &q,
                &format!(
                    "key '{key}' is not a command key (expected {}/command/ and 32 lowercase \
                     hex digits)",
                    self.settings.prefix
                ),
            );
            return;
        };
        let now = Instant::now();
        let payload = q
            .payload()
            .map(|p| p.to_bytes().into_owned())
            .unwrap_or_default();
        let link_ms = monotonic_ms(self.started);
        if payload.is_empty() {
            // A hello: opens the session if new; the identity and the clock.
            if !self.sessions.contains_key(&token) {
                let who = q
                    .attachment()
                    .and_then(|a| crate::wire::operator_name(&a.to_bytes()));
                if !self.open_session(&q, &token, now, who.as_deref()) {
                    return;
                }
            }
            let Some(sess) = self.sessions.get_mut(&token) else {
                return;
            };
            sess.last_seen = now;
            let r = Hello {
                id: sess.client.id(),
                clock: Stamp {
                    epoch: self.epoch,
                    link_ms,
                },
            }
            .encode();
            if let Err(e) = q.reply(q.key_expr().clone(), r).wait() {
                tracing::debug!("hello reply: {e}");
            }
            return;
        }
        let Some(sess) = self.sessions.get_mut(&token) else {
            self.reject(
                &q,
                "no session for this token (the link restarted, or closed it when silent): \
                 say hello first",
            );
            return;
        };
        sess.last_seen = now;
        let Some(req) = CommandRequest::from_bytes(&payload) else {
            let n = payload.len();
            self.reject(
                &q,
                &format!(
                    "a command is one CommandRequest of {} bytes (docs/ipc.md), not {n} bytes",
                    size_of::<CommandRequest>()
                ),
            );
            return;
        };
        // The tool's stamp: this link's epoch and its estimate of this
        // link's clock when it sent the command.
        let stamp = q.attachment().map(|a| a.to_bytes().into_owned());
        if let Some(b) = stamp {
            let Some(sent) = Stamp::decode(&b) else {
                self.reject(
                    &q,
                    &format!(
                        "the stamp (attachment) is {} bytes, not {} (epoch, link clock)",
                        b.len(),
                        Stamp::LEN
                    ),
                );
                return;
            };
            if sent.epoch != self.epoch {
                self.reject(
                    &q,
                    "stamped for another link (it restarted): say hello again",
                );
                return;
            }
            // A tool's estimate of this clock lags it (the hello's reply
            // took time to arrive): a stamp ahead by more than a small
            // skew is forged, and would pass the age check for as long.
            if sent.link_ms > link_ms.saturating_add(MAX_STAMP_AHEAD_MS) {
                let why = format!(
                    "command {} is stamped {} ms ahead of the link's clock (at most \
                     {MAX_STAMP_AHEAD_MS} ms accepted): forged or corrupt; dropped",
                    req.sequence,
                    sent.link_ms.saturating_sub(link_ms)
                );
                tracing::warn!("remote session {}: {why}", &token[..8]);
                self.reject(&q, &why);
                return;
            }
            let age_ms = link_ms.saturating_sub(sent.link_ms);
            let max_age = i64::try_from(self.command_timeout.as_millis()).unwrap_or(i64::MAX);
            if age_ms > max_age {
                let why = format!(
                    "command {} is {age_ms} ms old, beyond the daemon's command timeout \
                     ({max_age} ms): the link or the network stalled; dropped",
                    req.sequence
                );
                tracing::warn!("remote session {}: {why}", &token[..8]);
                self.reject(&q, &why);
                return;
            }
        }
        let Some(sess) = self.sessions.get_mut(&token) else {
            return;
        };
        match sess.client.send_request(req) {
            Ok(_) => {
                self.stats.commands.fetch_add(1, Ordering::Relaxed);
                if sess.pending.len() >= SESSION_PENDING {
                    let old = sess.pending.remove(0);
                    reply_err(
                        &old.query,
                        "too many commands in flight: the daemon's reply to this one is given \
                         up (outcome unknown)",
                    );
                }
                sess.pending.push(Pending {
                    sequence: req.sequence,
                    query: q,
                    since: now,
                });
            }
            Err(e) => {
                self.reject(&q, &format!("forwarding to the daemon: {e}"));
            }
        }
    }

    fn collect(&mut self) -> Result<(), LinkError> {
        let mut broken = Vec::new();
        for (token, sess) in &mut self.sessions {
            if sess.pending.is_empty() {
                continue;
            }
            let id = sess.client.id();
            let mut got: Vec<CommandReply> = Vec::new();
            if let Err(e) = sess.client.replies(|r| got.push(*r)) {
                // This session's client only: close it, serve the others.
                tracing::error!("remote session {}: {e}; closed", &token[..8]);
                broken.push(token.clone());
                continue;
            }
            for r in got {
                if let Some(i) = sess.pending.iter().position(|p| p.sequence == r.sequence) {
                    let p = sess.pending.remove(i);
                    let bytes = crate::wire::encode_reply(id, &r);
                    if let Err(e) = p.query.reply(p.query.key_expr().clone(), bytes).wait() {
                        tracing::debug!("command reply: {e}");
                    }
                }
            }
            let now = Instant::now();
            sess.pending.retain(|p| {
                let keep = now.duration_since(p.since) < REPLY_TIMEOUT;
                if !keep {
                    reply_err(&p.query, "the daemon did not reply in time");
                }
                keep
            });
        }
        for t in broken {
            if let Some(s) = self.sessions.remove(&t) {
                for p in s.pending {
                    reply_err(
                        &p.query,
                        "the link lost this session's client (outcome unknown)",
                    );
                }
            }
        }
        Ok(())
    }

    /// Opens a session for `token` (answering `q` with why not); whether it
    /// did. `who`: the operator's name the hello carried; the session's
    /// iceoryx2 node is then `anguilla-link:WHO-…`, which the daemon's
    /// tools show as the holder `link:WHO`.
    fn open_session(&mut self, q: &Query, token: &str, now: Instant, who: Option<&str>) -> bool {
        if self.sessions.len() >= self.settings.max_clients {
            self.reject(
                q,
                &format!(
                    "the link serves {} remote clients already ([link] max-clients); an idle \
                     one is closed after {:?}",
                    self.settings.max_clients, self.settings.idle_timeout
                ),
            );
            return false;
        }
        self.next_node += 1;
        let name = match who {
            Some(w) => format!(
                "anguilla-link:{w}-{}-{}",
                std::process::id(),
                self.next_node
            ),
            None => format!("anguilla-link-{}-{}", std::process::id(), self.next_node),
        };
        match Client::new(&self.settings.prefix, &name) {
            Ok(client) => {
                tracing::info!(
                    "remote session {} opened (operator {})",
                    &token[..8],
                    who.unwrap_or("unnamed")
                );
                self.sessions.insert(
                    token.to_string(),
                    RemoteSession {
                        client,
                        last_seen: now,
                        pending: Vec::new(),
                    },
                );
                true
            }
            Err(e) => {
                self.reject(q, &format!("the daemon's interface: {e}"));
                false
            }
        }
    }

    fn expire(&mut self) {
        let idle = self.settings.idle_timeout;
        self.sessions.retain(|token, s| {
            let keep = s.last_seen.elapsed() < idle || !s.pending.is_empty();
            if !keep {
                tracing::info!("remote session {} closed: silent for {idle:?}", &token[..8]);
            }
            keep
        });
    }

    /// Runs until `stop` says so.
    pub fn run(&mut self, stop: &dyn Fn() -> bool) -> Result<(), LinkError> {
        while !stop() {
            self.step(Duration::from_millis(1))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A link on prefix `p` that publishes the state and takes E-stops.
    fn settings(ros2: Option<Ros2Settings>) -> LinkSettings {
        LinkSettings {
            prefix: "p".into(),
            listen: Vec::new(),
            tls: None,
            state_rate: 50.0,
            max_clients: 8,
            idle_timeout: Duration::from_secs(10),
            allow_command: false,
            allow_estop: true,
            publish_state: true,
            ros2,
        }
    }

    #[test]
    fn the_access_list_follows_the_allowlist() {
        let mut s = settings(None);
        let acl = access_control(&s);
        assert!(acl.contains("\"default_permission\":\"deny\""));
        assert!(acl.contains("p/estop") && acl.contains("p/state"));
        assert!(!acl.contains("p/command"), "{acl}");
        s.allow_command = true;
        assert!(access_control(&s).contains("p/command/*"));
    }

    /// A watch-only ROS 2 node (inbound: estop) lets no one put on
    /// cmd_vel or call a service but ~/estop; with commands, those keys
    /// and no others; and nothing outside the node's domain.
    #[test]
    fn the_ros2_access_list_follows_the_allowlist() {
        let ros2 = Ros2Settings {
            domain: 7,
            namespace: "/eel".into(),
            node: "anguilla".into(),
            rates: [20.0; crate::ros2::N_TOPICS],
            humble: false,
            geometry: crate::ros2::state::Geometry {
                segments: vec![(0.5, 0.05, 0.03); 2],
                limits: [1.0, 8.0, 4.0],
            },
            allow_command: false,
            allow_estop: true,
            speeds: crate::ros2::node::SpeedTable::linear(0.4),
            max_speed: 0.4,
            frequency: 1.0,
            pose: None,
        };
        let mut s = settings(Some(ros2));
        let acl: serde_json::Value = serde_json::from_str(&access_control(&s)).unwrap();
        let keys = |acl: &serde_json::Value, msg: &str, flow: &str| -> Vec<String> {
            acl["rules"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|r| r["messages"][0] == msg && r["flows"][0] == flow)
                .map(|r| r["key_exprs"][0].as_str().unwrap().to_string())
                .collect()
        };
        let queries = keys(&acl, "query", "ingress");
        assert!(
            queries
                .iter()
                .any(|k| k.starts_with("7/eel/anguilla/estop/"))
        );
        assert!(
            !queries
                .iter()
                .any(|k| k.contains("take_control") || k.contains("enable"))
        );
        assert!(keys(&acl, "put", "ingress").is_empty(), "no cmd_vel: {acl}");
        // A client's own tokens stay out; the robot's go out.
        assert!(
            keys(&acl, "liveliness_token", "ingress").is_empty(),
            "tokens from clients: {acl}"
        );
        assert!(!keys(&acl, "liveliness_token", "egress").is_empty());
        for k in keys(&acl, "liveliness_query", "ingress") {
            assert!(k.starts_with("@ros2_lv/7/") || k.contains("/@adv/"), "{k}");
        }
        s.ros2.as_mut().unwrap().allow_command = true;
        let acl: serde_json::Value = serde_json::from_str(&access_control(&s)).unwrap();
        let puts = keys(&acl, "put", "ingress");
        assert_eq!(
            puts.len(),
            3,
            "Twist and TwistStamped on cmd_vel and a Path on path only: {puts:?}"
        );
        assert!(puts.iter().all(|k| {
            k.starts_with("7/eel/cmd_vel/geometry_msgs::msg::dds_::Twist")
                || k.starts_with("7/eel/path/nav_msgs::msg::dds_::Path_/")
        }));
        assert_eq!(
            keys(&acl, "query", "ingress").len(),
            6 + 2 + 2 + 2,
            "six services, two path services, two caches, the link's prefix and e-stop"
        );
        // Position fixes: a PoseStamped on pose_fix and an Odometry on
        // odom_fix, only when the node takes them.
        s.ros2.as_mut().unwrap().pose = Some(crate::ros2::node::PoseSettings {
            to: ([127, 0, 0, 1], 14660).into(),
            frame: "odom".into(),
            sigma: 0.01,
        });
        let acl: serde_json::Value = serde_json::from_str(&access_control(&s)).unwrap();
        let puts = keys(&acl, "put", "ingress");
        assert_eq!(puts.len(), 5, "{puts:?}");
        assert!(
            puts.iter()
                .any(|k| k.starts_with("7/eel/pose_fix/geometry_msgs::msg::dds_::PoseStamped_/"))
        );
        assert!(
            puts.iter()
                .any(|k| k.starts_with("7/eel/odom_fix/nav_msgs::msg::dds_::Odometry_/"))
        );
    }
}
