//! A tool's side of the operator interface: the [`Session`] every tool
//! talks through, and its local implementation, [`Client`] (iceoryx2).
//! The remote one, over Zenoh, is `anguilla_link::RemoteClient`.

use core::time::Duration;

use iceoryx2::prelude::*;

use crate::command::{CommandReply, CommandRequest};
use crate::payload::StateSnapshot;
use crate::service::{
    CommandService, IpcError, MAX_REQUESTS_PER_CLIENT, Role, StateService, command_service,
    event_service, ice, new_node, publisher_and_server_pids, state_service,
};
use crate::vocabulary::Command;

/// Unanswered requests a client keeps (the service allows
/// [`MAX_REQUESTS_PER_CLIENT`]); the oldest is given up beyond.
const MAX_PENDING: usize = MAX_REQUESTS_PER_CLIENT - 1;

/// How long a tool that finds the daemon's services waits for its command
/// server (the daemon creates them in that order).
const SERVER_WAIT: Duration = Duration::from_secs(2);

/// A tool's side: reads state, waits for new state, sends commands.
///
/// Each `Client` is one session: its iceoryx2 client port is its identity
/// for the daemon ([`Client::id`]), so a tool that restarts is a new client
/// and holds nothing the old one held.
pub struct Client {
    _node: Node<ipc::Service>,
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
    state_service: StateService,
    command_service: CommandService,
    sequence: u32,
    prefix: String,
}

impl Client {
    /// Connects to the daemon's services under `prefix` (they must exist:
    /// a tool never creates them), naming the iceoryx2 node `name`.
    pub fn new(prefix: &str, name: &str) -> Result<Self, IpcError> {
        crate::guard::bounded("opening the daemon's services", || Self::open(prefix, name))
    }

    fn open(prefix: &str, name: &str) -> Result<Self, IpcError> {
        let node = new_node(name)?;
        let state_service = state_service(&node, prefix, Role::Tool)?;
        let ready = event_service(&node, prefix, "state-ready", Role::Tool)?;
        let command_service = command_service(&node, prefix, Role::Tool)?;
        let command_ready = event_service(&node, prefix, "command-ready", Role::Tool)?;
        let subscriber = state_service
            .subscriber_builder()
            .create()
            .map_err(ice("state subscriber"))?;
        let listener = ready
            .listener_builder()
            .create()
            .map_err(ice("state-ready listener"))?;
        let client = command_service
            .client_builder()
            .create()
            .map_err(ice("command client"))?;
        let command_ready = command_ready
            .notifier_builder()
            .create()
            .map_err(ice("command-ready notifier"))?;
        // The daemon creates its services before its command server: a
        // tool that opens in between waits for the server, briefly (a dead
        // daemon's services have none, and its requests are then refused
        // at once by `send_request`).
        let until = std::time::Instant::now() + SERVER_WAIT;
        while command_service.dynamic_config().number_of_servers() == 0
            && std::time::Instant::now() < until
        {
            std::thread::sleep(Duration::from_millis(10));
        }
        Ok(Self {
            _node: node,
            subscriber,
            listener,
            client,
            command_ready,
            pending: Vec::new(),
            state_service,
            command_service,
            sequence: 0,
            prefix: prefix.to_string(),
        })
    }

    /// This client's identity as the daemon knows it: the unique id of its
    /// iceoryx2 client port (what [`StateSnapshot::holder`] names).
    pub fn id(&self) -> u128 {
        self.client.id().value()
    }

    /// Who owns the client port `id` (e.g. the holder of control):
    /// `ctl (user alice, pid 4242)`; `None` if it is gone or unknown.
    pub fn who(&self, id: u128) -> Option<String> {
        crate::service::describe_client(&self.command_service, id)
    }

    /// When the state this client reads is not published by the process
    /// that serves its commands (a program squatting the state service, or
    /// a daemon that has gone), says so; `None` when they are one process.
    pub fn provenance_problem(&self) -> Option<String> {
        let (publishers, servers) =
            publisher_and_server_pids(&self.state_service, &self.command_service);
        match (publishers.as_slice(), servers.as_slice()) {
            ([p], [s]) if p == s => None,
            ([], _) => Some("nobody publishes the state: is the daemon running?".into()),
            (_, []) => Some("nobody serves commands: is the daemon running?".into()),
            (p, s) => Some(format!(
                "the state is published by pid {p:?} but commands are served by pid {s:?}: \
                 the state shown may not be the robot's"
            )),
        }
    }

