//! Node conformance: does a vertebra node do what `protocol/README.md`
//! says?
//!
//! This crate owns the conformance suite a firmware author runs against a
//! node on a bus (`anguilla conform --bus SPEC --node N`). It drives the
//! node through every row of the transition table
//! [`anguilla_protocol::behaviour::TRANSITIONS`] with real frames, reaching
//! each state by the documented means (Disabled after boot or ClearFaults,
//! Enabled by Enable, Fault by letting the watchdog expire, EStop by an
//! EStop frame), and looks only at what the node puts on the wire: the
//! heartbeat `State` and `BAD_FRAME` bit, the heartbeat sent at once on a
//! state change, the `ConfigAck` `Result` and the `Feedback` flags. Each
//! (state, input) pair that disagrees with the table is reported, naming
//! the state, the input, what was expected and what was seen.
//!
//! Boot is left by the node on its own after power-on, so the suite cannot
//! hold a node there: Boot rows are reported as not checked.
//!
//! The suite talks to the node through a [`Wire`]: [`BusWire`] wraps any
//! [`Bus`] in real time; a test can implement [`Wire`] on simulated time.
//!
//! ```no_run
//! use anguilla_conform::{BusWire, Options, run};
//! use anguilla_protocol::message::{NodeId, Variant};
//!
//! let bus = anguilla_drivers::open("socketcan:can0")?;
//! let mut wire = BusWire::new(bus);
//! let report = run(&mut wire, &Options::new(NodeId::new(3).unwrap(), Variant::Classic))?;
//! print!("{report}");
//! assert!(report.conforms());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::time::{Duration, Instant};

use anguilla_drivers::{Bus, LinkError};
use anguilla_protocol::behaviour::{
    FeedbackFlags, Input, Outcome, STATES, expected, result_name, state_name,
};
use anguilla_protocol::message::{
    self, AxisSetpoint, Command, ConfigParam, ConfigResult, EncodeError, ErrorBits, Message,
    NodeId, NodeSet, NodeState, SafeAction, Setpoint, SetpointGroup, Target, Variant,
};
use anguilla_protocol::{Frame, FrameError};

mod report;

pub use report::{Mismatch, Observed, Report, RowReport, Verdict};

/// What can stop the suite as a whole (a disagreement never does: it is
/// reported in the [`Report`]).
#[derive(Debug, thiserror::Error)]
pub enum ConformError {
    /// Sending or receiving on the bus failed.
    #[error("bus {spec}: {source}")]
    Bus {
        /// The bus spec.
        spec: String,
        /// What went wrong.
        #[source]
        source: LinkError,
    },
    /// A frame could not be built (a bug of the suite, not of the node).
    #[error("encoding a frame: {0}")]
    Encode(#[from] EncodeError),
    /// A raw frame could not be built.
    #[error("building a frame: {0}")]
    Frame(#[from] FrameError),
    /// The node sent no heartbeat at all: nothing can be checked.
    #[error(
        "node {node} sent no heartbeat within {waited_ms} ms: is it powered, on this bus, with this id and bit rate?"
    )]
    Silent {
        /// The node's id.
        node: u8,
        /// How long the suite listened.
        waited_ms: u64,
    },
}

impl ConformError {
    /// A send or receive error of `bus`, named by its spec.
    pub fn on_bus<B: Bus + ?Sized>(bus: &B, source: LinkError) -> Self {
        ConformError::Bus {
            spec: bus.spec().to_owned(),
            source,
        }
    }
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, ConformError>;

/// The suite's view of the bus: send a frame, wait for one, read the time.
pub trait Wire {
    /// Sends one frame.
    fn send(&mut self, frame: &Frame) -> Result<()>;
    /// The next frame received, or `None` once [`now`](Wire::now) reaches
    /// `deadline`.
    fn recv_until(&mut self, deadline: Duration) -> Result<Option<Frame>>;
    /// Time since an origin of the wire's choice; never decreases.
    fn now(&self) -> Duration;
}

/// A [`Bus`] in real time.
pub struct BusWire<B: Bus> {
    bus: B,
    origin: Instant,
}

impl<B: Bus> BusWire<B> {
    /// Wraps `bus`; time starts now.
    pub fn new(bus: B) -> Self {
        Self {
            bus,
            origin: Instant::now(),
        }
    }
}

impl<B: Bus> Wire for BusWire<B> {
    fn send(&mut self, frame: &Frame) -> Result<()> {
        self.bus
            .send(frame)
            .map_err(|e| ConformError::on_bus(&self.bus, e))
    }
    fn recv_until(&mut self, deadline: Duration) -> Result<Option<Frame>> {
        let left = deadline.saturating_sub(self.now());
        match self.bus.recv(left) {
            Ok(r) => Ok(r.map(|r| r.frame)),
            Err(e) => Err(ConformError::on_bus(&self.bus, e)),
        }
    }
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }
}

