//! A connection to the daemon as one operator tool: commands with their
//! refusals remembered, the latest state, and the steady sender.

use std::time::{Duration, Instant};

use anguilla_ipc::{Client, CommandReply, IpcError, Session, StateSnapshot};
use anguilla_ipc::{Command, CommandKind};

use crate::app::{Action, Intent};

/// How often the holder sends its intent (10 Hz: five times within the
/// daemon's default 0.5 s command timeout).
pub const STEADY_PERIOD: Duration = Duration::from_millis(100);

/// How long the quit sequence waits for each reply.
pub const QUIT_TIMEOUT: Duration = Duration::from_secs(1);

/// A refused command and the daemon's reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refused {
    /// What was refused (`None`: a reply to a request this tool no longer
    /// remembers, one of 128 older ones).
    pub kind: Option<CommandKind>,
    /// The daemon's reason.
    pub reason: String,
}

impl Refused {
    /// The refused command's name, for operators.
    pub fn name(&self) -> &'static str {
        self.kind.map_or("command", CommandKind::name)
    }
}

/// One operator tool's connection to the daemon.
pub struct Operator {
    client: Box<dyn Session>,
    sent: Vec<(u32, CommandKind)>,
    state: Option<StateSnapshot>,
    last_refused: Option<Refused>,
    refusals: u64,
}

impl std::fmt::Debug for Operator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Operator")
            .field("id", &self.client.id())
            .field("last_refused", &self.last_refused)
            .finish()
    }
}

impl Operator {
    /// Connects to the daemon under `prefix` as a new client (a new
    /// iceoryx2 client port, so a new identity); `tool` names the node.
    pub fn connect(prefix: &str, tool: &str) -> Result<Self, IpcError> {
        let name = format!("{tool}-{}", std::process::id());
        Ok(Self::over(Box::new(Client::new(prefix, &name)?)))
    }

    /// An operator over an open session, local or remote.
    pub fn over(client: Box<dyn Session>) -> Self {
        Self {
            client,
            sent: Vec::new(),
            state: None,
            last_refused: None,
            refusals: 0,
        }
    }

    /// An E-stop goes out on the path no queue or session limit blocks
    /// (the E-stop socket, or the link's E-stop key) before the command.
    fn estop_first(&mut self, cmd: Command) {
        if cmd == Command::EStop {
            let _ = self.client.estop_out_of_band();
        }
    }

    /// Sends an E-stop on the out-of-band path only (see
    /// [`anguilla_ipc::Session::estop_out_of_band`]).
    pub fn estop_out_of_band(&mut self) -> Result<(), IpcError> {
        self.client.estop_out_of_band()
    }

    /// Where the session reaches the daemon (for messages).
    pub fn describe(&self) -> String {
        self.client.describe()
    }

    /// This client's id (compare with [`StateSnapshot::holder`]).
    pub fn id(&self) -> u128 {
        self.client.id()
    }

    /// When the state read does not come from the process that serves the
    /// commands, says so (see [`anguilla_ipc::Client::provenance_problem`]).
    pub fn provenance_problem(&self) -> Option<String> {
        self.client.provenance_problem()
    }

    /// Sends `cmd` without waiting; its reply is collected by [`Operator::poll`].
    pub fn send(&mut self, cmd: Command) -> Result<(), IpcError> {
        self.estop_first(cmd);
        let seq = self.client.send(cmd)?;
        if self.sent.len() >= 256 {
            self.sent.drain(..128);
        }
        self.sent.push((seq, cmd.kind()));
        Ok(())
    }

    /// Sends `cmd` and waits up to `timeout` for its reply (a refusal is
    /// also remembered as the last refused command).
    pub fn request(&mut self, cmd: Command, timeout: Duration) -> Result<CommandReply, IpcError> {
        self.estop_first(cmd);
        let r = self.client.request(cmd, timeout)?;
        if r.accepted == 0 {
            self.refusals += 1;
            self.last_refused = Some(Refused {
                kind: Some(cmd.kind()),
                reason: r.reason().to_string(),
            });
        }
        Ok(r)
    }

