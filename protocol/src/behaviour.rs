//! The node's state machine as data: what a node in each state does with
//! each host input, as far as the host can see it on the wire.
//!
//! [`TRANSITIONS`] is the rule table of `protocol/README.md` ("The node's
//! required behaviour"): the README's transition table is generated from it
//! ([`crate::doc::transitions_markdown`], a test checks the text), the
//! simulated node is checked against it, and `anguilla conform` drives a
//! real node through every row. Each row says only what is observable:
//! the `State` of the next heartbeat, whether a heartbeat reports
//! `BAD_FRAME`, the `Result` of a `ConfigAck` and the flags of the
//! `Feedback` answering a SYNC.
//!
//! ```
//! use anguilla_protocol::behaviour::{expected, Input};
//! use anguilla_protocol::message::{ConfigResult, NodeState};
//!
//! // Enable outside Disabled is ignored and reported with BAD_FRAME.
//! let o = expected(NodeState::Fault, Input::Enable);
//! assert_eq!(o.next, NodeState::Fault);
//! assert!(o.bad_frame);
//! // Configuration is refused outside Disabled.
//! let o = expected(NodeState::Enabled, Input::ConfigWrite);
//! assert_eq!(o.ack, Some(ConfigResult::NotDisabled));
//! ```

use crate::message::{ConfigResult, NodeState};

/// Every state of the node's state machine, in heartbeat `State` order.
pub const STATES: [NodeState; 5] = [
    NodeState::Boot,
    NodeState::Disabled,
    NodeState::Enabled,
    NodeState::Fault,
    NodeState::EStop,
];

/// A host input the rules cover: one frame (or, for
/// [`Input::SetpointSync`], one setpoint and its SYNC) addressed to the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Input {
    /// Command 1 Enable.
    Enable,
    /// Command 2 Disable.
    Disable,
    /// Command 3 ClearFaults (no fault condition persisting).
    ClearFaults,
    /// An EStop frame (0x000 or 0x000 + node).
    EStop,
    /// A valid ConfigWrite for a value every node supports (SafeAction Limp).
    ConfigWrite,
    /// A setpoint tagged for the next SYNC, then that SYNC.
    SetpointSync,
    /// A frame for this node that does not decode (a Command with value 0).
    BadFrame,
}

impl Input {
    /// Every input, in the order of the README's columns.
    pub const ALL: [Input; 7] = [
        Input::Enable,
        Input::Disable,
        Input::ClearFaults,
        Input::EStop,
        Input::ConfigWrite,
        Input::SetpointSync,
        Input::BadFrame,
    ];

    /// The input's name as the README's column heading writes it.
    pub const fn name(self) -> &'static str {
        match self {
            Input::Enable => "Enable",
            Input::Disable => "Disable",
            Input::ClearFaults => "ClearFaults",
            Input::EStop => "EStop",
            Input::ConfigWrite => "ConfigWrite",
            Input::SetpointSync => "Setpoint + SYNC",
            Input::BadFrame => "bad frame",
        }
    }
}

/// The `Feedback` flags a node sends in answer to a SYNC.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FeedbackFlags {
    /// `Enabled` bit.
    pub enabled: bool,
    /// `Fault` bit (node in Fault or EStop).
    pub fault: bool,
}

/// What the host sees after one input: the expectation of one row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Outcome {
    /// The state the node is in afterwards (its heartbeat `State`); a change
    /// is announced by a heartbeat at once.
    pub next: NodeState,
    /// Whether the next heartbeat reports `BAD_FRAME`.
    pub bad_frame: bool,
    /// The `Result` of the `ConfigAck` the node answers with; `None`: no
    /// ConfigAck.
    pub ack: Option<ConfigResult>,
    /// The `Feedback` the node sends at the SYNC; `None`: no Feedback.
    pub feedback: Option<FeedbackFlags>,
}

/// One rule: in `state`, on `input`, the node does `outcome`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Transition {
    /// The state the node is in when the input arrives.
    pub state: NodeState,
    /// The input.
    pub input: Input,
    /// What the host sees afterwards.
    pub outcome: Outcome,
}