/// How to run the suite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// The node under test.
    pub node: NodeId,
    /// Classic CAN or CAN FD.
    pub variant: Variant,
    /// How long the suite watches after an input: at least two heartbeat
    /// periods, so that a heartbeat sent after the input is seen.
    pub window: Duration,
    /// A state change must be announced by a heartbeat within this time of
    /// the input ("at once"; a periodic heartbeat could take 100 ms).
    pub prompt: Duration,
    /// How long to wait for a state the suite drives the node to.
    pub reach: Duration,
}

impl Options {
    /// Defaults: a 250 ms window, 50 ms for the heartbeat of a state
    /// change, 1 s to reach a state.
    pub fn new(node: NodeId, variant: Variant) -> Self {
        Self {
            node,
            variant,
            window: Duration::from_millis(250),
            prompt: Duration::from_millis(50),
            reach: Duration::from_secs(1),
        }
    }
}

/// The watchdog the suite configures before Enable when it wants the node
/// to stay Enabled for a whole row without setpoints (ms, the maximum).
pub const LONG_WATCHDOG_MS: u16 = message::WATCHDOG_RANGE_MS.1;

/// The watchdog the suite configures to bring a node to Fault (ms).
pub const SHORT_WATCHDOG_MS: u16 = 20;

const NOT_REACHABLE_BOOT: &str =
    "Boot is left by the node on its own after power-on; the suite cannot hold a node there";

/// Runs the whole suite against the node of `opts` and reports every row.
///
/// Leaves the node Disabled with the default watchdog when it can. Fails
/// only if the bus fails or the node never sends a heartbeat.
pub fn run(wire: &mut dyn Wire, opts: &Options) -> Result<Report> {
    let mut s = Session {
        wire,
        opts: *opts,
        sync: 0,
        last_state: None,
    };
    s.first_heartbeat()?;
    let mut rows = Vec::with_capacity(STATES.len() * Input::ALL.len());
    for state in STATES {
        for input in Input::ALL {
            let exp = expected(state, input);
            let (observed, verdict) = if state == NodeState::Boot {
                (None, Verdict::NotChecked(NOT_REACHABLE_BOOT))
            } else {
                match s.reach(state)? {
                    Err(why) => (None, Verdict::NotReached(why)),
                    Ok(()) => {
                        let obs = s.apply(state, input)?;
                        let verdict = judge(state, &exp, &obs, opts.prompt);
                        (Some(obs), verdict)
                    }
                }
            };
            rows.push(RowReport {
                state,
                input,
                expected: exp,
                observed,
                verdict,
            });
        }
    }
    // Leave the node as a host finds it after boot.
    if s.reset()?.is_ok() {
        s.config(ConfigParam::WatchdogTimeout {
            ms: message::DEFAULT_WATCHDOG_MS,
        })?;
    }
    Ok(Report {
        node: opts.node,
        rows,
    })
}

