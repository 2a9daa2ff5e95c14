//! A simulated robot's configuration: its joints, drives and ids, checked.

use std::time::Duration;

use anguilla_model::Current;
use anguilla_protocol::Family;
use anguilla_protocol::message::{NodeId, Variant};

use crate::actuator::ActuatorParams;
use crate::device::JointDevice;
use crate::node::{Nanos, NodeConfig, VertebraNode};
use crate::odrive::{OdriveJoint, OdriveJointConfig};
use crate::plant::PlantConfig;
use crate::sensor::SensorConfig;

use crate::error::{Result, SimError};

/// Configuration of a simulated robot.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotConfig {
    /// Which protocol the joints' drives speak (docs/drives.md).
    pub drive: Family,
    /// Joint 1 (head end) first: the vertebra nodes' bus ids (1..=63) for
    /// [`Family::Anguilla`]; for the bought families, the joint numbers
    /// `1..=n` a scenario's `node N` names (the drives' ids are
    /// [`RobotConfig::axis_ids`]).
    pub node_ids: Vec<u8>,
    /// Bought families only: the drives' node ids `[pitch, yaw]` of each
    /// joint, joint 1 first, in [`Family::id_range`] and all distinct.
    /// Empty: the family's defaults ([`Family::default_ids`]). Must be
    /// empty for [`Family::Anguilla`].
    pub axis_ids: Vec<[u8; 2]>,
    /// The bought drives' own watchdog: an ODrive axis's
    /// `axis.config.watchdog_timeout`, an MIT drive's CAN timeout. `None`:
    /// the family's default (docs/drives.md: [`ODRIVE_WATCHDOG`],
    /// [`crate::mit::CAN_TIMEOUT`]).
    pub drive_watchdog: Option<Duration>,
    /// Classic CAN or CAN FD nodes (anguilla family only).
    pub variant: Variant,
    /// Parameters of every actuator axis.
    pub actuator: ActuatorParams,
    /// Drive boot time (power-on to Disabled).
    pub boot_time: Duration,
    /// Seed of sensor noise and random faults.
    pub seed: u64,
    /// Physics step; also the period at which drives are advanced and the
    /// loads updated (frames are still handled at their own times).
    pub tick: Duration,
    /// Requested space intervals of the body model.
    pub model_nodes: usize,
    /// Initial head speed along `t1` (m/s).
    pub v_init: f64,
    /// The water's uniform current at the start (earth frame; still water
    /// by default). A scenario's `water current` events change it.
    pub current: Current,
    /// The simulated body: geometry, mass, ballast, hydrodynamic
    /// coefficients and laws, its own and not the daemon's `[model]` (a
    /// body that is not the model, `docs/calibration.md`). Default: the
    /// paper's body with [`anguilla_model::TYPICAL_BALLAST`], as the
    /// daemon's default `[model]`.
    pub body: anguilla_model::Body,
    /// A head sensor beside the joints (anguilla family only), or none.
    pub head_sensor: Option<SensorConfig>,
    /// An IMU in the tail section (the head sensor's protocol; anguilla
    /// family only), or none. Its pressure is the tail's depth.
    pub tail_sensor: Option<SensorConfig>,
    /// Whether the water has a surface: a nose that would rise above depth
    /// 0 is put back on it ([`crate::plant::Plant::surface`]). On by
    /// default; off, the body swims in open water without bound, as the
    /// swimming model knows it (tests of the model against its own body
    /// whose gaits climb more than the start's depth).
    pub surface: bool,
    /// Nodes of [`RobotConfig::node_ids`] the simulator does not play
    /// (anguilla family only): real vertebrae on the same bus, whose
    /// measured motion the body swims with ([`crate::observed`]; `anguilla
    /// sim --skip`). Empty: every joint simulated.
    pub observed: Vec<u8>,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self::with_joints(12)
    }
}

/// The watchdog of a simulated ODrive axis unless configured (docs/drives.md).
pub const ODRIVE_WATCHDOG: Duration = Duration::from_millis(100);