/// The name of a state as the heartbeat's value table writes it.
pub const fn state_name(s: NodeState) -> &'static str {
    match s {
        NodeState::Boot => "Boot",
        NodeState::Disabled => "Disabled",
        NodeState::Enabled => "Enabled",
        NodeState::Fault => "Fault",
        NodeState::EStop => "EStop",
    }
}

/// The name of a ConfigAck result as its value table writes it.
pub const fn result_name(r: ConfigResult) -> &'static str {
    match r {
        ConfigResult::Accepted => "Accepted",
        ConfigResult::OutOfRange => "OutOfRange",
        ConfigResult::NotDisabled => "NotDisabled",
    }
}

const fn to(next: NodeState) -> Outcome {
    Outcome {
        next,
        bad_frame: false,
        ack: None,
        feedback: None,
    }
}

const fn bad(stay: NodeState) -> Outcome {
    Outcome {
        bad_frame: true,
        ..to(stay)
    }
}

const fn ack(stay: NodeState, r: ConfigResult) -> Outcome {
    Outcome {
        ack: Some(r),
        ..to(stay)
    }
}

const fn fb(stay: NodeState, enabled: bool, fault: bool) -> Outcome {
    Outcome {
        feedback: Some(FeedbackFlags { enabled, fault }),
        ..to(stay)
    }
}

const fn row(state: NodeState, input: Input, outcome: Outcome) -> Transition {
    Transition {
        state,
        input,
        outcome,
    }
}

use ConfigResult::{Accepted, NotDisabled};
use Input::{BadFrame, ClearFaults, ConfigWrite, Disable, EStop, Enable, SetpointSync};
use NodeState as S;

/// The rules, one row per (state, input), states in [`STATES`] order and
/// inputs in [`Input::ALL`] order.
///
/// The principles behind them (the README's prose): Enable is valid only in
/// Disabled and reported with `BAD_FRAME` elsewhere; Disable and ClearFaults
/// are ignored without `BAD_FRAME` where they do not apply, because the host
/// repeats Disable while its nodes are off and broadcasts ClearFaults on a
/// reset; an E-stop wins in every state; every ConfigWrite is answered, and
/// only Disabled accepts it; every state but Boot answers a SYNC with
/// feedback; a frame that does not decode is reported everywhere.
pub const TRANSITIONS: [Transition; 35] = [
    row(S::Boot, Enable, bad(S::Boot)),
    row(S::Boot, Disable, to(S::Boot)),
    row(S::Boot, ClearFaults, to(S::Boot)),
    row(S::Boot, EStop, to(S::EStop)),
    row(S::Boot, ConfigWrite, ack(S::Boot, NotDisabled)),
    row(S::Boot, SetpointSync, to(S::Boot)),
    row(S::Boot, BadFrame, bad(S::Boot)),
    row(S::Disabled, Enable, to(S::Enabled)),
    row(S::Disabled, Disable, to(S::Disabled)),
    row(S::Disabled, ClearFaults, to(S::Disabled)),
    row(S::Disabled, EStop, to(S::EStop)),
    row(S::Disabled, ConfigWrite, ack(S::Disabled, Accepted)),
    row(S::Disabled, SetpointSync, fb(S::Disabled, false, false)),
    row(S::Disabled, BadFrame, bad(S::Disabled)),
    row(S::Enabled, Enable, bad(S::Enabled)),
    row(S::Enabled, Disable, to(S::Disabled)),
    row(S::Enabled, ClearFaults, to(S::Enabled)),
    row(S::Enabled, EStop, to(S::EStop)),
    row(S::Enabled, ConfigWrite, ack(S::Enabled, NotDisabled)),
    row(S::Enabled, SetpointSync, fb(S::Enabled, true, false)),
    row(S::Enabled, BadFrame, bad(S::Enabled)),
    row(S::Fault, Enable, bad(S::Fault)),
    row(S::Fault, Disable, to(S::Fault)),
    row(S::Fault, ClearFaults, to(S::Disabled)),
    row(S::Fault, EStop, to(S::EStop)),
    row(S::Fault, ConfigWrite, ack(S::Fault, NotDisabled)),
    row(S::Fault, SetpointSync, fb(S::Fault, false, true)),
    row(S::Fault, BadFrame, bad(S::Fault)),
    row(S::EStop, Enable, bad(S::EStop)),
    row(S::EStop, Disable, to(S::EStop)),
    row(S::EStop, ClearFaults, to(S::Disabled)),
    row(S::EStop, EStop, to(S::EStop)),
    row(S::EStop, ConfigWrite, ack(S::EStop, NotDisabled)),
    row(S::EStop, SetpointSync, fb(S::EStop, false, true)),
    row(S::EStop, BadFrame, bad(S::EStop)),
];