    /// Sends `req` exactly as given, its sequence number included (for a
    /// tool that numbers its own requests, and for tests that play a
    /// careless or hostile client); its reply arrives through
    /// [`Client::replies`]. Returns the request's sequence number.
    pub fn send_request(&mut self, req: CommandRequest) -> Result<u32, IpcError> {
        if self.pending.len() >= MAX_PENDING {
            self.pending.remove(0);
        }
        let pending = self.client.send_copy(req).map_err(ice("send command"))?;
        // A request no server received would wait for ever: the daemon's
        // command server is not up (it is starting, or its services are a
        // dead daemon's). Say so now.
        if pending.number_of_server_connections() == 0 {
            return Err(IpcError::NoDaemon {
                prefix: self.prefix.clone(),
                detail: "its command server is not up: the daemon is starting or has stopped"
                    .into(),
            });
        }
        self.pending.push(pending);
        self.command_ready
            .notify()
            .map_err(ice("notify command-ready"))?;
        Ok(req.sequence)
    }

    /// Wakes the daemon's command thread, as [`Client::send_request`] does
    /// after each request (the daemon also polls every 10 ms).
    pub fn notify_command_ready(&self) -> Result<(), IpcError> {
        self.command_ready
            .notify()
            .map(|_| ())
            .map_err(ice("notify command-ready"))
    }

    /// Sends `cmd`; its reply arrives through [`Client::replies`].
    /// Returns the sequence number used.
    pub fn send(&mut self, cmd: Command) -> Result<u32, IpcError> {
        // A slow daemon must not exhaust the service's active requests:
        // beyond MAX_PENDING the oldest unanswered request is given up.
        Session::send(self, cmd)
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
        Session::request(self, cmd, timeout)
    }

    /// Sends `req` exactly as given (see [`Client::send_request`]) and
    /// waits up to `timeout` for its reply.
    pub fn request_raw(
        &mut self,
        req: CommandRequest,
        timeout: Duration,
    ) -> Result<CommandReply, IpcError> {
        Session::request_raw(self, req, timeout)
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
    /// A zero `timeout` does not wait (iceoryx2 would take it as "no
    /// timeout"); a wait a signal interrupts ends early, without error.
    pub fn wait_state(&self, timeout: Duration) -> Result<Option<StateSnapshot>, IpcError> {
        if let Some(s) = self.latest()? {
            return Ok(Some(s));
        }
        if timeout.is_zero() {
            return Ok(None);
        }
        match self.listener.timed_wait(|_| {}, timeout) {
            Ok(_) => {}
            Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => return Ok(None),
            Err(e) => return Err(ice("wait for state")(e)),
        }
        self.latest()
    }
}

/// An operator tool's session with the daemon, local ([`Client`], iceoryx2)
/// or remote (`anguilla_link::RemoteClient`, through `anguilla link`): the
/// tools are written against this, so a remote tool behaves as a local one.
///
/// A session is one identity for the daemon ([`Session::id`]): the client
/// port its commands arrive on, never a field of a request.
pub trait Session {
    /// This session's identity as the daemon knows it (what
    /// [`StateSnapshot::holder`] names); 0 until a remote link has said.
    fn id(&self) -> u128;
    /// Where the session reaches the daemon, for messages ("prefix
    /// 'anguilla'", "prefix 'anguilla' through tcp/127.0.0.1:7447").
    fn describe(&self) -> String;
    /// Who owns the client port `id` (the holder of control, say), in
    /// words: `ctl (user alice, pid 4242)`; `None` where this session
    /// cannot tell (a remote one).
    fn who(&self, _id: u128) -> Option<String> {
        None
    }
    /// When the state read may not be the robot's, says why.
    fn provenance_problem(&self) -> Option<String>;
    /// What to ask when a request went unanswered: what may have gone
    /// away on this session's path ("is the daemon running?" locally; a
    /// remote session names the link when it is the link that went).
    fn silence_hint(&self) -> String {
        "is the daemon running?".into()
    }
    /// Sends `req` exactly as given; its reply arrives through
    /// [`Session::replies`]. Returns its sequence number.
    fn send_request(&mut self, req: CommandRequest) -> Result<u32, IpcError>;
    /// Collects the replies that have arrived.
    fn replies(&mut self, f: &mut dyn FnMut(&CommandReply)) -> Result<(), IpcError>;
    /// Replies still awaited.
    fn awaiting(&self) -> usize;
    /// Waits up to `timeout` for a reply or a state to arrive (returns
    /// early on either; a zero timeout does not wait).
    fn wait_any(&mut self, timeout: Duration) -> Result<(), IpcError>;
    /// The newest state, if any arrived since the last call.
    fn latest(&mut self) -> Result<Option<StateSnapshot>, IpcError>;
    /// Waits up to `timeout` for new state; the newest one, `None` on timeout.
    fn wait_state(&mut self, timeout: Duration) -> Result<Option<StateSnapshot>, IpcError>;
    /// The E-stop path that no capacity limit blocks (the local E-stop
    /// socket, or the link's E-stop key). Not a command: nothing to reply.
    fn estop_out_of_band(&mut self) -> Result<(), IpcError>;
    /// The next sequence number for a request.
    fn next_sequence(&mut self) -> u32;