    /// Collects the replies and the newest state that arrived.
    pub fn poll(&mut self) -> Result<(), IpcError> {
        let mut refused = None;
        let mut count = 0;
        let sent = &mut self.sent;
        self.client.replies(&mut |r| {
            let kind = sent
                .iter()
                .position(|(s, _)| *s == r.sequence)
                .map(|i| sent.swap_remove(i).1);
            if r.accepted == 0 {
                count += 1;
                refused = Some(Refused {
                    kind,
                    reason: r.reason().to_string(),
                });
            }
        })?;
        self.refusals += count;
        if refused.is_some() {
            self.last_refused = refused;
        }
        if let Some(s) = self.client.latest()? {
            self.state = Some(s);
        }
        Ok(())
    }

    /// Waits up to `timeout` for a new state; returns the newest known.
    pub fn wait_state(&mut self, timeout: Duration) -> Result<Option<&StateSnapshot>, IpcError> {
        if let Some(s) = self.client.wait_state(timeout)? {
            self.state = Some(s);
        }
        Ok(self.state.as_ref())
    }

    /// The newest state received.
    pub fn state(&self) -> Option<&StateSnapshot> {
        self.state.as_ref()
    }

    /// Whether the newest state says this client holds control.
    pub fn holds_control(&self) -> bool {
        self.state.is_some_and(|s| s.holder() == Some(self.id()))
    }

    /// A command this tool refused before sending it (a path whose frame
    /// needs a pose the daemon has not given): shown as the daemon's
    /// refusals are.
    pub fn refuse_locally(&mut self, kind: Option<CommandKind>, reason: String) {
        self.refusals += 1;
        self.last_refused = Some(Refused { kind, reason });
    }

    /// The last refused command and why.
    pub fn last_refused(&self) -> Option<&Refused> {
        self.last_refused.as_ref()
    }

    /// Refusals received since connecting.
    pub fn refusals(&self) -> u64 {
        self.refusals
    }

    /// Replies still awaited.
    pub fn awaiting(&self) -> usize {
        self.client.awaiting()
    }
}

/// How long the keyboard client waits for a waypoint's reply.
const WAYPOINT_REPLY: Duration = Duration::from_secs(1);

/// The keyboard client's driving logic without a terminal: an [`Intent`],
/// its immediate commands, and the steady 10 Hz sender while holding
/// control. `anguilla teleop` and the system tests use the same code.
#[derive(Debug)]
pub struct Driver {
    /// The connection.
    pub op: Operator,
    /// The operator's intent.
    pub intent: Intent,
    /// The path [`Action::Follow`] follows (`anguilla teleop --path`).
    pub path: Option<crate::path::PathFile>,
    /// The waypoints last sent, in the estimate's frame, and whether the
    /// path loops: for the view to draw (taken by it).
    pub placed: Option<(Vec<(f64, f64)>, bool)>,
    next_steady: Instant,
    refusals_seen: u64,
}

impl Driver {
    /// A driver over `op`, at rest.
    pub fn new(op: Operator, intent: Intent) -> Self {
        Self {
            op,
            intent,
            path: None,
            placed: None,
            next_steady: Instant::now(),
            refusals_seen: 0,
        }
    }

    /// Applies `action` and sends its command at once (not for
    /// [`Action::Quit`]: see [`Driver::quit`]), then a hold armed at rest
    /// when the action started a swim ([`Intent::hold_update`]). Returns
    /// the action's command.
    pub fn act(&mut self, action: Action) -> Result<Option<Command>, IpcError> {
        if action == Action::Follow {
            return self.follow();
        }
        let cmd = self.intent.apply(action);
        if let Some(c) = cmd {
            self.op.send(c)?;
            self.next_steady = Instant::now() + STEADY_PERIOD;
        }
        if let Some(h) = self.intent.hold_update() {
            self.op.send(h)?;
        }
        Ok(cmd)
    }

