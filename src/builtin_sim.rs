//! The simulated robot that `anguilla run` drives when no bus is named:
//! `anguilla_sim::builtin` (an in-process bus with CAN wire time at the
//! configured bit rates, the vertebra nodes and the swimming body, on its
//! own thread in real time), configured from the daemon's configuration.

use anguilla_daemon::config::Config;
use anguilla_drivers::Bus;
use anguilla_sim::SimError;
use anguilla_sim::builtin::{Builtin, BuiltinConfig};
use anguilla_sim::dvl::DvlSimConfig;
use anguilla_sim::sensor::SensorConfig;
use anguilla_sim::usbl::UsblSimConfig;

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
        usbl: udp_target(cfg.sensor.usbl.as_ref().map(|u| u.source.as_str())).map(|addr| {
            UsblSimConfig::typical(addr, cfg.sensor.usbl.as_ref().map_or(0.0, |u| u.latency))
        }),
        dvl: udp_target(cfg.sensor.dvl.as_ref().map(|d| d.source.as_str())).map(|addr| {
            DvlSimConfig::typical(addr, cfg.sensor.dvl.as_ref().map_or(0.0, |d| d.latency))
        }),
    }
}

/// Where a simulated sensor off the bus sends, for a `udp:` `source` (the
/// machine's own address if it is unspecified): the built-in robot's USBL
/// (typical fixes, [`UsblSimConfig::typical`]) and DVL
/// ([`DvlSimConfig::typical`]), each with its configured latency. None for
/// a serial source: a serial sensor is a real one.
fn udp_target(source: Option<&str>) -> Option<std::net::SocketAddr> {
    anguilla_daemon::sensors::usbl::Source::parse(source?)
        .ok()?
        .send_to()
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
