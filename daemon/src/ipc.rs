//! The operator interface on iceoryx2: state, commands and wake-ups.
//!
//! Four services, named under a prefix (`anguilla` by default, so several
//! daemons can share a machine):
//!
//! | service | pattern | payload | who |
//! |---|---|---|---|
//! | `<prefix>/state` | publish-subscribe, history 1 | [`StateSnapshot`] | daemon publishes every period |
//! | `<prefix>/state-ready` | event | — | daemon notifies after each publication |
//! | `<prefix>/command` | request-response | [`CommandRequest`] → [`CommandReply`] | tools send, daemon replies to each |
//! | `<prefix>/command-ready` | event | — | tools notify after sending a request |
//!
//! The daemon's two sides are separate so that each can live on its own
//! helper thread, never on the control loop's (iceoryx2 allocates when it
//! loans a sample or answers a request): [`StatePublisher`] and
//! [`CommandServer`]. A tool uses one [`Client`].
//!
//! Every payload is `#[repr(C)]`, `Copy` and [`ZeroCopySend`], made of fixed
//! size integers, floats and arrays, so C, C++ and Python iceoryx2 clients can
//! read it with the layout documented in `docs/ipc.md` (generated from
//! [`layout_table`] and checked by a test).

use core::fmt::{self, Write as _};
use core::time::Duration;

use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{
    event::PortFactory as EventFactory, publish_subscribe::PortFactory as PubSubFactory,
    request_response::PortFactory as ReqResFactory,
};

use crate::supervisor::{Command, SwimParams};

/// Most joints a snapshot carries.
pub const MAX_JOINTS: usize = 32;
/// Version of the payload layouts; bumped on any change.
pub const LAYOUT_VERSION: u32 = 2;
/// Bytes of reason text in a [`CommandReply`].
pub const REASON_LEN: usize = 120;

/// One joint in a [`StateSnapshot`]: angles (rad), velocities (rad/s) and
/// torques (N·m) of its pitch and yaw axes.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::JointSnapshot")]
pub struct JointSnapshot {
    /// Commanded pitch angle (rad).
    pub commanded_pitch: f32,
    /// Commanded yaw angle (rad).
    pub commanded_yaw: f32,
    /// Measured pitch angle (rad).
    pub measured_pitch: f32,
    /// Measured yaw angle (rad).
    pub measured_yaw: f32,
    /// Commanded pitch velocity (rad/s).
    pub commanded_pitch_velocity: f32,
    /// Commanded yaw velocity (rad/s).
    pub commanded_yaw_velocity: f32,
    /// Measured pitch velocity (rad/s).
    pub measured_pitch_velocity: f32,
    /// Measured yaw velocity (rad/s).
    pub measured_yaw_velocity: f32,
    /// The model's predicted pitch torque, sent as feedforward (N·m).
    pub predicted_pitch_torque: f32,
    /// The model's predicted yaw torque, sent as feedforward (N·m).
    pub predicted_yaw_torque: f32,
    /// Measured pitch torque (N·m).
    pub measured_pitch_torque: f32,
    /// Measured yaw torque (N·m).
    pub measured_yaw_torque: f32,
    /// The node's state as it last reported it (protocol encoding).
    pub node_state: u8,
    /// 1 if the node's heartbeat is current, 0 if it is overdue.
    pub node_alive: u8,
    /// Padding, always 0.
    pub reserved: [u8; 2],
    /// The node's error bits as it last reported them (protocol encoding).
    pub node_errors: u32,
}

/// Gait parameters in a [`StateSnapshot`].
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::GaitSnapshot")]
pub struct GaitSnapshot {
    /// Amplitude, fraction of the configured maximum (0..=1).
    pub amplitude: f32,
    /// Frequency (Hz).
    pub frequency: f32,
    /// Yaw turn curvature K_c3 (1/m).
    pub turn: f32,
    /// Pitch curvature K_c2 (1/m).
    pub pitch: f32,
}

impl From<SwimParams> for GaitSnapshot {
    fn from(p: SwimParams) -> Self {
        Self {
            amplitude: p.amplitude as f32,
            frequency: p.frequency as f32,
            turn: p.turn as f32,
            pitch: p.pitch as f32,
        }
    }
}