    /// [`Action::Follow`]: with a path, start it (its waypoints one a
    /// request, then the follow), pause the one followed (the operator
    /// takes over: a straight swim), or resume the one paused on its leg.
    /// Returns the last command sent; none without a path.
    fn follow(&mut self) -> Result<Option<Command>, IpcError> {
        use anguilla_ipc::{Follow, GuideState};
        let Some(path) = &self.path else {
            return Ok(None);
        };
        let guide = self.op.state().map(|s| s.guide);
        let state = guide.and_then(|g| g.guide_state());
        let cmd = if state == Some(GuideState::Following) {
            self.intent.take_over()
        } else {
            let n = path.waypoints.len();
            let resume = state == Some(GuideState::Interrupted)
                && guide.is_some_and(|g| usize::from(g.waypoints) == n);
            if !resume {
                // In the estimate's frame (from the robot's pose now, for a
                // path in the frame "here"); without the pose it needs,
                // nothing is sent and the status says why.
                let here = self.op.state().filter(|s| s.nav.samples > 0).map(|s| {
                    (
                        f64::from(s.nav.x_m),
                        f64::from(s.nav.y_m),
                        f64::from(s.nav.heading_deg),
                    )
                });
                let waypoints = match path.placed(here) {
                    Ok(w) => w,
                    Err(e) => {
                        self.op.refuse_locally(Some(CommandKind::Follow), e);
                        return Ok(None);
                    }
                };
                // One a request, each answered before the next (the
                // daemon keeps only a few unanswered requests per
                // client); a refusal (outside the fence, too deep) is the
                // operator's to read in the header, and nothing follows.
                self.placed = Some((waypoints.iter().map(|w| (w.x, w.y)).collect(), path.looped));
                for w in &waypoints {
                    if self
                        .op
                        .request(Command::Waypoint(*w), WAYPOINT_REPLY)?
                        .accepted
                        == 0
                    {
                        return Ok(None);
                    }
                }
            }
            let f = Command::Follow(Follow {
                swim: self.intent.follow_gait(),
                count: n as u32,
                looped: path.looped,
                from_here: false,
                resume,
            });
            self.intent.follow_started();
            f
        };
        self.op.send(cmd)?;
        self.next_steady = Instant::now() + STEADY_PERIOD;
        Ok(Some(cmd))
    }

    /// One turn of the tool's loop: collect replies and state, follow the
    /// daemon's mode, and send the steady command when due while holding
    /// control. Returns when the next steady command is due.
    pub fn pump(&mut self, now: Instant) -> Result<Instant, IpcError> {
        self.op.poll()?;
        if self.op.refusals() != self.refusals_seen {
            self.refusals_seen = self.op.refusals();
            match self.op.last_refused().and_then(|r| r.kind) {
                Some(CommandKind::Swim) => self.intent.swim_refused(),
                Some(CommandKind::Hold) => self.intent.hold_refused(),
                _ => {}
            }
        }
        if let Some(s) = self.op.state() {
            self.intent.observe(s.mode, s.cause);
            self.intent.observe_nav(&s.nav);
        }
        if now >= self.next_steady {
            if self.op.holds_control() {
                self.op.send(self.intent.steady())?;
            }
            self.next_steady = now + STEADY_PERIOD;
        }
        Ok(self.next_steady)
    }

    /// The quit sequence: if holding control, stop the swim and release
    /// control, each waiting for its reply up to `timeout`.
    pub fn quit(&mut self, timeout: Duration) -> Result<(), IpcError> {
        self.op.poll()?;
        self.intent.apply(Action::Stop);
        if self.op.holds_control() {
            self.op.request(Command::Stop, timeout)?;
            self.op.request(Command::ReleaseControl, timeout)?;
        }
        Ok(())
    }
}
