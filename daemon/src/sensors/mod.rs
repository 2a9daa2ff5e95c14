//! The robot's sensors, as one list: each configured sensor claims its
//! frames (routed by the node id in the frame's identifier), moves on once
//! a period with the model's prediction, judges its own health and fills
//! its entry of the snapshot ([`anguilla_ipc::SensorEntry`], whose kind
//! code and value names are [`SensorKind`]'s).
//!
//! - [`crate::nav::Nav`]: the head's IMU and pressure sensor and the
//!   navigation estimate on it (`[sensor] node`); the autopilot's, and the
//!   supervisor's judge of a hold;
//! - [`tail_imu::TailImu`]: an IMU in the tail (`[sensor] tail-imu`),
//!   shown and recorded as measured.
//!
//! A further kind is a module here implementing [`Sensor`], a line in
//! [`Sensors::new`] that builds it from its configuration, and its
//! [`SensorKind`] (code, name, values) in the operator vocabulary, from
//! which `ctl status`, the recordings and the Foxglove view show it.
//!
//! The list is built once; nothing here allocates in the control period.

pub mod frames;
pub mod head_nav;
pub mod tail_imu;

use anguilla_ipc::{MAX_SENSORS, SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::Frame;
use anguilla_protocol::message::Function;
use anguilla_protocol::time::Nanos;

use crate::config::Config;
use crate::nav::{Nav, Prediction};

/// One sensor on the bus. Every method runs in the control period and
/// allocates nothing.
pub trait Sensor: Send {
    /// What it is.
    fn kind(&self) -> SensorKind;
    /// Its node id (its frames carry it in their identifier).
    fn id(&self) -> u8;
    /// Takes one of its frames (the list routes by id); `false` if the
    /// frame is not one of its kind's (it then goes to the drives).
    fn ingest(&mut self, now: Nanos, frame: &Frame) -> bool;
    /// One control period of `dt` s at `now`, with what the model predicts
    /// of the head; `bus` is the bus's clock, which moves on only in
    /// periods in which the bus carried a frame, anyone's (silence is
    /// counted on it: [`frames::SampleReader::silence`]).
    fn step(&mut self, now: Nanos, bus: Nanos, dt: f64, pred: &Prediction);
    /// Its health after the last step.
    fn health(&self) -> SensorHealth;
    /// Its entry of the snapshot (kind, id and health are filled by the
    /// list; this fills samples and values).
    fn fill(&self, entry: &mut SensorEntry);
    /// The head sensor's estimate, if this is it.
    fn as_nav(&self) -> Option<&Nav> {
        None
    }
}

/// No sensor at this node id.
const NONE: u8 = u8::MAX;

/// The configured sensors, the head sensor first.
pub struct Sensors {
    list: Vec<Box<dyn Sensor>>,
    /// Node id (0..=63) → index in `list`.
    by_id: [u8; 64],
    /// The bus's clock: the time of the periods in which the bus carried
    /// a frame, anyone's.
    bus: Nanos,
    /// Whether a frame came since the last step.
    heard: bool,
    /// The last step's time.
    stepped: Nanos,
}

impl Sensors {
    /// The sensors of `cfg`, unheard-of at `now` (at most
    /// [`MAX_SENSORS`], one per node id: the configuration checks both).
    pub fn new(cfg: &Config, now: Nanos) -> Self {
        let mut list: Vec<Box<dyn Sensor>> = Vec::with_capacity(MAX_SENSORS);
        if let Some(nav) = Nav::new(cfg, now) {
            list.push(Box::new(nav));
        }
        if let Some(imu) = tail_imu::TailImu::new(cfg, now) {
            list.push(Box::new(imu));
        }
        list.truncate(MAX_SENSORS);
        let mut by_id = [NONE; 64];
        for (i, s) in list.iter().enumerate() {
            if let Some(slot) = by_id.get_mut(s.id() as usize) {
                *slot = i as u8;
            }
        }
        Self {
            list,
            by_id,
            bus: now,
            heard: false,
            stepped: now,
        }
    }

    /// Gives `frame` to the sensor whose id it carries; `false` if no
    /// sensor takes it. Every frame of the bus comes here first (the
    /// bus was heard in this period).
    pub fn ingest(&mut self, now: Nanos, frame: &Frame) -> bool {
        self.heard = true;
        let Some(raw) = frame.id().as_standard() else {
            return false;
        };
        let Some((_, node)) = Function::split_id(raw) else {
            return false;
        };
        match self.by_id.get(node as usize) {
            Some(&i) if i != NONE => self.list[i as usize].ingest(now, frame),
            _ => false,
        }
    }

    /// Whether no sensor is configured.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Moves every sensor on by one period; the bus's clock moves on by
    /// it if a frame came in it.
    pub fn step(&mut self, now: Nanos, dt: f64, pred: &Prediction) {
        if self.heard {
            self.bus += now.saturating_sub(self.stepped);
        }
        self.heard = false;
        self.stepped = now;
        for s in &mut self.list {
            s.step(now, self.bus, dt, pred);
        }
    }

    /// The head sensor's estimate, if there is one.
    pub fn nav(&self) -> Option<&Nav> {
        self.list.iter().find_map(|s| s.as_nav())
    }

    /// The head sensor's health ([`SensorHealth::None`] without one).
    pub fn head_health(&self) -> SensorHealth {
        self.nav().map_or(SensorHealth::None, Nav::health)
    }

    /// Every sensor, the head sensor first.
    pub fn iter(&self) -> impl Iterator<Item = &dyn Sensor> {
        self.list.iter().map(|s| &**s)
    }

    /// The snapshot's list: one entry per sensor, kind 0 past the last.
    pub fn fill(&self, entries: &mut [SensorEntry; MAX_SENSORS]) {
        for (i, e) in entries.iter_mut().enumerate() {
            *e = SensorEntry::default();
            if let Some(s) = self.list.get(i) {
                e.kind = s.kind() as u8;
                e.id = s.id();
                e.health = s.health() as u8;
                s.fill(e);
            }
        }
    }
}
