//! CiA 402 (drives and motion control): object indices, the statusword's
//! drive states and the controlword's commands.

use super::error::DecodeError;
use super::types::PdoData;

/// 0x1006 communication cycle period (u32, µs; CiA 301).
pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
/// 0x1016 consumer heartbeat time (array of u32: node << 16 | ms; CiA 301).
pub const HEARTBEAT_CONSUMER: u16 = 0x1016;
/// 0x1017 producer heartbeat time (u16, ms; CiA 301).
pub const HEARTBEAT_PRODUCER: u16 = 0x1017;
/// 0x6040 controlword (u16).
pub const CONTROLWORD: u16 = 0x6040;
/// 0x6041 statusword (u16).
pub const STATUSWORD: u16 = 0x6041;
/// 0x6060 modes of operation (i8; 8 = cyclic synchronous position).
pub const MODES_OF_OPERATION: u16 = 0x6060;
/// 0x6061 modes of operation display (i8).
pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// 0x6064 position actual value (i32, increments).
pub const POSITION_ACTUAL: u16 = 0x6064;
/// 0x606C velocity actual value (i32).
pub const VELOCITY_ACTUAL: u16 = 0x606C;
/// 0x6076 motor rated torque (u32, mNm): the unit of the torque objects.
pub const RATED_TORQUE: u16 = 0x6076;
/// 0x6077 torque actual value (i16, ‰ of rated torque).
pub const TORQUE_ACTUAL: u16 = 0x6077;
/// 0x607A target position (i32).
pub const TARGET_POSITION: u16 = 0x607A;
/// 0x60B1 velocity offset (i32).
pub const VELOCITY_OFFSET: u16 = 0x60B1;
/// 0x60B2 torque offset (i16, ‰ of rated torque).
pub const TORQUE_OFFSET: u16 = 0x60B2;
/// 0x60C2 interpolation time period (record: sub 1 value u8, sub 2
/// index i8, period = value × 10^index s).
pub const INTERPOLATION_TIME_PERIOD: u16 = 0x60C2;
/// 0x6060 value of cyclic synchronous position mode.
pub const MODE_CSP: i8 = 8;

/// A PDO mapping entry (CiA 301: index << 16 | sub << 8 | bit length).
pub const fn mapping_entry(index: u16, sub: u8, bits: u8) -> u32 {
    (index as u32) << 16 | (sub as u32) << 8 | bits as u32
}

/// RPDO1 as anguilla's master maps it (`docs/drives.md`): controlword,
/// target position, torque offset — 8 bytes, little-endian.
pub const CSP_RPDO1: [u32; 3] = [
    mapping_entry(CONTROLWORD, 0, 16),
    mapping_entry(TARGET_POSITION, 0, 32),
    mapping_entry(TORQUE_OFFSET, 0, 16),
];

/// TPDO1 as anguilla's master maps it: statusword, position actual,
/// torque actual — 8 bytes, little-endian.
pub const CSP_TPDO1: [u32; 3] = [
    mapping_entry(STATUSWORD, 0, 16),
    mapping_entry(POSITION_ACTUAL, 0, 32),
    mapping_entry(TORQUE_ACTUAL, 0, 16),
];

/// What RPDO1 ([`CSP_RPDO1`]) carries to a drive each period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CspCommand {
    /// 0x6040.
    pub controlword: u16,
    /// 0x607A, increments.
    pub target: i32,
    /// 0x60B2, ‰ of the rated torque.
    pub torque_offset: i16,
}

/// What TPDO1 ([`CSP_TPDO1`]) reports at each SYNC.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CspStatus {
    /// 0x6041.
    pub statusword: u16,
    /// 0x6064, increments.
    pub position: i32,
    /// 0x6077, ‰ of the rated torque.
    pub torque: i16,
}

fn pack(a: u16, b: i32, c: i16) -> PdoData {
    let mut d = [0u8; 8];
    d[0..2].copy_from_slice(&a.to_le_bytes());
    d[2..6].copy_from_slice(&b.to_le_bytes());
    d[6..8].copy_from_slice(&c.to_le_bytes());
    PdoData::new(&d).expect("8 bytes")
}

fn unpack(data: &PdoData) -> Option<(u16, i32, i16)> {
    let d: &[u8; 8] = data.bytes().try_into().ok()?;
    Some((
        u16::from_le_bytes([d[0], d[1]]),
        i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
        i16::from_le_bytes([d[6], d[7]]),
    ))
}

impl CspCommand {
    /// The RPDO's 8 bytes.
    pub fn to_pdo(self) -> PdoData {
        pack(self.controlword, self.target, self.torque_offset)
    }

