//! A simulated CANopen CiA 402 servo drive per axis, two per joint
//! ([`Cia402Joint`]), as `docs/drives.md` (the contract with the daemon's
//! CiA 402 master) and the standards say.
//!
//! Each [`Cia402Axis`] is one CANopen node (id 1..=127) with:
//!
//! - an object dictionary kept as data ([`od::OBJECTS`]: index, sub-index,
//!   name, data type, access, PDO mapping, default), from which the SDO
//!   checks and the EDS file ([`eds`]) are made;
//! - NMT (CiA 301): boot-up after the boot time (heartbeat 0x700 + n with
//!   `0x00`, then pre-operational), start, stop, enter pre-operational,
//!   reset node (every value back to its default, boot again after the boot
//!   time), reset communication (0x1000–0x1FFF back to defaults, boot-up at
//!   once); the heartbeat producer 0x1017;
//! - an SDO server on 0x600 + n / 0x580 + n: expedited download and upload,
//!   segmented upload and download (values longer than 4 bytes, e.g. the
//!   device name 0x1008 or the axis label 0x2000), CiA 301 abort codes;
//! - PDOs following the mapping in the dictionary (RPDO1/2, TPDO1/2):
//!   synchronous RPDOs (transmission type 0..=240) are applied at the next
//!   SYNC, 254/255 at once; synchronous TPDOs (1..=240) are sent every Nth
//!   SYNC, type 0 on a SYNC when their bytes changed, 254/255 never (there
//!   is no event timer); a short RPDO is ignored, counted and reported by
//!   EMCY 0x8210;
//! - the CiA 402 power drive state machine on the controlword 0x6040
//!   (written by SDO at once, by RPDO at the SYNC), the statusword 0x6041
//!   ([`DriveState::pattern`], bit 4 voltage enabled, bit 9 remote, bit 12
//!   "following the target" in CSP), quick stop option code 2 (hold, then
//!   Switch on disabled once stopped);
//! - cyclic synchronous position (0x6060 = 8): at each SYNC the target
//!   position 0x607A, velocity offset 0x60B1 (increments, 65536 a turn,
//!   gear 1, direction +1) and torque offset 0x60B2 (‰ of the rated torque
//!   0x6076 = 500 mN·m) become the actuator's servo setpoint; the actual
//!   values 0x6064, 0x606C, 0x6077 are updated every 250 µs servo step;
//! - faults with EMCY (code, error register 0x1001): the heartbeat consumer
//!   0x1016 (EMCY 0x8130), the SYNC watchdog (no SYNC for 3 × 0x1006, at
//!   least 100 ms and at least the consumer heartbeat time of 0x1016, in
//!   Operation enabled: EMCY 0x8700, what stops a robot whose master died),
//!   injected faults (0x4210 over-temperature, else 0x1000); Fault reset
//!   sends EMCY 0x0000.
//!
//! Leaving NMT operational (stop, pre-operational, resets) while the power
//! stage is on switches it off (Switch on disabled), as a drive whose abort
//! connection option code 0x6007 is 2 does. Time is a parameter (`now`),
//! nothing allocates after construction.
//!
//! ```
//! use anguilla_protocol::canopen::{decode, Message, NmtState};
//! use anguilla_protocol::time::Nanos;
//! use anguilla_sim::cia402::{Cia402Joint, Cia402JointConfig};
//! use anguilla_sim::device::JointDevice;
//!
//! let mut joint = Cia402Joint::new(Cia402JointConfig::for_joint(0, 7), Nanos::ZERO);
//! let mut out = Vec::new();
//! joint.advance(Nanos::from_millis(50), &mut |f| out.push(f));
//! // Both drives (ids 1 and 2) sent their boot-up message.
//! let boot_ups = out
//!     .iter()
//!     .filter(|f| matches!(decode(f), Ok(Message::Heartbeat { state: NmtState::BootUp, .. })))
//!     .count();
//! assert_eq!(boot_ups, 2);
//! ```