    /// Sends `cmd`; its reply arrives through [`Session::replies`].
    fn send(&mut self, cmd: Command) -> Result<u32, IpcError> {
        let seq = self.next_sequence();
        self.send_request(CommandRequest::new(cmd, seq))
    }

    /// Sends `req` exactly as given and waits up to `timeout` for its reply.
    fn request_raw(
        &mut self,
        req: CommandRequest,
        timeout: Duration,
    ) -> Result<CommandReply, IpcError> {
        let seq = self.send_request(req)?;
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let mut found = None;
            self.replies(&mut |r| {
                if r.sequence == seq {
                    found = Some(*r);
                }
            })?;
            if let Some(r) = found {
                return Ok(r);
            }
            let now = std::time::Instant::now();
            if now >= deadline {
                return Err(IpcError::Iceoryx(format!(
                    "no reply to request {seq} (code {}) within {timeout:?} from {}: {}",
                    req.code,
                    self.describe(),
                    self.silence_hint()
                )));
            }
            self.wait_any((deadline - now).min(Duration::from_millis(2)))?;
        }
    }

    /// Sends `cmd` and waits up to `timeout` for its reply.
    fn request(&mut self, cmd: Command, timeout: Duration) -> Result<CommandReply, IpcError> {
        let seq = self.next_sequence();
        self.request_raw(CommandRequest::new(cmd, seq), timeout)
    }
}

impl Session for Client {
    fn id(&self) -> u128 {
        Client::id(self)
    }
    fn who(&self, id: u128) -> Option<String> {
        Client::who(self, id)
    }
    fn describe(&self) -> String {
        format!("prefix '{}'", self.prefix)
    }
    fn provenance_problem(&self) -> Option<String> {
        Client::provenance_problem(self)
    }
    fn send_request(&mut self, req: CommandRequest) -> Result<u32, IpcError> {
        Client::send_request(self, req)
    }
    fn replies(&mut self, f: &mut dyn FnMut(&CommandReply)) -> Result<(), IpcError> {
        Client::replies(self, f)
    }
    fn awaiting(&self) -> usize {
        Client::awaiting(self)
    }
    fn wait_any(&mut self, timeout: Duration) -> Result<(), IpcError> {
        if !timeout.is_zero() {
            let _ = self.listener.timed_wait(|_| {}, timeout);
        }
        Ok(())
    }
    fn latest(&mut self) -> Result<Option<StateSnapshot>, IpcError> {
        Client::latest(self)
    }
    fn wait_state(&mut self, timeout: Duration) -> Result<Option<StateSnapshot>, IpcError> {
        Client::wait_state(self, timeout)
    }
    fn estop_out_of_band(&mut self) -> Result<(), IpcError> {
        crate::estop::send(&self.prefix).map_err(|e| IpcError::EStopSocket(e.to_string()))
    }
    fn next_sequence(&mut self) -> u32 {
        self.sequence = self.sequence.wrapping_add(1);
        self.sequence
    }
}
