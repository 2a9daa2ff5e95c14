//! The head sensor (`Nav`) as the list's first [`Sensor`]: its frames,
//! its step with the model's prediction, its health, and the estimate as
//! its values ([`SensorKind::HeadNav`]).

use anguilla_ipc::{SensorEntry, SensorHealth, SensorKind};
use anguilla_protocol::Frame;
use anguilla_protocol::time::Nanos;

use super::Sensor;
use crate::nav::{Nav, Prediction};

impl Sensor for Nav {
    fn kind(&self) -> SensorKind {
        SensorKind::HeadNav
    }

    fn id(&self) -> u8 {
        Nav::id(self)
    }

    fn ingest(&mut self, now: Nanos, frame: &Frame) -> bool {
        Nav::ingest(self, now, frame)
    }

    fn step(&mut self, now: Nanos, bus: Nanos, dt: f64, pred: &Prediction) {
        Nav::step_on_bus(self, now, bus, dt, pred)
    }

    fn health(&self) -> SensorHealth {
        Nav::health(self)
    }

    /// The estimate's heading, pitch, roll, depth, depth rate and the
    /// water temperature ([`SensorKind::HeadNav`]'s values).
    fn fill(&self, entry: &mut SensorEntry) {
        entry.samples = self.samples().min(u32::MAX as u64) as u32;
        if self.has_estimate() {
            let e = self.estimate();
            let v = [
                e.heading.to_degrees().rem_euclid(360.0),
                e.pitch.to_degrees(),
                e.roll.to_degrees(),
                e.depth,
                e.depth_rate,
                self.temperature(),
            ];
            for (slot, x) in entry.values.iter_mut().zip(v) {
                *slot = x as f32;
            }
        }
    }
}
