//! MIT-mode quasi-direct-drive actuators (CubeMars AK, T-Motor and their
//! clones; `docs/drives.md`), one per axis.
//!
//! The protocol has no heartbeat, no state and no E-stop
//! ([`anguilla_protocol::mit`]): every frame the master sends is answered
//! by a reply carrying position, velocity, torque and (CubeMars) an error
//! code. So the master keeps what the drives cannot say:
//!
//! - **Liveness** is the last reply: disabled drives are asked every
//!   [`POLL`] (an Exit motor mode, which changes nothing in a limp drive),
//!   enabled ones answer the command of every period. A drive not heard for
//!   the heartbeat timeout is lost; one that left a frame of ours
//!   unanswered for the feedback periods is silent, in motor mode or not
//!   (counting does not stop when a fault ends motor mode).
//! - **Enabled** is motor mode, asked with Enter motor mode and confirmed
//!   by the reply that follows it. Entering, a drive holds where it is
//!   (the last reply's position, the gains [`KP`] and [`KD`]) until the
//!   first setpoint.
//! - **Setpoints** are a Command per axis and period: position, velocity
//!   feed-forward, [`KP`], [`KD`] and torque feed-forward at the actuator
//!   (the axis map's direction, offset and gear applied; velocity and torque
//!   clamped to [`anguilla_protocol::mit::DEFAULT_RANGES`], a position
//!   outside it not sent and counted).
//! - **E-stop** is Exit motor mode to every drive (limp); the master
//!   reports them in EStop until the operator clears faults. An Exit from
//!   another sender to one of our drives leaves it limp behind our back:
//!   it is taken as an E-stop on the bus.
//! - **Faults** are the reply's error code, latched: one reply carrying a
//!   code ends motor mode and reports the drive in Fault (the supervisor
//!   faults the robot) until the operator clears faults, whatever the
//!   replies after it say. Clearing sends Exit (CubeMars firmware clears a
//!   fault whose cause is gone when motor mode ends). Motor mode follows
//!   the replies: it starts with the reply that confirms our Enter, ends
//!   with a reply carrying an error code, and comes back only through
//!   another Enter of ours.
//! - **A reply with every field at the top of its range** (position,
//!   velocity and torque all ones: what a drive sends with its encoder
//!   unread, or a forger that knows no better) is counted
//!   ([`RxCounters::saturated`](super::RxCounters::saturated)) and logged
//!   once per drive ([`Notice::SaturatedReply`](super::Notice)); it still
//!   counts as the drive answering.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{AxisFeedback, NodeState};
use anguilla_protocol::mit::{self, Body, Command, DEFAULT_RANGES, Message, NodeId};

use super::bought::{DriveSet, Every, node_id};
use super::{AxisStatus, AxisView, DriveError, Drives, Out, Period};
use crate::config::{AxisMap, Config};
use crate::supervisor::Drive;
use anguilla_ipc::vocabulary::Nanos;

/// How often a drive out of motor mode is asked for a reply.
pub const POLL: Nanos = Nanos::from_millis(20);
/// How often Enter motor mode is asked again while a drive has not
/// confirmed it.
pub const RETRY: Nanos = Nanos::from_millis(100);
/// The position gain sent with every command, N·m/rad at the actuator.
pub const KP: f32 = 40.0;
/// The velocity gain sent with every command, N·m·s/rad at the actuator.
pub const KD: f32 = 1.2;

#[derive(Debug, Clone, Copy)]
struct Axis {
    map: AxisMap,
    node: NodeId,
    /// Enter motor mode sent, not yet confirmed by a reply.
    entering: bool,
    /// In motor mode (confirmed).
    motor_mode: bool,
    /// E-stopped by us, until faults are cleared.
    estopped: bool,
    /// The error code of the replies since faults were last cleared: the
    /// first nonzero one, latched.
    error: u8,
    /// A frame of ours not answered yet.
    owed: bool,
    /// Replies with every field at the top of its range.
    saturated: u64,
    last_reply: Option<Nanos>,
    /// Position, velocity, torque of the last reply, at the actuator.
    reply: Option<(f32, f32, f32)>,
    /// Periods with a frame of ours unanswered since the last reply.
    periods_without_reply: u32,
}