/// Control-loop timing statistics over a sliding window (nanoseconds).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::LoopSnapshot")]
pub struct LoopSnapshot {
    /// The configured period.
    pub period_ns: u32,
    /// Wake-up lateness, median.
    pub jitter_p50_ns: u32,
    /// Wake-up lateness, 99th percentile.
    pub jitter_p99_ns: u32,
    /// Wake-up lateness, maximum.
    pub jitter_max_ns: u32,
    /// Compute time of one period, median.
    pub compute_p50_ns: u32,
    /// Compute time of one period, 99th percentile.
    pub compute_p99_ns: u32,
    /// Compute time of one period, maximum.
    pub compute_max_ns: u32,
    /// Padding, always 0.
    pub reserved: u32,
    /// Periods run since start.
    pub periods: u64,
    /// Periods that started late by more than a whole period (skipped, never caught up).
    pub overruns: u64,
}

/// Bus statistics since start.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::BusSnapshot")]
pub struct BusSnapshot {
    /// Frames sent.
    pub tx_frames: u64,
    /// Frames received.
    pub rx_frames: u64,
    /// Frames the driver could not send (queue full, bus-off).
    pub tx_dropped: u64,
    /// Frames received that did not decode (unknown id, bad length, bad value).
    pub malformed: u64,
    /// Bus error events reported by the driver.
    pub errors: u64,
    /// Frames lost on reception because a receive queue was full (the CAN
    /// controller's, or the kernel's socket buffer on SocketCAN).
    pub rx_overruns: u64,
    /// Times the bus went bus-off.
    pub bus_off_count: u32,
    /// 0 error-active, 1 error-passive, 2 bus-off.
    pub state: u8,
    /// Padding, always 0.
    pub reserved: [u8; 3],
}

/// Everything an operator tool shows, published every control period.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::StateSnapshot")]
pub struct StateSnapshot {
    /// [`LAYOUT_VERSION`] of the publisher.
    pub layout_version: u32,
    /// Joints in use (the first `joint_count` entries of `joints`).
    pub joint_count: u32,
    /// Increments with every publication.
    pub sequence: u64,
    /// The loop's clock at publication (ns).
    pub time_ns: u64,
    /// Operating mode (see the supervisor's `Mode`: 0 idle, 1 enabling,
    /// 2 ready, 3 swimming, 4 stopping, 5 fault, 6 e-stop).
    pub mode: u8,
    /// Why the mode last changed (0 none, 1 command, 2 operator silent,
    /// 3 fault, 4 progress).
    pub cause: u8,
    /// 1 while the torque feedforward is dropped (model diverged).
    pub feedforward_dropped: u8,
    /// Padding, always 0.
    pub reserved: u8,
    /// Latched faults, one bit per kind (supervisor's `FaultKind`).
    pub fault_kinds: u32,
    /// Nodes involved in the faults (bit = node id).
    pub fault_nodes: u64,
    /// Client holding control, 0 if none.
    pub holder: u64,
    /// The model's predicted forward speed of the head (m/s).
    pub predicted_head_speed: f32,
    /// The model's predicted turn rate of the head (rad/s, positive left).
    pub predicted_turn_rate: f32,
    /// The gait the operator asked for.
    pub gait_target: GaitSnapshot,
    /// The gait being executed (the target, shaped by trapezoidal profiles).
    pub gait_actual: GaitSnapshot,
    /// Loop timing.
    pub loop_stats: LoopSnapshot,
    /// Bus statistics.
    pub bus: BusSnapshot,
    /// Setpoints clamped to joint limits since start.
    pub clamped_setpoints: u64,
    /// Commands refused since start.
    pub refused_commands: u64,
    /// Swims stopped because the holder went silent.
    pub operator_silent_stops: u64,
    /// Per joint, from the head (index 0) to the tail.
    pub joints: [JointSnapshot; MAX_JOINTS],
}