mod config;
mod eds;
mod nmt;
pub mod od;
mod pdo;
mod sdo;

pub use config::{Cia402ConfigError, Cia402JointConfig};
pub use eds::eds;

use anguilla_protocol::canopen::cia402::{self, Command, DriveState};
use anguilla_protocol::canopen::{
    self, AbortCode, DecodeError, Emcy, Message, NmtState, NodeId, Object, PdoData,
};
use anguilla_protocol::frame::Frame;
use anguilla_protocol::message::{ErrorBits, NodeState};

use crate::actuator::{Actuator, ActuatorParams, AxisFaults, Drive, Load};
use crate::device::JointDevice;
use crate::node::{Nanos, NodeCounters};
use crate::rng::Rng;
use od::{LookupError, STRING_CAPACITY, Values, slot};

/// Servo integration step inside the drive (s), as the vertebra node's.
const SERVO_DT: f64 = 2.5e-4;
const SERVO_DT_NS: Nanos = Nanos::from_nanos(250_000);

/// Below this joint speed (rad/s) a quick-stopped axis counts as stopped.
const STOPPED_SPEED: f64 = 0.05;
/// A quick stop lasts at most this long before Switch on disabled.
const QUICK_STOP_MAX: Nanos = Nanos::from_millis(200);

/// The shortest SYNC watchdog (see the module docs).
pub const SYNC_TIMEOUT_MIN: Nanos = Nanos::from_millis(100);

/// EMCY: generic error (an injected fault other than over-temperature).
pub const EMCY_GENERIC: u16 = 0x1000;
/// EMCY: device temperature (injected over-temperature).
pub const EMCY_TEMPERATURE: u16 = 0x4210;
/// EMCY: heartbeat consumer timeout (life guard / heartbeat error).
pub const EMCY_HEARTBEAT: u16 = 0x8130;
/// EMCY: PDO not processed due to length error.
pub const EMCY_PDO_LENGTH: u16 = 0x8210;
/// EMCY: sync controller (no SYNC within 3 communication cycle periods).
pub const EMCY_SYNC: u16 = 0x8700;
/// EMCY: error reset / no error.
pub const EMCY_RESET: u16 = 0x0000;

/// Error register 0x1001 bits (CiA 301).
const ERR_GENERIC: u8 = 1 << 0;
const ERR_TEMPERATURE: u8 = 1 << 3;
const ERR_COMMUNICATION: u8 = 1 << 4;

// Slots of the entries the drive itself reads or writes (checked against
// the table at compile time).
const S_ERROR_REGISTER: usize = slot(0x1001, 0);
const S_CYCLE_PERIOD: usize = slot(cia402::COMMUNICATION_CYCLE_PERIOD, 0);
const S_CONSUMER: usize = slot(cia402::HEARTBEAT_CONSUMER, 1);
const S_PRODUCER: usize = slot(cia402::HEARTBEAT_PRODUCER, 0);
const S_CONTROLWORD: usize = slot(cia402::CONTROLWORD, 0);
const S_STATUSWORD: usize = slot(cia402::STATUSWORD, 0);
const S_MODE: usize = slot(cia402::MODES_OF_OPERATION, 0);
const S_MODE_DISPLAY: usize = slot(cia402::MODES_OF_OPERATION_DISPLAY, 0);
const S_POSITION: usize = slot(cia402::POSITION_ACTUAL, 0);
const S_VELOCITY: usize = slot(cia402::VELOCITY_ACTUAL, 0);
const S_RATED_TORQUE: usize = slot(cia402::RATED_TORQUE, 0);
const S_TORQUE: usize = slot(cia402::TORQUE_ACTUAL, 0);
const S_TARGET: usize = slot(cia402::TARGET_POSITION, 0);
const S_VELOCITY_OFFSET: usize = slot(cia402::VELOCITY_OFFSET, 0);
const S_TORQUE_OFFSET: usize = slot(cia402::TORQUE_OFFSET, 0);
const S_SIM_FAULT: usize = slot(0x2001, 0);

