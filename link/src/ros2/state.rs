//! The daemon's state as ROS 2 messages: what the node publishes live
//! ([`super::node`]) and `anguilla export --ros2` writes to a bag
//! ([`super::bag`]), from the same snapshot to the same bytes.

use anguilla_ipc::StateSnapshot;
use anguilla_ipc::vocabulary::{Cause, FaultKind, Mode};

use super::msgs;

/// Every topic's message of `s`, in [`super::TOPICS`]' order, stamped
/// `stamp_ns` (ns since the epoch).
pub fn all(s: &StateSnapshot, stamp_ns: u64) -> [Vec<u8>; 6] {
    let [a, b, c, d, e] = messages(s, stamp_ns);
    [a, b, c, d, e, diagnostics(s, stamp_ns).encode()]
}

/// The axes' names, in every array's order: `joint1_pitch`, `joint1_yaw`, …
pub fn axis_names(joints: usize) -> Vec<String> {
    (1..=joints)
        .flat_map(|j| [format!("joint{j}_pitch"), format!("joint{j}_yaw")])
        .collect()
}

/// Water's density (kg/m³) and gravity, for the pressure at a depth.
const RHO_G: f64 = 1000.0 * 9.806_65;
/// One standard atmosphere (Pa).
const ATMOSPHERE: f64 = 101_325.0;

/// The joint states, IMU, pressure, feed-forward and residual messages of
/// `s` (the first five topics).
pub fn messages(s: &StateSnapshot, stamp_ns: u64) -> [Vec<u8>; 5] {
    let n = (s.joint_count as usize).min(s.joints.len());
    let joints = &s.joints[..n];
    let pairs = |f: fn(&anguilla_ipc::JointSnapshot) -> [f32; 2]| -> Vec<f64> {
        joints
            .iter()
            .flat_map(f)
            .map(f64::from)
            .collect::<Vec<f64>>()
    };
    let header = |frame: &str| msgs::Header {
        stamp: msgs::Time::from_ns(stamp_ns),
        frame_id: frame.into(),
    };
    let js = msgs::JointState {
        header: header(""),
        name: axis_names(n),
        position: pairs(|j| [j.measured_pitch, j.measured_yaw]),
        velocity: pairs(|j| [j.measured_pitch_velocity, j.measured_yaw_velocity]),
        effort: pairs(|j| [j.measured_pitch_torque, j.measured_yaw_torque]),
    };
    let nav = &s.nav;
    // REP 103 (x forward, y left, z up): yaw anticlockwise seen from
    // above, as the daemon's heading (0 along the earth frame's x); pitch
    // about y is nose-down positive (the daemon's is nose-up); roll about
    // x is right side down positive, as the daemon's.
    let yaw = f64::from(nav.heading_deg).to_radians();
    let pitch = -f64::from(nav.pitch_deg).to_radians();
    let roll = f64::from(nav.roll_deg).to_radians();
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    let mut unknown = [0.0; 9];
    unknown[0] = -1.0;
    let imu = msgs::Imu {
        header: header("head"),
        orientation: [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ],
        orientation_covariance: [0.0; 9],
        angular_velocity: [0.0; 3],
        angular_velocity_covariance: unknown,
        linear_acceleration: [0.0; 3],
        linear_acceleration_covariance: unknown,
    };
    let pressure = msgs::FluidPressure {
        header: header("head"),
        fluid_pressure: ATMOSPHERE + RHO_G * f64::from(nav.depth_m),
        variance: 0.0,
    };
    let ff = pairs(|j| [j.predicted_pitch_torque, j.predicted_yaw_torque]);
    let res = pairs(|j| [j.pitch_torque_residual, j.yaw_torque_residual]);
    [
        js.encode(),
        imu.encode(),
        pressure.encode(),
        msgs::float64_array("axis", &ff),
        msgs::float64_array("axis", &res),
    ]
}

