//! The daemon's state as ROS 2 messages: what the node publishes live
//! ([`super::node`]) and `anguilla export --ros2` writes to a bag
//! ([`super::bag`]), from the same snapshot to the same bytes; the joints
//! and the head's pose as every viewer has them ([`anguilla_view`]).

use anguilla_ipc::StateSnapshot;
use anguilla_ipc::vocabulary::{Cause, FaultKind, Mode};
use anguilla_view::Joints;
use anguilla_view::pose::{HeadTrack, Pose, quaternion_rpy};

use super::msgs;

/// The head sensor's frame: `imu` and `pressure` are in it; `tf_static`
/// puts it at the head's origin.
pub const SENSOR_FRAME: &str = "head_sensor";
/// The world frame `tf` puts the head in (REP 105's `odom`: continuous,
/// drifting, its origin where the head was at the first state).
pub const ODOM_FRAME: &str = "odom";

/// The body as the URDF and `tf` draw it: each segment's length and
/// semi-axes (width, height) (m), head first (`joints + 1` of them), and
/// the joints' limits (rad, rad/s, N·m).
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// (length, half width, half height) of each segment, head first.
    pub segments: Vec<(f64, f64, f64)>,
    /// `[limits] angle`, `velocity`, `torque`.
    pub limits: [f64; 3],
}

/// A segment's frame: `head`, then `segment1`, `segment2`, …
pub fn segment_frame(k: usize) -> String {
    if k == 0 {
        "head".into()
    } else {
        format!("segment{k}")
    }
}

/// The robot as a URDF, for rviz2's RobotModel (`robot_description`):
/// the head, then for each joint `k` a pitch joint `joint<k>_pitch` into
/// the massless `segment<k>_pitch` and a yaw joint `joint<k>_yaw` into
/// `segment<k>`, as the daemon's joints turn (pitch, then yaw about the
/// pitched z). Frames face forward (x to the nose, REP 103), so each joint
/// sits a segment's length behind its parent's origin, the pitch axis is
/// −y (the model's `t2` seen from the front), and each segment is drawn
/// as a box of its length, width and height behind its joint. The head
/// sensor's frame is fixed at the head's origin.
pub fn urdf(g: &Geometry) -> String {
    use std::fmt::Write as _;
    let [angle, velocity, effort] = g.limits;
    let mut u = String::from(
        "<?xml version=\"1.0\"?>\n<robot name=\"anguilla\">\n  \
         <material name=\"eel\"><color rgba=\"0.1 0.6 0.6 1\"/></material>\n",
    );
    for (k, &(l, a, b)) in g.segments.iter().enumerate() {
        let this = segment_frame(k);
        if k > 0 {
            let parent = segment_frame(k - 1);
            let pl = g.segments[k - 1].0;
            let limit = format!(
                "<limit lower=\"{}\" upper=\"{angle}\" effort=\"{effort}\" velocity=\"{velocity}\"/>",
                -angle
            );
            let _ = write!(
                u,
                "  <link name=\"{this}_pitch\"/>\n  \
                 <joint name=\"joint{k}_pitch\" type=\"revolute\"><parent link=\"{parent}\"/>\
                 <child link=\"{this}_pitch\"/><origin xyz=\"{} 0 0\" rpy=\"0 0 0\"/>\
                 <axis xyz=\"0 -1 0\"/>{limit}</joint>\n  \
                 <joint name=\"joint{k}_yaw\" type=\"revolute\"><parent link=\"{this}_pitch\"/>\
                 <child link=\"{this}\"/><origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\
                 <axis xyz=\"0 0 1\"/>{limit}</joint>\n",
                -pl
            );
        }
        let _ = writeln!(
            u,
            "  <link name=\"{this}\"><visual><origin xyz=\"{} 0 0\" rpy=\"0 0 0\"/>\
             <geometry><box size=\"{l} {} {}\"/></geometry><material name=\"eel\"/></visual></link>",
            -l / 2.0,
            2.0 * a,
            2.0 * b
        );
    }
    let _ = write!(
        u,
        "  <link name=\"{SENSOR_FRAME}\"/>\n  <joint name=\"{SENSOR_FRAME}\" type=\"fixed\">\
         <parent link=\"head\"/><child link=\"{SENSOR_FRAME}\"/>\
         <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/></joint>\n</robot>\n"
    );
    u
}

