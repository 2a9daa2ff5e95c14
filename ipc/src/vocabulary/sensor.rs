//! The sensors: a head sensor's [`SensorHealth`], and what each
//! [`SensorKind`] of the snapshot's list measures.

use core::fmt;

/// The head sensor's health as the daemon judges it (`NavSnapshot::sensor`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SensorHealth {
    /// No head sensor is configured (`[sensor] node = 0`).
    None = 0,
    /// Samples arrive, plausible.
    Ok = 1,
    /// Configured, no sample yet (booting).
    Waiting = 2,
    /// No sample within the sensor timeout.
    Silent = 3,
    /// Samples arrive with their measured values frozen.
    Stuck = 4,
    /// The sensor reports an IMU or pressure fault in its error byte.
    Error = 5,
    /// The measurements disagree with the model's prediction beyond the
    /// configured bound (a gyro bias jump, a wrong estimate).
    Implausible = 6,
}

impl SensorHealth {
    /// Every value, in the order of their codes.
    pub const ALL: [SensorHealth; 7] = [
        SensorHealth::None,
        SensorHealth::Ok,
        SensorHealth::Waiting,
        SensorHealth::Silent,
        SensorHealth::Stuck,
        SensorHealth::Error,
        SensorHealth::Implausible,
    ];

    /// The health of a snapshot's code.
    pub fn from_code(code: u8) -> Option<SensorHealth> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            SensorHealth::None => "no sensor",
            SensorHealth::Ok => "ok",
            SensorHealth::Waiting => "waiting",
            SensorHealth::Silent => "silent",
            SensorHealth::Stuck => "stuck",
            SensorHealth::Error => "sensor error",
            SensorHealth::Implausible => "implausible",
        }
    }
}

impl fmt::Display for SensorHealth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Whether the position estimate is held by fixes
/// (`NavSnapshot::position_health`): the level an operator, the recording
/// and a path that is followed act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum PositionHealth {
    /// No position sensor (no head sensor, or no `[sensor.usbl]`): x, y
    /// are dead-reckoned alone, their uncertainty growing without bound.
    DeadReckoning = 0,
    /// A position sensor is configured and no fix has been taken yet.
    Waiting = 1,
    /// The last fix taken is at most `[autopilot] fix-stale` old.
    Fixed = 2,
    /// The last fix taken is older than `fix-stale`: x, y are drifting on
    /// dead reckoning (their uncertainty shows by how much).
    Stale = 3,
    /// The last fix taken is older than `fix-lost`: the position is no
    /// longer fit to steer by.
    Lost = 4,
}

impl PositionHealth {
    /// Every value, in the order of their codes.
    pub const ALL: [PositionHealth; 5] = [
        PositionHealth::DeadReckoning,
        PositionHealth::Waiting,
        PositionHealth::Fixed,
        PositionHealth::Stale,
        PositionHealth::Lost,
    ];

    /// The health of a snapshot's code.
    pub fn from_code(code: u8) -> Option<PositionHealth> {
        Self::ALL.get(code as usize).copied()
    }

    /// Lower-case name, as shown to operators.
    pub fn name(self) -> &'static str {
        match self {
            PositionHealth::DeadReckoning => "dead reckoning",
            PositionHealth::Waiting => "waiting for a fix",
            PositionHealth::Fixed => "fixed",
            PositionHealth::Stale => "fix stale",
            PositionHealth::Lost => "fix lost",
        }
    }
}

impl fmt::Display for PositionHealth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a sensor of the snapshot's list is ([`SensorEntry::kind`](crate::SensorEntry::kind)),
/// and what its values mean: a tool shows any sensor from this table alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum SensorKind {
    /// The head's IMU and pressure sensor and the navigation estimate
    /// built on it (`[sensor]`; the autopilot's). Its values are the
    /// estimate's, as `NavSnapshot`'s.
    HeadNav = 1,
    /// An IMU in the tail section (`[tail-imu]`): its attitude and rates
    /// as measured, no estimate.
    TailImu = 2,
    /// A USBL (or any position sensor off the bus) handing position fixes
    /// to the estimate (`[sensor.usbl]`): its last fix as sent, and the
    /// fix's age.
    Usbl = 3,
    /// A DVL off the bus handing its velocity over ground to the estimate
    /// (`[sensor.dvl]`): its last velocity as sent, and its age.
    Dvl = 4,
}

impl SensorKind {
    /// Every kind, in the order of their codes.
    pub const ALL: [SensorKind; 4] = [
        SensorKind::HeadNav,
        SensorKind::TailImu,
        SensorKind::Usbl,
        SensorKind::Dvl,
    ];

    /// The kind of a snapshot's code (0: an empty entry).
    pub fn from_code(code: u8) -> Option<SensorKind> {
        Self::ALL.into_iter().find(|k| *k as u8 == code)
    }

    /// Lower-case name, as shown to operators and in recordings.
    pub const fn name(self) -> &'static str {
        match self {
            SensorKind::HeadNav => "head-nav",
            SensorKind::TailImu => "tail-imu",
            SensorKind::Usbl => "usbl",
            SensorKind::Dvl => "dvl",
        }
    }

    /// The meaning of [`SensorEntry::values`](crate::SensorEntry::values),
    /// in order: `(name, unit)`. Values past these are 0.
    pub const fn values(self) -> &'static [(&'static str, &'static str)] {
        match self {
            SensorKind::HeadNav => &[
                ("heading", "deg"),
                ("pitch", "deg"),
                ("roll", "deg"),
                ("depth", "m"),
                ("depth_rate", "m/s"),
                ("temperature", "degC"),
            ],
            SensorKind::TailImu => &[
                ("heading", "deg"),
                ("pitch", "deg"),
                ("roll", "deg"),
                ("rate_x", "rad/s"),
                ("rate_y", "rad/s"),
                ("rate_z", "rad/s"),
                ("temperature", "degC"),
            ],
            SensorKind::Usbl => &[
                ("x", "m"),
                ("y", "m"),
                ("sigma", "m"),
                ("age", "s"),
                ("malformed", "count"),
                ("dropped", "count"),
            ],
            SensorKind::Dvl => &[
                ("vx", "m/s"),
                ("vy", "m/s"),
                ("sigma", "m/s"),
                ("age", "s"),
                ("malformed", "count"),
                ("dropped", "count"),
            ],
        }
    }
}

impl fmt::Display for SensorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
