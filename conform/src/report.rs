//! The suite's findings: what a node was seen to do in one row
//! ([`Observed`]), how it differs from the table ([`Mismatch`]), the
//! verdict, and the [`Report`] of every row, printable as a table.

use std::fmt;
use std::time::Duration;

use anguilla_protocol::behaviour::{
    FeedbackFlags, Input, Outcome, describe, result_name, state_name,
};
use anguilla_protocol::message::{ConfigResult, NodeId, NodeState};

/// What the node did after one input, as seen on the wire.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Observed {
    /// The `State`s of the heartbeats in the window, repeats removed (empty:
    /// no heartbeat). A node that conforms shows the new state (perhaps
    /// after one last heartbeat of the old one) and nothing else.
    pub states: Vec<NodeState>,
    /// Whether a heartbeat in the window reported `BAD_FRAME`.
    pub bad_frame: bool,
    /// The `Result` of the first ConfigAck, if any.
    pub ack: Option<ConfigResult>,
    /// The flags of the last Feedback, if any.
    pub feedback: Option<FeedbackFlags>,
    /// Time from the input to the first heartbeat in the new state, when
    /// the state changed.
    pub change_heartbeat: Option<Duration>,
}

/// One way a row disagrees with the table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Mismatch {
    /// The heartbeat `State` afterwards.
    State {
        /// As the table says.
        expected: NodeState,
        /// The states the heartbeats showed, in order (empty: no
        /// heartbeat in the window).
        observed: Vec<NodeState>,
    },
    /// The `BAD_FRAME` bit.
    BadFrame {
        /// As the table says.
        expected: bool,
    },
    /// The ConfigAck.
    Ack {
        /// As the table says (`None`: no ConfigAck).
        expected: Option<ConfigResult>,
        /// As seen.
        observed: Option<ConfigResult>,
    },
    /// The Feedback at the SYNC.
    Feedback {
        /// As the table says (`None`: no Feedback).
        expected: Option<FeedbackFlags>,
        /// As seen.
        observed: Option<FeedbackFlags>,
    },
    /// The state changed as required but its heartbeat came late (or not
    /// in the window).
    LateHeartbeat {
        /// The new state.
        state: NodeState,
        /// When it was announced after the input (`None`: never).
        after: Option<Duration>,
        /// The allowed delay ([`Options::prompt`](crate::Options::prompt)).
        allowed: Duration,
    },
}

fn flags(f: Option<FeedbackFlags>) -> String {
    match f {
        None => "no Feedback".into(),
        Some(f) => format!("Feedback E={} F={}", u8::from(f.enabled), u8::from(f.fault)),
    }
}

impl fmt::Display for Mismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Mismatch::State { expected, observed } => {
                write!(f, "state: expected {}, observed ", state_name(*expected))?;
                if observed.is_empty() {
                    write!(f, "no heartbeat")?;
                }
                for (k, s) in observed.iter().enumerate() {
                    let sep = if k > 0 { ", then " } else { "" };
                    write!(f, "{sep}{}", state_name(*s))?;
                }
                Ok(())
            }
            Mismatch::BadFrame { expected } => write!(
                f,
                "BAD_FRAME: expected {}, observed {}",
                if *expected { "set" } else { "clear" },
                if *expected { "clear" } else { "set" }
            ),
            Mismatch::Ack { expected, observed } => {
                let name = |r: &Option<ConfigResult>| {
                    r.map_or("no ConfigAck".to_string(), |r| {
                        format!("ConfigAck {}", result_name(r))
                    })
                };
                write!(
                    f,
                    "ConfigAck: expected {}, observed {}",
                    name(expected),
                    name(observed)
                )
            }
            Mismatch::Feedback { expected, observed } => write!(
                f,
                "Feedback: expected {}, observed {}",
                flags(*expected),
                flags(*observed)
            ),
            Mismatch::LateHeartbeat {
                state,
                after,
                allowed,
            } => match after {
                Some(d) => write!(
                    f,
                    "heartbeat of the change to {}: expected within {} ms, observed after {} ms",
                    state_name(*state),
                    allowed.as_millis(),
                    d.as_millis()
                ),
                None => write!(
                    f,
                    "heartbeat of the change to {}: expected within {} ms, observed none",
                    state_name(*state),
                    allowed.as_millis()
                ),
            },
        }
    }
}

/// The verdict on one row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// The node did what the table says.
    Agrees,
    /// The node did something else.
    Disagrees(Vec<Mismatch>),
    /// The suite could not bring the node into the row's state (the
    /// message says what happened instead).
    NotReached(String),
    /// The row cannot be checked over the bus.
    NotChecked(&'static str),
}

/// One row of the report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RowReport {
    /// The state the node was brought to.
    pub state: NodeState,
    /// The input sent.
    pub input: Input,
    /// What the table says.
    pub expected: Outcome,
    /// What the node did, when the row was run.
    pub observed: Option<Observed>,
    /// The verdict.
    pub verdict: Verdict,
}

/// The suite's findings, one row per (state, input) of the table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Report {
    /// The node tested.
    pub node: NodeId,
    /// Every row, in the table's order.
    pub rows: Vec<RowReport>,
}

impl Report {
    /// The rows whose verdict is not [`Verdict::Agrees`] or
    /// [`Verdict::NotChecked`]: disagreements and states not reached.
    pub fn failures(&self) -> impl Iterator<Item = &RowReport> {
        self.rows
            .iter()
            .filter(|r| matches!(r.verdict, Verdict::Disagrees(_) | Verdict::NotReached(_)))
    }

    /// Whether every row that could be checked agrees with the table.
    pub fn conforms(&self) -> bool {
        self.failures().next().is_none()
    }

    /// Counts of (agree, disagree, not reached, not checked).
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        let mut c = (0, 0, 0, 0);
        for r in &self.rows {
            match r.verdict {
                Verdict::Agrees => c.0 += 1,
                Verdict::Disagrees(_) => c.1 += 1,
                Verdict::NotReached(_) => c.2 += 1,
                Verdict::NotChecked(_) => c.3 += 1,
            }
        }
        c
    }
}

impl fmt::Display for RowReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let head = format!("{} × {}", state_name(self.state), self.input.name());
        let exp = describe(self.state, &self.expected);
        match &self.verdict {
            Verdict::Agrees => write!(f, "ok        {head}: {exp}"),
            Verdict::Disagrees(ms) => {
                write!(f, "DISAGREES {head} (table: {exp}): ")?;
                for (k, m) in ms.iter().enumerate() {
                    if k > 0 {
                        write!(f, "; ")?;
                    }
                    write!(f, "{m}")?;
                }
                Ok(())
            }
            Verdict::NotReached(why) => write!(f, "NOT RUN   {head}: {why}"),
            Verdict::NotChecked(why) => write!(f, "skipped   {head}: {why}"),
        }
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for r in &self.rows {
            writeln!(f, "{r}")?;
        }
        let (ok, bad, unreached, skipped) = self.counts();
        writeln!(
            f,
            "node {}: {} rows: {ok} agree, {bad} disagree, {unreached} not reached, {skipped} not checked — {}",
            self.node.get(),
            self.rows.len(),
            if self.conforms() {
                "conforms"
            } else {
                "DOES NOT CONFORM"
            }
        )
    }
}