/// RPDO communication and mapping parameter indices, PDO 1 and 2.
const RPDO_COMM: [u16; 2] = [0x1400, 0x1401];
const RPDO_MAP: [u16; 2] = [0x1600, 0x1601];
/// TPDO communication and mapping parameter indices, PDO 1 and 2.
const TPDO_COMM: [u16; 2] = [0x1800, 0x1801];
const TPDO_MAP: [u16; 2] = [0x1A00, 0x1A01];

/// Joint angle (rad) per position increment: 2π / 65536 (gear 1,
/// direction +1, offset 0; docs/drives.md).
pub const RAD_PER_INCREMENT: f64 = 2.0 * core::f64::consts::PI / od::INCREMENTS_PER_TURN as f64;

/// The NMT state of a drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Nmt {
    /// Powered, not yet booted (silent).
    Initialising,
    PreOperational,
    Operational,
    Stopped,
}

/// The SDO server's transfer in progress.
#[derive(Debug, Clone, Copy)]
enum Sdo {
    Idle,
    /// Segmented upload of `value` from `object`, `sent` bytes sent, next
    /// toggle.
    Upload {
        object: Object,
        value: od::Value,
        sent: usize,
        toggle: bool,
    },
    /// Segmented download to `object`, `len` bytes received.
    Download {
        object: Object,
        size: Option<u32>,
        buf: [u8; STRING_CAPACITY],
        len: usize,
        toggle: bool,
    },
}

/// Converts a joint angle (rad) to position increments (saturating).
fn increments(rad: f64) -> i64 {
    (rad / RAD_PER_INCREMENT)
        .round()
        .clamp(i32::MIN as f64, i32::MAX as f64) as i64
}

/// The controlword's state-machine command (CiA 402, bits 0-3; bit 7
/// fault reset is handled apart, on its rising edge).
fn command_of(word: u16) -> Command {
    if word & 0x02 == 0 {
        Command::DisableVoltage
    } else if word & 0x04 == 0 {
        Command::QuickStop
    } else if word & 0x01 == 0 {
        Command::Shutdown
    } else if word & 0x08 == 0 {
        Command::SwitchOn
    } else {
        Command::EnableOperation
    }
}

/// The power-drive-system transition a command makes from a state (CiA
/// 402 transitions 2-12 with quick stop option code 2), or `None` to stay.
fn transition(state: DriveState, cmd: Command) -> Option<DriveState> {
    use DriveState as S;
    Some(match (state, cmd) {
        (S::ReadyToSwitchOn | S::SwitchedOn | S::OperationEnabled, Command::DisableVoltage) => {
            S::SwitchOnDisabled
        }
        (S::QuickStopActive, Command::DisableVoltage) => S::SwitchOnDisabled,
        (S::ReadyToSwitchOn | S::SwitchedOn, Command::QuickStop) => S::SwitchOnDisabled,
        (S::OperationEnabled, Command::QuickStop) => S::QuickStopActive,
        (S::SwitchOnDisabled | S::SwitchedOn | S::OperationEnabled, Command::Shutdown) => {
            S::ReadyToSwitchOn
        }
        (S::ReadyToSwitchOn | S::OperationEnabled, Command::SwitchOn) => S::SwitchedOn,
        // "Switch on + enable operation" from Ready to switch on: 3 then 4.
        (S::ReadyToSwitchOn | S::SwitchedOn, Command::EnableOperation) => S::OperationEnabled,
        _ => return None,
    })
}