/// The daemon's health as ROS 2 diagnostics: one status for the daemon
/// (mode, cause, faults, who holds control), one for the bus, one per
/// joint's drive.
pub fn diagnostics(s: &StateSnapshot, stamp_ns: u64) -> msgs::DiagnosticArray {
    let mode = Mode::from_code(s.mode);
    let faults: Vec<&str> = FaultKind::ALL
        .iter()
        .enumerate()
        .filter(|(i, _)| s.fault_kinds & (1 << i) != 0)
        .map(|(_, k)| k.name())
        .collect();
    let level = match mode {
        Some(Mode::Fault | Mode::EStop) | None => 2,
        _ if !faults.is_empty() => 1,
        _ => 0,
    };
    let kv = |k: &str, v: String| (k.to_string(), v);
    let mut status = vec![msgs::DiagnosticStatus {
        level,
        name: "anguilla: daemon".into(),
        message: mode.map_or_else(|| format!("unknown mode {}", s.mode), |m| m.name().into()),
        hardware_id: "anguilla".into(),
        values: vec![
            kv("mode", mode.map_or("unknown", Mode::name).into()),
            kv(
                "cause",
                Cause::from_code(s.cause)
                    .map_or("unknown", |c| c.words())
                    .into(),
            ),
            kv("faults", faults.join(", ")),
            kv("controlled", (s.holder().is_some()).to_string()),
            kv("joints", s.joint_count.to_string()),
        ],
    }];
    let b = &s.bus;
    status.push(msgs::DiagnosticStatus {
        level: u8::from(b.bus_off_count > 0 || b.errors > 0),
        name: "anguilla: bus".into(),
        message: anguilla_ipc::bus_state_name(b.state).into(),
        hardware_id: "can".into(),
        values: vec![
            kv("tx frames", b.tx_frames.to_string()),
            kv("rx frames", b.rx_frames.to_string()),
            kv("tx dropped", b.tx_dropped.to_string()),
            kv("malformed", b.malformed.to_string()),
            kv("errors", b.errors.to_string()),
            kv("bus off", b.bus_off_count.to_string()),
        ],
    });
    let n = (s.joint_count as usize).min(s.joints.len());
    for (i, j) in s.joints[..n].iter().enumerate() {
        let alive = j.node_alive != 0;
        status.push(msgs::DiagnosticStatus {
            level: if !alive {
                2
            } else {
                u8::from(j.node_errors != 0 || j.residual_alarm != 0)
            },
            name: format!("anguilla: joint {}", i + 1),
            message: if alive { "alive" } else { "silent" }.into(),
            hardware_id: format!("joint{}", i + 1),
            values: vec![
                kv("drive state", j.node_state.to_string()),
                kv("errors", format!("{:#x}", j.node_errors)),
                kv("residual alarm", (j.residual_alarm != 0).to_string()),
            ],
        });
    }
    msgs::DiagnosticArray {
        header: msgs::Header {
            stamp: msgs::Time::from_ns(stamp_ns),
            frame_id: String::new(),
        },
        status,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::cdr::Reader;

    /// A silent drive, a fault and an e-stop are errors in the
    /// diagnostics, never hidden behind a healthy daemon's OK.
    #[test]
    fn a_dead_joint_or_a_fault_is_an_error_in_the_diagnostics() {
        let mut s = StateSnapshot {
            joint_count: 3,
            mode: Mode::Swimming as u8,
            ..StateSnapshot::default()
        };
        for j in &mut s.joints[..3] {
            j.node_alive = 1;
        }
        let d = diagnostics(&s, 1);
        assert_eq!(d.status.len(), 2 + 3);
        assert!(d.status.iter().all(|x| x.level == 0), "{d:?}");
        s.joints[1].node_alive = 0;
        let d = diagnostics(&s, 1);
        let j2 = d
            .status
            .iter()
            .find(|x| x.name == "anguilla: joint 2")
            .unwrap();
        assert_eq!((j2.level, j2.message.as_str()), (2, "silent"));
        s.mode = Mode::EStop as u8;
        s.fault_kinds = 1 << 5;
        let d = diagnostics(&s, 1);
        assert_eq!(d.status[0].level, 2);
        assert!(
            d.status[0]
                .values
                .iter()
                .any(|(k, v)| k == "faults" && v == "operator e-stop")
        );
        // an unknown mode code (a newer daemon) is an error, not OK
        s.mode = 200;
        assert_eq!(diagnostics(&s, 1).status[0].level, 2);
    }

    #[test]
    fn joint_states_hold_every_axis_in_order() {
        let mut s = StateSnapshot {
            joint_count: 2,
            ..StateSnapshot::default()
        };
        s.joints[0].measured_pitch = 0.25;
        s.joints[1].measured_yaw = -0.5;
        let [js, ..] = messages(&s, 2_000_000_123);
        let mut r = Reader::new(&js).unwrap();
        assert_eq!(r.i32("sec").unwrap(), 2);
        assert_eq!(r.u32("nanosec").unwrap(), 123);
        assert_eq!(r.string("frame").unwrap(), "");
        assert_eq!(r.u32("names").unwrap(), 4);
        let names: Vec<String> = (0..4).map(|_| r.string("name").unwrap()).collect();
        assert_eq!(names, axis_names(2));
        assert_eq!(r.u32("positions").unwrap(), 4);
        let p: Vec<f64> = (0..4).map(|_| r.f64("position").unwrap()).collect();
        assert_eq!(p, [0.25, 0.0, 0.0, -0.5]);
    }
}
