//! The simulated robot that `anguilla run` drives when no bus is named:
//! `anguilla_sim::builtin` (an in-process bus with CAN wire time at the
//! configured bit rates, the vertebra nodes and the swimming body, on its
//! own thread in real time), configured from the daemon's configuration.

use anguilla_daemon::config::Config;
use anguilla_daemon::sensors::Source;
use anguilla_drivers::Bus;
use anguilla_sim::SimError;
use anguilla_sim::builtin::{Builtin, BuiltinConfig};
use anguilla_sim::offbus::SimSensorConfig;
use anguilla_sim::sensor::SensorConfig;

/// The running built-in robot.
pub struct BuiltinSim {
    running: Builtin,
}

impl BuiltinSim {
    /// The simulation's ground truth, for the status line.
    pub fn truth_line(&self) -> String {
        let t = self.running.truth();
        format!(
            " | simulated robot: speed {:+.3} m/s, heading {:5.1}°, depth {:.2} m",
            t.forward_speed + 0.0, // no "-0.000" at rest
            t.heading.to_degrees().rem_euclid(360.0),
            t.depth + 0.0
        )
    }

    /// The simulation's ground truth, for the recording.
    pub fn ground_truth(&self) -> anguilla_daemon::truth::GroundTruth {
        ground_truth(&self.running.truth())
    }

    /// Stops the robot's thread.
    pub fn stop(self) {
        self.running.stop();
    }
}

/// A simulated robot's truth as the recording's `/sim/truth` holds it.
pub fn ground_truth(t: &anguilla_sim::Truth) -> anguilla_daemon::truth::GroundTruth {
    anguilla_daemon::truth::GroundTruth {
        sim_time: t.time.as_secs_f64(),
        position: t.position,
        orientation: t.orientation,
        velocity: t.velocity,
        speed: t.forward_speed,
        heading: t.heading,
        depth: t.depth,
    }
}

/// The built-in robot of `cfg`: its nodes, bus rates and protocol variant;
/// its thread one SCHED_FIFO priority below a real-time loop's.
pub fn builtin_config(cfg: &Config, bus_name: &str) -> BuiltinConfig {
    BuiltinConfig {
        bus_name: bus_name.to_string(),
        bitrate: cfg.bus.bitrate,
        data_bitrate: cfg.bus.fd.then_some(cfg.bus.data_bitrate),
        drive: cfg.robot.drive,
        node_ids: cfg.node_ids(),
        axis_ids: cfg.axis_ids(),
        variant: cfg.bus.variant(),
        fifo_priority: (cfg.realtime.fifo_priority > 1).then(|| cfg.realtime.fifo_priority - 1),
        scenario: String::new(),
        head_sensor: head_sensor(cfg, cfg.sensor.node),
        tail_sensor: head_sensor(cfg, cfg.sensor.tail_imu),
        body: cfg.model.body(),
        off_bus: simulated_off_bus(cfg),
    }
}

/// The simulated counterparts of `cfg`'s sensors off the bus
/// ([`anguilla_sim::offbus`], by the kind's name, typical noise and rate,
/// the configured latency), each sending to its section's `udp:` source
/// (the machine's own address if it is unspecified). None for a serial
/// source (a serial sensor is a real one), nor for a kind without a
/// simulated counterpart (it is warned of: the daemon will wait for it).
fn simulated_off_bus(cfg: &Config) -> Vec<SimSensorConfig> {
    let mut sims = Vec::new();
    for section in cfg.sensor.off_bus() {
        let Some(target) = Source::parse(section.source())
            .ok()
            .and_then(|s| s.send_to())
        else {
            continue;
        };
        let name = section.kind().name();
        match SimSensorConfig::typical(name, target, Some(section.latency())) {
            Some(sim) => sims.push(sim),
            None => tracing::warn!("[sensor.{name}]: the built-in robot does not simulate it"),
        }
    }
    sims
}

