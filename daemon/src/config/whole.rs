//! What the configuration asks of more than one section: the joints' and
//! drives' ids (`[robot]` with `[bus]`), the head sensor among them
//! (`[sensor]` with `[robot]`), and the built-in robot's adjustments.

use super::error::{ConfigError, fmt_number, range};
use super::{AxisMap, BUILTIN_TIMEOUT, Config, ControlConfig};

impl Config {
    /// Each joint's two axes (bought families), pitch then yaw, with
    /// `[robot.axis]` filling what `robot.axes` leaves out.
    pub fn axes(&self) -> Vec<[AxisMap; 2]> {
        let d = &self.robot.axis;
        let family = self.robot.drive;
        (0..self.robot.joints)
            .map(|j| {
                let ids = family.default_ids(j);
                [0, 1].map(|a| {
                    let e = self.robot.axes.get(2 * j + a).cloned().unwrap_or_default();
                    AxisMap {
                        node: e.node.unwrap_or(ids[a]),
                        direction: e.direction.unwrap_or(d.direction) as f64,
                        offset: e.offset.unwrap_or(d.offset),
                        gear: e.gear.unwrap_or(d.gear),
                        counts_per_turn: e.counts_per_turn.unwrap_or(d.counts_per_turn),
                        rated_torque: e.rated_torque.unwrap_or(d.rated_torque),
                    }
                })
            })
            .collect()
    }

    /// The bought drives' node ids, `[pitch, yaw]` per joint (empty for
    /// anguilla, whose node carries both axes).
    pub fn axis_ids(&self) -> Vec<[u8; 2]> {
        if !self.robot.drive.drive_per_axis() {
            return Vec::new();
        }
        self.axes().iter().map(|p| [p[0].node, p[1].node]).collect()
    }

    /// The node id of each joint, head to tail (anguilla); for the bought
    /// families, each joint's report id 1..=joints.
    pub fn node_ids(&self) -> Vec<u8> {
        if self.robot.drive.drive_per_axis() {
            return (1..=self.robot.joints as u8).collect();
        }
        if self.robot.node_ids.is_empty() {
            (1..=self.robot.joints as u8).collect()
        } else {
            self.robot.node_ids.clone()
        }
    }

    /// Checks `[robot]`: the joints, their ids, and a bought family's
    /// axes (which read `[bus]`'s bit rate for an EDS).
    pub(super) fn validate_robot(&self) -> Result<(), ConfigError> {
        let r = &self.robot;
        range("robot.joints", r.joints as f64, 1.0, 32.0, "1 ..= 32")?;
        if !r.node_ids.is_empty() {
            if r.node_ids.len() != r.joints {
                return Err(ConfigError::Range {
                    key: "robot.node-ids",
                    value: format!("{} ids", r.node_ids.len()),
                    expected: "one id per joint (robot.joints of them), or none for 1..=joints",
                });
            }
            let mut seen = [false; 256];
            for &id in &r.node_ids {
                if !(1..=63).contains(&id) || seen[id as usize] {
                    return Err(ConfigError::Range {
                        key: "robot.node-ids",
                        value: format!("{:?}", r.node_ids),
                        expected: "distinct ids in 1 ..= 63",
                    });
                }
                seen[id as usize] = true;
            }
        }
        self.validate_axes()
    }

