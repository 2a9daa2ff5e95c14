//! The conformance suite against the simulated node (over the in-process
//! bus, on simulated time) and against a small fake node built from the
//! table with one row changed: the suite must pass the first and report
//! exactly the changed row of the second.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

use anguilla_conform::{ConformError, Mismatch, Options, Report, Verdict, Wire, run};
use anguilla_drivers::mem::{MemBus, MemParticipant};
use anguilla_drivers::{Bus, Clock, ManualClock};
use anguilla_protocol::Frame;
use anguilla_protocol::behaviour::{FeedbackFlags, Input, Outcome, TRANSITIONS, expected};
use anguilla_protocol::message::{
    self, AxisFeedback, ConfigParam, ErrorBits, Feedback, Function, Heartbeat, Message, NodeId,
    NodeSet, NodeState, Target, Variant,
};
use anguilla_sim::{RobotConfig, SimRobot};

const MS: Duration = Duration::from_millis(1);

/// The simulated robot on a mem bus driven by a ManualClock: waiting steps
/// the clock (1 ms at a time) and the robot.
struct SimWire {
    clock: ManualClock,
    host: MemParticipant,
    robot: SimRobot,
}

impl SimWire {
    fn new(name: &str, variant: Variant) -> Self {
        let clock = ManualClock::new();
        let bus = MemBus::builder(&format!("conform-{name}-{}", std::process::id()))
            .clock(Arc::new(clock.clone()))
            .build();
        let host = bus.participant();
        // Three nodes: the suite must pick out the one under test.
        let cfg = RobotConfig {
            variant,
            ..RobotConfig::with_joints(3)
        };
        let robot = SimRobot::on_mem(cfg, bus.participant(), Duration::ZERO).unwrap();
        Self { clock, host, robot }
    }
}

impl Wire for SimWire {
    fn send(&mut self, frame: &Frame) -> anguilla_conform::Result<()> {
        self.host
            .send(frame)
            .map_err(|e| ConformError::on_bus(&self.host, e))
    }
    fn recv_until(&mut self, deadline: Duration) -> anguilla_conform::Result<Option<Frame>> {
        loop {
            if let Some(r) = self
                .host
                .try_recv()
                .map_err(|e| ConformError::on_bus(&self.host, e))?
            {
                return Ok(Some(r.frame));
            }
            let now = self.clock.now();
            if now >= deadline {
                return Ok(None);
            }
            self.clock.advance((deadline - now).min(MS));
            self.robot.step_until(self.clock.now());
        }
    }
    fn now(&self) -> Duration {
        self.clock.now()
    }
}

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn assert_conforms(report: &Report) {
    assert!(report.conforms(), "{report}");
    // Every row but Boot's was run (Boot cannot be held over the bus).
    let boot = TRANSITIONS
        .iter()
        .filter(|t| t.state == NodeState::Boot)
        .count();
    assert_eq!(
        report.counts(),
        (TRANSITIONS.len() - boot, 0, 0, boot),
        "{report}"
    );
}

#[test]
fn the_simulated_node_agrees_with_every_row_classic() {
    let mut wire = SimWire::new("classic", Variant::Classic);
    let report = run(&mut wire, &Options::new(node(2), Variant::Classic)).unwrap();
    assert_conforms(&report);
    // The suite leaves the node Disabled, and the other nodes untouched.
    wire.recv_until(wire.now() + 200 * MS).unwrap();
    let states: Vec<_> = wire.robot.nodes().iter().map(|n| n.state()).collect();
    assert_eq!(states, vec![NodeState::Disabled; 3]);
}

#[test]
fn the_simulated_node_agrees_with_every_row_fd() {
    let mut wire = SimWire::new("fd", Variant::Fd);
    let report = run(&mut wire, &Options::new(node(3), Variant::Fd)).unwrap();
    assert_conforms(&report);
}

/// A node firmware written from the table in a few lines, with one row
/// replaced (`deviation`) and optionally without the heartbeat at once on a
/// state change.
struct FakeNode {
    id: NodeId,
    state: NodeState,
    bad_frame: bool,
    watchdog: Duration,
    last_applied: Duration,
    pending: bool,
    next_heartbeat: Duration,
    counter: u8,
    deviation: Option<(NodeState, Input, Outcome)>,
    heartbeat_on_change: bool,
    silent: bool,
    out: VecDeque<Frame>,
}

impl FakeNode {
    fn new(id: u8) -> Self {
        Self {
            id: node(id),
            state: NodeState::Disabled,
            bad_frame: false,
            watchdog: 50 * MS,
            last_applied: Duration::ZERO,
            pending: false,
            next_heartbeat: Duration::ZERO,
            counter: 0,
            deviation: None,
            heartbeat_on_change: true,
            silent: false,
            out: VecDeque::new(),
        }
    }

    fn rule(&self, input: Input) -> Outcome {
        match self.deviation {
            Some((s, i, o)) if s == self.state && i == input => o,
            _ => expected(self.state, input),
        }
    }