/// The simulated IMU at node `id` of `cfg`'s `[sensor]` (the head sensor
/// or the tail IMU; none with id 0): a typical fusion IMU in the water the
/// daemon assumes.
fn head_sensor(cfg: &Config, id: u8) -> Option<SensorConfig> {
    let s = &cfg.sensor;
    (id != 0).then(|| SensorConfig::typical_in(id, s.rate_hz, s.water_density, s.surface_pressure))
}

/// A fault scenario file (`anguilla run --scenario`) and its text.
#[derive(Debug, Clone)]
pub struct ScenarioFile {
    /// Where it was read from (named in its errors).
    pub path: std::path::PathBuf,
    /// Its text.
    pub text: String,
}

/// Creates the in-process bus and the robot (on `body`, else the body
/// `[model]` describes; its nose `depth` m below the surface, else
/// [`anguilla_sim::sensor::DEFAULT_ORIGIN_DEPTH`]), playing `scenario` from its start; returns the
/// daemon's end of the bus. A scenario the robot cannot play (a line that
/// does not parse, a joint it does not have, a sensor fault without the
/// sensor) is an error naming the file and the line.
pub fn start_builtin(
    cfg: &Config,
    body: Option<anguilla_model::Body>,
    depth: Option<f64>,
    scenario: Option<&ScenarioFile>,
) -> anyhow::Result<(Box<dyn Bus>, BuiltinSim)> {
    let mut bc = builtin_config(cfg, &format!("anguilla-builtin-{}", std::process::id()));
    if let Some(body) = body {
        bc.body = body;
    }
    if let Some(d) = depth {
        // Where the water's surface is, for the body and both sensors; a
        // robot with no sensor has no depth to start at.
        let Some(head) = &mut bc.head_sensor else {
            anyhow::bail!(
                "--sim-depth: this simulated robot has no head sensor ({} drives), so no depth \
                 to start at (anguilla drives have one: [sensor] node)",
                cfg.robot.drive
            )
        };
        head.origin_depth = d;
        if let Some(tail) = &mut bc.tail_sensor {
            tail.origin_depth = d;
        }
    }
    if let Some(s) = scenario {
        bc.scenario = s.text.clone();
    }
    let (host, running) = Builtin::start(&bc).map_err(|e| match (&e, scenario) {
        (
            SimError::Scenario(_)
            | SimError::Config {
                field: "scenario", ..
            },
            Some(s),
        ) => {
            anyhow::anyhow!("--scenario {}: {e}", s.path.display())
        }
        _ => anyhow::Error::new(e).context("building the simulated robot"),
    })?;
    if let (Some(p), Some(e)) = (bc.fifo_priority, &running.priority_refused) {
        tracing::warn!("simulated robot thread: SCHED_FIFO priority {p} refused ({e})");
    }
    Ok((host, BuiltinSim { running }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kind off the bus the daemon reads has its simulated
    /// counterpart on the built-in robot, sending to its `udp:` source
    /// with its latency; a serial source is a real sensor, not simulated;
    /// and no simulated kind is one the daemon cannot read.
    #[test]
    fn every_off_bus_kind_is_simulated_on_the_builtin_robot() {
        let mut cfg = Config::default();
        cfg.sensor = cfg.sensor.with_every_off_bus();
        if let Some(u) = &mut cfg.sensor.usbl {
            u.source = "udp:0.0.0.0:14660".into();
            u.latency = 0.25;
        }
        let sims = simulated_off_bus(&cfg);
        let daemon: Vec<_> = cfg.sensor.off_bus().map(|s| s.kind().name()).collect();
        let simulated: Vec<_> = sims.iter().map(SimSensorConfig::name).collect();
        assert_eq!(simulated, daemon);
        assert_eq!(SimSensorConfig::NAMES.to_vec(), daemon);
        assert!(
            sims[0].describe() == "--sensor usbl=127.0.0.1:14660@0.25",
            "an unspecified address is sent to this machine: {}",
            sims[0].describe()
        );
        if let Some(d) = &mut cfg.sensor.dvl {
            d.source = "serial:/dev/ttyUSB0:115200".into();
        }
        let sims = simulated_off_bus(&cfg);
        assert_eq!(
            sims.iter().map(SimSensorConfig::name).collect::<Vec<_>>(),
            ["usbl"]
        );
    }
}
