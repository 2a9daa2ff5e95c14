//! CANopen CiA 402 drives: the master (`docs/drives.md`).
//!
//! One drive per axis, in cyclic synchronous position mode (8). The master
//! is written from CiA 301 and CiA 402 over [`anguilla_protocol::canopen`]
//! (no mature Rust CANopen crate existed to build on):
//!
//! - **NMT**: on its first period the master sends Reset communication to
//!   each configured drive; a drive is configured when its boot-up arrives
//!   (also after a reboot), then started (operational).
//! - **SDO client**, one transfer at a time per drive, expedited and
//!   segmented, with a timeout and retries; an abort fails the
//!   configuration with its CiA 301 code ([`ConfigFailure`]). The
//!   configuration ([`Step`]): device type 0x1000 (must be 402), device
//!   name 0x1008 (segmented), rated torque 0x6076, RPDO1 = controlword
//!   0x6040 + target position 0x607A + torque offset 0x60B2, TPDO1 =
//!   statusword 0x6041 + position actual 0x6064 + torque actual 0x6077
//!   (both synchronous), communication cycle 0x1006 and interpolation
//!   period 0x60C2 = the control period, mode 0x6060 = 8 checked through
//!   0x6061, heartbeat producer 0x1017 = 100 ms and consumer 0x1016 = the
//!   master's heartbeat within `control.heartbeat-timeout`.
//! - **Each period**: an RPDO1 to every operational drive, then SYNC; the
//!   master's own heartbeat every 100 ms. The controlword follows the
//!   statusword the last TPDO1 carried (shutdown → switch on → enable
//!   operation while enabling; quick stop while E-stopped; a fault reset on
//!   the operator's clear), with the target at the measured position until
//!   setpoints flow.
//! - **Faults**: EMCY is decoded into the joint's error code
//!   (`code << 16 | error register << 8`); Fault in the statusword, a
//!   failed configuration or a lost heartbeat fault the joint; an NMT Stop
//!   from another sender is a bus E-stop.
//!
//! Velocity actual is not mapped (a classic PDO holds 8 bytes): the
//! measured velocity is the difference of successive positions.

use anguilla_protocol::canopen::{
    self, AbortCode, Emcy, Message, NmtCommand, NmtState, NodeId, Object, Pdo, PdoData, SdoData,
    cia402::{Command, CspCommand, CspStatus, DriveState},
};
use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{AxisFeedback, NodeState};

use super::bought::{DriveSet, node_id};
use super::{AxisStatus, DriveError, Drives, Out, Period};
use crate::config::{AxisMap, Config};
use crate::supervisor::Drive;
use anguilla_ipc::vocabulary::{Mode, Nanos};

mod setup;

const MS: Nanos = Nanos::from_millis(1);
/// The shortest wait for an SDO response; the master waits
/// `control.heartbeat-timeout` when that is longer (a drive may be silent
/// that long before it counts as lost; a slow host declares a longer one).
pub const SDO_TIMEOUT: Nanos = Nanos::from_millis(100);
/// Attempts of one SDO transfer before the configuration fails.
pub const SDO_ATTEMPTS: u8 = 3;
/// The drives' heartbeat period written to 0x1017, and the master's own.
pub const HEARTBEAT_MS: u16 = 100;
/// The longest device name kept (bytes).
pub const NAME_LEN: usize = 32;
/// The error code of a joint whose configuration failed at step `s`:
/// `CONFIG_FAILED | s`.
pub const CONFIG_FAILED: u32 = 0xFFFF_0000;

/// One step of a drive's configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Read an entry; `check` says what it must be.
    Read(Object, Check),
    /// Write an entry (1..=4 bytes, little-endian).
    Write(Object, SdoData),
    /// NMT Start remote node: the configuration is done.
    Start,
}

/// What a read must return.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// 0x1000's low 16 bits are 402.
    DeviceProfile402,
    /// The device name (kept, any length, segmented or not).
    Name,
    /// 0x6076 rated torque (kept; mN·m, non-zero).
    RatedTorque,
    /// 0x6061 reports cyclic synchronous position.
    ModeCsp,
}

