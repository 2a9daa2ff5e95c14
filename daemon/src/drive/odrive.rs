//! ODrive axes over CANSimple (firmware 0.6; `docs/drives.md`).
//!
//! Setpoints are not SYNC-triggered: each period sends `Set_Input_Pos`
//! (turns, velocity feed-forward turns/s, torque feed-forward N·m at the
//! motor) to every axis, applied on arrival. The drive's own watchdog
//! (`axis.config.watchdog_timeout`, set with odrivetool) must be on: it is
//! what stops an axis whose master died. Enabling sets position control
//! with passthrough input and requests closed-loop control; disabling
//! requests idle; the E-stop is CANSimple's `Estop`; a fault reset is
//! `Clear_Errors`. The axes' cyclic `Heartbeat` (axis error, state) and
//! `Get_Encoder_Estimates` are what the master knows of them.

use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{AxisFeedback, NodeState};
use anguilla_protocol::odrive::{
    self, AxisState, Body, ControlMode, InputMode, InputPos, Message, NodeId,
};

use super::bought::{DriveSet, Every, node_id};
use super::{AxisStatus, AxisView, DriveError, Drives, Out, Period};
use crate::config::{AxisMap, Config};
use crate::supervisor::Drive;
use anguilla_ipc::vocabulary::{Mode, Nanos};

/// How often the enable sequence (while enabling) or the idle request
/// (while disabled) is sent again.
pub const RESEND: Nanos = Nanos::from_millis(100);

/// `ESTOP_REQUESTED` in the axis error: the axis was E-stopped.
pub const ESTOP_REQUESTED: u32 = 0x0200_0000;

#[derive(Debug, Clone, Copy)]
struct Axis {
    map: AxisMap,
    node: NodeId,
    state: Option<AxisState>,
    error: u32,
    last_heartbeat: Option<Nanos>,
    estimate: Option<(f32, f32)>,
    /// Periods since its last encoder estimates while in closed loop (an
    /// axis sends them every `encoder_msg_rate_ms`, 10 ms by default).
    periods_without_estimates: u32,
}

impl Axis {
    fn node_state(&self) -> Option<NodeState> {
        let s = self.state?;
        Some(if self.error == ESTOP_REQUESTED {
            NodeState::EStop
        } else if self.error != 0 {
            NodeState::Fault
        } else if s == AxisState::ClosedLoopControl {
            NodeState::Enabled
        } else if s == AxisState::Idle {
            NodeState::Disabled
        } else {
            // Calibration, start-up: busy, not ours to command yet.
            NodeState::Boot
        })
    }
}

impl super::AxisView for Axis {
    fn status(&self) -> AxisStatus {
        AxisStatus {
            state: self.node_state(),
            last_heard: self.last_heartbeat,
            periods_without_feedback: self.periods_without_estimates,
        }
    }

    fn error_code(&self) -> u32 {
        self.error
    }

    fn feedback(&self) -> Option<AxisFeedback> {
        let (pos, vel) = self.estimate?;
        Some(AxisFeedback {
            position: self.map.from_turns(pos as f64) as f32,
            velocity: self.map.joint_rate(vel as f64 * std::f64::consts::TAU) as f32,
            torque: 0.0,
            limited: false,
        })
    }
}

/// The ODrive axes of a robot, two per joint.
pub struct Axes {
    set: DriveSet<Axis>,
    /// Sends the state requests again ([`RESEND`]).
    resend: Every,
}

impl Axes {
    /// The axes of `cfg` (`robot.axes`), unheard-of at `now`.
    pub fn new(cfg: &Config, now: Nanos) -> Result<Self, DriveError> {
        let set = DriveSet::new(cfg, now, |map: AxisMap| {
            Ok(Axis {
                map,
                node: node_id(
                    anguilla_protocol::Family::Odrive,
                    map.node,
                    (0, odrive::MAX_NODE_ID),
                    NodeId::new,
                )?,
                state: None,
                error: 0,
                last_heartbeat: None,
                estimate: None,
                periods_without_estimates: 0,
            })
        })?;
        Ok(Self {
            set,
            resend: Every::new(RESEND),
        })
    }

    fn send(out: &mut Out<'_>, node: NodeId, body: Body) {
        match (Message { node, body }).encode() {
            Ok(f) => out.send(&f),
            Err(_) => out.encode_failed(),
        }
    }