/// Compares what was seen with a row of the table.
fn judge(state: NodeState, exp: &Outcome, obs: &Observed, prompt: Duration) -> Verdict {
    let mut ms = Vec::new();
    // The new state, perhaps after a last heartbeat of the old one.
    let states_ok = match obs.states.as_slice() {
        [s] => *s == exp.next,
        [a, b] => *a == state && *b == exp.next && state != exp.next,
        _ => false,
    };
    if !states_ok {
        ms.push(Mismatch::State {
            expected: exp.next,
            observed: obs.states.clone(),
        });
    } else if exp.next != state {
        match obs.change_heartbeat {
            Some(d) if d <= prompt => {}
            after => ms.push(Mismatch::LateHeartbeat {
                state: exp.next,
                after,
                allowed: prompt,
            }),
        }
    }
    if obs.bad_frame != exp.bad_frame {
        ms.push(Mismatch::BadFrame {
            expected: exp.bad_frame,
        });
    }
    if obs.ack != exp.ack {
        ms.push(Mismatch::Ack {
            expected: exp.ack,
            observed: obs.ack,
        });
    }
    if obs.feedback != exp.feedback {
        ms.push(Mismatch::Feedback {
            expected: exp.feedback,
            observed: obs.feedback,
        });
    }
    if ms.is_empty() {
        Verdict::Agrees
    } else {
        Verdict::Disagrees(ms)
    }
}

/// What the node sent, decoded and kept if it is from the node under test.
enum Heard {
    Heartbeat { state: NodeState, bad_frame: bool },
    Ack(ConfigResult),
    Feedback(FeedbackFlags, [f32; 2]),
}

struct Session<'a> {
    wire: &'a mut dyn Wire,
    opts: Options,
    sync: u16,
    last_state: Option<NodeState>,
}

/// Outcome of bringing the node to a state: `Err` says what happened
/// instead.
type Reached = std::result::Result<(), String>;