impl Default for StateSnapshot {
    fn default() -> Self {
        Self {
            layout_version: LAYOUT_VERSION,
            joint_count: 0,
            sequence: 0,
            time_ns: 0,
            mode: 0,
            cause: 0,
            feedforward_dropped: 0,
            reserved: 0,
            fault_kinds: 0,
            fault_nodes: 0,
            holder: 0,
            predicted_head_speed: 0.0,
            predicted_turn_rate: 0.0,
            gait_target: GaitSnapshot::default(),
            gait_actual: GaitSnapshot::default(),
            loop_stats: LoopSnapshot::default(),
            bus: BusSnapshot::default(),
            clamped_setpoints: 0,
            refused_commands: 0,
            operator_silent_stops: 0,
            joints: [JointSnapshot::default(); MAX_JOINTS],
        }
    }
}

/// Command codes of [`CommandRequest::code`].
pub mod code {
    /// Enable the actuators.
    pub const ENABLE: u32 = 1;
    /// Disable the actuators.
    pub const DISABLE: u32 = 2;
    /// Swim with the request's gait fields.
    pub const SWIM: u32 = 3;
    /// Stop swimming smoothly.
    pub const STOP: u32 = 4;
    /// Emergency stop (accepted from any client).
    pub const ESTOP: u32 = 5;
    /// Clear a fault or an E-stop.
    pub const RESET: u32 = 6;
    /// Take control authority.
    pub const TAKE_CONTROL: u32 = 7;
    /// Release control authority.
    pub const RELEASE_CONTROL: u32 = 8;
    /// Keep control and the swim alive.
    pub const KEEP_ALIVE: u32 = 9;
}

/// A command from an operator tool.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::CommandRequest")]
pub struct CommandRequest {
    /// [`LAYOUT_VERSION`] of the sender.
    pub layout_version: u32,
    /// One of the [`code`] constants.
    pub code: u32,
    /// The sender's identity (any non-zero number, stable for its session).
    pub client_id: u64,
    /// The sender's iceoryx2 node id, low 64 bits (lets the daemon release
    /// control when that node dies).
    pub node_id_lo: u64,
    /// The sender's iceoryx2 node id, high 64 bits.
    pub node_id_hi: u64,
    /// Increases with every command from this client.
    pub sequence: u32,
    /// Swim amplitude, fraction of the maximum (0..=1), for SWIM.
    pub amplitude: f32,
    /// Swim frequency (Hz), for SWIM.
    pub frequency: f32,
    /// Yaw turn curvature (1/m), for SWIM.
    pub turn: f32,
    /// Pitch curvature (1/m), for SWIM.
    pub pitch: f32,
    /// Padding, always 0.
    pub reserved: u32,
}

impl CommandRequest {
    /// A request for `cmd` from `client_id` with sequence number `sequence`.
    pub fn new(cmd: Command, client_id: u64, node_id: u128, sequence: u32) -> Self {
        let (code, p) = match cmd {
            Command::Enable => (code::ENABLE, SwimParams::REST),
            Command::Disable => (code::DISABLE, SwimParams::REST),
            Command::Swim(p) => (code::SWIM, p),
            Command::Stop => (code::STOP, SwimParams::REST),
            Command::EStop => (code::ESTOP, SwimParams::REST),
            Command::Reset => (code::RESET, SwimParams::REST),
            Command::TakeControl => (code::TAKE_CONTROL, SwimParams::REST),
            Command::ReleaseControl => (code::RELEASE_CONTROL, SwimParams::REST),
            Command::KeepAlive => (code::KEEP_ALIVE, SwimParams::REST),
        };
        Self {
            layout_version: LAYOUT_VERSION,
            code,
            client_id,
            node_id_lo: node_id as u64,
            node_id_hi: (node_id >> 64) as u64,
            sequence,
            amplitude: p.amplitude as f32,
            frequency: p.frequency as f32,
            turn: p.turn as f32,
            pitch: p.pitch as f32,
            reserved: 0,
        }
    }

    /// The sender's node id.
    pub fn node_id(&self) -> u128 {
        (self.node_id_hi as u128) << 64 | self.node_id_lo as u128
    }

