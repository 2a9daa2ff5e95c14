//! The services under a prefix and the daemon's two sides of them.

use core::fmt;
use core::time::Duration;

use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{
    event::PortFactory as EventFactory, publish_subscribe::PortFactory as PubSubFactory,
    request_response::PortFactory as ReqResFactory,
};

use crate::payload::{CommandReply, CommandRequest, StateSnapshot};

/// What went wrong setting up or using the operator interface.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    /// The prefix does not make valid service names.
    #[error("IPC prefix '{0}' is not valid (expected letters, digits, '-', '_' and '/')")]
    BadPrefix(String),
    /// iceoryx2 refused an operation; the text names it.
    #[error("iceoryx2: {0}")]
    Iceoryx(String),
}

pub(crate) fn ice<E: fmt::Debug>(what: &'static str) -> impl Fn(E) -> IpcError {
    move |e| IpcError::Iceoryx(format!("{what}: {e:?}"))
}

pub(crate) fn service_name(prefix: &str, leaf: &str) -> Result<ServiceName, IpcError> {
    let ok = !prefix.is_empty()
        && prefix
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '/'));
    if !ok {
        return Err(IpcError::BadPrefix(prefix.to_string()));
    }
    let full = format!("{prefix}/{leaf}");
    ServiceName::new(&full).map_err(|_| IpcError::BadPrefix(prefix.to_string()))
}

pub(crate) struct Services {
    pub(crate) state: PubSubFactory<ipc::Service, StateSnapshot, ()>,
    pub(crate) ready: EventFactory<ipc::Service>,
    pub(crate) command: ReqResFactory<ipc::Service, CommandRequest, (), CommandReply, ()>,
    pub(crate) command_ready: EventFactory<ipc::Service>,
}

/// Most clients (tools) at once.
const MAX_CLIENTS: usize = 32;

pub(crate) fn open_services(node: &Node<ipc::Service>, prefix: &str) -> Result<Services, IpcError> {
    let state = node
        .service_builder(&service_name(prefix, "state")?)
        .publish_subscribe::<StateSnapshot>()
        .history_size(1)
        .subscriber_max_buffer_size(2)
        .enable_safe_overflow(true)
        .max_subscribers(MAX_CLIENTS)
        .max_publishers(1)
        .open_or_create()
        .map_err(ice("state service"))?;
    let ready = node
        .service_builder(&service_name(prefix, "state-ready")?)
        .event()
        .max_listeners(MAX_CLIENTS)
        .open_or_create()
        .map_err(ice("state-ready event"))?;
    let command_ready = node
        .service_builder(&service_name(prefix, "command-ready")?)
        .event()
        .max_notifiers(MAX_CLIENTS)
        .max_listeners(1)
        .open_or_create()
        .map_err(ice("command-ready event"))?;
    let command = node
        .service_builder(&service_name(prefix, "command")?)
        .request_response::<CommandRequest, CommandReply>()
        .max_clients(MAX_CLIENTS)
        .max_servers(1)
        .max_active_requests_per_client(8)
        .enable_safe_overflow_for_requests(true)
        .open_or_create()
        .map_err(ice("command service"))?;
    Ok(Services {
        state,
        ready,
        command,
        command_ready,
    })
}

pub(crate) fn new_node(name: &str) -> Result<Node<ipc::Service>, IpcError> {
    // iceoryx2 logs to stdout; keep its chatter (e.g. "no config file was
    // loaded") out of tools whose stdout is data, unless asked for.
    set_log_level_from_env_or(LogLevel::Error);
    let name = NodeName::new(name).map_err(ice("node name"))?;
    NodeBuilder::new()
        .name(&name)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(ice("node"))
}

/// The daemon's state side: publishes snapshots and wakes the listeners.
/// Lives on the daemon's state thread (its ports are not `Send`).
pub struct StatePublisher {
    _node: Node<ipc::Service>,
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, StateSnapshot, ()>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    _services: Services,
}

impl StatePublisher {
    /// Opens (or creates) the services under `prefix` and the state ports.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        let node = new_node("anguilla-daemon-state")?;
        let services = open_services(&node, prefix)?;
        let publisher = services
            .state
            .publisher_builder()
            .create()
            .map_err(ice("state publisher"))?;
        let notifier = services
            .ready
            .notifier_builder()
            .create()
            .map_err(ice("state-ready notifier"))?;
        Ok(Self {
            _node: node,
            publisher,
            notifier,
            _services: services,
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

/// The daemon's command side: waits for requests and answers them. Lives
/// on the daemon's command thread (its ports are not `Send`).
pub struct CommandServer {
    _node: Node<ipc::Service>,
    server: iceoryx2::port::server::Server<ipc::Service, CommandRequest, (), CommandReply, ()>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    _services: Services,
}

impl CommandServer {
    /// Opens (or creates) the services under `prefix` and the command ports.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        let node = new_node("anguilla-daemon-command")?;
        let services = open_services(&node, prefix)?;
        let server = services
            .command
            .server_builder()
            .create()
            .map_err(ice("command server"))?;
        let listener = services
            .command_ready
            .listener_builder()
            .create()
            .map_err(ice("command-ready listener"))?;
        Ok(Self {
            _node: node,
            server,
            listener,
            _services: services,
        })
    }

    /// Blocks until a client announces a request on `command-ready`, or
    /// `timeout` passes (requests from clients that do not announce them
    /// are still taken by the next [`CommandServer::take`]).
    pub fn wait(&self, timeout: Duration) -> Result<(), IpcError> {
        self.listener
            .timed_wait(|_| {}, timeout)
            .map_err(ice("wait for commands"))?;
        Ok(())
    }

    /// The oldest request not yet taken, if any.
    pub fn take(&self) -> Result<Option<ActiveRequest>, IpcError> {
        self.server.receive().map_err(ice("receive command"))
    }

    /// Answers `request`. A client that left before its reply is not an
    /// error.
    pub fn reply(request: ActiveRequest, reply: CommandReply) {
        let _ = request.send_copy(reply);
    }

    /// Takes every pending request, in arrival order, and answers each with
    /// what `handle` returns. Returns how many were answered.
    pub fn serve(
        &self,
        mut handle: impl FnMut(&CommandRequest) -> CommandReply,
    ) -> Result<usize, IpcError> {
        let mut n = 0;
        while let Some(active) = self.take()? {
            let reply = handle(active.payload());
            Self::reply(active, reply);
            n += 1;
        }
        Ok(n)
    }
}

/// One scan of iceoryx2's node registry: the ids of the nodes that exist
/// (alive, or not ours to judge), and of those whose process died (their
/// resources are cleaned up here). `None` when the registry could not be
/// read. Allocates: run it on a helper thread, never in the control period.
pub fn scan_nodes() -> Option<(Vec<u128>, Vec<u128>)> {
    set_log_level_from_env_or(LogLevel::Error);
    let (mut alive, mut dead) = (Vec::new(), Vec::new());
    Node::<ipc::Service>::list(Config::global_config(), |state| {
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

    /// Feeds one scan; returns the watched ids that are gone (and forgets them).
    pub fn update(&mut self, alive: &[u128], dead: &[u128]) -> Vec<u128> {
        let (gone, kept): (Vec<u128>, Vec<u128>) = self
            .watched
            .iter()
            .partition(|id| dead.contains(id) || !alive.contains(id));
        self.watched = kept;
        gone
    }
}