/// The row of (`state`, `input`): what the host must see.
pub fn expected(state: NodeState, input: Input) -> Outcome {
    TRANSITIONS[index(state, input)].outcome
}

/// The position of (`state`, `input`) in [`TRANSITIONS`].
pub fn index(state: NodeState, input: Input) -> usize {
    let s = STATES.iter().position(|&x| x == state).unwrap_or(0);
    let i = Input::ALL.iter().position(|&x| x == input).unwrap_or(0);
    s * Input::ALL.len() + i
}

/// One cell of the README's table: what the host sees, in words.
pub fn describe(state: NodeState, o: &Outcome) -> String {
    let mut parts: Vec<String> = Vec::new();
    if o.next != state {
        parts.push(format!("→ {}", state_name(o.next)));
    }
    if o.bad_frame {
        parts.push("BAD_FRAME".into());
    }
    if let Some(r) = o.ack {
        parts.push(format!("ConfigAck {}", result_name(r)));
    }
    if let Some(f) = o.feedback {
        parts.push(format!(
            "Feedback E={} F={}",
            u8::from(f.enabled),
            u8::from(f.fault)
        ));
    }
    if parts.is_empty() {
        "—".into()
    } else {
        parts.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_row_per_state_and_input_in_order() {
        for (k, t) in TRANSITIONS.iter().enumerate() {
            assert_eq!(index(t.state, t.input), k, "{t:?}");
        }
    }

    #[test]
    fn the_principles_hold_in_every_row() {
        for t in TRANSITIONS {
            let o = t.outcome;
            // An E-stop wins everywhere.
            if t.input == EStop {
                assert_eq!(o.next, S::EStop, "{t:?}");
            }
            // Only Enable, Disable, ClearFaults and EStop change the state.
            if matches!(t.input, ConfigWrite | SetpointSync | BadFrame) {
                assert_eq!(o.next, t.state, "{t:?}");
            }
            // Every ConfigWrite is answered, and accepted only in Disabled.
            assert_eq!(o.ack.is_some(), t.input == ConfigWrite, "{t:?}");
            if t.input == ConfigWrite {
                assert_eq!(o.ack == Some(Accepted), t.state == S::Disabled, "{t:?}");
            }
            // Repeated Disable and broadcast ClearFaults never raise BAD_FRAME.
            if matches!(t.input, Disable | ClearFaults) {
                assert!(!o.bad_frame, "{t:?}");
            }
            // Feedback flags say the state.
            if let Some(f) = o.feedback {
                assert_eq!(f.enabled, o.next == S::Enabled, "{t:?}");
                assert_eq!(f.fault, matches!(o.next, S::Fault | S::EStop), "{t:?}");
            }
            assert_eq!(
                o.feedback.is_some(),
                t.input == SetpointSync && t.state != S::Boot,
                "{t:?}"
            );
        }
    }

    #[test]
    fn cells_read_as_the_readme_writes_them() {
        assert_eq!(
            describe(S::Disabled, &expected(S::Disabled, Enable)),
            "→ Enabled"
        );
        assert_eq!(describe(S::Fault, &expected(S::Fault, Disable)), "—");
        assert_eq!(
            describe(S::Enabled, &expected(S::Enabled, SetpointSync)),
            "Feedback E=1 F=0"
        );
    }
}
