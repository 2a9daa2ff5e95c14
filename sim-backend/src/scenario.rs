//! Fault-injection scenarios: a small line-based text format with times.
//!
//! One event per line, `TIME TARGET ...`; `#` starts a comment; blank lines
//! are ignored. Times are seconds since the simulation started (`1.5`,
//! `1.5s`, `1500ms`) and never go backwards. Durations take the same units.
//!
//! ```text
//! # node faults (by node id on the bus; for bought drives, cia402 or
//! # odrive, by joint number: "node 3" is joint 3's two drives)
//! 1.0  node 3 silent          # stops sending and hearing (for ever)
//! 1.0  node 3 silent 0.5      # ... for 0.5 s
//! 2.0  node 3 speak           # ends a silence
//! 2.5  node 3 reboot          # power cycle: boots again, volatile config lost
//! 3.0  node 3 fault           # a latched drive fault (over-temperature)...
//! 3.5  node 3 clear           # ... whose cause is gone (a fault reset clears it)
//! 1.0  node 5 spoof           # dies, and another sender forges its heartbeats
//!                             # (every 50 ms, the state the other nodes report,
//!                             # a counter +1 each): a dead joint masked
//! 1.0  node 5 twin            # a second node configured to id 5 (anguilla
//!                             # nodes): its own heartbeats, counter of its own
//! # joint faults (joint 1 is the one nearest the head; pitch or yaw)
//! 0.5  joint 4 yaw stuck      # jammed: does not move whatever the torque
//! 0.9  joint 4 yaw free       # unjammed
//! 1.0  joint 2 pitch torque-limit 0.5   # saturates at 0.5 N·m
//! 1.0  joint 2 pitch torque-limit off
//! 1.0  joint 2 pitch noise 0.01         # extra encoder noise (rad, std dev)
//! 1.2  joint 2 yaw spike 0.3            # one reading off by 0.3 rad
//! 1.5  joint 7 yaw snag 0.5             # an external 0.5 N·m on the axis (0: off)
//! # bus faults (in-process bus only, except flood)
//! 3.0  bus drop 5             # the next 5 frames on the wire are lost
//! 3.0  bus drop-fraction 0.1  # each frame lost with probability 0.1 (0 ends)
//! 3.0  bus delay 2ms          # every frame occupies the wire 2 ms longer
//! 3.0  bus corrupt 3          # one data bit flipped in each of the next 3
//! 4.0  bus bus-off 0.2        # the robot's controller is bus-off for 0.2 s
//! 5.0  bus flood 1000         # 1000 frames with unused ids over 0.1 s
//! 5.0  bus flood 1000 1s      # ... spread over 1 s
//! 6.0  bus clear              # ends drop-fraction, delay and pending drops
//! # the water (earth frame, m/s; e1 is the robot's initial axis, head at -e1)
//! 2.0  water current 0.1 0     # a current of 0.1 m/s along e1 (head-on)
//! 4.0  water current 0 -0.2 0  # VX VY [VZ]: now 0.2 m/s sideways
//! 6.0  water current 0 0       # still water again
//! # head sensor faults (a robot with a head sensor only)
//! 1.0  sensor silent          # sends nothing (for ever)
//! 1.0  sensor silent 0.5      # ... for 0.5 s
//! 2.0  sensor stuck           # repeats the last sample's values
//! 2.5  sensor bias-jump 0.05  # a step of 0.05 rad/s in the gyro bias (may be negative)
//! 3.0  sensor ok              # ends silent and stuck
//! ```
//!
//! Parsing never panics; every error names the line and says what was
//! expected ([`ScenarioError`]).

use anguilla_model::{Current, MAX_CURRENT};
use std::time::Duration;

pub use crate::sensor::SensorFault;

/// A scenario line that could not be parsed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("scenario line {line}: {reason}")]
pub struct ScenarioError {
    /// 1-based line number.
    pub line: usize,
    /// What was wrong and what was expected.
    pub reason: String,
}