    /// The command, or why the request cannot be read.
    pub fn command(&self) -> Result<Command, RequestError> {
        if self.layout_version != LAYOUT_VERSION {
            return Err(RequestError::Version(self.layout_version));
        }
        if self.client_id == 0 {
            return Err(RequestError::NoClientId);
        }
        Ok(match self.code {
            code::ENABLE => Command::Enable,
            code::DISABLE => Command::Disable,
            code::SWIM => Command::Swim(SwimParams {
                amplitude: self.amplitude as f64,
                frequency: self.frequency as f64,
                turn: self.turn as f64,
                pitch: self.pitch as f64,
            }),
            code::STOP => Command::Stop,
            code::ESTOP => Command::EStop,
            code::RESET => Command::Reset,
            code::TAKE_CONTROL => Command::TakeControl,
            code::RELEASE_CONTROL => Command::ReleaseControl,
            code::KEEP_ALIVE => Command::KeepAlive,
            other => return Err(RequestError::UnknownCode(other)),
        })
    }
}

/// Why a [`CommandRequest`] could not be read at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// The sender uses another layout version.
    #[error("layout version {0} is not the daemon's ({LAYOUT_VERSION}); update the tool")]
    Version(u32),
    /// The client id was 0.
    #[error("client id 0 is reserved (expected any non-zero number)")]
    NoClientId,
    /// The command code is not one of [`code`].
    #[error("unknown command code {0} (expected 1..=9)")]
    UnknownCode(u32),
}

/// The daemon's answer to one [`CommandRequest`].
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("anguilla::CommandReply")]
pub struct CommandReply {
    /// The request's client id.
    pub client_id: u64,
    /// The request's sequence number.
    pub sequence: u32,
    /// 1 accepted, 0 refused.
    pub accepted: u8,
    /// The mode after handling the command (as in [`StateSnapshot::mode`]).
    pub mode: u8,
    /// Bytes of `reason` in use.
    pub reason_len: u16,
    /// Why it was refused: UTF-8, `reason_len` bytes, zero padded.
    pub reason: [u8; REASON_LEN],
}

impl CommandReply {
    /// An acceptance.
    pub fn accepted(req: &CommandRequest, mode: u8) -> Self {
        Self {
            client_id: req.client_id,
            sequence: req.sequence,
            accepted: 1,
            mode,
            reason_len: 0,
            reason: [0; REASON_LEN],
        }
    }

    /// A refusal whose reason is `why`'s `Display` (cut to [`REASON_LEN`]
    /// bytes on a character boundary). Allocates nothing.
    pub fn refused(req: &CommandRequest, mode: u8, why: &dyn fmt::Display) -> Self {
        let mut w = FixedText::default();
        let _ = write!(w, "{why}");
        Self {
            client_id: req.client_id,
            sequence: req.sequence,
            accepted: 0,
            mode,
            reason_len: w.len as u16,
            reason: w.buf,
        }
    }

    /// The reason text ("" when accepted).
    pub fn reason(&self) -> &str {
        let n = (self.reason_len as usize).min(REASON_LEN);
        core::str::from_utf8(&self.reason[..n]).unwrap_or("(reason is not UTF-8)")
    }
}

#[derive(Debug)]
struct FixedText {
    buf: [u8; REASON_LEN],
    len: usize,
}

impl Default for FixedText {
    fn default() -> Self {
        Self {
            buf: [0; REASON_LEN],
            len: 0,
        }
    }
}

impl fmt::Write for FixedText {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for ch in s.chars() {
            let mut tmp = [0u8; 4];
            let enc = ch.encode_utf8(&mut tmp).as_bytes();
            if self.len + enc.len() > REASON_LEN {
                return Err(fmt::Error);
            }
            self.buf[self.len..self.len + enc.len()].copy_from_slice(enc);
            self.len += enc.len();
        }
        Ok(())
    }
}

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

fn ice<E: fmt::Debug>(what: &'static str) -> impl Fn(E) -> IpcError {
    move |e| IpcError::Iceoryx(format!("{what}: {e:?}"))
}