    /// From an RPDO's bytes; `None` unless exactly 8.
    pub fn from_pdo(data: &PdoData) -> Option<Self> {
        let (controlword, target, torque_offset) = unpack(data)?;
        Some(CspCommand {
            controlword,
            target,
            torque_offset,
        })
    }
}

impl CspStatus {
    /// The TPDO's 8 bytes.
    pub fn to_pdo(self) -> PdoData {
        pack(self.statusword, self.position, self.torque)
    }

    /// From a TPDO's bytes; `None` unless exactly 8.
    pub fn from_pdo(data: &PdoData) -> Option<Self> {
        let (statusword, position, torque) = unpack(data)?;
        Some(CspStatus {
            statusword,
            position,
            torque,
        })
    }
}

/// The states of the CiA 402 power drive system state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DriveState {
    /// Statusword `xxxx xxxx x0xx 0000`.
    NotReadyToSwitchOn,
    /// `xxxx xxxx x1xx 0000`.
    SwitchOnDisabled,
    /// `xxxx xxxx x01x 0001`.
    ReadyToSwitchOn,
    /// `xxxx xxxx x01x 0011`.
    SwitchedOn,
    /// `xxxx xxxx x01x 0111`: power on, setpoints followed.
    OperationEnabled,
    /// `xxxx xxxx x00x 0111`.
    QuickStopActive,
    /// `xxxx xxxx x0xx 1111`.
    FaultReactionActive,
    /// `xxxx xxxx x0xx 1000`.
    Fault,
}

impl DriveState {
    /// Every state.
    pub const ALL: [DriveState; 8] = [
        DriveState::NotReadyToSwitchOn,
        DriveState::SwitchOnDisabled,
        DriveState::ReadyToSwitchOn,
        DriveState::SwitchedOn,
        DriveState::OperationEnabled,
        DriveState::QuickStopActive,
        DriveState::FaultReactionActive,
        DriveState::Fault,
    ];

    /// The state bits' (mask, value) pattern: bits 0-3 and 6 (mask
    /// 0x4F) where bit 5 (quick stop) is free, bits 0-3, 5, 6 (mask
    /// 0x6F) otherwise.
    pub const fn pattern(self) -> (u16, u16) {
        match self {
            DriveState::NotReadyToSwitchOn => (0x4F, 0x00),
            DriveState::SwitchOnDisabled => (0x4F, 0x40),
            DriveState::ReadyToSwitchOn => (0x6F, 0x21),
            DriveState::SwitchedOn => (0x6F, 0x23),
            DriveState::OperationEnabled => (0x6F, 0x27),
            DriveState::QuickStopActive => (0x6F, 0x07),
            DriveState::FaultReactionActive => (0x4F, 0x0F),
            DriveState::Fault => (0x4F, 0x08),
        }
    }

    /// The state a statusword (0x6041) reports.
    pub fn from_statusword(word: u16) -> Result<DriveState, DecodeError> {
        DriveState::ALL
            .into_iter()
            .find(|s| {
                let (mask, value) = s.pattern();
                word & mask == value
            })
            .ok_or(DecodeError::Statusword(word))
    }

    /// The next controlword command on the way from this state to
    /// [`DriveState::OperationEnabled`], or `None` where the drive moves
    /// on its own (not ready to switch on, fault reaction active) and
    /// the master waits. In Operation enabled it is Enable operation
    /// (keep sending it). Fault reset acts on a rising edge of bit 7:
    /// the word sent before it must have had bit 7 clear.
    pub const fn next_toward_enabled(self) -> Option<Command> {
        match self {
            DriveState::NotReadyToSwitchOn | DriveState::FaultReactionActive => None,
            DriveState::SwitchOnDisabled => Some(Command::Shutdown),
            DriveState::ReadyToSwitchOn => Some(Command::SwitchOn),
            DriveState::SwitchedOn | DriveState::OperationEnabled => Some(Command::EnableOperation),
            DriveState::QuickStopActive => Some(Command::DisableVoltage),
            DriveState::Fault => Some(Command::FaultReset),
        }
    }
}

/// Controlword (0x6040) state-machine commands, bits 0-3 and 7.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum Command {
    /// 0x0000: → switch on disabled.
    DisableVoltage = 0x00,
    /// 0x0002: → quick stop active (from operation enabled).
    QuickStop = 0x02,
    /// 0x0006: → ready to switch on.
    Shutdown = 0x06,
    /// 0x0007: → switched on.
    SwitchOn = 0x07,
    /// 0x000F: → operation enabled.
    EnableOperation = 0x0F,
    /// 0x0080: fault → switch on disabled (on the rising edge).
    FaultReset = 0x80,
}

impl Command {
    /// The controlword value.
    pub const fn word(self) -> u16 {
        self as u16
    }
}
