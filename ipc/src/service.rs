//! The services under a prefix, their capacities, and the daemon's two
//! sides of them.
//!
//! The daemon **creates** its services; tools only **open** them. A
//! service that already exists when the daemon starts is either the trace
//! of a dead daemon (its node is cleaned up, the service is reused) or held
//! by a live process that publishes on it or serves it: then the daemon
//! refuses to start and names the process ([`IpcError::Squatted`]).

use core::fmt;
use core::time::Duration;

use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use iceoryx2::service::messaging_pattern::MessagingPattern;
use iceoryx2::service::port_factory::{
    event::PortFactory as EventFactory, publish_subscribe::PortFactory as PubSubFactory,
    request_response::PortFactory as ReqResFactory,
};

use crate::command::{CommandReply, CommandRequest};
pub use crate::error::IpcError;
use crate::payload::StateSnapshot;

/// Most operator tools connected at once: subscribers of `state`,
/// listeners of `state-ready`, clients of `command`, notifiers of
/// `command-ready`. A tool uses one of each.
pub const MAX_TOOLS: usize = 32;
/// Most iceoryx2 nodes on one service: every tool's node and the daemon's.
pub const MAX_NODES: usize = MAX_TOOLS + 4;
/// Requests one client may have in flight; more are refused by iceoryx2
/// at the client (`send` fails), so one tool cannot fill the server.
pub const MAX_REQUESTS_PER_CLIENT: usize = 4;

pub(crate) fn ice<E: fmt::Debug>(what: &'static str) -> impl Fn(E) -> IpcError {
    move |e| IpcError::Iceoryx(format!("{what}: {e:?}"))
}

/// Why a tool could not open the service `full`, in words: iceoryx2's
/// open errors are enum names (`DoesNotExist`, `InsufficientPermissions`,
/// …); the name is kept only for an error this does not know.
pub(crate) fn open_failure(full: &str, debug: &str) -> String {
    let name = debug.split(['(', ' ', '{']).next().unwrap_or(debug);
    match name {
        "DoesNotExist" => format!("its service '{full}' does not exist"),
        n if n.contains("Permission") => format!(
            "its service '{full}' cannot be opened: permission denied (the daemon's iceoryx2 \
             files are its user's: run the tool as that user, or through `anguilla link` with \
             `--connect local` as a member of the operator group)"
        ),
        "IsMarkedForDestruction" => {
            format!("its service '{full}' is being removed: the daemon is stopping")
        }
        n if n.contains("Corrupted") => format!(
            "its service '{full}' is damaged (a killed program left it half made): restart \
             the daemon"
        ),
        n if n.starts_with("Incompatible") => format!(
            "its service '{full}' has other message types or settings: a daemon of another \
             anguilla version ({name})"
        ),
        n if n.contains("Timeout") || n.contains("HangsInCreation") => {
            format!("its service '{full}' is still being created: try again")
        }
        _ => format!("its service '{full}' cannot be opened (iceoryx2: {debug})"),
    }
}

/// Whether `prefix` makes valid service names (letters, digits, '-', '_', '/').
pub fn valid_prefix(prefix: &str) -> bool {
    !prefix.is_empty()
        && prefix.len() <= 200
        && prefix
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '/'))
}

pub(crate) fn service_name(prefix: &str, leaf: &str) -> Result<ServiceName, IpcError> {
    if !valid_prefix(prefix) {
        return Err(IpcError::BadPrefix(prefix.to_string()));
    }
    let full = format!("{prefix}/{leaf}");
    ServiceName::new(&full).map_err(|_| IpcError::BadPrefix(prefix.to_string()))
}

pub(crate) type StateService = PubSubFactory<ipc::Service, StateSnapshot, ()>;
pub(crate) type CommandService = ReqResFactory<ipc::Service, CommandRequest, (), CommandReply, ()>;

/// How a side gets a service: the daemon creates, a tool opens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Role {
    Daemon,
    Tool,
}