    fn emit(&mut self, m: Message) {
        if !self.silent {
            self.out.push_back(m.encode(Variant::Classic).unwrap());
        }
    }

    fn heartbeat(&mut self, now: Duration) {
        let errors = if self.bad_frame {
            ErrorBits::BAD_FRAME
        } else {
            0
        };
        self.emit(Message::Heartbeat(Heartbeat {
            node: self.id,
            state: self.state,
            errors: ErrorBits(errors),
            counter: self.counter,
            missed_syncs: 0,
            temperature: 30,
        }));
        self.counter = self.counter.wrapping_add(1);
        self.bad_frame = false;
        self.next_heartbeat = now + 100 * MS;
    }

    fn input(&mut self, now: Duration, input: Input, param: Option<ConfigParam>) {
        let o = self.rule(input);
        self.bad_frame |= o.bad_frame;
        if let Some(result) = o.ack {
            let param = param.unwrap_or(ConfigParam::WatchdogTimeout { ms: 50 });
            if result == message::ConfigResult::Accepted
                && let ConfigParam::WatchdogTimeout { ms } = param
            {
                self.watchdog = u32::from(ms) * MS;
            }
            self.emit(Message::ConfigAck {
                node: self.id,
                param,
                result,
            });
        }
        if input == Input::SetpointSync {
            if self.state == NodeState::Enabled && self.pending {
                self.last_applied = now;
            }
            self.pending = false;
        }
        if let Some(FeedbackFlags { enabled, fault }) = o.feedback {
            self.emit(Message::Feedback(Feedback {
                node: self.id,
                enabled,
                fault,
                axes: [AxisFeedback::default(); 2],
            }));
        }
        self.go(now, o.next);
    }

    fn go(&mut self, now: Duration, next: NodeState) {
        if next != self.state {
            self.state = next;
            self.last_applied = now;
            if self.heartbeat_on_change {
                self.heartbeat(now);
            }
        }
    }

    fn receive(&mut self, now: Duration, f: &Frame) {
        let command_to_me = f.id().raw() == u32::from(Function::Command.id(self.id.get()));
        match message::decode(f, Variant::Classic, NodeSet::all()) {
            Err(_) if command_to_me => self.input(now, Input::BadFrame, None),
            Err(_) => {}
            Ok(Message::EStop(t)) if t == Target::Node(self.id) || t == Target::All => {
                self.input(now, Input::EStop, None)
            }
            Ok(Message::Command { target, command }) if target != Target::All => {
                if target == Target::Node(self.id) {
                    let input = match command {
                        message::Command::Enable => Input::Enable,
                        message::Command::Disable => Input::Disable,
                        message::Command::ClearFaults => Input::ClearFaults,
                    };
                    self.input(now, input, None);
                }
            }
            Ok(Message::ConfigWrite { node, param }) if node == self.id => {
                self.input(now, Input::ConfigWrite, Some(param))
            }
            Ok(Message::Setpoint(sp)) if sp.node == self.id => self.pending = true,
            Ok(Message::Sync { .. }) => self.input(now, Input::SetpointSync, None),
            Ok(_) => {}
        }
    }

    fn tick(&mut self, now: Duration) {
        if self.state == NodeState::Enabled && now - self.last_applied > self.watchdog {
            self.go(now, NodeState::Fault);
        }
        if now >= self.next_heartbeat {
            self.heartbeat(now);
        }
    }
}

struct FakeWire {
    now: Duration,
    node: FakeNode,
}

impl FakeWire {
    fn new(node: FakeNode) -> Self {
        Self {
            now: Duration::ZERO,
            node,
        }
    }
}

impl Wire for FakeWire {
    fn send(&mut self, frame: &Frame) -> anguilla_conform::Result<()> {
        self.node.receive(self.now, frame);
        Ok(())
    }
    fn recv_until(&mut self, deadline: Duration) -> anguilla_conform::Result<Option<Frame>> {
        loop {
            if let Some(f) = self.node.out.pop_front() {
                return Ok(Some(f));
            }
            if self.now >= deadline {
                return Ok(None);
            }
            self.now = (self.now + MS).min(deadline);
            self.node.tick(self.now);
        }
    }
    fn now(&self) -> Duration {
        self.now
    }
}

fn run_fake(node: FakeNode) -> Report {
    let id = node.id;
    run(
        &mut FakeWire::new(node),
        &Options::new(id, Variant::Classic),
    )
    .unwrap()
}

#[test]
fn the_fake_node_built_from_the_table_agrees() {
    assert_conforms(&run_fake(FakeNode::new(5)));
}