/// Pitch (0) or yaw (1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Pitch, axis 0.
    Pitch,
    /// Yaw, axis 1.
    Yaw,
}

impl Axis {
    /// The axis index of the node (0 pitch, 1 yaw).
    pub fn index(self) -> usize {
        match self {
            Axis::Pitch => 0,
            Axis::Yaw => 1,
        }
    }
}

/// A fault of one node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NodeFault {
    /// Neither sends nor hears anything, for a duration or for ever.
    Silent(Option<Duration>),
    /// Ends a silence.
    Speak,
    /// Power cycle.
    Reboot,
    /// A latched drive fault (over-temperature: the node's
    /// `OVER_TEMPERATURE` bit, a CiA 402 drive's EMCY 0x4210, an ODrive's
    /// `MOTOR_OVER_TEMP`) until `clear`; a fault reset clears it after that.
    Fault,
    /// Removes the cause of a `fault`.
    Clear,
    /// The node dies (silent for ever) and another sender on the bus forges
    /// its heartbeats: every 50 ms, with the state the robot's first other
    /// node reports (Enabled while the robot is enabled) and a counter
    /// that advances by one, as a careful forger would.
    Spoof,
    /// A second node is configured to this id (anguilla nodes only, whose
    /// heartbeats carry a counter): it sends its own heartbeats, with the
    /// node's state and a counter of its own, beside the node's.
    Twin,
}

/// A fault of one joint axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointFault {
    /// Jammed (`true`) or free again (`false`).
    Stuck(bool),
    /// Torque saturates at this value (N·m); `None` restores the actuator's
    /// own limit.
    TorqueLimit(Option<f64>),
    /// Extra encoder noise (rad, standard deviation).
    Noise(f64),
    /// One encoder reading offset by this much (rad).
    Spike(f64),
    /// A snag: this external torque (N·m) on the axis from now on (a line
    /// caught on the segment, a tether pulling); 0 ends it.
    Snag(f64),
}

/// A fault of the bus.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BusFault {
    /// The next n frames on the wire are lost.
    Drop(u64),
    /// Each frame is lost with this probability.
    DropFraction(f64),
    /// Every frame occupies the wire this much longer.
    Delay(Duration),
    /// One data bit is flipped in each of the next n frames.
    Corrupt(u64),
    /// The robot's controller is bus-off for this long.
    BusOff(Duration),
    /// `count` frames with ids the protocol does not use, spread over
    /// `over`.
    Flood {
        /// Number of frames.
        count: u64,
        /// Time over which they are sent.
        over: Duration,
    },
    /// Ends drops, drop fraction, delay and corruption.
    Clear,
}

impl BusFault {
    /// Whether this fault needs the in-process bus's fault hooks (all but
    /// the flood, which the robot can send on any bus).
    pub fn needs_mem_bus(&self) -> bool {
        !matches!(self, BusFault::Flood { .. })
    }
}

/// What happens at an event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// A node fault (by node id).
    Node {
        /// The node id.
        id: u8,
        /// The fault.
        fault: NodeFault,
    },
    /// A joint fault (joint 1 nearest the head).
    Joint {
        /// 1-based joint index.
        joint: usize,
        /// Pitch or yaw.
        axis: Axis,
        /// The fault.
        fault: JointFault,
    },
    /// A bus fault.
    Bus(BusFault),
    /// The water's uniform current (earth frame) from now on: `water current
    /// VX VY [VZ]` (m/s), steady.
    Water(Current),
    /// A head sensor fault.
    Sensor(SensorFault),
}

/// One timed event of a scenario.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    /// When, from the start of the simulation.
    pub at: Duration,
    /// The line it came from (1-based), for error messages.
    pub line: usize,
    /// What happens.
    pub action: Action,
}

/// A parsed scenario: events in time order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scenario {
    /// The events, in the order of the file (times never decrease).
    pub events: Vec<Event>,
}