/// Creates (daemon) or opens (tool) a service with `build`, which applies
/// the service's settings to a fresh builder and then `create`s or `open`s.
/// A daemon that finds the service existing opens it; `mismatch` says how
/// its settings differ from ours (iceoryx2 opens a service whose capacities
/// are at least those asked for: a second publisher's or server's room
/// would let a program in beside the daemon), and `live_holders` names the
/// live processes publishing on or serving it. Either refuses.
#[allow(clippy::too_many_arguments)]
fn obtain<F, E1: fmt::Debug, E2: fmt::Debug>(
    role: Role,
    prefix: &str,
    leaf: &str,
    pattern: MessagingPattern,
    create: impl Fn() -> Result<F, E1>,
    open: impl Fn() -> Result<F, E2>,
    mismatch: impl Fn(&F) -> Option<String>,
    live_holders: impl Fn(&F) -> Vec<i32>,
) -> Result<F, IpcError> {
    let full = format!("{prefix}/{leaf}");
    match role {
        Role::Tool => open().map_err(|e| IpcError::NoDaemon {
            prefix: prefix.to_string(),
            detail: open_failure(&full, &format!("{e:?}")),
        }),
        Role::Daemon => {
            let create_err = match create() {
                Ok(f) => return Ok(f),
                Err(e) => e,
            };
            // It exists: a dead daemon's service that a tool still holds
            // open (reuse it), or a live process's (refuse).
            let other_settings = |what: String| {
                let pids = attached_pids(&full, pattern);
                let who = if pids.is_empty() {
                    "a program".to_string()
                } else {
                    pids.iter()
                        .map(|p| format!("pid {p}{}", process_name(*p)))
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                IpcError::Iceoryx(format!(
                    "service '{full}' exists with other settings than the daemon's ({what}): \
                     {who} created it; stop it, or use another [ipc] prefix"
                ))
            };
            let f = open().map_err(|e| {
                other_settings(format!("not created: {create_err:?}; not opened: {e:?}"))
            })?;
            if let Some(what) = mismatch(&f) {
                return Err(other_settings(what));
            }
            let me = std::process::id() as i32;
            let holders: Vec<i32> = live_holders(&f)
                .into_iter()
                .filter(|&p| p != me && pid_alive(p))
                .collect();
            if holders.is_empty() {
                Ok(f)
            } else {
                Err(IpcError::Squatted {
                    service: full,
                    holders: holders
                        .iter()
                        .map(|p| format!("pid {p}{}", process_name(*p)))
                        .collect::<Vec<_>>()
                        .join(", "),
                })
            }
        }
    }
}

/// The settings that are not the daemon's, named, if any.
fn differs(settings: &[(&str, usize, usize)]) -> Option<String> {
    let off: Vec<String> = settings
        .iter()
        .filter(|(_, got, want)| got != want)
        .map(|(name, got, want)| format!("{name} {got}, expected {want}"))
        .collect();
    (!off.is_empty()).then(|| off.join(", "))
}

fn pid_alive(pid: i32) -> bool {
    // Signal 0 checks existence only; EPERM means it exists as another user's.
    // SAFETY: kill with signal 0 sends nothing.
    pid > 0
        && (unsafe { libc::kill(pid, 0) } == 0
            || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM))
}

fn process_name(pid: i32) -> String {
    std::fs::read_to_string(format!("/proc/{pid}/comm"))
        .map(|s| format!(" '{}'", s.trim()))
        .unwrap_or_default()
}

/// The live processes with a node on the service `full` (any settings).
fn attached_pids(full: &str, pattern: MessagingPattern) -> Vec<i32> {
    let Ok(name) = ServiceName::new(full) else {
        return Vec::new();
    };
    let me = std::process::id() as i32;
    let Ok(Some(details)) = ipc::Service::details(&name, crate::guard::config(), pattern) else {
        return Vec::new();
    };
    let mut pids: Vec<i32> = details
        .dynamic_details
        .map(|d| d.nodes)
        .unwrap_or_default()
        .iter()
        .filter_map(|n| match n {
            NodeState::Alive(view) => node_pid(view.id()),
            _ => None,
        })
        .filter(|&p| p != me)
        .collect();
    pids.sort_unstable();
    pids.dedup();
    pids
}

