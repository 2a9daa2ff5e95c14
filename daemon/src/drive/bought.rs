//! What the bought-drive masters (CiA 402, ODrive, MIT) keep alike: the
//! axes, pitch then yaw of each joint, found by node id; the joints' report
//! ids; the receive counters; a bus E-stop seen; when they started; a
//! received frame's way to its axis ([`DriveSet::addressed`]), the
//! period's setpoints by axis ([`DriveSet::setpoints`]), the node ids a
//! family accepts ([`node_id`]) and the timers of resends and polls
//! ([`Every`]). A master embeds a [`DriveSet`] and answers the
//! [`Drives`](super::Drives) questions about liveness, counters and joints
//! from it (`drive_set_answers!`); its protocol is its own.

use anguilla_ipc::vocabulary::Nanos;
use anguilla_protocol::Family;
use anguilla_protocol::message::{AxisSetpoint, NodeSet};

use super::report::{Liveness, NodeReport, RxCounters};
use super::{
    AxisIndex, AxisView, DriveError, JointReport, Period, joint_ids, joint_report, observe_pairs,
};
use crate::config::{AxisMap, Config};

/// The axes of a bought family's joints, and what every master counts.
#[derive(Debug, Clone)]
pub struct DriveSet<A> {
    /// The axes, `[pitch, yaw]` per joint, head first.
    pub joints: Vec<[A; 2]>,
    /// Node id → `(joint, axis)`.
    pub index: AxisIndex,
    /// The joints' report ids, 1..=joints.
    pub ids: NodeSet,
    /// Frames not used.
    pub counters: RxCounters,
    /// An E-stop seen on the bus and not yet taken by the supervisor.
    pub bus_estop: bool,
    /// Joints another sender told to change state, not yet taken by the
    /// supervisor.
    pub foreign: NodeSet,
    /// When the master started: liveness counts from here.
    pub started: Nanos,
}

impl<A: AxisView> DriveSet<A> {
    /// The axes of `cfg` (`robot.axes`, resolved), each made by `axis`,
    /// unheard-of at `now`.
    pub fn new(
        cfg: &Config,
        now: Nanos,
        mut axis: impl FnMut(AxisMap) -> Result<A, DriveError>,
    ) -> Result<Self, DriveError> {
        let maps = cfg.axes();
        let joints = maps
            .iter()
            .map(|pair| Ok([axis(pair[0])?, axis(pair[1])?]))
            .collect::<Result<Vec<_>, DriveError>>()?;
        Ok(Self {
            index: AxisIndex::new(maps.iter().map(|p| [p[0].node, p[1].node])),
            ids: joint_ids(joints.len()),
            joints,
            counters: RxCounters::default(),
            bus_estop: false,
            foreign: NodeSet::empty(),
            started: now,
        })
    }

    /// The joints' liveness and states at `now`.
    pub fn observe(&self, now: Nanos, limits: &Liveness) -> NodeReport {
        observe_pairs(&self.joints, self.started, now, limits)
    }

    /// Whether an E-stop was seen on the bus since the last call.
    pub fn take_bus_estop(&mut self) -> bool {
        core::mem::take(&mut self.bus_estop)
    }

    /// Notes a state-changing command from another sender to joint `j`'s
    /// drives (counted with the foreign commands).
    pub fn foreign_command(&mut self, j: usize) {
        self.counters.foreign_commands += 1;
        if let Ok(id) = anguilla_protocol::message::NodeId::new(j as u8 + 1) {
            self.foreign = self.foreign.with(id);
        }
    }

    /// The joints another sender told to change state since the last call.
    pub fn take_foreign_command(&mut self) -> NodeSet {
        core::mem::replace(&mut self.foreign, NodeSet::empty())
    }

    /// Joint `j`'s report.
    pub fn joint(&self, j: usize) -> JointReport {
        joint_report(&self.joints[j])
    }

    /// A received frame's message (`decoded`) with the joint and axis its
    /// node id (`node`) addresses; `None`, counted as malformed, for a
    /// frame that did not decode or that names another device on the bus.
    pub fn addressed<M, E>(
        &mut self,
        decoded: Result<M, E>,
        node: impl FnOnce(&M) -> u8,
    ) -> Option<(M, usize, usize)> {
        let found = decoded
            .ok()
            .and_then(|m| self.index.get(node(&m)).map(|(j, a)| (m, j, a)));
        if found.is_none() {
            self.counters.malformed += 1;
        }
        found
    }

    /// Each axis with its setpoint of period `p`, pitch then yaw, head
    /// first; the joints `p` skips (lost, in Fault) are left out.
    pub fn setpoints<'s>(
        &'s mut self,
        p: &'s Period<'_>,
    ) -> impl Iterator<Item = (&'s mut A, &'s AxisSetpoint)> + 's {
        let skip = p.skip;
        self.joints
            .iter_mut()
            .zip(p.setpoints)
            .enumerate()
            .filter(move |(j, _)| !skip.contains(*j as u8 + 1))
            .flat_map(|(_, (pair, sp))| pair.iter_mut().zip(sp))
    }
}

/// Drive `raw` of `family` as the family's node id (`new`), or the error
/// that names the family and its range `min..=max`.
pub fn node_id<N, E>(
    family: Family,
    raw: u8,
    (min, max): (u8, u8),
    new: impl FnOnce(u8) -> Result<N, E>,
) -> Result<N, DriveError> {
    new(raw).map_err(|_| DriveError::NodeId {
        family,
        id: raw,
        min,
        max,
    })
}

/// A master's timer for what it sends again every `period` (an enable
/// request until confirmed, a poll of a quiet drive): due when forced (the
/// mode just changed) or once `period` has passed since it was last due.
#[derive(Debug, Clone, Copy)]
pub struct Every {
    period: Nanos,
    last: Nanos,
}

impl Every {
    /// A timer of `period`, first due `period` after time zero.
    pub const fn new(period: Nanos) -> Self {
        Self {
            period,
            last: Nanos::ZERO,
        }
    }

    /// Whether it is due at `now` (always when `force`); counts again from
    /// `now` when it is.
    pub fn due(&mut self, now: Nanos, force: bool) -> bool {
        let due = force || now.saturating_sub(self.last) >= self.period;
        if due {
            self.last = now;
        }
        due
    }
}

/// The [`Drives`](super::Drives) methods a master with a [`DriveSet`] in
/// its field `$set` answers from it: `report_ids`, `observe`,
/// `take_bus_estop`, `take_foreign_command`, `counters` and `joint`. Used inside the master's
/// `impl Drives`.
macro_rules! drive_set_answers {
    ($set:ident) => {
        fn report_ids(&self) -> anguilla_protocol::message::NodeSet {
            self.$set.ids
        }

        fn observe(
            &self,
            now: anguilla_ipc::vocabulary::Nanos,
            limits: &$crate::drive::Liveness,
        ) -> $crate::drive::NodeReport {
            self.$set.observe(now, limits)
        }

        fn take_bus_estop(&mut self) -> bool {
            self.$set.take_bus_estop()
        }

        fn take_foreign_command(&mut self) -> anguilla_protocol::message::NodeSet {
            self.$set.take_foreign_command()
        }

        fn counters(&self) -> $crate::drive::RxCounters {
            self.$set.counters
        }

        fn joint(&self, j: usize) -> $crate::drive::JointReport {
            self.$set.joint(j)
        }
    };
}
pub(crate) use drive_set_answers;
