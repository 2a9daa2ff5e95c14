//! The joint drives: between the controller and the bus.
//!
//! The controller computes, each period, a setpoint per axis (position,
//! velocity feed-forward, torque feed-forward, at the joint) and the
//! supervisor decides what the drives must do (`Drive`: disabled,
//! enabling, following setpoints) and when to E-stop or reset faults. A
//! [`Drives`] implementation turns that into its family's frames and turns
//! the frames its drives send into what the supervisor observes
//! ([`NodeReport`]) and what the operator sees ([`JointReport`]):
//!
//! - [`anguilla`]: the vertebra nodes of `protocol/README.md` (one node,
//!   two axes, per joint);
//! - [`cia402`]: CANopen CiA 402 drives in cyclic synchronous position
//!   mode, with the master's NMT, SDO configuration, PDOs, SYNC, heartbeat
//!   and EMCY handling (one drive per axis);
//! - [`odrive`]: ODrive CANSimple axes (one per axis);
//! - [`mit`]: MIT-mode actuators (CubeMars AK, T-Motor; one per axis).
//!
//! The supervisor, the modes, the watchdogs and recording/replay are the
//! same for every family: they see joints, numbered by their report id
//! (the node id for anguilla, the joint number 1..=joints for the bought
//! families). A bought family's master embeds a [`bought::DriveSet`] (its
//! axes by joint and id, counters, liveness) and adds its protocol.
//!
//! A further family (moteus, say) is, as MIT mode was: its codec, budget
//! traffic and DBC in a `protocol` module, and the arms of the protocol's
//! `Family` (no catch-all arm: the compiler lists them); its master here,
//! implementing [`Drives`] around a [`bought::DriveSet`], and an arm in
//! [`build`]; its simulated drive in `sim-backend` (a `Firmware` in the
//! shared two-axis `BoughtJoint`) and an arm in the simulator's
//! `joint_device`; two lines declaring the new modules; in
//! `tests/tests/families.rs` two tests and its entry in `owed`: a property
//! test of its codec, a fuzz target CI runs, a simulator no-allocation
//! test (a test fails without any of them; the match there does not
//! compile without the entry). The `==
//! Family::…` tests that remain are one family's own settings (CiA 402's
//! configuration and reserved ids, ODrive's watchdog, the simulator's
//! anguilla-only twin node), which a new family need not touch.
//!
//! Every method runs in the control period: none allocates (the
//! counting-allocator test runs every family).

pub mod anguilla;
pub mod axis;
pub mod bought;
pub mod cia402;
pub mod mit;
pub mod odrive;
pub mod report;

use anguilla_drivers::Bus;
use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{AxisFeedback, AxisSetpoint, NodeSet};

use crate::config::Config;
use crate::session::Record;
use crate::supervisor::Drive;
use anguilla_ipc::vocabulary::{Mode, Nanos};
pub use report::{Liveness, NodeReport, RxCounters};

/// Where a family's frames go: the bus, with each frame recorded (sent or
/// refused) and every failure counted. Never blocks, never allocates.
pub struct Out<'a> {
    pub(crate) bus: &'a mut dyn Bus,
    pub(crate) tap: &'a Option<crossbeam_channel::Sender<Record>>,
    pub(crate) tap_dropped: &'a mut u64,
    pub(crate) tx_errors: &'a mut u64,
    pub(crate) now: Nanos,
}

impl Out<'_> {
    /// Sends one frame (a refusal is counted and recorded as such).
    pub fn send(&mut self, f: &Frame) {
        let r = if self.bus.send(f).is_err() {
            *self.tx_errors += 1;
            Record::Refused(self.now, *f)
        } else {
            Record::Tx(self.now, *f)
        };
        if let Some(t) = self.tap
            && t.try_send(r).is_err()
        {
            *self.tap_dropped += 1;
        }
    }

    /// Counts a frame that could not even be encoded.
    pub fn encode_failed(&mut self) {
        *self.tx_errors += 1;
    }

    /// Drops every frame still queued for sending (before an E-stop).
    pub fn flush(&mut self) {
        let _ = self.bus.flush_tx();
    }
}