fn node_pid(id: &iceoryx2::identifiers::UniqueNodeId) -> Option<i32> {
    id.pid::<ipc::Service>().ok().map(|p| p.value())
}

pub(crate) fn state_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    role: Role,
) -> Result<StateService, IpcError> {
    let name = service_name(prefix, "state")?;
    let builder = || {
        node.service_builder(&name)
            .publish_subscribe::<StateSnapshot>()
            .history_size(1)
            .subscriber_max_buffer_size(2)
            .enable_safe_overflow(true)
            .max_subscribers(MAX_TOOLS)
            .max_publishers(1)
            .max_nodes(MAX_NODES)
    };
    obtain(
        role,
        prefix,
        "state",
        MessagingPattern::PublishSubscribe,
        || builder().create(),
        || builder().open(),
        |f: &StateService| {
            let c = f.static_config();
            differs(&[
                ("max publishers", c.max_publishers(), 1),
                ("max subscribers", c.max_subscribers(), MAX_TOOLS),
                ("max nodes", c.max_nodes(), MAX_NODES),
                ("history", c.history_size(), 1),
            ])
        },
        |f: &StateService| {
            let mut pids = Vec::new();
            f.dynamic_config().list_publishers(|d| {
                pids.extend(node_pid(&d.node_id));
                CallbackProgression::Continue
            });
            pids
        },
    )
}

pub(crate) fn command_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    role: Role,
) -> Result<CommandService, IpcError> {
    let name = service_name(prefix, "command")?;
    let builder = || {
        node.service_builder(&name)
            .request_response::<CommandRequest, CommandReply>()
            .max_clients(MAX_TOOLS)
            .max_servers(1)
            .max_active_requests_per_client(MAX_REQUESTS_PER_CLIENT)
            .enable_safe_overflow_for_requests(true)
            .max_nodes(MAX_NODES)
    };
    obtain(
        role,
        prefix,
        "command",
        MessagingPattern::RequestResponse,
        || builder().create(),
        || builder().open(),
        |f: &CommandService| {
            let c = f.static_config();
            differs(&[
                ("max servers", c.max_servers(), 1),
                ("max clients", c.max_clients(), MAX_TOOLS),
                ("max nodes", c.max_nodes(), MAX_NODES),
                (
                    "max active requests per client",
                    c.max_active_requests_per_client(),
                    MAX_REQUESTS_PER_CLIENT,
                ),
            ])
        },
        |f: &CommandService| {
            let mut pids = Vec::new();
            f.dynamic_config().list_servers(|d| {
                pids.extend(node_pid(&d.node_id));
                CallbackProgression::Continue
            });
            pids
        },
    )
}

/// `state-ready` (the daemon notifies) or `command-ready` (tools notify,
/// the daemon listens).
pub(crate) fn event_service(
    node: &Node<ipc::Service>,
    prefix: &str,
    leaf: &'static str,
    role: Role,
) -> Result<EventFactory<ipc::Service>, IpcError> {
    let name = service_name(prefix, leaf)?;
    let daemon_listens = leaf == "command-ready";
    let builder = || {
        let b = node.service_builder(&name).event().max_nodes(MAX_NODES);
        if daemon_listens {
            b.max_notifiers(MAX_TOOLS).max_listeners(1)
        } else {
            b.max_notifiers(1).max_listeners(MAX_TOOLS)
        }
    };
    obtain(
        role,
        prefix,
        leaf,
        MessagingPattern::Event,
        || builder().create(),
        || builder().open(),
        |f: &EventFactory<ipc::Service>| {
            let c = f.static_config();
            let (notifiers, listeners) = if daemon_listens {
                (MAX_TOOLS, 1)
            } else {
                (1, MAX_TOOLS)
            };
            differs(&[
                ("max notifiers", c.max_notifiers(), notifiers),
                ("max listeners", c.max_listeners(), listeners),
                ("max nodes", c.max_nodes(), MAX_NODES),
            ])
        },
        |f: &EventFactory<ipc::Service>| {
            let mut pids = Vec::new();
            if daemon_listens {
                f.dynamic_config().list_listeners(|d| {
                    pids.extend(node_pid(&d.node_id));
                    CallbackProgression::Continue
                });
            } else {
                f.dynamic_config().list_notifiers(|d| {
                    pids.extend(node_pid(&d.node_id));
                    CallbackProgression::Continue
                });
            }
            pids
        },
    )
}