#[test]
fn enable_accepted_in_fault_is_reported_as_exactly_that_row() {
    let mut fake = FakeNode::new(5);
    let wrong = Outcome {
        next: NodeState::Enabled,
        bad_frame: false,
        ..expected(NodeState::Fault, Input::Enable)
    };
    fake.deviation = Some((NodeState::Fault, Input::Enable, wrong));
    let report = run_fake(fake);
    let failures: Vec<_> = report.failures().collect();
    assert_eq!(failures.len(), 1, "{report}");
    let row = failures[0];
    assert_eq!((row.state, row.input), (NodeState::Fault, Input::Enable));
    assert_eq!(
        row.verdict,
        Verdict::Disagrees(vec![
            Mismatch::State {
                expected: NodeState::Fault,
                observed: vec![NodeState::Enabled, NodeState::Fault],
            },
            Mismatch::BadFrame { expected: true },
        ])
    );
    assert_eq!(
        row.to_string(),
        "DISAGREES Fault × Enable (table: BAD_FRAME): state: expected Fault, observed Enabled, \
         then Fault; \
         BAD_FRAME: expected set, observed clear"
    );
    assert!(!report.conforms());
    assert!(report.to_string().contains("DOES NOT CONFORM"));
}

#[test]
fn a_flipped_bad_frame_is_reported_in_exactly_its_row_for_every_row() {
    // Each checkable row in turn: the fake gets BAD_FRAME wrong there and
    // nowhere else, and the suite must name that row and only it. (This is
    // also the proof that every row is really exercised.)
    for t in TRANSITIONS.iter().filter(|t| t.state != NodeState::Boot) {
        let mut fake = FakeNode::new(7);
        let mut wrong = t.outcome;
        wrong.bad_frame = !wrong.bad_frame;
        fake.deviation = Some((t.state, t.input, wrong));
        let report = run_fake(fake);
        let failures: Vec<_> = report.failures().collect();
        assert_eq!(failures.len(), 1, "{t:?}\n{report}");
        assert_eq!((failures[0].state, failures[0].input), (t.state, t.input));
        assert_eq!(
            failures[0].verdict,
            Verdict::Disagrees(vec![Mismatch::BadFrame {
                expected: t.outcome.bad_frame
            }]),
            "{report}"
        );
    }
}

#[test]
fn wrong_ack_and_feedback_are_named() {
    let mut fake = FakeNode::new(1);
    let o = expected(NodeState::Enabled, Input::ConfigWrite);
    fake.deviation = Some((
        NodeState::Enabled,
        Input::ConfigWrite,
        Outcome {
            ack: Some(message::ConfigResult::Accepted),
            ..o
        },
    ));
    let report = run_fake(fake);
    let f: Vec<_> = report.failures().map(|r| r.to_string()).collect();
    assert_eq!(
        f,
        vec![
            "DISAGREES Enabled × ConfigWrite (table: ConfigAck NotDisabled): ConfigAck: \
             expected ConfigAck NotDisabled, observed ConfigAck Accepted"
        ]
    );

    let mut fake = FakeNode::new(1);
    fake.deviation = Some((
        NodeState::EStop,
        Input::SetpointSync,
        Outcome {
            feedback: None,
            ..expected(NodeState::EStop, Input::SetpointSync)
        },
    ));
    let report = run_fake(fake);
    let f: Vec<_> = report.failures().map(|r| r.to_string()).collect();
    assert_eq!(
        f,
        vec![
            "DISAGREES EStop × Setpoint + SYNC (table: Feedback E=0 F=1): Feedback: \
             expected Feedback E=0 F=1, observed no Feedback"
        ]
    );
}

#[test]
fn a_state_change_without_its_heartbeat_at_once_is_reported() {
    let mut fake = FakeNode::new(4);
    fake.heartbeat_on_change = false;
    let report = run_fake(fake);
    // Every row that changes the state, and only those (the periodic
    // heartbeat still brings the new state within the window).
    let changing: Vec<_> = TRANSITIONS
        .iter()
        .filter(|t| t.state != NodeState::Boot && t.outcome.next != t.state)
        .map(|t| (t.state, t.input))
        .collect();
    let late: Vec<_> = report
        .failures()
        .filter(|r| {
            matches!(&r.verdict, Verdict::Disagrees(ms)
                if ms.iter().all(|m| matches!(m, Mismatch::LateHeartbeat { .. })))
        })
        .map(|r| (r.state, r.input))
        .collect();
    // A row is only judged late if the periodic heartbeat did not happen
    // to fall within the allowed 50 ms; at least some must be caught, and
    // nothing else may be reported.
    assert!(!late.is_empty(), "{report}");
    assert!(late.iter().all(|r| changing.contains(r)), "{report}");
    assert_eq!(report.failures().count(), late.len(), "{report}");
}

#[test]
fn a_silent_node_is_an_error_naming_it() {
    let mut fake = FakeNode::new(9);
    fake.silent = true;
    let e = run(
        &mut FakeWire::new(fake),
        &Options::new(node(9), Variant::Classic),
    )
    .unwrap_err();
    assert!(matches!(e, ConformError::Silent { node: 9, .. }), "{e}");
    assert!(e.to_string().contains("node 9 sent no heartbeat"), "{e}");
}
