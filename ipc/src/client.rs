//! A tool's side of the operator interface.

use core::time::Duration;

use iceoryx2::prelude::*;

use crate::payload::{CommandReply, CommandRequest, StateSnapshot};
use crate::service::{IpcError, ice, new_node, open_services};
use crate::vocabulary::Command;

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