/// The process ids of the nodes publishing `state` and serving `command`
/// on `prefix`, as a tool sees them: when they differ, the state a tool
/// shows does not come from the daemon that takes its commands.
pub(crate) fn publisher_and_server_pids(
    state: &StateService,
    command: &CommandService,
) -> (Vec<i32>, Vec<i32>) {
    let (mut p, mut s) = (Vec::new(), Vec::new());
    state.dynamic_config().list_publishers(|d| {
        p.extend(node_pid(&d.node_id));
        CallbackProgression::Continue
    });
    command.dynamic_config().list_servers(|d| {
        s.extend(node_pid(&d.node_id));
        CallbackProgression::Continue
    });
    (p, s)
}

pub(crate) fn new_node(name: &str) -> Result<Node<ipc::Service>, IpcError> {
    // iceoryx2 logs to stdout; keep its chatter (e.g. "no config file was
    // loaded") out of tools whose stdout is data, unless asked for.
    set_log_level_from_env_or(LogLevel::Error);
    let name = NodeName::new(name).map_err(ice("node name"))?;
    // The node-id segment private from its first instant (iceoryx2 would
    // make it 0666): guard's module doc.
    crate::guard::prepare()?;
    let node = crate::guard::bounded("making an iceoryx2 node", || {
        NodeBuilder::new()
            .name(&name)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
    })
    .map_err(|e| match crate::guard::closed_to_this_user() {
        Some(why) => IpcError::Foreign(format!("making an iceoryx2 node ({e:?}): {why}")),
        None => ice("node")(e),
    })?;
    Ok(node)
}

/// The daemon's state side: publishes snapshots and wakes the listeners.
/// Lives on the daemon's state thread (its ports are not `Send`).
pub struct StatePublisher {
    _node: Node<ipc::Service>,
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, StateSnapshot, ()>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    _state: StateService,
    _ready: EventFactory<ipc::Service>,
}

impl StatePublisher {
    /// Creates the `state` and `state-ready` services under `prefix` (or
    /// takes over those a dead daemon left) and the state ports.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        let node = new_node("anguilla-daemon-state")?;
        // Dead nodes' resources (a crashed daemon's) go first.
        let _ = scan_nodes();
        let state = state_service(&node, prefix, Role::Daemon)?;
        let ready = event_service(&node, prefix, "state-ready", Role::Daemon)?;
        let publisher = state
            .publisher_builder()
            .create()
            .map_err(ice("state publisher"))?;
        let notifier = ready
            .notifier_builder()
            .create()
            .map_err(ice("state-ready notifier"))?;
        Ok(Self {
            _node: node,
            publisher,
            notifier,
            _state: state,
            _ready: ready,
        })
    }

    /// Publishes one snapshot and wakes the listeners. Allocates (iceoryx2
    /// 0.10 creates an `Arc` per loaned sample).
    pub fn publish(&self, snapshot: &StateSnapshot) -> Result<(), IpcError> {
        let sample = self
            .publisher
            .loan_uninit()
            .map_err(ice("loan state sample"))?;
        let sample = sample.write_payload(*snapshot);
        sample.send().map_err(ice("send state"))?;
        self.notifier.notify().map_err(ice("notify"))?;
        Ok(())
    }
}

/// A request taken from a client, to be answered once with
/// [`CommandServer::reply`].
pub type ActiveRequest =
    iceoryx2::active_request::ActiveRequest<ipc::Service, CommandRequest, (), CommandReply, ()>;

/// A request as the daemon received it, with who sent it as iceoryx2 knows
/// it: the sending client port and its node. Neither is a field of the
/// request, so a client cannot claim to be another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// The unique id of the client port that sent the request.
    pub origin: u128,
    /// The unique id of that port's iceoryx2 node (0 if unknown).
    pub node: u128,
    /// The request as sent.
    pub request: CommandRequest,
}