impl RobotConfig {
    /// `n` joints on nodes `1..=n`, anguilla vertebra nodes on classic
    /// CAN, default servos.
    pub fn with_joints(n: usize) -> Self {
        let p = PlantConfig::default();
        Self {
            drive: Family::Anguilla,
            node_ids: (1..=n.min(63) as u8).collect(),
            axis_ids: Vec::new(),
            drive_watchdog: None,
            variant: Variant::Classic,
            actuator: ActuatorParams::default(),
            boot_time: Duration::from_millis(20),
            seed: 1,
            tick: Duration::from_secs_f64(p.dt),
            model_nodes: p.nodes,
            v_init: 0.0,
            current: Current::ZERO,
            body: anguilla_model::Body {
                ballast: anguilla_model::TYPICAL_BALLAST,
                ..anguilla_model::Body::paper()
            },
            head_sensor: None,
            tail_sensor: None,
            surface: true,
            observed: Vec::new(),
        }
    }

    /// The drives' node ids `[pitch, yaw]` of joint `j` (0 = head end):
    /// `[id, id]` of the vertebra node for anguilla, else
    /// [`RobotConfig::axis_ids`] or the family's defaults.
    pub fn drive_ids(&self, j: usize) -> [u8; 2] {
        if self.drive.drive_per_axis() {
            self.axis_ids
                .get(j)
                .copied()
                .unwrap_or_else(|| self.drive.default_ids(j))
        } else {
            let id = self.node_ids.get(j).copied().unwrap_or(0);
            [id, id]
        }
    }

    /// Checks every setting (what building a robot checks first); the
    /// error names the setting and what is accepted.
    pub fn validate(&self) -> Result<()> {
        if let Err(e) = self.body.validate() {
            return Err(SimError::Config {
                field: "body",
                reason: e.to_string(),
            });
        }
        if self.node_ids.is_empty() {
            return Err(SimError::Config {
                field: "node_ids",
                reason: "at least one node".into(),
            });
        }
        for (i, id) in self.observed.iter().enumerate() {
            let why = if self.drive != Family::Anguilla {
                Some(format!(
                    "real joints on the bus are anguilla vertebrae; {} drives are all simulated",
                    self.drive
                ))
            } else if !self.node_ids.contains(id) {
                Some(format!(
                    "node {id} is not one of the robot's {:?}",
                    self.node_ids
                ))
            } else if self.observed[..i].contains(id) {
                Some(format!("node {id} named twice"))
            } else {
                None
            };
            if let Some(reason) = why {
                return Err(SimError::Config {
                    field: "observed",
                    reason,
                });
            }
        }
        for (i, &id) in self.node_ids.iter().enumerate() {
            if NodeId::new(id).is_err() {
                return Err(SimError::Config {
                    field: "node_ids",
                    reason: format!("node id {id} outside 1..=63"),
                });
            }
            if self.node_ids[..i].contains(&id) {
                return Err(SimError::Config {
                    field: "node_ids",
                    reason: format!("node id {id} appears twice"),
                });
            }
        }
        self.validate_drive_ids()?;
        if let Some(s) = &self.head_sensor {
            s.validate()
                .map_err(|(field, reason)| SimError::Config { field, reason })?;
            if !self.drive.carries_head_sensor() {
                return Err(SimError::Config {
                    field: "head_sensor",
                    reason: "a head sensor speaks the anguilla protocol (drive = anguilla)".into(),
                });
            }
            if self.node_ids.contains(&s.id) {
                return Err(SimError::Config {
                    field: "head_sensor.id",
                    reason: format!("{} is a vertebra's node id (expected a distinct id)", s.id),
                });
            }
        }
        if let Some(s) = &self.tail_sensor {
            s.validate().map_err(|(field, reason)| SimError::Config {
                field: if field.starts_with("head_sensor") {
                    "tail_sensor"
                } else {
                    field
                },
                reason,
            })?;
            if !self.drive.carries_head_sensor() {
                return Err(SimError::Config {
                    field: "tail_sensor",
                    reason: "an IMU speaks the anguilla protocol (drive = anguilla)".into(),
                });
            }
            if self.node_ids.contains(&s.id) || self.head_sensor.is_some_and(|h| h.id == s.id) {
                return Err(SimError::Config {
                    field: "tail_sensor.id",
                    reason: format!(
                        "{} is a vertebra's or the head sensor's node id (expected a distinct id)",
                        s.id
                    ),
                });
            }
        }
        let t = self.tick.as_secs_f64();
        if !TICK_RANGE.contains(&t) {
            return Err(SimError::Config {
                field: "tick",
                reason: format!("{t} s outside 0.1 ms..=20 ms"),
            });
        }
        if let Some(w) = self.drive_watchdog
            && !(Duration::from_millis(1)..=Duration::from_secs(60)).contains(&w)
        {
            return Err(SimError::Config {
                field: "drive_watchdog",
                reason: format!("{w:?} outside 1 ms..=60 s"),
            });
        }
        Ok(())
    }