fn service_name(prefix: &str, leaf: &str) -> Result<ServiceName, IpcError> {
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

struct Services {
    state: PubSubFactory<ipc::Service, StateSnapshot, ()>,
    ready: EventFactory<ipc::Service>,
    command: ReqResFactory<ipc::Service, CommandRequest, (), CommandReply, ()>,
    command_ready: EventFactory<ipc::Service>,
}

/// Most clients (tools) at once.
const MAX_CLIENTS: usize = 32;

fn open_services(node: &Node<ipc::Service>, prefix: &str) -> Result<Services, IpcError> {
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

fn new_node(name: &str) -> Result<Node<ipc::Service>, IpcError> {
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

/// Unanswered requests a client keeps (the service allows 8 per client).
const MAX_PENDING: usize = 6;

/// A tool's side: reads state, waits for new state, sends commands.
pub struct Client {
    node: Node<ipc::Service>,
    subscriber: iceoryx2::port::subscriber::Subscriber<ipc::Service, StateSnapshot, ()>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    client: iceoryx2::port::client::Client<ipc::Service, CommandRequest, (), CommandReply, ()>,
    command_ready: iceoryx2::port::notifier::Notifier<ipc::Service>,
    pending: Vec<
        iceoryx2::pending_response::PendingResponse<
            ipc::Service,
            CommandRequest,
            (),
            CommandReply,
            (),
        >,
    >,
    client_id: u64,
    sequence: u32,
}

impl Client {
    /// Connects to the daemon's services under `prefix` as `client_id`
    /// (non-zero), naming the iceoryx2 node `name`.
    pub fn new(prefix: &str, name: &str, client_id: u64) -> Result<Self, IpcError> {
        let node = new_node(name)?;
        let services = open_services(&node, prefix)?;
        let subscriber = services
            .state
            .subscriber_builder()
            .create()
            .map_err(ice("state subscriber"))?;
        let listener = services
            .ready
            .listener_builder()
            .create()
            .map_err(ice("state-ready listener"))?;
        let client = services
            .command
            .client_builder()
            .create()
            .map_err(ice("command client"))?;
        let command_ready = services
            .command_ready
            .notifier_builder()
            .create()
            .map_err(ice("command-ready notifier"))?;
        Ok(Self {
            node,
            subscriber,
            listener,
            client,
            command_ready,
            pending: Vec::new(),
            client_id,
            // Sequence numbers start from the wall clock so a restarted tool
            // with the same id is not taken for a replay of old commands.
            sequence: (std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_millis() as u64)
                .unwrap_or(0)
                & 0x3FFF_FFFF) as u32,
        })
    }

    /// This client's id.
    pub fn id(&self) -> u64 {
        self.client_id
    }

    /// Sends `cmd`; its reply arrives through [`Client::replies`].
    /// Returns the sequence number used.
    pub fn send(&mut self, cmd: Command) -> Result<u32, IpcError> {
        // A slow daemon must not exhaust the service's active requests: the
        // oldest unanswered request is given up (its reply is not awaited).
        if self.pending.len() >= MAX_PENDING {
            self.pending.remove(0);
        }
        self.sequence = self.sequence.wrapping_add(1);
        let req = CommandRequest::new(cmd, self.client_id, self.node.id().value(), self.sequence);
        let pending = self.client.send_copy(req).map_err(ice("send command"))?;
        self.pending.push(pending);
        // Wake the daemon's command thread at once; without this it would
        // take the request at its next poll.
        self.command_ready
            .notify()
            .map_err(ice("notify command-ready"))?;
        Ok(self.sequence)
    }

    /// Collects the replies that have arrived.
    pub fn replies(&mut self, mut f: impl FnMut(&CommandReply)) -> Result<(), IpcError> {
        let mut i = 0;
        while i < self.pending.len() {
            let mut got = false;
            while let Some(r) = self.pending[i].receive().map_err(ice("receive reply"))? {
                f(r.payload());
                got = true;
            }
            if got {
                self.pending.swap_remove(i);
            } else {
                i += 1;
            }
        }
        Ok(())
    }

    /// Replies still awaited.
    pub fn awaiting(&self) -> usize {
        self.pending.len()
    }

    /// Sends `cmd` and waits up to `timeout` for its reply.
    pub fn request(&mut self, cmd: Command, timeout: Duration) -> Result<CommandReply, IpcError> {
        let seq = self.send(cmd)?;
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let mut found = None;
            self.replies(|r| {
                if r.sequence == seq {
                    found = Some(*r);
                }
            })?;
            if let Some(r) = found {
                return Ok(r);
            }
            if std::time::Instant::now() >= deadline {
                return Err(IpcError::Iceoryx(format!(
                    "no reply to '{}' within {timeout:?}: is the daemon running?",
                    cmd.name()
                )));
            }
            let _ = self
                .listener
                .timed_wait(|_| {}, Duration::from_millis(2).min(timeout));
        }
    }

    /// The newest state, if any was published since the last call (or the
    /// history on first call).
    pub fn latest(&self) -> Result<Option<StateSnapshot>, IpcError> {
        let mut last = None;
        while let Some(s) = self.subscriber.receive().map_err(ice("receive state"))? {
            last = Some(*s.payload());
        }
        Ok(last)
    }

    /// Waits up to `timeout` for the daemon to announce new state, then
    /// returns the newest one (`None` on timeout).
    pub fn wait_state(&self, timeout: Duration) -> Result<Option<StateSnapshot>, IpcError> {
        if let Some(s) = self.latest()? {
            return Ok(Some(s));
        }
        self.listener
            .timed_wait(|_| {}, timeout)
            .map_err(ice("wait for state"))?;
        self.latest()
    }
}

/// One row of the documented payload layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LayoutRow {
    /// Payload type.
    pub ty: &'static str,
    /// Field name.
    pub field: &'static str,
    /// Byte offset within the type.
    pub offset: usize,
    /// Size in bytes.
    pub size: usize,
    /// C type.
    pub c_type: &'static str,
}