    fn validate_axes(&self) -> Result<(), ConfigError> {
        let r = &self.robot;
        let family = r.drive;
        if !family.drive_per_axis() {
            if !r.axes.is_empty() {
                return Err(ConfigError::Range {
                    key: "robot.axes",
                    value: format!("{} entries", r.axes.len()),
                    expected: "none with drive = \"anguilla\" (a node carries both axes; \
                               use robot.node-ids)",
                });
            }
            return Ok(());
        }
        if !r.node_ids.is_empty() {
            return Err(ConfigError::Range {
                key: "robot.node-ids",
                value: format!("{:?}", r.node_ids),
                expected: "[] with a bought drive family (give the drives' ids in robot.axes)",
            });
        }
        if !r.axes.is_empty() && r.axes.len() != 2 * r.joints {
            return Err(ConfigError::Range {
                key: "robot.axes",
                value: format!("{} entries", r.axes.len()),
                expected: "2 × robot.joints entries (pitch then yaw of each joint, head \
                           first), or none for the default ids",
            });
        }
        if !r.eds.is_empty() {
            if family != anguilla_protocol::Family::Cia402 {
                return Err(ConfigError::Range {
                    key: "robot.eds",
                    value: format!("{:?}", r.eds),
                    expected: "\"\" unless drive = \"cia402\" (an EDS describes a CANopen device)",
                });
            }
            use anguilla_protocol::canopen::eds;
            let text = std::fs::read_to_string(&r.eds).map_err(|source| ConfigError::Read {
                path: r.eds.clone(),
                source,
            })?;
            eds::Eds::parse(&text)
                .and_then(|e| eds::check_cia402(&e, self.bus.bitrate))
                .map_err(|e| ConfigError::Derived(format!("robot.eds = {:?}: {e}", r.eds)))?;
        }
        let (lo, hi) = family.id_range();
        let mut seen = [false; 256];
        if family == anguilla_protocol::Family::Cia402 {
            if !(1..=127).contains(&r.master_node_id) {
                return Err(ConfigError::Range {
                    key: "robot.master-node-id",
                    value: r.master_node_id.to_string(),
                    expected: "1 ..= 127",
                });
            }
            seen[r.master_node_id as usize] = true;
        }
        for (j, axes) in self.axes().iter().enumerate() {
            for a in axes {
                if a.node < lo || a.node > hi || seen[a.node as usize] {
                    return Err(ConfigError::Derived(format!(
                        "robot.axes: joint {} has drive id {}; {} drives take distinct ids in \
                         {lo}..={hi}{} (by default pitch 2j+1, yaw 2j+2 for joint j from 0: \
                         at most {} joints)",
                        j + 1,
                        a.node,
                        family,
                        if family == anguilla_protocol::Family::Cia402 {
                            ", other than robot.master-node-id"
                        } else {
                            ""
                        },
                        (hi as usize) / 2
                    )));
                }
                seen[a.node as usize] = true;
                if a.direction != 1.0 && a.direction != -1.0 {
                    return Err(ConfigError::Range {
                        key: "robot.axis.direction",
                        value: fmt_number(a.direction),
                        expected: "1 or -1",
                    });
                }
                range("robot.axis.offset", a.offset, -3.2, 3.2, "-3.2 ..= 3.2 rad")?;
                range("robot.axis.gear", a.gear, 1e-3, 1e4, "0.001 ..= 10000")?;
                range(
                    "robot.axis.counts-per-turn",
                    a.counts_per_turn as f64,
                    4.0,
                    (1u64 << 24) as f64,
                    "4 ..= 16777216",
                )?;
                if a.rated_torque != 0.0 {
                    range(
                        "robot.axis.rated-torque",
                        a.rated_torque,
                        1e-3,
                        1e4,
                        "0 (read from the drive) or 0.001 ..= 10000 N·m",
                    )?;
                }
            }
        }
        Ok(())
    }
}
/// What [`Config::fit_builtin`] changed for the built-in simulated robot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BuiltinFit {
    /// The head sensor's node id, where one was added
    /// ([`Config::fit_builtin_sensor`]).
    pub sensor: Option<u8>,
    /// The timeouts relaxed, as `key = value`
    /// ([`Config::relax_for_builtin`]).
    pub relaxed: Vec<String>,
}

impl Config {
    /// The configuration the daemon runs against the built-in simulated
    /// robot: the head sensor added ([`Config::fit_builtin_sensor`]), then
    /// the timeouts relaxed ([`Config::relax_for_builtin`]). `anguilla run`
    /// and `anguilla config check` both call this, so the control rate that
    /// the check prints is the daemon's (the sensor's frames take bus time:
    /// with the defaults 160.8 Hz, not 176.8).
    pub fn fit_builtin(&mut self) -> BuiltinFit {
        let sensor = self.fit_builtin_sensor();
        let relaxed = self.relax_for_builtin();
        BuiltinFit { sensor, relaxed }
    }
}

impl Config {
    /// The timeouts of the built-in simulated robot. It shares the CPU
    /// with the daemon and the operator's tools: on a busy machine all of
    /// them stall together, and a 0.35 s heartbeat or 0.5 s command
    /// timeout then faults or stops a robot that did nothing wrong. Keys
    /// still at their defaults become [`BUILTIN_TIMEOUT`] (the node
    /// watchdog: 1 s, its maximum); keys set in the file are kept. A real
    /// bus keeps the strict defaults. Returns the keys changed, as
    /// `key = value` (for the log).
    pub fn relax_for_builtin(&mut self) -> Vec<String> {
        let d = ControlConfig::default();
        let mut changed = Vec::new();
        let secs = BUILTIN_TIMEOUT;
        let c = &mut self.control;
        if c.command_timeout == d.command_timeout {
            c.command_timeout = secs;
            changed.push(format!("control.command-timeout = {secs}"));
        }
        if c.heartbeat_timeout == d.heartbeat_timeout {
            c.heartbeat_timeout = secs;
            changed.push(format!("control.heartbeat-timeout = {secs}"));
        }
        if c.node_watchdog == d.node_watchdog {
            c.node_watchdog = 1.0;
            changed.push("control.node-watchdog = 1".to_string());
        }
        // The head sensor's samples share the starved CPU too: 0.1 s of
        // silence made the autopilot let go of a hold under CI's load.
        if self.sensor.timeout == super::SensorConfig::default().timeout {
            self.sensor.timeout = secs;
            changed.push(format!("sensor.timeout = {secs}"));
        }
        if c.feedback_timeout == d.feedback_timeout
            && let Ok(rate) = self.control_rate()
        {
            let periods = (secs * rate).ceil().min(10_000.0) as u32;
            self.control.feedback_timeout = periods;
            changed.push(format!("control.feedback-timeout = {periods}"));
        }
        changed
    }
}
impl Config {
    /// The head sensor of the built-in simulated robot: with `[sensor]
    /// node = 0` (the default) and anguilla drives, the sensor goes on the
    /// first id no joint uses (13 with the default 12 joints), so heading
    /// and depth hold work out of the box. A real bus keeps "no sensor"
    /// unless the key is set. Returns the id chosen, or `None` (a sensor
    /// already configured, a bought family, no free id, or a configuration
    /// that the sensor's traffic would not fit: then it is left as it was).
    pub fn fit_builtin_sensor(&mut self) -> Option<u8> {
        if self.sensor.node != 0 || !self.robot.drive.carries_head_sensor() {
            return None;
        }
        let joints = self.node_ids();
        let id = (1..=63u8).find(|id| !joints.contains(id))?;
        self.sensor.node = id;
        if self.validate().is_err() {
            self.sensor.node = 0;
            return None;
        }
        Some(id)
    }