/// One simulated CiA 402 drive: a CANopen node servoing one actuator.
#[derive(Debug, Clone)]
pub struct Cia402Axis {
    /// `None` for an id outside 1..=127: such a drive never boots.
    node: Option<NodeId>,
    raw_id: u8,
    boot_time: Nanos,
    od: Values,
    nmt: Nmt,
    boot_at: Nanos,
    drive: DriveState,
    /// The controlword last acted on (for the fault reset edge).
    last_controlword: u16,
    injected: u16,
    /// The CSP setpoint latched at the last SYNC (rad, rad/s, N·m).
    setpoint: (f64, f64, f64),
    /// Position held in Quick stop active (rad) and since when.
    hold: f64,
    quick_stop_since: Nanos,
    sdo: Sdo,
    rpdo_pending: [Option<PdoData>; 2],
    tpdo_count: [u8; 2],
    /// The bytes each TPDO last carried (type 0 sends on a change).
    tpdo_last: [Option<([u8; 8], usize)>; 2],
    last_sync: Nanos,
    next_heartbeat: Option<Nanos>,
    consumer_last: Option<Nanos>,
    consumer_expired: bool,
    time: Nanos,
    actuator: Actuator,
    rng: Rng,
    silent: bool,
    counters: NodeCounters,
}

impl Cia402Axis {
    /// A drive with node id `id` (1..=127; another id gives a drive that
    /// never boots) powered on at `now`, driving an actuator of `params`.
    pub fn new(id: u8, params: ActuatorParams, boot_time: Nanos, seed: u64, now: Nanos) -> Self {
        let node = NodeId::new(id).ok();
        let mut axis = Self {
            node,
            raw_id: id,
            boot_time,
            od: Values::new(id),
            nmt: Nmt::Initialising,
            boot_at: now + boot_time,
            drive: DriveState::NotReadyToSwitchOn,
            last_controlword: 0,
            injected: 0,
            setpoint: (0.0, 0.0, 0.0),
            hold: 0.0,
            quick_stop_since: now,
            sdo: Sdo::Idle,
            rpdo_pending: [None; 2],
            tpdo_count: [0; 2],
            tpdo_last: [None; 2],
            last_sync: now,
            next_heartbeat: None,
            consumer_last: None,
            consumer_expired: false,
            time: now,
            actuator: Actuator::new(params),
            rng: Rng::new(seed),
            silent: false,
            counters: NodeCounters::default(),
        };
        axis.refresh_statusword();
        axis
    }

    /// The node id as configured.
    pub fn node_id(&self) -> u8 {
        self.raw_id
    }

    /// The NMT state, or `None` before boot-up.
    pub fn nmt_state(&self) -> Option<NmtState> {
        match self.nmt {
            Nmt::Initialising => None,
            Nmt::PreOperational => Some(NmtState::PreOperational),
            Nmt::Operational => Some(NmtState::Operational),
            Nmt::Stopped => Some(NmtState::Stopped),
        }
    }

    /// The CiA 402 drive state.
    pub fn drive_state(&self) -> DriveState {
        self.drive
    }

    /// The statusword 0x6041.
    pub fn statusword(&self) -> u16 {
        self.od.num(S_STATUSWORD) as u16
    }

    /// The bytes of entry `index:sub` as the drive holds them (a local
    /// read: no SDO access check), or the abort code an SDO upload of a
    /// missing entry gets.
    pub fn value(&self, index: u16, sub: u8) -> Result<&[u8], AbortCode> {
        Ok(self.od.get(lookup(index, sub)?).bytes())
    }

    /// The anguilla state of this drive (see [`JointDevice::state`]).
    pub fn node_state(&self) -> NodeState {
        if self.nmt == Nmt::Initialising {
            return NodeState::Boot;
        }
        match self.drive {
            DriveState::Fault | DriveState::FaultReactionActive => NodeState::Fault,
            DriveState::QuickStopActive => NodeState::EStop,
            DriveState::OperationEnabled => NodeState::Enabled,
            _ => NodeState::Disabled,
        }
    }