impl Session<'_> {
    fn heartbeat_period() -> Duration {
        Duration::from_millis(message::HEARTBEAT_PERIOD_MS as u64)
    }

    fn send(&mut self, m: Message) -> Result<()> {
        let f = m.encode(self.opts.variant)?;
        self.wire.send(&f)
    }

    fn me(&self) -> Target {
        Target::Node(self.opts.node)
    }

    /// The next frame of the node under test before `deadline`.
    fn next(&mut self, deadline: Duration) -> Result<Option<(Duration, Heard)>> {
        while let Some(f) = self.wire.recv_until(deadline)? {
            let at = self.wire.now();
            // Frames of other nodes, of the host and undecodable ones are
            // not the node's answer.
            let Ok(m) = message::decode(&f, self.opts.variant, NodeSet::all()) else {
                continue;
            };
            let heard = match m {
                Message::Heartbeat(h) if h.node == self.opts.node => {
                    self.last_state = Some(h.state);
                    Heard::Heartbeat {
                        state: h.state,
                        bad_frame: h.errors.any(ErrorBits::BAD_FRAME),
                    }
                }
                Message::ConfigAck { node, result, .. } if node == self.opts.node => {
                    Heard::Ack(result)
                }
                Message::Feedback(fb) if fb.node == self.opts.node => Heard::Feedback(
                    FeedbackFlags {
                        enabled: fb.enabled,
                        fault: fb.fault,
                    },
                    [fb.axes[0].position, fb.axes[1].position],
                ),
                _ => continue,
            };
            return Ok(Some((at, heard)));
        }
        Ok(None)
    }

    fn first_heartbeat(&mut self) -> Result<()> {
        let wait = 3 * Self::heartbeat_period() + self.opts.reach;
        let deadline = self.wire.now() + wait;
        while let Some((_, h)) = self.next(deadline)? {
            if matches!(h, Heard::Heartbeat { .. }) {
                return Ok(());
            }
        }
        Err(ConformError::Silent {
            node: self.opts.node.get(),
            waited_ms: wait.as_millis() as u64,
        })
    }

    /// Waits for two heartbeats (the second one was sent after the node
    /// handled everything sent before this call) and returns the state.
    fn settle(&mut self) -> Result<Option<NodeState>> {
        let mut seen = 0;
        let deadline = self.wire.now() + 3 * Self::heartbeat_period() + self.opts.reach;
        while let Some((_, h)) = self.next(deadline)? {
            if let Heard::Heartbeat { state, .. } = h {
                seen += 1;
                if seen == 2 {
                    return Ok(Some(state));
                }
            }
        }
        Ok(None)
    }

    /// Waits for a heartbeat in `target`; `Err` names the last state seen.
    fn wait_state(&mut self, target: NodeState, after: &str) -> Result<Reached> {
        let deadline = self.wire.now() + self.opts.reach;
        while let Some((_, h)) = self.next(deadline)? {
            if let Heard::Heartbeat { state, .. } = h
                && state == target
            {
                return Ok(Ok(()));
            }
        }
        Ok(Err(format!(
            "after {after} the node was in {}, not {} ({} ms)",
            self.last_state.map_or("no heartbeat", state_name),
            state_name(target),
            self.opts.reach.as_millis()
        )))
    }

    /// Writes one parameter; `None`: no ConfigAck came.
    fn config(&mut self, param: ConfigParam) -> Result<Option<ConfigResult>> {
        self.send(Message::ConfigWrite {
            node: self.opts.node,
            param,
        })?;
        let deadline = self.wire.now() + self.opts.reach;
        while let Some((_, h)) = self.next(deadline)? {
            if let Heard::Ack(r) = h {
                return Ok(Some(r));
            }
        }
        Ok(None)
    }

    fn command(&mut self, command: Command) -> Result<()> {
        self.send(Message::Command {
            target: self.me(),
            command,
        })
    }

    /// Brings the node to Disabled the way a host does: Disable from
    /// Enabled, ClearFaults from Fault and EStop, waiting out Boot.
    fn reset(&mut self) -> Result<Reached> {
        let now = self.settle()?;
        match now {
            Some(NodeState::Disabled) => return Ok(Ok(())),
            Some(NodeState::Enabled) => self.command(Command::Disable)?,
            Some(NodeState::Fault | NodeState::EStop) => self.command(Command::ClearFaults)?,
            Some(NodeState::Boot) | None => {}
        }
        let how = match now {
            Some(NodeState::Enabled) => "Disable in Enabled",
            Some(NodeState::Fault) => "ClearFaults in Fault",
            Some(NodeState::EStop) => "ClearFaults in EStop",
            _ => "waiting for the end of Boot",
        };
        self.wait_state(NodeState::Disabled, how)
    }

    /// Configures the watchdog (in Disabled).
    fn set_watchdog(&mut self, ms: u16) -> Result<Reached> {
        match self.config(ConfigParam::WatchdogTimeout { ms })? {
            Some(ConfigResult::Accepted) => Ok(Ok(())),
            other => Ok(Err(format!(
                "ConfigWrite WatchdogTimeout {ms} ms in Disabled was answered with {}, not Accepted",
                other.map_or("no ConfigAck", result_name)
            ))),
        }
    }

    /// Brings the node to `state` by the documented means, then lets two
    /// heartbeats pass so that nothing from getting there is reported in
    /// the row's window.
    fn reach(&mut self, state: NodeState) -> Result<Reached> {
        let got = self.reset()?;
        if got.is_err() {
            return Ok(got);
        }
        // A watchdog long enough for a whole row in Enabled without
        // setpoints (Disabled × Enable ends there too), or short to reach
        // Fault.
        let ms = if state == NodeState::Fault {
            SHORT_WATCHDOG_MS
        } else {
            LONG_WATCHDOG_MS
        };
        let got = self.set_watchdog(ms)?;
        if got.is_err() {
            return Ok(got);
        }
        let got = match state {
            NodeState::Disabled => Ok(()),
            NodeState::Enabled => {
                self.command(Command::Enable)?;
                self.wait_state(NodeState::Enabled, "Enable in Disabled")?
            }
            NodeState::Fault => {
                self.command(Command::Enable)?;
                self.wait_state(
                    NodeState::Fault,
                    &format!("Enable with a {SHORT_WATCHDOG_MS} ms watchdog and no setpoint"),
                )?
            }
            NodeState::EStop => {
                self.send(Message::EStop(self.me()))?;
                self.wait_state(NodeState::EStop, "EStop in Disabled")?
            }
            NodeState::Boot => Err(NOT_REACHABLE_BOOT.to_string()),
        };
        if got.is_err() {
            return Ok(got);
        }
        match self.settle()? {
            Some(s) if s == state => Ok(Ok(())),
            other => Ok(Err(format!(
                "the node reached {} but then reported {}",
                state_name(state),
                other.map_or("no heartbeat", state_name)
            ))),
        }
    }

    /// Sends `input` to the node (in `state`) and watches the window.
    fn apply(&mut self, state: NodeState, input: Input) -> Result<Observed> {
        let mut obs = Observed {
            states: Vec::new(),
            bad_frame: false,
            ack: None,
            feedback: None,
            change_heartbeat: None,
        };
        let start = self.wire.now();
        let end = start + self.opts.window;
        let mut sent_at = start;
        let new_state = expected(state, input).next;
        let note = |obs: &mut Observed, at: Duration, h: &Heard, sent_at: Duration| match *h {
            Heard::Heartbeat {
                state: s,
                bad_frame,
            } => {
                if obs.states.last() != Some(&s) {
                    obs.states.push(s);
                }
                obs.bad_frame |= bad_frame;
                if s != state && s == new_state && obs.change_heartbeat.is_none() {
                    obs.change_heartbeat = Some(at.saturating_sub(sent_at));
                }
            }
            Heard::Ack(r) => {
                obs.ack.get_or_insert(r);
            }
            Heard::Feedback(f, _) => obs.feedback = Some(f),
        };
        match input {
            Input::Enable => self.command(Command::Enable)?,
            Input::Disable => self.command(Command::Disable)?,
            Input::ClearFaults => self.command(Command::ClearFaults)?,
            Input::EStop => self.send(Message::EStop(self.me()))?,
            Input::ConfigWrite => self.send(Message::ConfigWrite {
                node: self.opts.node,
                param: ConfigParam::SafeAction(SafeAction::Limp),
            })?,
            Input::BadFrame => {
                // A Command with value 0 (valid: 1..=3) for this node.
                let f = Frame::new_standard(
                    Message::Command {
                        target: self.me(),
                        command: Command::Enable,
                    }
                    .encode(self.opts.variant)?
                    .id()
                    .raw() as u16,
                    &[0],
                )?;
                self.wire.send(&f)?;
            }
            Input::SetpointSync => {
                // A SYNC first, to learn where the joint is: the setpoint
                // holds it there (a node under test may be on a robot).
                self.sync += 1;
                self.send(Message::Sync { counter: self.sync })?;
                let mut at_pos = [0.0f32; 2];
                let until = self.wire.now() + self.opts.prompt;
                while let Some((at, h)) = self.next(until)? {
                    note(&mut obs, at, &h, sent_at);
                    if let Heard::Feedback(_, p) = h {
                        at_pos = p;
                        break;
                    }
                }
                self.sync += 1;
                let axes = at_pos.map(|position| AxisSetpoint {
                    position,
                    velocity: 0.0,
                    torque: 0.0,
                });
                let cycle = self.opts.variant.cycle_tag(self.sync);
                let sp = match self.opts.variant {
                    Variant::Classic => Message::Setpoint(Setpoint {
                        node: self.opts.node,
                        cycle,
                        axes,
                    }),
                    Variant::Fd => {
                        let (group, slot) = SetpointGroup::locate(self.opts.node);
                        let mut slots = [None; message::GROUP_SLOTS];
                        slots[slot] = Some(axes);
                        Message::SetpointGroup(SetpointGroup {
                            group,
                            cycle,
                            slots,
                        })
                    }
                };
                self.send(sp)?;
                self.send(Message::Sync { counter: self.sync })?;
                // The Feedback of the row is the one answering this SYNC.
                obs.feedback = None;
            }
        }
        sent_at = sent_at.max(self.wire.now());
        while let Some((at, h)) = self.next(end.max(sent_at + self.opts.window))? {
            note(&mut obs, at, &h, sent_at);
        }
        Ok(obs)
    }
}