const NODE_FAULTS: &str = "silent [DURATION], speak, reboot, fault, clear, spoof, twin";
const JOINT_FAULTS: &str = "stuck, free, torque-limit N·m|off, noise RAD, spike RAD, snag N·m";
const SENSOR_FAULTS: &str = "silent [DURATION], stuck, bias-jump RAD/S, ok";
const BUS_FAULTS: &str = "drop N, drop-fraction F, delay DURATION, corrupt N, bus-off DURATION, flood N [DURATION], clear";

/// Parses a time or duration: seconds, with an optional `s`, `ms` or `us`
/// suffix; finite, non-negative and at most 10⁶ s.
pub fn parse_duration(word: &str) -> Option<Duration> {
    let (num, scale) = if let Some(n) = word.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = word.strip_suffix("us") {
        (n, 1e-6)
    } else if let Some(n) = word.strip_suffix('s') {
        (n, 1.0)
    } else {
        (word, 1.0)
    };
    let v: f64 = num.parse().ok()?;
    let secs = v * scale;
    if !(secs.is_finite() && (0.0..=1e6).contains(&secs)) {
        return None;
    }
    Some(Duration::from_secs_f64(secs))
}

impl Scenario {
    /// Parses `text`. `node_ids` are the robot's node ids, joint `j` being
    /// `node_ids[j - 1]` (for bought drive families they are the joint
    /// numbers `1..=n`, so `node N` is joint `N`'s drives): a node or joint
    /// that does not exist is an error.
    pub fn parse(text: &str, node_ids: &[u8]) -> Result<Self, ScenarioError> {
        let mut events = Vec::new();
        let mut last = Duration::ZERO;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.split('#').next().unwrap_or("");
            let words: Vec<&str> = content.split_whitespace().collect();
            if words.is_empty() {
                continue;
            }
            let err = |reason: String| ScenarioError { line, reason };
            let at = parse_duration(words[0]).ok_or_else(|| {
                err(format!(
                    "bad time '{}': expected seconds such as 1.5, 1.5s or 1500ms",
                    words[0]
                ))
            })?;
            if at < last {
                return Err(err(format!(
                    "time {} s is before the previous event's {} s: times must not go backwards",
                    at.as_secs_f64(),
                    last.as_secs_f64()
                )));
            }
            last = at;
            let action = parse_action(&words[1..], node_ids).map_err(err)?;
            events.push(Event { at, line, action });
        }
        Ok(Self { events })
    }

    /// The first event that scripts a head sensor fault, if any.
    pub fn first_sensor_fault(&self) -> Option<&Event> {
        self.events
            .iter()
            .find(|e| matches!(e.action, Action::Sensor(_)))
    }

    /// The first event that needs the in-process bus, if any.
    pub fn first_mem_only(&self) -> Option<&Event> {
        self.events
            .iter()
            .find(|e| matches!(e.action, Action::Bus(b) if b.needs_mem_bus()))
    }
}

fn number<T: std::str::FromStr>(w: Option<&&str>, what: &str) -> Result<T, String> {
    let w = w.ok_or_else(|| format!("missing {what}"))?;
    w.parse()
        .map_err(|_| format!("bad number '{w}': expected {what}"))
}

fn real(w: Option<&&str>, what: &str, max: f64) -> Result<f64, String> {
    let v: f64 = number(w, what)?;
    if v.is_finite() && (0.0..=max).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{what} {v} out of range 0..={max}"))
    }
}

fn duration(w: Option<&&str>, what: &str) -> Result<Duration, String> {
    let w = w.ok_or_else(|| format!("missing {what}"))?;
    parse_duration(w)
        .ok_or_else(|| format!("bad duration '{w}': expected {what} such as 0.2, 0.2s or 200ms"))
}

fn no_more(words: &[&str], n: usize) -> Result<(), String> {
    match words.get(n) {
        Some(w) => Err(format!("unexpected '{w}' at the end of the line")),
        None => Ok(()),
    }
}

