//! The in-process robot: an in-process bus with CAN wire time at the given
//! bit rates, and the whole simulated robot on it (vertebra nodes, actuators
//! and the swimming body) on its own thread in real time. `anguilla run`
//! drives it when no bus is named, and the system tests drive the same one.

use std::sync::Arc;
use std::time::Duration;

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::{Bus, Clock};
use anguilla_protocol::Family;
use anguilla_protocol::message::Variant;

use crate::robot::{RobotConfig, RunningSim, SimError, SimRobot};

/// What the in-process robot is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct BuiltinConfig {
    /// The in-process bus's name (unique in the process).
    pub bus_name: String,
    /// Nominal bit rate, bit/s (wire time of every frame).
    pub bitrate: u32,
    /// CAN FD data-phase bit rate, bit/s (FD only).
    pub data_bitrate: Option<u32>,
    /// Which protocol the joints' drives speak (docs/drives.md).
    pub drive: Family,
    /// The nodes' ids, joint 1 (head end) first, for anguilla; for the
    /// bought families only their number counts (joints `1..=n`).
    pub node_ids: Vec<u8>,
    /// Bought families: the drives' node ids `[pitch, yaw]` per joint
    /// (empty: the family's defaults; [`RobotConfig::axis_ids`]).
    pub axis_ids: Vec<[u8; 2]>,
    /// Classic CAN or CAN FD nodes.
    pub variant: Variant,
    /// The robot thread's SCHED_FIFO priority, if any (keep it below a
    /// real-time control loop's, so the loop never waits on the bus lock
    /// held by a preempted robot thread).
    pub fifo_priority: Option<u8>,
    /// A fault scenario to play from the robot's start (the text of a
    /// scenario file; empty: none).
    pub scenario: String,
    /// A head sensor (IMU and pressure) beside the joints, or none.
    pub head_sensor: Option<crate::sensor::SensorConfig>,
    /// An IMU in the tail, or none.
    pub tail_sensor: Option<crate::sensor::SensorConfig>,
    /// The simulated body (its own, not necessarily the daemon's model).
    pub body: anguilla_model::Body,
    /// Sensors off the bus beside the robot (a USBL, a DVL), sending
    /// what the body's truth gives.
    pub off_bus: Vec<crate::offbus::SimSensorConfig>,
}

/// The in-process robot, running.
pub struct Builtin {
    running: RunningSim,
    bus: MemBus,
    host: anguilla_drivers::mem::ParticipantId,
    off_bus: crate::offbus::SimSensors,
    /// A priority the system refused (the robot runs without it).
    pub priority_refused: Option<std::io::Error>,
}

impl Builtin {
    /// Starts the robot; returns the controller's end of the bus.
    pub fn start(cfg: &BuiltinConfig) -> Result<(Box<dyn Bus>, Builtin), SimError> {
        let mut b = MemBus::builder(&cfg.bus_name)
            .bitrate(cfg.bitrate)
            .capacity(4096);
        if let Some(d) = cfg.data_bitrate {
            b = b.data_bitrate(d);
        }
        let bus = b.build();
        let host_end = bus.participant();
        let host_id = host_end.id();
        let host: Box<dyn Bus> = Box::new(host_end);
        let n = cfg.node_ids.len();
        let rc = RobotConfig {
            drive: cfg.drive,
            node_ids: if cfg.drive.drive_per_axis() {
                (1..=n.min(63) as u8).collect()
            } else {
                cfg.node_ids.clone()
            },
            axis_ids: cfg.axis_ids.clone(),
            variant: cfg.variant,
            boot_time: Duration::from_millis(50),
            head_sensor: cfg.head_sensor,
            tail_sensor: cfg.tail_sensor,
            body: cfg.body.clone(),
            ..RobotConfig::with_joints(n)
        };
        let clock: Arc<dyn Clock> = bus.clock();
        let mut robot = SimRobot::on_mem(rc, bus.participant(), clock.now())?;
        if !cfg.scenario.is_empty() {
            robot.load_scenario(&cfg.scenario)?;
        }
        let running = robot.spawn(clock).map_err(SimError::Thread)?;
        let priority_refused = cfg
            .fifo_priority
            .and_then(|p| running.set_fifo_priority(p).err());
        let off_bus = match crate::offbus::SimSensors::beside(&cfg.off_bus, &running) {
            Ok(s) => s,
            Err((_, e)) => {
                let _ = running.stop();
                return Err(SimError::Thread(e));
            }
        };
        Ok((
            host,
            Builtin {
                running,
                bus,
                host: host_id,
                off_bus,
                priority_refused,
            },
        ))
    }

    /// Fault injection on the controller's end of the bus: its CAN
    /// controller goes to `state` (e.g. bus-off) until set back.
    pub fn force_host_state(&self, state: anguilla_drivers::BusState) {
        self.bus.force_state(self.host, state);
    }

    /// Another sender on the bus: `frame` goes on the wire now, heard by
    /// the controller and the robot alike (an attack: `cansend` on the
    /// robot's bus).
    pub fn send_foreign(&self, frame: &anguilla_protocol::frame::Frame) {
        self.bus.inject(frame);
    }

    /// Applies a scenario action at the robot's next tick.
    pub fn inject(&self, action: crate::scenario::Action) {
        self.running.inject(action);
    }

    /// The simulation's ground truth.
    pub fn truth(&self) -> crate::robot::Truth {
        self.running.truth()
    }

    /// Sentences the simulated sensors off the bus named `name` (`usbl`,
    /// `dvl`) have sent (0 without one).
    pub fn sent_off_bus(&self, name: &str) -> u64 {
        self.off_bus.sent(name)
    }

    /// Stops the robot's thread (and its sensors' off the bus).
    pub fn stop(self) {
        drop(self.off_bus);
        let _ = self.running.stop();
    }
}