/// What the supervisor decided for this period, as the drives act on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Period<'a> {
    /// The time of the period.
    pub now: Nanos,
    /// What the drives must do.
    pub drive: Drive,
    /// The supervisor's mode.
    pub mode: Mode,
    /// The mode changed this period.
    pub entering: bool,
    /// The bus is off or gone: nothing is sent.
    pub bus_off: bool,
    /// The period's counter (anguilla's SYNC counter and cycle tag).
    pub counter: u16,
    /// Each joint's setpoints, `[pitch, yaw]`, at the joint, limits applied.
    pub setpoints: &'a [[AxisSetpoint; 2]],
    /// Joints that get no setpoint (lost, in Fault).
    pub skip: NodeSet,
}

/// What one joint's drives report, for the operator.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointReport {
    /// The joint's state in the anguilla vocabulary (a `NodeState` code;
    /// `None` before the drives were heard).
    pub state: Option<anguilla_protocol::message::NodeState>,
    /// The drives' error code: anguilla error bits; the last EMCY code
    /// (CiA 402: error code << 16 | error register << 8) or the ODrive
    /// axis error of the first faulted axis.
    pub errors: u32,
    /// When the joint's drives were last all heard (heartbeats).
    pub last_heard: Option<Nanos>,
    /// Measured position, velocity, torque at the joint, `[pitch, yaw]`.
    pub feedback: Option<[AxisFeedback; 2]>,
    /// Periods (SYNCs) since each axis's feedback last arrived, `[pitch,
    /// yaw]`: 0 when it came since the last period (or none is owed).
    pub feedback_age: [u32; 2],
}

/// Something a drive did that the operator's log should say (a `Copy`
/// value: the loop hands it to the logger thread without allocating).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Notice {
    /// A drive finished its configuration and started.
    Configured {
        /// Joint (0 = head end).
        joint: u8,
        /// 0 pitch, 1 yaw.
        axis: u8,
        /// Its node id.
        node: u8,
    },
    /// A drive's configuration failed: the joint reports Fault until the
    /// operator clears faults (which configures it again).
    ConfigFailed {
        /// Joint (0 = head end).
        joint: u8,
        /// 0 pitch, 1 yaw.
        axis: u8,
        /// Its node id.
        node: u8,
        /// The step of `docs/drives.md`'s list (from 0).
        step: u8,
        /// Why.
        why: cia402::ConfigFailure,
    },
    /// A drive's reply had every field at the top of its range (MIT:
    /// position, velocity and torque all ones): an unread encoder, or a
    /// forger. Said once per drive; every one is counted
    /// ([`RxCounters::saturated`]).
    SaturatedReply {
        /// Joint (0 = head end).
        joint: u8,
        /// 0 pitch, 1 yaw.
        axis: u8,
        /// Its node id.
        node: u8,
    },
}

impl std::fmt::Display for Notice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let axis = |a: u8| if a == 0 { "pitch" } else { "yaw" };
        match *self {
            Notice::Configured {
                joint,
                axis: a,
                node,
            } => write!(
                f,
                "joint {} {} drive (node {node}) configured and started",
                joint + 1,
                axis(a)
            ),
            Notice::ConfigFailed {
                joint,
                axis: a,
                node,
                step,
                why,
            } => write!(
                f,
                "joint {} {} drive (node {node}): configuration step {step} failed: {why}",
                joint + 1,
                axis(a)
            ),
            Notice::SaturatedReply {
                joint,
                axis: a,
                node,
            } => write!(
                f,
                "joint {} {} drive (node {node}): a reply with every field at the top of its \
                 range (an unread encoder, or not the drive); taken, counted, said once",
                joint + 1,
                axis(a)
            ),
        }
    }
}