    /// Checks `[sensor]`, with what it shares with `[robot]` (the family,
    /// the joints' ids).
    pub(super) fn validate_sensor(&self) -> Result<(), ConfigError> {
        let s = &self.sensor;
        for section in s.off_bus() {
            section.validate()?;
            if s.node == 0 {
                let (name, why) = (section.kind().name(), section.needs_head());
                return Err(ConfigError::Derived(format!(
                    "[sensor.{name}] needs the head sensor (sensor.node): {why}; set sensor.node \
                     or remove [sensor.{name}]"
                )));
            }
        }
        if s.tail_imu != 0 {
            range(
                "sensor.tail-imu",
                s.tail_imu as f64,
                1.0,
                63.0,
                "0 (none) or 1 ..= 63",
            )?;
            if !self.robot.drive.carries_head_sensor() {
                return Err(ConfigError::Derived(format!(
                    "sensor.tail-imu = {} needs robot.drive = \"anguilla\": an IMU's frames \
                     (0x240 + id ..) share identifiers with {} drives' traffic; set \
                     sensor.tail-imu = 0",
                    s.tail_imu, self.robot.drive
                )));
            }
            if self.node_ids().contains(&s.tail_imu) || s.tail_imu == s.node {
                return Err(ConfigError::Derived(format!(
                    "sensor.tail-imu = {} is also a joint's or the head sensor's node id \
                     (robot.node-ids {:?}, sensor.node {}); the IMU needs an id of its own",
                    s.tail_imu,
                    self.node_ids(),
                    s.node
                )));
            }
        }
        if s.node != 0 {
            range(
                "sensor.node",
                s.node as f64,
                1.0,
                63.0,
                "0 (none) or 1 ..= 63",
            )?;
            if !self.robot.drive.carries_head_sensor() {
                return Err(ConfigError::Derived(format!(
                    "sensor.node = {} needs robot.drive = \"anguilla\": the head sensor's \
                     frames (0x240 + id ..) share identifiers with {} drives' traffic; \
                     set sensor.node = 0",
                    s.node, self.robot.drive
                )));
            }
            if self.node_ids().contains(&s.node) {
                return Err(ConfigError::Derived(format!(
                    "sensor.node = {} is also a joint's node id (robot.node-ids {:?}); \
                     the sensor needs an id of its own",
                    s.node,
                    self.node_ids()
                )));
            }
        }
        let (lo, hi) = anguilla_protocol::message::HEAD_SENSOR_RATE_HZ;
        range(
            "sensor.rate-hz",
            s.rate_hz as f64,
            lo as f64,
            hi as f64,
            "100 ..= 200 Hz",
        )?;
        range("sensor.timeout", s.timeout, 0.02, 5.0, "0.02 ..= 5 s")?;
        range(
            "sensor.water-density",
            s.water_density,
            900.0,
            1100.0,
            "900 ..= 1100 kg/m³",
        )?;
        range(
            "sensor.surface-pressure",
            s.surface_pressure,
            50_000.0,
            120_000.0,
            "50000 ..= 120000 Pa",
        )?;
        range(
            "sensor.max-rate-innovation",
            s.max_rate_innovation,
            0.05,
            10.0,
            "0.05 ..= 10 rad/s",
        )?;
        range(
            "sensor.roll-alarm",
            s.roll_alarm,
            5.0,
            180.0,
            "5 ..= 180 deg",
        )?;
        Ok(())
    }
}