/// A `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    /// The parent frame.
    pub parent: String,
    /// The child frame.
    pub child: String,
    /// The child's origin and orientation in the parent.
    pub pose: Pose,
}

/// A `tf2_msgs/msg/TFMessage` of `transforms`, stamped `stamp_ns`.
pub fn tf_message(transforms: &[Transform], stamp_ns: u64) -> Vec<u8> {
    let mut w = super::cdr::Writer::new();
    w.len(transforms.len());
    let t = msgs::Time::from_ns(stamp_ns);
    for x in transforms {
        w.i32(t.sec)
            .u32(t.nanosec)
            .string(&x.parent)
            .string(&x.child);
        for v in x.pose.translation.iter().chain(&x.pose.rotation) {
            w.f64(*v);
        }
    }
    w.finish()
}

/// `tf_static`: the head sensor at the head's origin.
pub fn tf_static(stamp_ns: u64) -> Vec<u8> {
    tf_message(
        &[Transform {
            parent: "head".into(),
            child: SENSOR_FRAME.into(),
            pose: Pose {
                translation: [0.0; 3],
                rotation: [0.0, 0.0, 0.0, 1.0],
            },
        }],
        stamp_ns,
    )
}

/// The transforms of `s`: the head in `odom` (the daemon's estimate with a
/// head sensor: its x, y, depth and attitude; else the model's prediction
/// integrated in the plane), and each joint's
/// pitch and yaw as the URDF's joints.
pub fn transforms(s: &StateSnapshot, head: Pose, g: &Geometry) -> Vec<Transform> {
    let mut out = vec![Transform {
        parent: ODOM_FRAME.into(),
        child: "head".into(),
        pose: head,
    }];
    let n = (s.joint_count as usize)
        .min(s.joints.len())
        .min(g.segments.len().saturating_sub(1));
    let finite = |v: f32| if v.is_finite() { f64::from(v) } else { 0.0 };
    for (i, j) in s.joints[..n].iter().enumerate() {
        let k = i + 1;
        let (sp, cp) = (finite(j.measured_pitch) / 2.0).sin_cos();
        let (sy, cy) = (finite(j.measured_yaw) / 2.0).sin_cos();
        out.push(Transform {
            parent: segment_frame(k - 1),
            child: format!("{}_pitch", segment_frame(k)),
            pose: Pose {
                translation: [-g.segments[k - 1].0, 0.0, 0.0],
                rotation: [0.0, -sp, 0.0, cp],
            },
        });
        out.push(Transform {
            parent: format!("{}_pitch", segment_frame(k)),
            child: segment_frame(k),
            pose: Pose {
                translation: [0.0; 3],
                rotation: [0.0, 0.0, sy, cy],
            },
        });
    }
    out
}

/// Turns a stream of snapshots into the node's topics: keeps the head's
/// track (the prediction `tf` falls back on without a head sensor) and the
/// body's geometry.
#[derive(Debug, Clone)]
pub struct RosState {
    geometry: Geometry,
    track: HeadTrack,
}

impl RosState {
    /// For a body of `geometry`, the head at `odom`'s origin.
    pub fn new(geometry: Geometry) -> Self {
        Self {
            geometry,
            track: HeadTrack::default(),
        }
    }

    /// The body's geometry.
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// Advances the head's track to `s` (a snapshot not published).
    pub fn advance(&mut self, s: &StateSnapshot) {
        self.track.update(s);
    }

