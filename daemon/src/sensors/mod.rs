//! The robot's sensors, as one list: each configured sensor claims its
//! frames (routed by the node id in the frame's identifier) or reads its
//! own wire on a thread of its own, moves on once a period, judges its own
//! health, hands the estimate what it observed ([`Observation`]), and
//! fills its entry of the snapshot ([`anguilla_ipc::SensorEntry`], whose
//! kind code and value names are [`SensorKind`]'s).
//!
//! - `crate::nav::Nav`: the head's IMU and pressure sensor and the
//!   navigation estimate on it (`[sensor] node`); the autopilot's, the
//!   supervisor's judge of a hold, and where the others' observations go;
//! - [`tail_imu::TailImu`]: an IMU in the tail (`[sensor] tail-imu`),
//!   shown and recorded as measured;
//! - [`usbl::Usbl`]: a USBL off the bus (`[sensor.usbl]`), whose position
//!   fixes correct the estimate's x, y.
//!
//! A further kind off the bus is a module here implementing [`Sensor`]
//! and, for its section, [`OffBusSection`] (its keys, checks, default
//! text and how it opens); the section is a field of
//! [`crate::config::SensorConfig`] listed by its `off_bus`, from which
//! [`Sensors::new`] opens it, the checks check it and the built-in robot
//! simulates it (`anguilla_sim::offbus`, by the kind's name); and its
//! [`SensorKind`] (code, name, values) in the operator vocabulary, from
//! which `ctl status`, the recordings and the Foxglove view show it. What
//! it observes is an [`Observation`] the estimate takes.
//!
//! The list is built once; nothing here allocates in the control period.

pub mod dvl;
pub mod frames;
pub mod head_nav;
pub mod observation;
mod offbus;
pub mod tail_imu;
pub mod usbl;

use anguilla_ipc::{MAX_SENSORS, SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::Frame;
use anguilla_protocol::message::Function;
use anguilla_protocol::time::Nanos;

use crate::config::Config;
use crate::nav::{Nav, Prediction};
pub use observation::Observation;
pub use offbus::{OffBusSection, Source};

/// One sensor. Every method runs in the control period and allocates
/// nothing.
pub trait Sensor: Send {
    /// What it is.
    fn kind(&self) -> SensorKind;
    /// Its node id (its frames carry it in their identifier); 0 for a
    /// sensor off the bus.
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
    /// What it observed in the last step for the estimate, taken once.
    fn observation(&mut self) -> Option<Observation> {
        None
    }
}

/// Why a sensor could not be started.
#[derive(Debug, thiserror::Error)]
#[error("sensor {kind}: {source}")]
pub struct SensorError {
    /// Which.
    pub kind: SensorKind,
    /// What the system said (it names the source).
    pub source: std::io::Error,
}

/// No sensor at this node id.
const NONE: u8 = u8::MAX;

/// The head sensor's place in `by_id`.
const HEAD: u8 = u8::MAX - 1;

/// The configured sensors: the head sensor (the estimate) and the others.
pub struct Sensors {
    nav: Option<Nav>,
    others: Vec<Box<dyn Sensor>>,
    /// Node id (0..=63) → index in `others`, or [`HEAD`].
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
    /// [`MAX_SENSORS`], one per node id: the configuration checks both);
    /// an error if a sensor off the bus cannot open its source.
    pub fn new(cfg: &Config, now: Nanos) -> Result<Self, SensorError> {
        let nav = Nav::new(cfg, now);
        let mut others: Vec<Box<dyn Sensor>> = Vec::with_capacity(MAX_SENSORS);
        if let Some(imu) = tail_imu::TailImu::new(cfg, now) {
            others.push(Box::new(imu));
        }
        for section in cfg.sensor.off_bus() {
            let sensor = section.open(now).map_err(|source| SensorError {
                kind: section.kind(),
                source,
            })?;
            others.push(sensor);
        }
        others.truncate(MAX_SENSORS - nav.is_some() as usize);
        let mut by_id = [NONE; 64];
        if let Some(n) = &nav {
            by_id[n.id() as usize % 64] = HEAD;
        }
        for (i, s) in others.iter().enumerate() {
            if s.id() != 0
                && let Some(slot) = by_id.get_mut(s.id() as usize)
            {
                *slot = i as u8;
            }
        }
        Ok(Self {
            nav,
            others,
            by_id,
            bus: now,
            heard: false,
            stepped: now,
        })
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
        match (self.by_id.get(node as usize), &mut self.nav) {
            (Some(&HEAD), Some(nav)) => nav.ingest(now, frame),
            (Some(&i), _) if i != NONE && i != HEAD => self.others[i as usize].ingest(now, frame),
            _ => false,
        }
    }

    /// Whether no sensor is configured.
    pub fn is_empty(&self) -> bool {
        self.nav.is_none() && self.others.is_empty()
    }

    /// Moves every sensor on by one period (the bus's clock moves on by
    /// it if a frame came in it), then hands the estimate what the others
    /// observed.
    pub fn step(&mut self, now: Nanos, dt: f64, pred: &Prediction) {
        if self.heard {
            self.bus += now.saturating_sub(self.stepped);
        }
        self.heard = false;
        self.stepped = now;
        if let Some(nav) = &mut self.nav {
            nav.step_on_bus(now, self.bus, dt, pred);
        }
        for s in &mut self.others {
            s.step(now, self.bus, dt, pred);
            // A fix the estimate leaves out is counted by it
            // (`Plane::rejected`); without a head sensor there is none.
            if let (Some(obs), Some(nav)) = (s.observation(), &mut self.nav) {
                nav.observe(&obs);
            }
        }
    }

    /// Hands the estimate an observation the host read itself (a pose
    /// from the ROS 2 node, a test rig's truth); `false` if it was left
    /// out (no head sensor, an outlier, before the estimate began).
    pub fn observe(&mut self, obs: &Observation) -> bool {
        self.nav.as_mut().is_some_and(|n| n.observe(obs))
    }

    /// The head sensor's estimate, if there is one.
    pub fn nav(&self) -> Option<&Nav> {
        self.nav.as_ref()
    }

    /// The head sensor's health ([`SensorHealth::None`] without one).
    pub fn head_health(&self) -> SensorHealth {
        self.nav().map_or(SensorHealth::None, Nav::health)
    }

    /// Every sensor, the head sensor first.
    pub fn iter(&self) -> impl Iterator<Item = &dyn Sensor> {
        let head = self.nav.iter().map(|n| n as &dyn Sensor);
        head.chain(self.others.iter().map(|s| &**s))
    }

    /// The snapshot's list: one entry per sensor, kind 0 past the last.
    pub fn fill(&self, entries: &mut [SensorEntry; MAX_SENSORS]) {
        let mut list = self.iter();
        for e in entries.iter_mut() {
            *e = SensorEntry::default();
            if let Some(s) = list.next() {
                e.kind = s.kind() as u8;
                e.id = s.id();
                e.health = s.health() as u8;
                s.fill(e);
            }
        }
    }
}