    fn validate_drive_ids(&self) -> Result<()> {
        let n = self.node_ids.len();
        if self.drive == Family::Anguilla {
            if !self.axis_ids.is_empty() {
                return Err(SimError::Config {
                    field: "axis_ids",
                    reason: "only for drives with one axis per node id (cia402, odrive); \
                             anguilla nodes are node_ids"
                        .into(),
                });
            }
            return Ok(());
        }
        let family = self.drive;
        if self.node_ids.iter().copied().ne(1..=n as u8) {
            return Err(SimError::Config {
                field: "node_ids",
                reason: format!(
                    "{family} joints are numbered 1..={n} in order (the drives' ids are axis_ids), \
                     not {:?}",
                    self.node_ids
                ),
            });
        }
        if !self.axis_ids.is_empty() && self.axis_ids.len() != n {
            return Err(SimError::Config {
                field: "axis_ids",
                reason: format!(
                    "{} pairs of ids for {n} joints: give one [pitch, yaw] pair per joint",
                    self.axis_ids.len()
                ),
            });
        }
        let (lo, hi) = family.id_range();
        let mut seen = [false; 256];
        for j in 0..n {
            for (axis, id) in ["pitch", "yaw"].into_iter().zip(self.drive_ids(j)) {
                if !(lo..=hi).contains(&id) {
                    return Err(SimError::Config {
                        field: "axis_ids",
                        reason: format!(
                            "joint {} {axis} id {id} outside {family}'s {lo}..={hi}",
                            j + 1
                        ),
                    });
                }
                if std::mem::replace(&mut seen[id as usize], true) {
                    return Err(SimError::Config {
                        field: "axis_ids",
                        reason: format!("id {id} appears twice (joint {} {axis})", j + 1),
                    });
                }
            }
        }
        Ok(())
    }
}

/// The drives of joint `j` (0 = head end) of a robot of `cfg`, powered on
/// at `start`, with sensor-noise seed `seed`: a vertebra node for
/// anguilla, two ODrive axes for odrive, two CiA 402 drives for cia402.
/// Ids are checked again: a bad one is an error, never a panic.
pub fn joint_device(
    cfg: &RobotConfig,
    j: usize,
    seed: u64,
    start: Nanos,
) -> Result<Box<dyn JointDevice>> {
    let boot_time = Nanos::from(cfg.boot_time);
    match cfg.drive {
        Family::Anguilla => {
            let id = cfg.drive_ids(j)[0];
            let id = NodeId::new(id).map_err(|_| SimError::Config {
                field: "node_ids",
                reason: format!("node id {id} outside 1..=63"),
            })?;
            if cfg.observed.contains(&id.get()) {
                return Ok(Box::new(crate::observed::ObservedJoint::new(
                    id,
                    cfg.variant,
                    start,
                )));
            }
            let nc = NodeConfig {
                id,
                variant: cfg.variant,
                axes: [cfg.actuator; 2],
                boot_time,
                seed,
            };
            Ok(Box::new(VertebraNode::new(nc, start)))
        }
        Family::Odrive => Ok(Box::new(OdriveJoint::new(
            OdriveJointConfig {
                ids: cfg.drive_ids(j),
                axes: [cfg.actuator; 2],
                boot_time,
                seed,
                watchdog: Nanos::from(cfg.drive_watchdog.unwrap_or(ODRIVE_WATCHDOG)),
            },
            start,
        )?)),
        Family::Mit => Ok(Box::new(crate::mit::MitJoint::new(
            crate::mit::MitJointConfig {
                ids: cfg.drive_ids(j),
                axes: [cfg.actuator; 2],
                boot_time,
                seed,
                timeout: cfg
                    .drive_watchdog
                    .map_or(crate::mit::CAN_TIMEOUT, Nanos::from),
            },
            start,
        )?)),
        Family::Cia402 => Ok(Box::new(
            crate::cia402::Cia402Joint::try_new(
                crate::cia402::Cia402JointConfig {
                    ids: cfg.drive_ids(j),
                    axes: [cfg.actuator; 2],
                    boot_time,
                    seed,
                },
                start,
            )
            .map_err(|e| SimError::Config {
                field: "axis_ids",
                reason: e.to_string(),
            })?,
        )),
    }
}

/// Physics steps a robot accepts ([`RobotConfig::tick`], seconds).
pub const TICK_RANGE: std::ops::RangeInclusive<f64> = 1e-4..=0.02;