    /// True angle, velocity and acceleration of the axis.
    pub fn kinematics(&self) -> (f64, f64, f64) {
        self.actuator.kinematics()
    }

    /// The actuator's torque (N·m).
    pub fn motor_torque(&self) -> f64 {
        self.actuator.torque()
    }

    /// The body's load from now on
    /// ([`crate::actuator::Actuator::set_load`]).
    pub fn set_load(&mut self, load: Load) {
        self.actuator.set_load(load);
    }

    /// Counters.
    pub fn counters(&self) -> NodeCounters {
        self.counters
    }

    /// Fault injection: a silent drive neither sends nor hears anything.
    pub fn set_silent(&mut self, silent: bool) {
        self.silent = silent;
    }

    /// Fault injection: power cycle (the dictionary back to defaults, boot
    /// again); the joint stays where it is.
    pub fn reboot(&mut self, now: Nanos) {
        let mut fresh = Self::new(self.raw_id, *self.actuator.params(), self.boot_time, 0, now);
        fresh.actuator = self.actuator.clone();
        fresh.rng = self.rng.clone();
        *self = fresh;
    }

    /// Fault injection: the actuator's faults.
    pub fn axis_faults_mut(&mut self) -> &mut AxisFaults {
        self.actuator.faults_mut()
    }

    /// Fault injection: a fault condition (anguilla [`ErrorBits`]) that
    /// persists until [`Cia402Axis::clear_injected_fault`]: the drive
    /// faults with EMCY 0x4210 for over-temperature, 0x1000 otherwise.
    pub fn inject_fault(&mut self, bits: u16, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        self.advance(now, tx);
        self.injected |= bits;
        self.injected_fault(tx);
    }

    /// Faults for the injected condition: EMCY 0x4210 for
    /// over-temperature, 0x1000 otherwise.
    fn injected_fault(&mut self, tx: &mut dyn FnMut(Frame)) {
        if self.injected & ErrorBits::OVER_TEMPERATURE != 0 {
            self.fault(EMCY_TEMPERATURE, ERR_TEMPERATURE, tx);
        } else {
            self.fault(EMCY_GENERIC, 0, tx);
        }
    }

    /// Removes the injected fault condition (a fault reset can then succeed).
    pub fn clear_injected_fault(&mut self) {
        self.injected = 0;
    }

    fn send(&self, tx: &mut dyn FnMut(Frame), m: Message) {
        if !self.silent {
            tx(m.encode());
        }
    }

    fn emcy(&self, code: u16, register: u8, tx: &mut dyn FnMut(Frame)) {
        // CiA 301: EMCY in pre-operational and operational only.
        if let Some(node) = self.node
            && matches!(self.nmt, Nmt::PreOperational | Nmt::Operational)
        {
            self.send(
                tx,
                Message::Emcy {
                    node,
                    emcy: Emcy {
                        code,
                        register,
                        manufacturer: [0; 5],
                    },
                },
            );
        }
    }

    /// A fault: error register set, EMCY, Fault reaction active (Fault at
    /// the next servo step) unless faulted already.
    fn fault(&mut self, code: u16, register: u8, tx: &mut dyn FnMut(Frame)) {
        let reg = self.od.num(S_ERROR_REGISTER) as u8 | register | ERR_GENERIC;
        self.od.set_num(S_ERROR_REGISTER, reg.into());
        self.emcy(code, reg, tx);
        if !matches!(
            self.drive,
            DriveState::Fault | DriveState::FaultReactionActive
        ) {
            self.set_drive(DriveState::FaultReactionActive);
        }
    }

    fn mode(&self) -> i8 {
        self.od.num(S_MODE) as i8
    }