macro_rules! rows {
    ($ty:ty, $name:literal, [$( $f:ident : $c:literal ),* $(,)?]) => {
        [$( LayoutRow {
            ty: $name,
            field: stringify!($f),
            offset: core::mem::offset_of!($ty, $f),
            size: {
                fn size_of_field<T, F>(_: impl Fn(&T) -> &F) -> usize { core::mem::size_of::<F>() }
                size_of_field(|s: &$ty| &s.$f)
            },
            c_type: $c,
        } ),*]
    };
}

/// The layout of every payload, field by field, from the compiler's own
/// offsets: the source of `docs/ipc.md`'s tables.
pub fn layout_table() -> Vec<LayoutRow> {
    let mut v = Vec::new();
    v.extend(rows!(StateSnapshot, "StateSnapshot", [
        layout_version: "uint32_t", joint_count: "uint32_t", sequence: "uint64_t",
        time_ns: "uint64_t", mode: "uint8_t", cause: "uint8_t", feedforward_dropped: "uint8_t",
        reserved: "uint8_t", fault_kinds: "uint32_t", fault_nodes: "uint64_t", holder: "uint64_t",
        predicted_head_speed: "float", predicted_turn_rate: "float",
        gait_target: "GaitSnapshot", gait_actual: "GaitSnapshot", loop_stats: "LoopSnapshot",
        bus: "BusSnapshot", clamped_setpoints: "uint64_t", refused_commands: "uint64_t",
        operator_silent_stops: "uint64_t", joints: "JointSnapshot[32]",
    ]));
    v.extend(rows!(JointSnapshot, "JointSnapshot", [
        commanded_pitch: "float", commanded_yaw: "float", measured_pitch: "float",
        measured_yaw: "float", commanded_pitch_velocity: "float", commanded_yaw_velocity: "float",
        measured_pitch_velocity: "float", measured_yaw_velocity: "float",
        predicted_pitch_torque: "float", predicted_yaw_torque: "float",
        measured_pitch_torque: "float", measured_yaw_torque: "float", node_state: "uint8_t",
        node_alive: "uint8_t", reserved: "uint8_t[2]", node_errors: "uint32_t",
    ]));
    v.extend(rows!(GaitSnapshot, "GaitSnapshot", [
        amplitude: "float", frequency: "float", turn: "float", pitch: "float",
    ]));
    v.extend(rows!(LoopSnapshot, "LoopSnapshot", [
        period_ns: "uint32_t", jitter_p50_ns: "uint32_t", jitter_p99_ns: "uint32_t",
        jitter_max_ns: "uint32_t", compute_p50_ns: "uint32_t", compute_p99_ns: "uint32_t",
        compute_max_ns: "uint32_t", reserved: "uint32_t", periods: "uint64_t", overruns: "uint64_t",
    ]));
    v.extend(rows!(BusSnapshot, "BusSnapshot", [
        tx_frames: "uint64_t", rx_frames: "uint64_t", tx_dropped: "uint64_t",
        malformed: "uint64_t", errors: "uint64_t", rx_overruns: "uint64_t",
        bus_off_count: "uint32_t", state: "uint8_t",
        reserved: "uint8_t[3]",
    ]));
    v.extend(rows!(CommandRequest, "CommandRequest", [
        layout_version: "uint32_t", code: "uint32_t", client_id: "uint64_t",
        node_id_lo: "uint64_t", node_id_hi: "uint64_t", sequence: "uint32_t", amplitude: "float",
        frequency: "float", turn: "float", pitch: "float", reserved: "uint32_t",
    ]));
    v.extend(rows!(CommandReply, "CommandReply", [
        client_id: "uint64_t", sequence: "uint32_t", accepted: "uint8_t", mode: "uint8_t",
        reason_len: "uint16_t", reason: "char[120]",
    ]));
    v
}