/// Why a drive's configuration failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigFailure {
    /// The drive aborted the transfer.
    Abort {
        /// The entry.
        object: Object,
        /// Its code.
        code: AbortCode,
    },
    /// No answer after [`SDO_ATTEMPTS`] tries (each waiting the SDO
    /// timeout, see [`SDO_TIMEOUT`]).
    Timeout(Object),
    /// The value read is not what anguilla needs (e.g. not a CiA 402
    /// device, mode 8 refused, rated torque 0).
    Unexpected {
        /// The entry.
        object: Object,
        /// Its value (zero-extended).
        value: u32,
    },
}

impl std::fmt::Display for ConfigFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let o = |o: &Object| format!("0x{:04X}:{:02X}", o.index, o.sub);
        match self {
            ConfigFailure::Abort { object, code } => write!(
                f,
                "SDO to {} aborted: 0x{:08X} {}",
                o(object),
                code.raw(),
                code.description()
            ),
            ConfigFailure::Timeout(obj) => {
                write!(f, "SDO to {} not answered ({SDO_ATTEMPTS} tries)", o(obj))
            }
            ConfigFailure::Unexpected { object, value } => {
                write!(f, "{} = 0x{value:X} is not what anguilla needs", o(object))
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Setup {
    /// Nothing heard since the master started (or reset communication).
    Waiting,
    /// Configuring: the step, and the outstanding transfer.
    Step {
        step: u8,
        sent: Option<Nanos>,
        attempts: u8,
        /// A segmented upload in progress: the next toggle bit.
        segment: Option<bool>,
    },
    /// Configured and started.
    Done,
    /// Failed at a step.
    Failed(u8, ConfigFailure),
}

#[derive(Debug, Clone, Copy)]
struct Axis {
    map: AxisMap,
    node: NodeId,
    nmt: Option<NmtState>,
    last_heard: Option<Nanos>,
    /// SYNCs since its last TPDO1 while operational (it owes one per SYNC).
    syncs_since_tpdo: u32,
    setup: Setup,
    statusword: Option<u16>,
    position: Option<(i32, Nanos)>,
    velocity: f64,
    torque: i16,
    rated_mnm: u32,
    emcy: Option<Emcy>,
    reset_fault: bool,
    name: [u8; NAME_LEN],
    name_len: u8,
}

fn word(v: u32, len: usize) -> SdoData {
    SdoData::new(&v.to_le_bytes()[..len]).expect("1..=4 bytes")
}

impl Axis {
    fn drive_state(&self) -> Option<DriveState> {
        DriveState::from_statusword(self.statusword?).ok()
    }

    fn node_state(&self) -> Option<NodeState> {
        self.last_heard?;
        Some(match self.setup {
            Setup::Failed(..) => NodeState::Fault,
            Setup::Waiting | Setup::Step { .. } => NodeState::Boot,
            Setup::Done => match (self.nmt, self.drive_state()) {
                (Some(NmtState::Operational), Some(s)) => match s {
                    DriveState::OperationEnabled => NodeState::Enabled,
                    DriveState::Fault | DriveState::FaultReactionActive => NodeState::Fault,
                    DriveState::QuickStopActive => NodeState::EStop,
                    DriveState::NotReadyToSwitchOn
                    | DriveState::SwitchOnDisabled
                    | DriveState::ReadyToSwitchOn
                    | DriveState::SwitchedOn => NodeState::Disabled,
                },
                _ => NodeState::Boot,
            },
        })
    }

    fn rated_nm(&self) -> f64 {
        if self.map.rated_torque > 0.0 {
            self.map.rated_torque
        } else {
            self.rated_mnm as f64 / 1000.0
        }
    }

    fn torque_permille(&self, tau: f64) -> i16 {
        let rated = self.rated_nm();
        if rated <= 0.0 {
            return 0;
        }
        (self.map.motor_torque(tau) / rated * 1000.0)
            .round()
            .clamp(i16::MIN as f64, i16::MAX as f64) as i16
    }

    fn restart_setup(&mut self) {
        self.setup = Setup::Step {
            step: 0,
            sent: None,
            attempts: 0,
            segment: None,
        };
        self.statusword = None;
        self.position = None;
        self.name_len = 0;
    }
}

impl super::AxisView for Axis {
    fn status(&self) -> AxisStatus {
        AxisStatus {
            state: self.node_state(),
            last_heard: self.last_heard,
            periods_without_feedback: self.syncs_since_tpdo,
        }
    }

    fn error_code(&self) -> u32 {
        match (self.setup, self.emcy) {
            (Setup::Failed(step, _), _) => CONFIG_FAILED | step as u32,
            (_, Some(e)) => (e.code as u32) << 16 | (e.register as u32) << 8,
            _ => 0,
        }
    }

    fn feedback(&self) -> Option<AxisFeedback> {
        let (counts, _) = self.position?;
        let rated = self.rated_nm();
        Some(AxisFeedback {
            position: self.map.from_counts(counts) as f32,
            velocity: self.velocity as f32,
            torque: self.map.joint_torque(self.torque as f64 * rated / 1000.0) as f32,
            limited: false,
        })
    }
}

/// The CiA 402 master and its drives, two per joint.
pub struct Master {
    set: DriveSet<Axis>,
    master: NodeId,
    period: Nanos,
    consumer_ms: u16,
    sdo_timeout: Nanos,
    reset_sent: bool,
    last_heartbeat: Option<Nanos>,
    /// Drives whose setup ended (done or failed) and was not yet told.
    untold: u128,
}

impl Master {
    /// The drives of `cfg` (`robot.axes`), unheard-of at `now`, for the
    /// control period `period`.
    pub fn new(cfg: &Config, now: Nanos, period: Nanos) -> Result<Self, DriveError> {
        let id = |raw| {
            node_id(
                anguilla_protocol::Family::Cia402,
                raw,
                (1, canopen::MAX_NODE_ID),
                NodeId::new,
            )
        };
        let set = DriveSet::new(cfg, now, |map: AxisMap| {
            Ok(Axis {
                map,
                node: id(map.node)?,
                nmt: None,
                last_heard: None,
                syncs_since_tpdo: 0,
                setup: Setup::Waiting,
                statusword: None,
                position: None,
                velocity: 0.0,
                torque: 0,
                rated_mnm: 0,
                emcy: None,
                reset_fault: false,
                name: [0; NAME_LEN],
                name_len: 0,
            })
        })?;
        let master = cfg.robot.master_node_id;
        Ok(Self {
            set,
            master: id(master)?,
            period,
            consumer_ms: (cfg.control.heartbeat_timeout * 1e3)
                .round()
                .clamp(1.0, 65535.0) as u16,
            sdo_timeout: Nanos::from_secs_f64(cfg.control.heartbeat_timeout).max(SDO_TIMEOUT),
            reset_sent: false,
            last_heartbeat: None,
            untold: 0,
        })
    }

    /// Why drive `axis` (0 pitch, 1 yaw) of joint `j` failed its
    /// configuration, if it did.
    pub fn config_failure(&self, j: usize, axis: usize) -> Option<(Step, ConfigFailure)> {
        match self.set.joints.get(j)?.get(axis)?.setup {
            Setup::Failed(step, why) => Some((self.step(&self.set.joints[j][axis], step)?, why)),
            _ => None,
        }
    }

    /// The device name drive `axis` of joint `j` reported (0x1008).
    pub fn device_name(&self, j: usize, axis: usize) -> Option<&str> {
        let a = self.set.joints.get(j)?.get(axis)?;
        std::str::from_utf8(&a.name[..a.name_len as usize]).ok()
    }

    /// Whether every drive is configured and started.
    pub fn configured(&self) -> bool {
        self.set
            .joints
            .iter()
            .flatten()
            .all(|a| a.setup == Setup::Done)
    }

    fn send(out: &mut Out<'_>, m: Message) {
        out.send(&m.encode());
    }

    fn tpdo(&mut self, now: Nanos, j: usize, ax: usize, data: &PdoData) {
        let Some(st) = CspStatus::from_pdo(data) else {
            self.set.counters.malformed += 1;
            return;
        };
        let a = &mut self.set.joints[j][ax];
        a.syncs_since_tpdo = 0;
        a.statusword = Some(st.statusword);
        if let Some((prev, t)) = a.position {
            let dt = now.saturating_sub(t).as_nanos() as f64 * 1e-9;
            if dt > 0.0 {
                a.velocity = (a.map.from_counts(st.position) - a.map.from_counts(prev)) / dt;
            }
        }
        a.position = Some((st.position, now));
        a.torque = st.torque;
    }

    fn rpdo(out: &mut Out<'_>, a: &Axis, controlword: u16, target: i32, torque_offset: i16) {
        let data = CspCommand {
            controlword,
            target,
            torque_offset,
        }
        .to_pdo();
        Self::send(
            out,
            Message::Rpdo {
                node: a.node,
                pdo: Pdo::One,
                data,
            },
        );
    }

    fn sync(out: &mut Out<'_>) {
        Self::send(out, Message::Sync { counter: None });
    }
}

impl Drives for Master {
    super::bought::drive_set_answers!(set);

    fn family(&self) -> anguilla_protocol::Family {
        anguilla_protocol::Family::Cia402
    }

    fn ingest(&mut self, now: Nanos, frame: &Frame) {
        let m = match canopen::decode(frame) {
            Ok(m) => m,
            Err(_) => {
                self.set.counters.malformed += 1;
                return;
            }
        };
        let ours = |node: NodeId| self.set.index.get(node.get());
        match m {
            Message::Nmt { command, node } => {
                let at_us = node.is_none_or(|n| ours(n).is_some());
                if command == NmtCommand::Stop && at_us {
                    self.set.counters.estops_seen += 1;
                    self.set.bus_estop = true;
                } else if let Some(n) = node {
                    match ours(n) {
                        // Start, enter pre-operational, reset: our drive
                        // obeys it behind the master's back.
                        Some((j, _)) => self.set.foreign_command(j),
                        None => self.set.counters.foreign_commands += 1,
                    }
                } else {
                    for j in 0..self.set.joints.len() {
                        self.set.foreign_command(j);
                    }
                }
            }
            Message::Heartbeat { node, state } => {
                let Some((j, ax)) = ours(node) else { return };
                let a = &mut self.set.joints[j][ax];
                a.last_heard = Some(now);
                a.nmt = Some(state);
                // A boot-up (a fresh or rebooted drive), or a drive heard
                // before it was configured: configure it.
                if state == NmtState::BootUp || a.setup == Setup::Waiting {
                    a.restart_setup();
                    a.nmt = Some(NmtState::PreOperational);
                }
            }
            Message::Tpdo {
                node,
                pdo: Pdo::One,
                data,
            } => {
                if let Some((j, ax)) = ours(node) {
                    self.tpdo(now, j, ax, &data);
                }
            }
            Message::Emcy { node, emcy } => {
                if let Some((j, ax)) = ours(node) {
                    self.set.joints[j][ax].emcy = (emcy.code != 0).then_some(emcy);
                }
            }
            Message::SdoResponse { node, sdo } => {
                if let Some((j, ax)) = ours(node) {
                    self.sdo_response(j, ax, sdo);
                }
            }
            Message::Tpdo { .. } => {}
            // A controlword and target from another sender: our drive
            // obeys it (disable voltage, fault reset, another position).
            Message::Rpdo { node, .. } => match ours(node) {
                Some((j, _)) => self.set.foreign_command(j),
                None => self.set.counters.foreign_commands += 1,
            },
            Message::Sync { .. } | Message::SdoRequest { .. } => {
                self.set.counters.foreign_commands += 1
            }
        }
    }

    fn estop(&mut self, out: &mut Out<'_>) {
        out.flush();
        for a in self.set.joints.iter().flatten() {
            if a.setup == Setup::Done {
                let hold = a.position.map_or(0, |p| p.0);
                Self::rpdo(out, a, Command::QuickStop.word(), hold, 0);
            }
        }
        Self::sync(out);
    }

    fn clear_faults(&mut self, _out: &mut Out<'_>) {
        for a in self.set.joints.iter_mut().flatten() {
            a.emcy = None;
            match a.setup {
                // Configure again from the start.
                Setup::Failed(..) => a.restart_setup(),
                _ => a.reset_fault = true,
            }
            a.statusword = None;
        }
    }

    fn period(&mut self, p: &Period<'_>, out: &mut Out<'_>) {
        if p.bus_off {
            return;
        }
        if !self.reset_sent {
            self.reset_sent = true;
            for a in self.set.joints.iter().flatten() {
                Self::send(
                    out,
                    Message::Nmt {
                        command: NmtCommand::ResetCommunication,
                        node: Some(a.node),
                    },
                );
            }
        }
        self.configure(p.now, out);
        for (j, pair) in self.set.joints.iter_mut().enumerate() {
            let skip = p.skip.contains(j as u8 + 1);
            for (ax, a) in pair.iter_mut().enumerate() {
                if a.setup != Setup::Done || a.nmt != Some(NmtState::Operational) {
                    continue;
                }
                let hold = a.position.map_or(0, |p| p.0);
                let state = a.drive_state();
                let (control, target, torque) = if core::mem::take(&mut a.reset_fault) {
                    (Command::FaultReset.word(), hold, 0)
                } else if p.mode == Mode::EStop {
                    (Command::QuickStop.word(), hold, 0)
                } else {
                    match p.drive {
                        Drive::Disabled => (Command::Shutdown.word(), hold, 0),
                        Drive::Enable => {
                            let c = match state.and_then(DriveState::next_toward_enabled) {
                                // Faults are reset by the operator only.
                                Some(Command::FaultReset) | None => Command::DisableVoltage,
                                Some(c) => c,
                            };
                            (c.word(), hold, 0)
                        }
                        Drive::Setpoints if skip => continue,
                        Drive::Setpoints => {
                            let s = p.setpoints[j][ax];
                            (
                                Command::EnableOperation.word(),
                                a.map.counts(s.position as f64),
                                a.torque_permille(s.torque as f64),
                            )
                        }
                    }
                };
                Self::rpdo(out, a, control, target, torque);
            }
        }
        Self::sync(out);
        // Each drive that is started owes a TPDO1 for this SYNC.
        for a in self.set.joints.iter_mut().flatten() {
            a.syncs_since_tpdo = if a.setup == Setup::Done && a.nmt == Some(NmtState::Operational) {
                a.syncs_since_tpdo.saturating_add(1)
            } else {
                0
            };
        }
        if self
            .last_heartbeat
            .is_none_or(|t| p.now.saturating_sub(t) >= HEARTBEAT_MS as u64 * MS)
        {
            self.last_heartbeat = Some(p.now);
            Self::send(
                out,
                Message::Heartbeat {
                    node: self.master,
                    state: NmtState::Operational,
                },
            );
        }
    }

    fn take_notice(&mut self) -> Option<super::Notice> {
        while self.untold != 0 {
            let i = self.untold.trailing_zeros() as usize;
            self.untold &= !(1 << i);
            let (j, ax) = (i / 2, i % 2);
            let Some(a) = self.set.joints.get(j).map(|p| p[ax]) else {
                continue;
            };
            let (joint, axis, node) = (j as u8, ax as u8, a.node.get());
            match a.setup {
                Setup::Done => return Some(super::Notice::Configured { joint, axis, node }),
                Setup::Failed(step, why) => {
                    return Some(super::Notice::ConfigFailed {
                        joint,
                        axis,
                        node,
                        step,
                        why,
                    });
                }
                _ => {}
            }
        }
        None
    }

    fn disable_all(&mut self, out: &mut Out<'_>) {
        for a in self.set.joints.iter().flatten() {
            if a.setup == Setup::Done {
                let hold = a.position.map_or(0, |p| p.0);
                Self::rpdo(out, a, Command::DisableVoltage.word(), hold, 0);
            }
        }
        Self::sync(out);
    }
}