/// One drive family's master: the joints' drives as the controller sees
/// them. Every method runs in the control period and allocates nothing.
pub trait Drives: Send {
    /// The family's name (as in `[robot] drive`).
    fn family(&self) -> anguilla_protocol::Family;
    /// The joints' report ids, in joint order (anguilla: node ids; bought
    /// families: 1..=joints).
    fn report_ids(&self) -> NodeSet;
    /// Takes one received frame into account.
    fn ingest(&mut self, now: Nanos, frame: &Frame);
    /// What the joints report at `now`: a joint is lost once any of its
    /// drives has not been heard for the heartbeat timeout, and silent once
    /// any of them owes feedback for more than the feedback periods
    /// (whatever its heartbeats say: `crate::nodes`).
    fn observe(&self, now: Nanos, limits: &Liveness) -> NodeReport;
    /// Whether an E-stop from another sender was seen since the last call
    /// (then cleared).
    fn take_bus_estop(&mut self) -> bool;
    /// The joints (report ids) that another sender told to change state
    /// since the last call (then cleared): the family's commands that
    /// enable, disable, clear faults, re-zero or change mode, which the
    /// drives obey behind the master's back (`docs/safety.md`). Frames
    /// that change no state (SYNC, requests, setpoints) are only counted.
    fn take_foreign_command(&mut self) -> NodeSet;
    /// Receive counters.
    fn counters(&self) -> RxCounters;
    /// Joint `j`'s report (`j` in 0..joints).
    fn joint(&self, j: usize) -> JointReport;
    /// Sends the E-stop to every drive, at once.
    fn estop(&mut self, out: &mut Out<'_>);
    /// Resets every drive's faults (the operator cleared them); the old
    /// reports are stale from now on.
    fn clear_faults(&mut self, out: &mut Out<'_>);
    /// This period's frames: drive commands, setpoints, and the
    /// synchronisation the family needs.
    fn period(&mut self, p: &Period<'_>, out: &mut Out<'_>);
    /// Disables every drive now (shutdown).
    fn disable_all(&mut self, out: &mut Out<'_>);
    /// The next notice for the log, if any (taken once).
    fn take_notice(&mut self) -> Option<Notice> {
        None
    }
    /// Whether the drives report the torque they apply (the torque
    /// residual needs it).
    fn measures_torque(&self) -> bool {
        true
    }
}

/// What went wrong building the drives from a configuration.
#[derive(Debug, thiserror::Error)]
pub enum DriveError {
    /// A node id is not valid for the family.
    #[error("{family} node id {id} is invalid (expected {min}..={max})")]
    NodeId {
        /// The family.
        family: anguilla_protocol::Family,
        /// The id.
        id: u8,
        /// Smallest valid id.
        min: u8,
        /// Largest valid id.
        max: u8,
    },
}

/// The drives of `cfg`'s family, created at `now`, for the control
/// period `period`.
pub fn build(cfg: &Config, now: Nanos, period: Nanos) -> Result<Box<dyn Drives>, DriveError> {
    Ok(match cfg.robot.drive {
        anguilla_protocol::Family::Anguilla => Box::new(anguilla::Nodes::new(cfg, now, period)?),
        anguilla_protocol::Family::Cia402 => Box::new(cia402::Master::new(cfg, now, period)?),
        anguilla_protocol::Family::Odrive => Box::new(odrive::Axes::new(cfg, now)?),
        anguilla_protocol::Family::Mit => Box::new(mit::Master::new(cfg, now)?),
    })
}

/// One bought drive's liveness and state, as the supervisor sees it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisStatus {
    /// Its state in the anguilla vocabulary (`None` before it was heard).
    pub state: Option<anguilla_protocol::message::NodeState>,
    /// When it was last heard (heartbeat).
    pub last_heard: Option<Nanos>,
    /// Periods since its last feedback while it owed some (0 while it owes
    /// none: not enabled, not operational).
    pub periods_without_feedback: u32,
}

/// One bought drive as the shared joint reporting sees it.
pub trait AxisView {
    /// Liveness and state.
    fn status(&self) -> AxisStatus;
    /// The drive's error code (0: none).
    fn error_code(&self) -> u32;
    /// Measured position, velocity, torque at the joint, once known.
    fn feedback(&self) -> Option<AxisFeedback>;
}

/// The report of a joint of two drives: the worse state, the first
/// drive's error code (pitch first), both feedbacks once both are known.
pub fn joint_report(pair: &[impl AxisView; 2]) -> JointReport {
    let st = [pair[0].status(), pair[1].status()];
    let e0 = pair[0].error_code();
    JointReport {
        state: joint_state(st),
        errors: if e0 != 0 { e0 } else { pair[1].error_code() },
        last_heard: joint_heard(st),
        feedback: match (pair[0].feedback(), pair[1].feedback()) {
            (Some(a), Some(b)) => Some([a, b]),
            _ => None,
        },
        feedback_age: [
            st[0].periods_without_feedback,
            st[1].periods_without_feedback,
        ],
    }
}

/// The supervisor's report of joints of two drives each (see
/// [`observe_joints`]).
pub fn observe_pairs<A: AxisView>(
    joints: &[[A; 2]],
    started: Nanos,
    now: Nanos,
    limits: &Liveness,
) -> NodeReport {
    observe_joints(
        joints.iter().map(|p| [p[0].status(), p[1].status()]),
        started,
        now,
        limits,
    )
}

/// How bad a state is, to report a joint's two drives as one: EStop, then
/// Fault, then unheard, then Boot, Disabled, Enabled.
fn badness(s: Option<anguilla_protocol::message::NodeState>) -> u8 {
    use anguilla_protocol::message::NodeState as S;
    match s {
        Some(S::EStop) => 6,
        Some(S::Fault) => 5,
        None => 4,
        Some(S::Boot) => 3,
        Some(S::Disabled) => 2,
        Some(S::Enabled) => 1,
    }
}

/// A joint's state from its two drives': the worse of the two.
pub fn joint_state(axes: [AxisStatus; 2]) -> Option<anguilla_protocol::message::NodeState> {
    if badness(axes[0].state) >= badness(axes[1].state) {
        axes[0].state
    } else {
        axes[1].state
    }
}

/// When a joint's two drives were last both heard.
pub fn joint_heard(axes: [AxisStatus; 2]) -> Option<Nanos> {
    Some(axes[0].last_heard?.min(axes[1].last_heard?))
}

/// The supervisor's report of joints with two drives each: joint `j` is
/// report id `j + 1`; it is lost when either drive has not been heard for
/// the heartbeat timeout (counted from `started` for a drive never heard),
/// silent when either owed feedback for more than the feedback periods.
pub fn observe_joints(
    joints: impl Iterator<Item = [AxisStatus; 2]>,
    started: Nanos,
    now: Nanos,
    limits: &Liveness,
) -> NodeReport {
    use anguilla_protocol::message::{NodeId, NodeState};
    let mut r = NodeReport {
        all_enabled: true,
        ..NodeReport::default()
    };
    for (j, axes) in joints.enumerate() {
        let Ok(id) = NodeId::new(j as u8 + 1) else {
            continue;
        };
        for a in axes {
            if now.saturating_sub(a.last_heard.unwrap_or(started)) > limits.heartbeat_timeout {
                r.lost = r.lost.with(id);
            }
            if a.periods_without_feedback > limits.feedback_periods {
                r.silent = r.silent.with(id);
            }
        }
        match joint_state(axes) {
            Some(NodeState::Enabled) => {}
            Some(NodeState::Fault) => {
                r.fault = r.fault.with(id);
                r.all_enabled = false;
            }
            Some(NodeState::EStop) => {
                r.estop = r.estop.with(id);
                r.all_enabled = false;
            }
            Some(NodeState::Boot) => {
                r.booting = r.booting.with(id);
                r.all_enabled = false;
            }
            Some(NodeState::Disabled) => {
                r.disabled = r.disabled.with(id);
                r.all_enabled = false;
            }
            None => r.all_enabled = false,
        }
    }
    r
}

/// Where each node id of a bought family's drives sits: `(joint, axis)`.
#[derive(Debug, Clone)]
pub struct AxisIndex {
    at: [(u8, u8); 128],
}

const NO_AXIS: (u8, u8) = (u8::MAX, u8::MAX);

impl AxisIndex {
    /// The index of the drives `ids` (`[pitch, yaw]` per joint).
    pub fn new(ids: impl Iterator<Item = [u8; 2]>) -> Self {
        let mut at = [NO_AXIS; 128];
        for (j, pair) in ids.enumerate() {
            for (a, id) in pair.into_iter().enumerate() {
                if let Some(slot) = at.get_mut(id as usize) {
                    *slot = (j as u8, a as u8);
                }
            }
        }
        Self { at }
    }

    /// `(joint, axis)` of drive `id`, if it is one of ours.
    pub fn get(&self, id: u8) -> Option<(usize, usize)> {
        match self.at.get(id as usize) {
            Some(&(j, a)) if (j, a) != NO_AXIS => Some((j as usize, a as usize)),
            _ => None,
        }
    }
}

/// The report ids 1..=joints of a bought family's joints.
pub fn joint_ids(joints: usize) -> NodeSet {
    NodeSet::of((1..=joints as u8).filter_map(|i| anguilla_protocol::message::NodeId::new(i).ok()))
}

#[cfg(test)]
mod tests;