    /// Every topic's message of `s`, in [`super::TOPICS`]' order, stamped
    /// `stamp_ns` (ns since the epoch). Advances the head's track: call
    /// it with every snapshot, due or not, or the track skips.
    pub fn all(&mut self, s: &StateSnapshot, stamp_ns: u64) -> [Vec<u8>; super::N_TOPICS] {
        let (head, _) = self.track.update(s);
        let [a, b, c, d, e] = messages(s, stamp_ns);
        let [cross_track, current] = guidance(s, stamp_ns);
        [
            a,
            b,
            c,
            d,
            e,
            diagnostics(s, stamp_ns).encode(),
            tf_message(&transforms(s, head, &self.geometry), stamp_ns),
            cross_track,
            current,
        ]
    }
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
    // The joints as every viewer has them (the recording's
    // /anguilla/joints), pitch and yaw axes interleaved, head first.
    let j = Joints::from(s);
    let n = j.measured_pitch.len();
    let pairs = |pitch: &[f32], yaw: &[f32]| -> Vec<f64> {
        pitch
            .iter()
            .zip(yaw)
            .flat_map(|(&p, &y)| [f64::from(p), f64::from(y)])
            .collect()
    };
    let header = |frame: &str| msgs::Header {
        stamp: msgs::Time::from_ns(stamp_ns),
        frame_id: frame.into(),
    };
    let js = msgs::JointState {
        header: header(""),
        name: axis_names(n),
        position: pairs(&j.measured_pitch, &j.measured_yaw),
        velocity: pairs(&j.measured_pitch_velocity, &j.measured_yaw_velocity),
        effort: pairs(&j.measured_pitch_torque, &j.measured_yaw_torque),
    };
    let nav = &s.nav;
    let mut unknown = [0.0; 9];
    unknown[0] = -1.0;
    // The attitude as the recording's /tf and this node's tf give it
    // (REP 103; anguilla_view::pose); unknown without a head sensor.
    let sensed = nav.samples > 0;
    let imu = msgs::Imu {
        header: header(SENSOR_FRAME),
        orientation: if sensed {
            quaternion_rpy(
                f64::from(nav.roll_deg).to_radians(),
                -f64::from(nav.pitch_deg).to_radians(),
                f64::from(nav.heading_deg).to_radians(),
            )
        } else {
            [0.0, 0.0, 0.0, 1.0]
        },
        orientation_covariance: if sensed { [0.0; 9] } else { unknown },
        angular_velocity: [0.0; 3],
        angular_velocity_covariance: unknown,
        linear_acceleration: [0.0; 3],
        linear_acceleration_covariance: unknown,
    };
    let pressure = msgs::FluidPressure {
        header: header(SENSOR_FRAME),
        fluid_pressure: ATMOSPHERE + RHO_G * f64::from(nav.depth_m),
        variance: 0.0,
    };
    let ff = pairs(&j.feedforward_pitch_torque, &j.feedforward_yaw_torque);
    let res = pairs(&j.pitch_torque_residual, &j.yaw_torque_residual);
    [
        js.encode(),
        imu.encode(),
        pressure.encode(),
        msgs::float64_array("axis", &ff),
        msgs::float64_array("axis", &res),
    ]
}