    fn refresh_statusword(&mut self) {
        let (_, mut w) = self.drive.pattern();
        if matches!(
            self.drive,
            DriveState::ReadyToSwitchOn
                | DriveState::SwitchedOn
                | DriveState::OperationEnabled
                | DriveState::QuickStopActive
        ) {
            w |= 1 << 4; // voltage enabled
        }
        if self.nmt != Nmt::Initialising {
            w |= 1 << 9; // remote: the controlword is obeyed
        }
        if self.drive == DriveState::OperationEnabled && self.mode() == cia402::MODE_CSP {
            w |= 1 << 12; // CSP: the drive follows the target
        }
        self.od.set_num(S_STATUSWORD, w.into());
    }

    fn set_drive(&mut self, state: DriveState) {
        if self.drive == state {
            return;
        }
        let (theta, _, _) = self.actuator.kinematics();
        match state {
            DriveState::OperationEnabled => {
                // Hold still where we are until the first SYNC's target.
                self.setpoint = (theta, 0.0, 0.0);
                self.last_sync = self.time;
            }
            DriveState::QuickStopActive => {
                self.hold = theta;
                self.quick_stop_since = self.time;
            }
            _ => {}
        }
        self.drive = state;
        self.refresh_statusword();
    }

    fn drive_command(&self) -> Drive {
        match self.drive {
            DriveState::OperationEnabled if self.mode() == cia402::MODE_CSP => {
                let (position, velocity, torque) = self.setpoint;
                Drive::Servo {
                    position,
                    velocity,
                    torque,
                }
            }
            DriveState::QuickStopActive => Drive::Servo {
                position: self.hold,
                velocity: 0.0,
                torque: 0.0,
            },
            _ => Drive::Limp,
        }
    }

    /// Runs the drive's own loop (servo, actual values, boot, heartbeat,
    /// watchdogs) up to `now`.
    pub fn advance(&mut self, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        while self.time + SERVO_DT_NS <= now {
            self.time += SERVO_DT_NS;
            let t = self.time;
            let drive = self.drive_command();
            self.actuator.step(SERVO_DT, drive);
            let measured = self.actuator.measure(&mut self.rng);
            let (_, omega, _) = self.actuator.kinematics();
            self.od.set_num(S_POSITION, increments(measured));
            self.od.set_num(S_VELOCITY, increments(omega));
            let rated = self.od.num(S_RATED_TORQUE).max(1) as f64;
            let permille = (self.actuator.torque() * 1e6 / rated).round();
            self.od.set_num(
                S_TORQUE,
                permille.clamp(i16::MIN as f64, i16::MAX as f64) as i64,
            );
            match self.drive {
                DriveState::FaultReactionActive => self.set_drive(DriveState::Fault),
                DriveState::QuickStopActive
                    if omega.abs() < STOPPED_SPEED
                        || t.saturating_sub(self.quick_stop_since) >= QUICK_STOP_MAX =>
                {
                    self.set_drive(DriveState::SwitchOnDisabled)
                }
                _ => {}
            }
            if self.silent {
                continue;
            }
            if self.nmt == Nmt::Initialising && t >= self.boot_at {
                self.boot_up(t, tx);
            }
            self.watchdogs(t, tx);
            if let Some(next) = self.next_heartbeat
                && t >= next
            {
                self.heartbeat(tx);
                let period = Nanos::from_millis(self.od.num(S_PRODUCER) as u64);
                self.next_heartbeat = (period > Nanos::ZERO).then(|| t + period);
            }
        }
    }

