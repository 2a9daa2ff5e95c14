//! A tool's side of the operator interface.

use core::time::Duration;

use iceoryx2::prelude::*;

use crate::payload::{CommandReply, CommandRequest, StateSnapshot};
use crate::service::{
    CommandService, IpcError, MAX_REQUESTS_PER_CLIENT, Role, StateService, command_service,
    event_service, ice, new_node, publisher_and_server_pids, state_service,
};
use crate::vocabulary::Command;

/// Unanswered requests a client keeps (the service allows
/// [`MAX_REQUESTS_PER_CLIENT`]); the oldest is given up beyond.
const MAX_PENDING: usize = MAX_REQUESTS_PER_CLIENT - 1;

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
}

impl Client {
    /// Connects to the daemon's services under `prefix` (they must exist:
    /// a tool never creates them), naming the iceoryx2 node `name`.
    pub fn new(prefix: &str, name: &str) -> Result<Self, IpcError> {
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
        })
    }

    /// This client's identity as the daemon knows it: the unique id of its
    /// iceoryx2 client port (what [`StateSnapshot::holder`] names).
    pub fn id(&self) -> u128 {
        self.client.id().value()
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
        self.sequence = self.sequence.wrapping_add(1);
        self.send_request(CommandRequest::new(cmd, self.sequence))
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
        self.sequence = self.sequence.wrapping_add(1);
        self.request_raw(CommandRequest::new(cmd, self.sequence), timeout)
    }

    /// Sends `req` exactly as given (see [`Client::send_request`]) and
    /// waits up to `timeout` for its reply.
    pub fn request_raw(
        &mut self,
        req: CommandRequest,
        timeout: Duration,
    ) -> Result<CommandReply, IpcError> {
        let seq = self.send_request(req)?;
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
                    "no reply to request {seq} (code {}) within {timeout:?}: is the daemon running?",
                    req.code
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