/// The path's cross-track error (m; NaN when no path is followed) and the
/// estimated current (m/s, in `odom`) of `s`.
pub fn guidance(s: &StateSnapshot, stamp_ns: u64) -> [Vec<u8>; 2] {
    let following = s.guide.guide_state() == Some(anguilla_ipc::GuideState::Following);
    let cross_track = if following {
        f64::from(s.guide.cross_track_m)
    } else {
        f64::NAN
    };
    let header = msgs::Header {
        stamp: msgs::Time::from_ns(stamp_ns),
        frame_id: "odom".into(),
    };
    [
        msgs::float64(cross_track),
        msgs::vector3_stamped(
            &header,
            [f64::from(s.nav.current_x), f64::from(s.nav.current_y), 0.0],
        ),
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
    // The path and the estimated current (docs/autopilot.md, "Following
    // a path"): the cross-track error and the current, as the recording's
    // `guide` and `nav` have them.
    let g = &s.guide;
    let guide = anguilla_ipc::GuideState::from_code(g.state);
    let nav = &s.nav;
    status.push(msgs::DiagnosticStatus {
        level: u8::from(guide.is_some_and(anguilla_ipc::GuideState::failed)),
        name: "anguilla: path".into(),
        message: guide
            .map_or("unknown", anguilla_ipc::GuideState::name)
            .into(),
        hardware_id: "anguilla".into(),
        values: vec![
            kv("leg", g.leg.to_string()),
            kv("waypoints", g.waypoints.to_string()),
            kv("cross_track_m", format!("{:.3}", g.cross_track_m)),
            kv("along_track_m", format!("{:.3}", g.along_track_m)),
            kv("to_go_m", format!("{:.3}", g.to_go_m)),
            kv("heading_deg", format!("{:.1}", g.heading_deg)),
            kv("current_x", format!("{:.3}", nav.current_x)),
            kv("current_y", format!("{:.3}", nav.current_y)),
            kv("current_sigma", format!("{:.3}", nav.current_sigma)),
            kv("speed_scale", format!("{:.3}", nav.speed_scale)),
            kv(
                "position",
                nav.position_state()
                    .map_or("unknown", anguilla_ipc::PositionHealth::name)
                    .into(),
            ),
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
        assert_eq!(d.status.len(), 3 + 3, "daemon, bus, path and the joints");
        assert!(d.status.iter().all(|x| x.level == 0), "{d:?}");
        // A path stopped for a lost fix is a warning, with its cross-track
        // error and the current.
        let mut lost = s;
        lost.guide.state = anguilla_ipc::GuideState::FixLost as u8;
        lost.guide.cross_track_m = 0.25;
        lost.nav.current_y = 0.1;
        let d = diagnostics(&lost, 1);
        let p = d
            .status
            .iter()
            .find(|x| x.name == "anguilla: path")
            .unwrap();
        assert_eq!(p.level, 1);
        assert!(p.message.contains("fix lost"), "{}", p.message);
        let value = |k: &str| {
            p.values
                .iter()
                .find(|(n, _)| n == k)
                .map(|(_, v)| v.clone())
        };
        assert_eq!(value("cross_track_m").as_deref(), Some("0.250"));
        assert_eq!(value("current_y").as_deref(), Some("0.100"));
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

    fn geometry(joints: usize) -> Geometry {
        Geometry {
            segments: (0..=joints)
                .map(|k| (0.1, 0.05 - 0.002 * k as f64, 0.02))
                .collect(),
            limits: [1.0, 8.0, 4.0],
        }
    }

    /// The URDF's chain and `tf`'s transforms are the same joints: a
    /// pitch about −y a segment behind its parent, then a yaw about z.
    #[test]
    fn the_urdf_and_tf_chain_the_joints_alike() {
        let u = urdf(&geometry(2));
        for want in [
            "<joint name=\"joint1_pitch\" type=\"revolute\"><parent link=\"head\"/><child link=\"segment1_pitch\"/><origin xyz=\"-0.1 0 0\"",
            "<joint name=\"joint2_yaw\" type=\"revolute\"><parent link=\"segment2_pitch\"/><child link=\"segment2\"/>",
            "<axis xyz=\"0 -1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"4\" velocity=\"8\"/>",
            "<link name=\"segment2\"><visual><origin xyz=\"-0.05 0 0\"",
            "<joint name=\"head_sensor\" type=\"fixed\">",
        ] {
            assert!(u.contains(want), "{want} not in\n{u}");
        }
        assert_eq!(u.matches("type=\"revolute\"").count(), 4);
        let mut s = StateSnapshot {
            joint_count: 2,
            ..StateSnapshot::default()
        };
        s.joints[1].measured_pitch = 0.5;
        s.joints[1].measured_yaw = f32::NAN;
        let head = Pose {
            translation: [1.0, 2.0, -3.0],
            rotation: [0.0, 0.0, 0.0, 1.0],
        };
        let t = transforms(&s, head, &geometry(2));
        let names: Vec<(&str, &str)> = t
            .iter()
            .map(|x| (x.parent.as_str(), x.child.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("odom", "head"),
                ("head", "segment1_pitch"),
                ("segment1_pitch", "segment1"),
                ("segment1", "segment2_pitch"),
                ("segment2_pitch", "segment2"),
            ]
        );
        assert_eq!(t[3].pose.translation, [-0.1, 0.0, 0.0]);
        let half = 0.25f64;
        assert_eq!(t[3].pose.rotation, [0.0, -half.sin(), 0.0, half.cos()]);
        // a yaw that is not finite is drawn straight, not as NaN
        assert_eq!(t[4].pose.rotation, [0.0, 0.0, 0.0, 1.0]);
        // more joints in the state than segments: only what the body has
        s.joint_count = 3;
        assert_eq!(transforms(&s, head, &geometry(2)).len(), 5);
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