    /// Handles one frame seen on the bus at `now` (advancing to `now`
    /// first).
    pub fn receive(&mut self, now: Nanos, frame: &Frame, tx: &mut dyn FnMut(Frame)) {
        self.advance(now, tx);
        let Some(node) = self.node else {
            return;
        };
        if self.silent || self.nmt == Nmt::Initialising || frame.is_remote() || frame.is_fd() {
            return;
        }
        let Some(cob) = frame.id().as_standard() else {
            return;
        };
        if self.nmt == Nmt::Operational {
            for (p, comm) in RPDO_COMM.into_iter().enumerate() {
                if self.pdo_cob(comm) == Some(cob) {
                    self.on_rpdo(p, frame.data(), now, tx);
                    return;
                }
            }
        }
        let sdo_rx = canopen::Function::SdoRx(node).cob_id().as_raw();
        let msg = match canopen::decode(frame) {
            Ok(m) => m,
            Err(e) => {
                if cob == sdo_rx && self.nmt != Nmt::Stopped {
                    match e {
                        // Block transfers (8 bytes, an unimplemented
                        // command specifier): refused by abort.
                        DecodeError::SdoCommand { .. } => {
                            let d = frame.data();
                            let object = Object::new(u16::from_le_bytes([d[1], d[2]]), d[3]);
                            self.abort(object, AbortCode::InvalidCommandSpecifier, tx)
                        }
                        _ => self.counters.bad_frames += 1,
                    }
                } else if cob == 0 {
                    // A malformed NMT command: addressed to everyone.
                    self.counters.bad_frames += 1;
                }
                return;
            }
        };
        match msg {
            Message::Nmt { command, node: to } if to.is_none_or(|n| n == node) => {
                self.on_nmt(command, now, tx)
            }
            Message::Sync { .. } if self.nmt == Nmt::Operational => self.on_sync(now, tx),
            Message::SdoRequest { node: to, sdo } if to == node && self.nmt != Nmt::Stopped => {
                self.on_sdo(sdo, now, tx)
            }
            Message::Heartbeat { node: from, .. } => {
                let consumer = self.od.num(S_CONSUMER) as u32;
                let producer = ((consumer >> 16) & 0x7F) as u8;
                if consumer & 0xFFFF != 0 && from.get() == producer {
                    self.consumer_last = Some(now);
                    self.consumer_expired = false;
                }
            }
            _ => {}
        }
    }

    /// The controlword 0x6040 changed (or was written again): CiA 402's
    /// state machine.
    fn on_controlword(&mut self, tx: &mut dyn FnMut(Frame)) {
        let word = self.od.num(S_CONTROLWORD) as u16;
        let previous = core::mem::replace(&mut self.last_controlword, word);
        match self.drive {
            DriveState::Fault => {
                let rising = word & 0x80 != 0 && previous & 0x80 == 0;
                if rising && self.injected == 0 {
                    self.od.set_num(S_ERROR_REGISTER, 0);
                    self.emcy(EMCY_RESET, 0, tx);
                    self.set_drive(DriveState::SwitchOnDisabled);
                }
            }
            DriveState::NotReadyToSwitchOn | DriveState::FaultReactionActive => {}
            state => {
                if let Some(next) = transition(state, command_of(word)) {
                    self.set_drive(next);
                }
            }
        }
    }
}

/// The slot of `index:sub`, or the SDO abort code for a missing entry.
fn lookup(index: u16, sub: u8) -> Result<usize, AbortCode> {
    od::find(index, sub).map_err(|e| match e {
        LookupError::NoObject => AbortCode::ObjectDoesNotExist,
        LookupError::NoSubIndex => AbortCode::SubIndexDoesNotExist,
    })
}

/// One joint's two simulated CiA 402 drives (pitch, yaw).
#[derive(Debug, Clone)]
pub struct Cia402Joint {
    axes: [Cia402Axis; 2],
}

impl Cia402Joint {
    /// A joint whose drives are powered on at `now`. Ids outside 1..=127
    /// give drives that never boot: check with
    /// [`Cia402JointConfig::validate`] or use [`Cia402Joint::try_new`].
    pub fn new(cfg: Cia402JointConfig, now: Nanos) -> Self {
        let axis = |i: usize| {
            Cia402Axis::new(
                cfg.ids[i],
                cfg.axes[i],
                cfg.boot_time,
                cfg.seed ^ (0x9E37_79B9_7F4A_7C15u64.wrapping_mul(i as u64 + 1)),
                now,
            )
        };
        Self {
            axes: [axis(0), axis(1)],
        }
    }