fn parse_action(words: &[&str], node_ids: &[u8]) -> Result<Action, String> {
    match words.first().copied() {
        Some("sensor") => {
            let (fault, n) = match words.get(1).copied() {
                Some("silent") => match words.get(2) {
                    Some(_) => (
                        SensorFault::Silent(Some(duration(words.get(2), "a duration")?)),
                        3,
                    ),
                    None => (SensorFault::Silent(None), 2),
                },
                Some("stuck") => (SensorFault::Stuck, 2),
                Some("bias-jump") => {
                    let r: f64 = number(words.get(2), "a gyro bias step in rad/s")?;
                    if !(r.is_finite() && r.abs() <= 35.0) {
                        return Err(format!("gyro bias step {r} rad/s out of range -35..=35"));
                    }
                    (SensorFault::BiasJump(r), 3)
                }
                Some("ok") => (SensorFault::Ok, 2),
                Some(other) => {
                    return Err(format!(
                        "unknown sensor fault '{other}': expected one of {SENSOR_FAULTS}"
                    ));
                }
                None => {
                    return Err(format!(
                        "missing sensor fault: expected one of {SENSOR_FAULTS}"
                    ));
                }
            };
            no_more(words, n)?;
            Ok(Action::Sensor(fault))
        }
        Some("node") => {
            let id: u8 = number(words.get(1), "a node id")?;
            if !node_ids.contains(&id) {
                return Err(format!(
                    "node {id} does not exist (the robot's nodes are {node_ids:?})"
                ));
            }
            let (fault, n) = match words.get(2).copied() {
                Some("silent") => match words.get(3) {
                    Some(_) => (
                        NodeFault::Silent(Some(duration(words.get(3), "a duration")?)),
                        4,
                    ),
                    None => (NodeFault::Silent(None), 3),
                },
                Some("speak") => (NodeFault::Speak, 3),
                Some("reboot") => (NodeFault::Reboot, 3),
                Some("fault") => (NodeFault::Fault, 3),
                Some("clear") => (NodeFault::Clear, 3),
                Some("spoof") => (NodeFault::Spoof, 3),
                Some("twin") => (NodeFault::Twin, 3),
                Some(other) => {
                    return Err(format!(
                        "unknown node fault '{other}': expected one of {NODE_FAULTS}"
                    ));
                }
                None => return Err(format!("missing node fault: expected one of {NODE_FAULTS}")),
            };
            no_more(words, n)?;
            Ok(Action::Node { id, fault })
        }
        Some("joint") => {
            let joint: usize = number(words.get(1), "a joint number")?;
            if joint == 0 || joint > node_ids.len() {
                return Err(format!(
                    "joint {joint} does not exist (joints are 1..={})",
                    node_ids.len()
                ));
            }
            let axis = match words.get(2).copied() {
                Some("pitch") => Axis::Pitch,
                Some("yaw") => Axis::Yaw,
                Some(other) => {
                    return Err(format!("unknown axis '{other}': expected pitch or yaw"));
                }
                None => return Err("missing axis: expected pitch or yaw".into()),
            };
            let (fault, n) = match words.get(3).copied() {
                Some("stuck") => (JointFault::Stuck(true), 4),
                Some("free") => (JointFault::Stuck(false), 4),
                Some("torque-limit") => match words.get(4).copied() {
                    Some("off") => (JointFault::TorqueLimit(None), 5),
                    _ => (
                        JointFault::TorqueLimit(Some(real(words.get(4), "a torque in N·m", 1e3)?)),
                        5,
                    ),
                },
                Some("noise") => (
                    JointFault::Noise(real(words.get(4), "a noise in rad", 10.0)?),
                    5,
                ),
                Some("snag") => {
                    let v: f64 = number(words.get(4), "a torque in N·m")?;
                    if !(v.is_finite() && v.abs() <= 100.0) {
                        return Err(format!("snag {v} out of range -100..=100 N·m"));
                    }
                    (JointFault::Snag(v), 5)
                }
                Some("spike") => {
                    let v: f64 = number(words.get(4), "a spike in rad")?;
                    if !(v.is_finite() && v.abs() <= 10.0) {
                        return Err(format!("spike {v} out of range -10..=10 rad"));
                    }
                    (JointFault::Spike(v), 5)
                }
                Some(other) => {
                    return Err(format!(
                        "unknown joint fault '{other}': expected one of {JOINT_FAULTS}"
                    ));
                }
                None => {
                    return Err(format!(
                        "missing joint fault: expected one of {JOINT_FAULTS}"
                    ));
                }
            };
            no_more(words, n)?;
            Ok(Action::Joint { joint, axis, fault })
        }
        Some("bus") => {
            let (fault, n) = match words.get(1).copied() {
                Some("drop") => (BusFault::Drop(number(words.get(2), "a frame count")?), 3),
                Some("drop-fraction") => (
                    BusFault::DropFraction(real(words.get(2), "a fraction", 1.0)?),
                    3,
                ),
                Some("delay") => (BusFault::Delay(duration(words.get(2), "a delay")?), 3),
                Some("corrupt") => (BusFault::Corrupt(number(words.get(2), "a frame count")?), 3),
                Some("bus-off") => (BusFault::BusOff(duration(words.get(2), "a duration")?), 3),
                Some("flood") => {
                    let count: u64 = number(words.get(2), "a frame count")?;
                    if count > 10_000_000 {
                        return Err(format!("flood of {count} frames: at most 10000000"));
                    }
                    match words.get(3) {
                        Some(_) => (
                            BusFault::Flood {
                                count,
                                over: duration(words.get(3), "a duration")?,
                            },
                            4,
                        ),
                        None => (
                            BusFault::Flood {
                                count,
                                over: Duration::from_millis(100),
                            },
                            3,
                        ),
                    }
                }
                Some("clear") => (BusFault::Clear, 2),
                Some(other) => {
                    return Err(format!(
                        "unknown bus fault '{other}': expected one of {BUS_FAULTS}"
                    ));
                }
                None => return Err(format!("missing bus fault: expected one of {BUS_FAULTS}")),
            };
            no_more(words, n)?;
            Ok(Action::Bus(fault))
        }
        Some("water") => {
            match words.get(1).copied() {
                Some("current") => {}
                Some(other) => {
                    return Err(format!(
                        "unknown water setting '{other}': expected current VX VY [VZ]"
                    ));
                }
                None => return Err("missing water setting: expected current VX VY [VZ]".into()),
            }
            let mut v = [0.0; 3];
            for (k, (c, name)) in v.iter_mut().zip(["VX", "VY", "VZ"]).enumerate() {
                let w = words.get(2 + k);
                if k == 2 && w.is_none() {
                    break;
                }
                let what = format!("the current's {name} in m/s (earth frame)");
                let x: f64 = number(w, &what)?;
                if !(x.is_finite() && x.abs() <= MAX_CURRENT) {
                    return Err(format!(
                        "current {name} {x} out of range -{MAX_CURRENT}..={MAX_CURRENT} m/s"
                    ));
                }
                *c = x;
            }
            no_more(words, 5)?;
            let current = Current::steady(v).map_err(|e| e.to_string())?;
            Ok(Action::Water(current))
        }
        Some(other) => Err(format!(
            "unknown target '{other}': expected node, joint, bus, water or sensor"
        )),
        None => {
            Err("missing target after the time: expected node, joint, bus, water or sensor".into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    const IDS: [u8; 4] = [1, 2, 3, 4];

    #[test]
    fn every_fault_of_the_language_parses() {
        let text = "\
# header
0.5 joint 4 yaw stuck
0.9 joint 4 yaw free   # comment
1 node 3 silent
1.0s node 3 silent 500ms
1.0 joint 2 pitch torque-limit 0.5
1.0 joint 2 pitch torque-limit off
1.0 joint 2 pitch noise 0.01
1.2 joint 2 yaw spike -0.3
1.3 joint 4 yaw snag -0.5
2.0 node 3 speak
2.5 node 3 reboot
3000ms bus drop 5
3.0 bus drop-fraction 0.1
3.0 bus delay 2ms
3.0 bus corrupt 3
4.0 bus bus-off 0.2

5.0 bus flood 1000
5.0 bus flood 10 1s
6 bus clear
";
        let s = Scenario::parse(text, &IDS).unwrap();
        assert_eq!(s.events.len(), 19);
        assert_eq!(s.events[0].line, 2);
        assert_eq!(
            s.events[3].action,
            Action::Node {
                id: 3,
                fault: NodeFault::Silent(Some(Duration::from_millis(500)))
            }
        );
        assert_eq!(
            s.events[7].action,
            Action::Joint {
                joint: 2,
                axis: Axis::Yaw,
                fault: JointFault::Spike(-0.3)
            }
        );
        assert_eq!(
            s.events[8].action,
            Action::Joint {
                joint: 4,
                axis: Axis::Yaw,
                fault: JointFault::Snag(-0.5)
            }
        );
        assert_eq!(s.events[11].at, Duration::from_secs(3));
        assert_eq!(
            s.events[17].action,
            Action::Bus(BusFault::Flood {
                count: 10,
                over: Duration::from_secs(1)
            })
        );
        assert!(s.first_mem_only().is_some());
    }

    fn error(text: &str) -> ScenarioError {
        Scenario::parse(text, &IDS).unwrap_err()
    }

    #[test]
    fn errors_name_the_line_and_what_was_expected() {
        let e = error("0.1 node 1 reboot\n\n0.2 node 1 explode\n");
        assert_eq!(e.line, 3);
        assert!(e.reason.contains("unknown node fault 'explode'"), "{e}");
        assert!(e.to_string().starts_with("scenario line 3:"), "{e}");

        let e = error("1.0 node 1 reboot\n0.5 node 2 reboot\n");
        assert_eq!(e.line, 2);
        assert!(e.reason.contains("before the previous"), "{e}");

        let e = error("1.0 node 9 reboot");
        assert_eq!(e.line, 1);
        assert!(e.reason.contains("node 9 does not exist"), "{e}");

        let e = error("# c\n1.0 joint 5 pitch stuck");
        assert_eq!(e.line, 2);
        assert!(e.reason.contains("joint 5 does not exist"), "{e}");

        let e = error("abc node 1 reboot");
        assert!(e.reason.contains("bad time 'abc'"), "{e}");
        let e = error("1 bus drop x");
        assert!(e.reason.contains("bad number 'x'"), "{e}");
        let e = error("1 bus melt");
        assert!(e.reason.contains("unknown bus fault 'melt'"), "{e}");
        let e = error("1 joint 1 roll stuck");
        assert!(e.reason.contains("unknown axis 'roll'"), "{e}");
        let e = error("1 joint 1 yaw jam");
        assert!(e.reason.contains("unknown joint fault 'jam'"), "{e}");
        let e = error("1 tail wag");
        assert!(e.reason.contains("unknown target 'tail'"), "{e}");
        let e = error("1 bus drop-fraction 2");
        assert!(e.reason.contains("out of range"), "{e}");
        let e = error("1 node 1 reboot now");
        assert!(e.reason.contains("unexpected 'now'"), "{e}");
        let e = error("-1 node 1 reboot");
        assert!(e.reason.contains("bad time"), "{e}");
        let e = error("nan node 1 reboot");
        assert!(e.reason.contains("bad time"), "{e}");
        let e = error("1 sensor explode");
        assert!(e.reason.contains("unknown sensor fault 'explode'"), "{e}");
        let e = error("1 sensor bias-jump");
        assert!(e.reason.contains("missing a gyro bias step"), "{e}");
        let e = error("1 sensor bias-jump 99");
        assert!(e.reason.contains("out of range -35..=35"), "{e}");
        let e = error("1 sensor stuck now");
        assert!(e.reason.contains("unexpected 'now'"), "{e}");
    }

    #[test]
    fn sensor_faults_parse() {
        let s = Scenario::parse(
            "1 sensor silent\n1.5 sensor silent 200ms\n2 sensor stuck\n2.5 sensor bias-jump -0.05\n3 sensor ok\n",
            &IDS,
        )
        .unwrap();
        let actions: Vec<_> = s.events.iter().map(|e| e.action).collect();
        assert_eq!(
            actions,
            [
                Action::Sensor(SensorFault::Silent(None)),
                Action::Sensor(SensorFault::Silent(Some(Duration::from_millis(200)))),
                Action::Sensor(SensorFault::Stuck),
                Action::Sensor(SensorFault::BiasJump(-0.05)),
                Action::Sensor(SensorFault::Ok),
            ]
        );
        assert_eq!(s.first_sensor_fault().map(|e| e.line), Some(1));
        assert!(s.first_mem_only().is_none());
    }

    #[test]
    fn water_current_events_parse_in_the_earth_frame() {
        let s = Scenario::parse(
            "2 water current 0.1 0\n4.0 water current 0 -0.2 0.05 # comment\n6 water current 0 0\n",
            &IDS,
        )
        .unwrap();
        let v = |e: &Event| match e.action {
            Action::Water(c) => {
                assert!(c.is_steady());
                c.velocity(0.0)
            }
            a => panic!("{a:?}"),
        };
        assert_eq!(v(&s.events[0]), Vector3::new(0.1, 0.0, 0.0));
        assert_eq!(v(&s.events[1]), Vector3::new(0.0, -0.2, 0.05));
        assert_eq!(v(&s.events[2]), Vector3::zeros());
        assert_eq!(s.events[1].at, Duration::from_secs(4));
        assert!(s.first_mem_only().is_none(), "a current needs no bus hooks");

        let e = error("0.1 node 1 reboot\n1 water current 0.1");
        assert_eq!(e.line, 2);
        assert!(e.reason.contains("missing the current's VY in m/s"), "{e}");
        let e = error("1 water current x 0");
        assert!(
            e.reason
                .contains("bad number 'x': expected the current's VX"),
            "{e}"
        );
        let e = error("1 water current 0 9");
        assert!(
            e.reason.contains("current VY 9 out of range -5..=5 m/s"),
            "{e}"
        );
        let e = error("1 water current 0 0 inf");
        assert!(e.reason.contains("current VZ inf out of range"), "{e}");
        let e = error("1 water current 0 0 0 0");
        assert!(e.reason.contains("unexpected '0' at the end"), "{e}");
        let e = error("1 water temperature 12");
        assert!(
            e.reason.contains("unknown water setting 'temperature'"),
            "{e}"
        );
        let e = error("1 water");
        assert!(e.reason.contains("expected current VX VY [VZ]"), "{e}");
        let e = error("1 wind 3");
        assert!(
            e.reason
                .contains("expected node, joint, bus, water or sensor"),
            "{e}"
        );
    }

    proptest! {
        #[test]
        fn arbitrary_text_never_panics(text in "\\PC*") {
            let _ = Scenario::parse(&text, &IDS);
        }

        #[test]
        fn arbitrary_words_never_panic(
            words in proptest::collection::vec(
                prop_oneof![
                    Just("node"), Just("joint"), Just("bus"), Just("sensor"), Just("bias-jump"), Just("pitch"), Just("yaw"),
                    Just("silent"), Just("stuck"), Just("flood"), Just("torque-limit"),
                    Just("spike"), Just("1"), Just("-1"), Just("1e308"), Just("0.5ms"),
                    Just("inf"), Just("\n"), Just("#"), Just("3"), Just("bus-off"),
                    Just("water"), Just("current"), Just("0.1"), Just("nan"),
                ],
                0..12,
            )
        ) {
            let _ = Scenario::parse(&words.join(" "), &IDS);
        }
    }
}