impl Axis {
    fn node_state(&self) -> Option<NodeState> {
        self.last_reply?;
        Some(if self.estopped {
            NodeState::EStop
        } else if self.error != 0 {
            NodeState::Fault
        } else if self.motor_mode {
            NodeState::Enabled
        } else {
            NodeState::Disabled
        })
    }
}

impl AxisView for Axis {
    fn status(&self) -> AxisStatus {
        AxisStatus {
            state: self.node_state(),
            last_heard: self.last_reply,
            periods_without_feedback: self.periods_without_reply,
        }
    }

    fn error_code(&self) -> u32 {
        self.error.into()
    }

    fn feedback(&self) -> Option<AxisFeedback> {
        let (p, v, t) = self.reply?;
        Some(AxisFeedback {
            position: self.map.joint_angle(p.into()) as f32,
            velocity: self.map.joint_rate(v.into()) as f32,
            torque: self.map.joint_torque(t.into()) as f32,
            limited: false,
        })
    }
}

/// The MIT-mode drives of a robot, two per joint.
pub struct Master {
    set: DriveSet<Axis>,
    /// Asks the drives out of motor mode for a reply ([`POLL`]).
    poll: Every,
    /// Asks for motor mode again ([`RETRY`]).
    enter: Every,
    /// The next notice for the log.
    notice: Option<super::Notice>,
}

impl Master {
    /// The drives of `cfg` (`robot.axes`), unheard-of at `now`.
    pub fn new(cfg: &Config, now: Nanos) -> Result<Self, DriveError> {
        let set = DriveSet::new(cfg, now, |map: AxisMap| {
            Ok(Axis {
                map,
                node: node_id(
                    anguilla_protocol::Family::Mit,
                    map.node,
                    (1, mit::MAX_NODE_ID),
                    NodeId::new,
                )?,
                entering: false,
                motor_mode: false,
                estopped: false,
                error: 0,
                owed: false,
                saturated: 0,
                last_reply: None,
                reply: None,
                periods_without_reply: 0,
            })
        })?;
        Ok(Self {
            set,
            poll: Every::new(POLL),
            enter: Every::new(RETRY),
            notice: None,
        })
    }

    /// Sends `body` to `a`'s drive, which owes a reply from then on.
    fn send(out: &mut Out<'_>, a: &mut Axis, body: Body) {
        match (Message { node: a.node, body }).encode(&DEFAULT_RANGES) {
            Ok(f) => {
                out.send(&f);
                a.owed = true;
            }
            Err(_) => out.encode_failed(),
        }
    }

    /// Exit motor mode to every drive: limp, and a reply from each.
    fn exit_all(&mut self, out: &mut Out<'_>) {
        for a in self.set.joints.iter_mut().flatten() {
            Self::send(out, a, Body::ExitMotorMode);
            a.motor_mode = false;
            a.entering = false;
        }
    }

    fn command(out: &mut Out<'_>, a: &mut Axis, position: f64, velocity: f64, torque: f64) {
        let r = DEFAULT_RANGES;
        let body = Body::Command(Command {
            position: a.map.motor_angle(position) as f32,
            velocity: (a.map.motor_rate(velocity) as f32).clamp(-r.velocity, r.velocity),
            kp: KP,
            kd: KD,
            torque: (a.map.motor_torque(torque) as f32).clamp(-r.torque, r.torque),
        });
        Self::send(out, a, body);
    }
}

/// Whether a reply has every field at the top of its range: position,
/// velocity and torque all ones (bytes 1..=5 of the frame).
fn saturated(frame: &Frame) -> bool {
    frame.data().get(1..6) == Some(&[0xFF; 5][..])
}

impl Drives for Master {
    super::bought::drive_set_answers!(set);