    fn all(&self, out: &mut Out<'_>, body: Body) {
        for a in self.set.joints.iter().flatten() {
            Self::send(out, a.node, body);
        }
    }

    fn enable(out: &mut Out<'_>, a: &Axis) {
        Self::send(
            out,
            a.node,
            Body::SetControllerMode {
                control_mode: ControlMode::PositionControl,
                input_mode: InputMode::Passthrough,
            },
        );
        Self::send(
            out,
            a.node,
            Body::SetAxisState(AxisState::ClosedLoopControl),
        );
    }

    fn input_pos(out: &mut Out<'_>, a: &Axis, position: f64, velocity: f64, torque: f64) {
        let ff = |v: f64| (v as f32).clamp(odrive::FF_MIN, odrive::FF_MAX);
        let body = Body::SetInputPos(InputPos {
            input_pos: a.map.turns(position) as f32,
            vel_ff: ff(a.map.motor_rate(velocity) / std::f64::consts::TAU),
            torque_ff: ff(a.map.motor_torque(torque)),
        });
        Self::send(out, a.node, body);
    }
}

impl Drives for Axes {
    super::bought::drive_set_answers!(set);

    fn family(&self) -> anguilla_protocol::Family {
        anguilla_protocol::Family::Odrive
    }

    /// CANSimple's cyclic messages carry no torque.
    fn measures_torque(&self) -> bool {
        false
    }

    fn ingest(&mut self, now: Nanos, frame: &Frame) {
        let Some((m, j, ax)) = self.set.addressed(odrive::decode(frame), |m| m.node.get()) else {
            return;
        };
        let a = &mut self.set.joints[j][ax];
        match m.body {
            Body::Heartbeat(hb) => {
                a.state = Some(hb.axis_state);
                a.error = hb.axis_error;
                a.last_heartbeat = Some(now);
            }
            Body::EncoderEstimates(e) => {
                a.estimate = Some((e.pos, e.vel));
                a.periods_without_estimates = 0;
            }
            Body::Estop => {
                // Someone else E-stopped one of our axes.
                self.set.counters.estops_seen += 1;
                self.set.bus_estop = true;
            }
            // Another sender changes our axis' state (idle: limp), its
            // control mode or clears its errors, behind the master's back.
            Body::SetAxisState(_) | Body::SetControllerMode { .. } | Body::ClearErrors { .. } => {
                self.set.foreign_command(j)
            }
            Body::SetInputPos(_) | Body::Request(_) => self.set.counters.foreign_commands += 1,
        }
    }

    fn estop(&mut self, out: &mut Out<'_>) {
        out.flush();
        self.all(out, Body::Estop);
    }

    fn clear_faults(&mut self, out: &mut Out<'_>) {
        self.all(out, Body::ClearErrors { identify: false });
        for a in self.set.joints.iter_mut().flatten() {
            a.state = None;
            a.error = 0;
        }
    }

    fn period(&mut self, p: &Period<'_>, out: &mut Out<'_>) {
        if p.bus_off {
            return;
        }
        // An axis in closed loop owes its cyclic encoder estimates.
        for a in self.set.joints.iter_mut().flatten() {
            a.periods_without_estimates = if a.state == Some(AxisState::ClosedLoopControl) {
                a.periods_without_estimates.saturating_add(1)
            } else {
                0
            };
        }
        match p.drive {
            Drive::Disabled => {
                if p.mode != Mode::EStop && self.resend.due(p.now, p.entering) {
                    self.all(out, Body::SetAxisState(AxisState::Idle));
                }
            }
            Drive::Enable => {
                let resend = self.resend.due(p.now, p.entering);
                for a in self.set.joints.iter().flatten() {
                    match (a.state, a.error) {
                        // In closed loop: hold where it is, feeding the
                        // drive's watchdog.
                        (Some(AxisState::ClosedLoopControl), _) => {
                            if let Some(fb) = a.feedback() {
                                Self::input_pos(out, a, fb.position as f64, 0.0, 0.0);
                            }
                        }
                        (_, 0) if resend => Self::enable(out, a),
                        _ => {}
                    }
                }
            }
            Drive::Setpoints => {
                for (a, s) in self.set.setpoints(p) {
                    Self::input_pos(
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
        self.all(out, Body::SetAxisState(AxisState::Idle));
    }
}