/// The daemon's command side: waits for requests and answers them. Lives
/// on the daemon's command thread (its ports are not `Send`).
pub struct CommandServer {
    _node: Node<ipc::Service>,
    server: iceoryx2::port::server::Server<ipc::Service, CommandRequest, (), CommandReply, ()>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    command: CommandService,
    _ready: EventFactory<ipc::Service>,
    /// Origin → node of the clients seen (refreshed when one is unknown).
    nodes: Vec<(u128, u128)>,
}

impl CommandServer {
    /// Creates the `command` and `command-ready` services under `prefix`
    /// (or takes over those a dead daemon left) and the command ports.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        let node = new_node("anguilla-daemon-command")?;
        let _ = scan_nodes();
        let command = command_service(&node, prefix, Role::Daemon)?;
        let ready = event_service(&node, prefix, "command-ready", Role::Daemon)?;
        let server = command
            .server_builder()
            .create()
            .map_err(ice("command server"))?;
        let listener = ready
            .listener_builder()
            .create()
            .map_err(ice("command-ready listener"))?;
        Ok(Self {
            _node: node,
            server,
            listener,
            command,
            _ready: ready,
            nodes: Vec::with_capacity(MAX_TOOLS),
        })
    }

    /// Blocks until a client announces a request on `command-ready`, or
    /// `timeout` passes (requests from clients that do not announce them
    /// are still taken by the next [`CommandServer::take`]). However many
    /// notifications arrived, one call consumes them all. Returns whether
    /// any had arrived (`false`: the timeout passed).
    pub fn wait(&self, timeout: Duration) -> Result<bool, IpcError> {
        let mut notified = false;
        self.listener
            .timed_wait(|_| notified = true, timeout)
            .map_err(ice("wait for commands"))?;
        Ok(notified)
    }

    /// The oldest request not yet taken, if any, with who sent it.
    pub fn take(&mut self) -> Result<Option<(Envelope, ActiveRequest)>, IpcError> {
        let Some(active) = self.server.receive().map_err(ice("receive command"))? else {
            return Ok(None);
        };
        let origin = active.origin().value();
        let node = self.node_of(origin);
        let env = Envelope {
            origin,
            node,
            request: *active.payload(),
        };
        Ok(Some((env, active)))
    }

    fn node_of(&mut self, origin: u128) -> u128 {
        if let Some(&(_, n)) = self.nodes.iter().find(|(o, _)| *o == origin) {
            return n;
        }
        self.nodes.clear();
        let nodes = &mut self.nodes;
        self.command.dynamic_config().list_clients(|d| {
            nodes.push((d.client_id.value(), d.node_id.value()));
            CallbackProgression::Continue
        });
        self.nodes
            .iter()
            .find(|(o, _)| *o == origin)
            .map_or(0, |&(_, n)| n)
    }

    /// Answers `request`. A client that left before its reply is not an
    /// error.
    pub fn reply(request: ActiveRequest, reply: CommandReply) {
        let _ = request.send_copy(reply);
    }

    /// Takes every pending request, in arrival order, and answers each with
    /// what `handle` returns. Returns how many were answered.
    pub fn serve(
        &mut self,
        mut handle: impl FnMut(&Envelope) -> CommandReply,
    ) -> Result<usize, IpcError> {
        let mut n = 0;
        while let Some((env, active)) = self.take()? {
            let reply = handle(&env);
            Self::reply(active, reply);
            n += 1;
        }
        Ok(n)
    }
}