    /// [`Cia402Joint::new`] after [`Cia402JointConfig::validate`].
    pub fn try_new(cfg: Cia402JointConfig, now: Nanos) -> Result<Self, Cia402ConfigError> {
        cfg.validate()?;
        Ok(Self::new(cfg, now))
    }

    /// The drive of axis 0 (pitch) or 1 (yaw; any index above 1 is yaw).
    pub fn axis(&self, axis: usize) -> &Cia402Axis {
        &self.axes[axis.min(1)]
    }

    /// The drive of an axis, mutable (as [`Cia402Joint::axis`]).
    pub fn axis_mut(&mut self, axis: usize) -> &mut Cia402Axis {
        &mut self.axes[axis.min(1)]
    }
}

/// The worse of two anguilla states: EStop, then Fault, then Boot, then
/// Disabled; Enabled only when both are.
fn worse(a: NodeState, b: NodeState) -> NodeState {
    let rank = |s: NodeState| match s {
        NodeState::EStop => 0,
        NodeState::Fault => 1,
        NodeState::Boot => 2,
        NodeState::Disabled => 3,
        NodeState::Enabled => 4,
    };
    if rank(a) <= rank(b) { a } else { b }
}

impl JointDevice for Cia402Joint {
    fn receive(&mut self, now: Nanos, frame: &Frame, tx: &mut dyn FnMut(Frame)) {
        for a in &mut self.axes {
            a.receive(now, frame, tx);
        }
    }

    fn advance(&mut self, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        for a in &mut self.axes {
            a.advance(now, tx);
        }
    }

    fn kinematics(&self, axis: usize) -> (f64, f64, f64) {
        self.axis(axis).kinematics()
    }

    fn motor_torque(&self, axis: usize) -> f64 {
        self.axis(axis).motor_torque()
    }

    fn set_load(&mut self, load: [Load; 2]) {
        for (a, l) in self.axes.iter_mut().zip(load) {
            a.set_load(l);
        }
    }

    fn set_pose(&mut self, angles: [f64; 2]) {
        for (a, th) in self.axes.iter_mut().zip(angles) {
            a.actuator.set_state(th, 0.0);
        }
    }

    fn state(&self) -> NodeState {
        worse(self.axes[0].node_state(), self.axes[1].node_state())
    }

    fn counters(&self) -> NodeCounters {
        let (a, b) = (self.axes[0].counters, self.axes[1].counters);
        NodeCounters {
            bad_frames: a.bad_frames + b.bad_frames,
            stale_setpoints: a.stale_setpoints + b.stale_setpoints,
            applied: a.applied + b.applied,
            clamped: a.clamped + b.clamped,
            watchdog_expiries: a.watchdog_expiries + b.watchdog_expiries,
        }
    }

    fn set_silent(&mut self, silent: bool) {
        for a in &mut self.axes {
            a.set_silent(silent);
        }
    }

    fn reboot(&mut self, now: Nanos) {
        for a in &mut self.axes {
            a.reboot(now);
        }
    }

    fn axis_faults_mut(&mut self, axis: usize) -> &mut AxisFaults {
        self.axis_mut(axis).axis_faults_mut()
    }

    fn inject_fault(&mut self, bits: u16, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        for a in &mut self.axes {
            a.inject_fault(bits, now, tx);
        }
    }

    fn clear_injected_fault(&mut self) {
        for a in &mut self.axes {
            a.clear_injected_fault();
        }
    }
    fn impostor_heartbeat(&self, _state: NodeState, _counter: u8, tx: &mut dyn FnMut(Frame)) {
        use anguilla_protocol::canopen::{Message, NmtState};
        for a in &self.axes {
            if let Some(node) = a.node {
                let hb = Message::Heartbeat {
                    node,
                    state: NmtState::Operational,
                };
                tx(hb.encode());
            }
        }
    }
}