    fn family(&self) -> anguilla_protocol::Family {
        anguilla_protocol::Family::Mit
    }

    fn ingest(&mut self, now: Nanos, frame: &Frame) {
        let Some((m, j, ax)) = self
            .set
            .addressed(mit::decode(frame, &DEFAULT_RANGES), |m| m.node.get())
        else {
            return;
        };
        let a = &mut self.set.joints[j][ax];
        match m.body {
            Body::Reply(r) => {
                a.last_reply = Some(now);
                a.reply = Some((r.position, r.velocity, r.torque));
                a.periods_without_reply = 0;
                a.owed = false;
                let error = r.status.map_or(0, |s| s.error);
                if a.error == 0 {
                    // Latched until faults are cleared: one reply with a
                    // code is a fault, whatever the next ones say.
                    a.error = error;
                }
                if a.entering && a.error == 0 {
                    a.entering = false;
                    a.motor_mode = true;
                }
                if a.error != 0 {
                    // A faulted drive leaves motor mode.
                    a.motor_mode = false;
                    a.entering = false;
                }
                if saturated(frame) {
                    a.saturated += 1;
                    self.set.counters.saturated += 1;
                    if a.saturated == 1 {
                        self.notice = Some(super::Notice::SaturatedReply {
                            joint: j as u8,
                            axis: ax as u8,
                            node: a.node.get(),
                        });
                    }
                }
            }
            Body::ExitMotorMode => {
                // Someone else made one of our drives limp.
                self.set.counters.foreign_commands += 1;
                self.set.counters.estops_seen += 1;
                self.set.bus_estop = true;
            }
            // Another sender puts our drive in motor mode (zero gains: limp
            // until commanded) or moves its zero (every position after it
            // off by where the joint stood): behind the master's back.
            Body::EnterMotorMode | Body::SetZero => self.set.foreign_command(j),
            Body::Command(_) => self.set.counters.foreign_commands += 1,
        }
    }

    fn estop(&mut self, out: &mut Out<'_>) {
        out.flush();
        self.exit_all(out);
        for a in self.set.joints.iter_mut().flatten() {
            a.estopped = true;
        }
    }

    fn clear_faults(&mut self, out: &mut Out<'_>) {
        self.exit_all(out);
        for a in self.set.joints.iter_mut().flatten() {
            a.estopped = false;
            a.error = 0;
        }
    }

    fn period(&mut self, p: &Period<'_>, out: &mut Out<'_>) {
        if p.bus_off {
            return;
        }
        for a in self.set.joints.iter_mut().flatten() {
            // In motor mode or not: a faulted drive still owes replies.
            if a.owed {
                a.periods_without_reply = a.periods_without_reply.saturating_add(1);
            }
        }
        let poll = self.poll.due(p.now, false);
        match p.drive {
            Drive::Disabled => {
                if p.entering || poll {
                    self.exit_all(out);
                }
            }
            Drive::Enable => {
                let retry = self.enter.due(p.now, p.entering);
                for a in self.set.joints.iter_mut().flatten() {
                    if a.motor_mode {
                        // Hold where it is until the first setpoint.
                        if let Some(fb) = a.feedback() {
                            Self::command(out, a, fb.position.into(), 0.0, 0.0);
                        }
                    } else if a.error == 0 && !a.estopped && (retry || !a.entering) {
                        Self::send(out, a, Body::EnterMotorMode);
                        a.entering = true;
                    } else if poll && !a.entering {
                        // Faulted or E-stopped: still asked, to be heard.
                        Self::send(out, a, Body::ExitMotorMode);
                    }
                }
            }
            Drive::Setpoints => {
                for (a, s) in self.set.setpoints(p) {
                    Self::command(
                        out,
                        a,
                        s.position.into(),
                        s.velocity.into(),
                        s.torque.into(),
                    );
                }
            }
        }
    }

    fn disable_all(&mut self, out: &mut Out<'_>) {
        self.exit_all(out);
    }

    fn take_notice(&mut self) -> Option<super::Notice> {
        self.notice.take()
    }
}