/// Who owns the command service's client port `client_id`, for operators:
/// the tool (its node's name without the `anguilla-` and the numbers),
/// its process's user and its pid, e.g. `ctl (user alice, pid 4242)`.
/// `None` when the port or its node is gone. Allocates and scans the node
/// registry: for tools, never the control period.
pub(crate) fn describe_client(command: &CommandService, client_id: u128) -> Option<String> {
    let mut node = None;
    command.dynamic_config().list_clients(|d| {
        if d.client_id.value() == client_id {
            node = Some(d.node_id.value());
            CallbackProgression::Stop
        } else {
            CallbackProgression::Continue
        }
    });
    let node = node?;
    let mut found = None;
    Node::<ipc::Service>::list(crate::guard::config(), |state| {
        if let NodeState::Alive(view) = &state
            && view.id().value() == node
        {
            found = view
                .details()
                .as_ref()
                .map(|d| (d.name().to_string(), d.process_id().value()));
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    })
    .ok()?;
    let (name, pid) = found?;
    Some(format!(
        "{} (user {}, pid {pid})",
        tool_of(&name),
        user_of(pid).unwrap_or_else(|| "?".into())
    ))
}

/// The tool a node name stands for: `anguilla-ctl-4242` → `ctl`,
/// `anguilla-link-17-3` → `link`.
pub(crate) fn tool_of(node_name: &str) -> String {
    let mut parts: Vec<&str> = node_name.split('-').collect();
    while parts.len() > 1
        && parts
            .last()
            .is_some_and(|p| p.chars().all(|c| c.is_ascii_digit()))
    {
        parts.pop();
    }
    if parts.len() > 1 && parts[0] == "anguilla" {
        parts.remove(0);
    }
    parts.join("-")
}

/// The name of the user running `pid` (its real uid, from /proc), or the
/// uid when /etc/passwd does not name it.
fn user_of(pid: i32) -> Option<String> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let uid = status
        .lines()
        .find_map(|l| l.strip_prefix("Uid:"))?
        .split_whitespace()
        .next()?
        .to_string();
    let name = std::fs::read_to_string("/etc/passwd").ok().and_then(|p| {
        p.lines().find_map(|l| {
            let mut f = l.split(':');
            let name = f.next()?;
            (f.nth(1)? == uid).then(|| name.to_string())
        })
    });
    Some(name.unwrap_or(format!("uid {uid}")))
}

/// One scan of iceoryx2's node registry: the ids of the nodes that exist
/// (alive, or not ours to judge), and of those whose process died (their
/// resources are cleaned up here). `None` when the registry could not be
/// read. Allocates: run it on a helper thread, never in the control period.
pub fn scan_nodes() -> Option<(Vec<u128>, Vec<u128>)> {
    set_log_level_from_env_or(LogLevel::Error);
    let (mut alive, mut dead) = (Vec::new(), Vec::new());
    Node::<ipc::Service>::list(crate::guard::config(), |state| {
        match state {
            NodeState::Alive(view) => alive.push(view.id().value()),
            NodeState::Dead(view) => {
                dead.push(view.id().value());
                let _ = view.try_remove_stale_resources();
            }
            NodeState::Inaccessible(id) | NodeState::Undefined(id) => alive.push(id.value()),
        }
        CallbackProgression::Continue
    })
    .ok()?;
    Some((alive, dead))
}

/// Watches the nodes of clients that hold control. A watched node is gone
/// when a scan sees it dead, or no longer lists it: any iceoryx2 node's
/// creation cleans up dead nodes, so another tool starting can remove a
/// dead client's traces before a scan sees it dead.
#[derive(Debug, Default)]
pub struct NodeWatch {
    watched: Vec<u128>,
}

impl NodeWatch {
    /// Starts watching `id` (idempotent).
    pub fn watch(&mut self, id: u128) {
        if !self.watched.contains(&id) {
            self.watched.push(id);
        }
    }

    /// Feeds one scan; returns the watched ids that are gone (and forgets
    /// them), each with whether its process was seen dead (`true`) or the
    /// node simply left the registry (an ended process, or a dead one that
    /// another process cleaned up first).
    pub fn update(&mut self, alive: &[u128], dead: &[u128]) -> Vec<(u128, bool)> {
        let (gone, kept): (Vec<u128>, Vec<u128>) = self
            .watched
            .iter()
            .partition(|id| dead.contains(id) || !alive.contains(id));
        self.watched = kept;
        gone.into_iter()
            .map(|id| (id, dead.contains(&id)))
            .collect()
    }
}