/// Renders [`layout_table`] as Markdown tables with each type's size.
pub fn layout_markdown() -> String {
    let sizes = [
        ("StateSnapshot", core::mem::size_of::<StateSnapshot>()),
        ("JointSnapshot", core::mem::size_of::<JointSnapshot>()),
        ("GaitSnapshot", core::mem::size_of::<GaitSnapshot>()),
        ("LoopSnapshot", core::mem::size_of::<LoopSnapshot>()),
        ("BusSnapshot", core::mem::size_of::<BusSnapshot>()),
        ("CommandRequest", core::mem::size_of::<CommandRequest>()),
        ("CommandReply", core::mem::size_of::<CommandReply>()),
    ];
    let rows = layout_table();
    let mut out = String::new();
    for (ty, size) in sizes {
        let _ = writeln!(out, "### `{ty}` ({size} bytes)\n");
        let _ = writeln!(out, "| offset | size | C type | field |");
        let _ = writeln!(out, "|---:|---:|---|---|");
        for r in rows.iter().filter(|r| r.ty == ty) {
            let _ = writeln!(
                out,
                "| {} | {} | `{}` | `{}` |",
                r.offset, r.size, r.c_type, r.field
            );
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::{Mode, Refusal};

    #[test]
    fn requests_roundtrip_and_bad_ones_are_named() {
        let p = SwimParams {
            amplitude: 0.5,
            frequency: 1.25,
            turn: -0.5,
            pitch: 0.25,
        };
        let r = CommandRequest::new(Command::Swim(p), 7, 1 << 100 | 5, 3);
        assert_eq!(r.command(), Ok(Command::Swim(p)));
        assert_eq!(r.node_id(), 1 << 100 | 5);
        let mut bad = r;
        bad.code = 42;
        assert_eq!(
            bad.command().unwrap_err().to_string(),
            "unknown command code 42 (expected 1..=9)"
        );
        bad = r;
        bad.client_id = 0;
        assert_eq!(bad.command(), Err(RequestError::NoClientId));
        bad = r;
        bad.layout_version = 99;
        assert!(matches!(bad.command(), Err(RequestError::Version(99))));
    }

    #[test]
    fn node_watch_reports_dead_and_vanished_nodes_once() {
        let mut w = NodeWatch::default();
        w.watch(2);
        w.watch(9);
        w.watch(2);
        assert!(w.update(&[1, 2, 3, 9], &[]).is_empty());
        // 2 vanished (cleaned up by someone else), 9 seen dead; 5 is not watched.
        let mut gone = w.update(&[1, 3], &[9, 5]);
        gone.sort_unstable();
        assert_eq!(gone, vec![2, 9]);
        assert!(w.update(&[1, 3], &[]).is_empty(), "reported once");
    }

    #[test]
    fn reply_reason_is_cut_on_a_character_boundary() {
        let req = CommandRequest::new(Command::Stop, 1, 0, 1);
        let long = "é".repeat(100); // 200 bytes
        let r = CommandReply::refused(&req, Mode::Idle as u8, &long);
        assert_eq!(r.reason().len(), 120);
        assert!(r.reason().chars().all(|c| c == 'é'));
        let ok = CommandReply::accepted(&req, 2);
        assert_eq!(ok.reason(), "");
        let why = Refusal::NotInControl;
        assert_eq!(
            CommandReply::refused(&req, 0, &why).reason(),
            "take control first"
        );
    }

    #[test]
    fn layout_table_covers_every_byte() {
        // Fields of each type tile it exactly: no hidden padding a C client
        // would have to guess.
        let rows = layout_table();
        for (ty, size) in [
            ("StateSnapshot", core::mem::size_of::<StateSnapshot>()),
            ("JointSnapshot", core::mem::size_of::<JointSnapshot>()),
            ("LoopSnapshot", core::mem::size_of::<LoopSnapshot>()),
            ("BusSnapshot", core::mem::size_of::<BusSnapshot>()),
            ("CommandRequest", core::mem::size_of::<CommandRequest>()),
            ("CommandReply", core::mem::size_of::<CommandReply>()),
        ] {
            let mut end = 0;
            for r in rows.iter().filter(|r| r.ty == ty) {
                assert_eq!(r.offset, end, "{ty}.{} leaves a gap", r.field);
                end = r.offset + r.size;
            }
            assert_eq!(end, size, "{ty} has trailing padding");
        }
    }

    #[test]
    fn docs_match_the_generated_layout() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/ipc.md");
        let doc = std::fs::read_to_string(path).unwrap();
        let (begin, end) = ("<!-- layout:begin -->\n", "<!-- layout:end -->");
        let (head, rest) = doc.split_once(begin).expect("layout:begin marker");
        let (current, tail) = rest.split_once(end).expect("layout:end marker");
        let generated = layout_markdown();
        if std::env::var_os("ANGUILLA_BLESS").is_some() {
            std::fs::write(path, format!("{head}{begin}{generated}{end}{tail}")).unwrap();
            return;
        }
        assert_eq!(
            current, generated,
            "docs/ipc.md is out of date: rerun this test with ANGUILLA_BLESS=1"
        );
    }

    /// A unique prefix per test so parallel tests do not share services.
    fn prefix(tag: &str) -> String {
        format!("anguilla-test/{tag}-{}", std::process::id())
    }

    #[test]
    fn server_and_client_talk() {
        let p = prefix("talk");
        // iceoryx2's ipc ports are not Send: the server lives on its thread.
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let stop = std::sync::atomic::AtomicBool::new(false);
        std::thread::scope(|s| {
            s.spawn(|| {
                let server = StatePublisher::new(&p).unwrap();
                let commands = CommandServer::new(&p).unwrap();
                let mut snap = StateSnapshot {
                    sequence: 9,
                    joint_count: 12,
                    ..Default::default()
                };
                snap.joints[3].measured_yaw = 0.25;
                server.publish(&snap).unwrap();
                ready_tx.send(snap).unwrap();
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    // Like the daemon: publish every period.
                    server.publish(&snap).unwrap();
                    let _ = commands.wait(Duration::from_millis(1));
                    commands
                        .serve(|req| match req.command() {
                            Ok(Command::TakeControl) => CommandReply::accepted(req, 0),
                            Ok(other) => CommandReply::refused(req, 0, &other.name()),
                            Err(e) => CommandReply::refused(req, 0, &e),
                        })
                        .unwrap();
                    std::thread::yield_now();
                }
            });
            // Stop the server however this thread ends (a failed assert
            // included), or the scope would wait for it forever.
            struct StopOnDrop<'a>(&'a std::sync::atomic::AtomicBool);
            impl Drop for StopOnDrop<'_> {
                fn drop(&mut self) {
                    self.0.store(true, std::sync::atomic::Ordering::Relaxed);
                }
            }
            let _guard = StopOnDrop(&stop);
            let snap = ready_rx
                .recv_timeout(Duration::from_secs(10))
                .expect("server up");
            let mut client = Client::new(&p, "test-client", 42).unwrap();
            let got = client
                .wait_state(Duration::from_secs(1))
                .unwrap()
                .expect("state");
            assert_eq!(got, snap);
            let r = client
                .request(Command::TakeControl, Duration::from_secs(2))
                .unwrap();
            assert_eq!(r.accepted, 1);
            assert_eq!(r.client_id, 42);
            let r = client
                .request(Command::Stop, Duration::from_secs(2))
                .unwrap();
            assert_eq!(r.accepted, 0);
            assert_eq!(r.reason(), "stop");
            assert_eq!(client.awaiting(), 0);
        });
    }
}
