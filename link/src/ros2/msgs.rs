//! The ROS 2 messages the link publishes and reads, in CDR
//! ([`super::cdr`]), with their type names and RIHS01 type hashes.
//!
//! The hashes (REP-2016: the SHA-256 of the type's description with every
//! type it refers to) are pinned here for Jazzy's definitions (the same
//! in Kilted); `scripts/check-ros2` checks every one against the PyPI
//! package `rosbags`' own computation (a service's from its request,
//! response and event, as rosidl describes one: the same computation
//! reproduces rmw_zenoh's documented `AddTwoInts` hash), and decodes every
//! message the link publishes with `rosbags`' CDR reader.

use super::cdr::{CdrError, Reader, Writer};

/// A ROS 2 message type the link speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgType {
    /// `pkg/msg/Type`, as `ros2 topic list -t` prints it.
    pub name: &'static str,
    /// `RIHS01_` and the SHA-256 in hex (Jazzy's definitions).
    pub hash: &'static str,
}

impl MsgType {
    /// The DDS-mangled name rmw_zenoh puts in keys and tokens:
    /// `pkg::msg::dds_::Type_`.
    pub fn dds_name(&self) -> String {
        let mut parts = self.name.split('/');
        let (pkg, kind, ty) = (
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
        );
        format!("{pkg}::{kind}::dds_::{ty}_")
    }
}

macro_rules! types {
    ($($id:ident = $name:literal, $hash:literal;)*) => {
        $(
            #[doc = concat!("`", $name, "`")]
            pub const $id: MsgType = MsgType { name: $name, hash: $hash };
        )*
        /// Every type of this module.
        pub const ALL: &[MsgType] = &[$($id),*];
    };
}

types! {
    JOINT_STATE = "sensor_msgs/msg/JointState", "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e";
    IMU = "sensor_msgs/msg/Imu", "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b";
    FLUID_PRESSURE = "sensor_msgs/msg/FluidPressure", "RIHS01_22dfb2b145a0bd5a31a1ac3882a1b32148b51d9b2f3bab250290d66f3595bc32";
    DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray", "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e";
    FLOAT64_MULTI_ARRAY = "std_msgs/msg/Float64MultiArray", "RIHS01_1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f";
    STRING = "std_msgs/msg/String", "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";
    TF_MESSAGE = "tf2_msgs/msg/TFMessage", "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087";
    TWIST = "geometry_msgs/msg/Twist", "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a";
    TWIST_STAMPED = "geometry_msgs/msg/TwistStamped", "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64";
    TRIGGER = "std_srvs/srv/Trigger", "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f";
    PATH = "nav_msgs/msg/Path", "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b";
    POSE_STAMPED = "geometry_msgs/msg/PoseStamped", "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8";
    ODOMETRY = "nav_msgs/msg/Odometry", "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0";
    FLOAT64 = "std_msgs/msg/Float64", "RIHS01_705ba9c3d1a09df43737eb67095534de36fd426c0587779bda2bc51fe790182a";
    VECTOR3_STAMPED = "geometry_msgs/msg/Vector3Stamped", "RIHS01_d4829622288cbb443886e7ea94ea5671a3b1be6bab4ad04224432a65f7d7887a";
}

/// `std_srvs/srv/Trigger`'s response: `bool success`, `string message`.
pub fn trigger_response(success: bool, message: &str) -> Vec<u8> {
    let mut w = Writer::new();
    w.u8(u8::from(success)).string(message);
    w.finish()
}

/// `builtin_interfaces/msg/Time`, from nanoseconds since the epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// From nanoseconds (saturates past 2038, as `int32` seconds do).
    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX),
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Header {
    /// The time of the data.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

fn header(w: &mut Writer, h: &Header) {
    w.i32(h.stamp.sec).u32(h.stamp.nanosec).string(&h.frame_id);
}

fn read_header(r: &mut Reader) -> Result<Header, CdrError> {
    Ok(Header {
        stamp: Time {
            sec: r.i32("header.stamp.sec")?,
            nanosec: r.u32("header.stamp.nanosec")?,
        },
        frame_id: r.string("header.frame_id")?,
    })
}

/// `sensor_msgs/msg/JointState`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointState {
    /// Stamp and frame.
    pub header: Header,
    /// One name per axis.
    pub name: Vec<String>,
    /// rad.
    pub position: Vec<f64>,
    /// rad/s.
    pub velocity: Vec<f64>,
    /// N·m.
    pub effort: Vec<f64>,
}

impl JointState {
    /// CDR.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        header(&mut w, &self.header);
        w.len(self.name.len());
        for n in &self.name {
            w.string(n);
        }
        w.f64_seq(&self.position)
            .f64_seq(&self.velocity)
            .f64_seq(&self.effort);
        w.finish()
    }
}

/// `geometry_msgs/msg/Vector3` (and a quaternion's vector part).
pub type Vector3 = [f64; 3];

/// `sensor_msgs/msg/Imu`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Imu {
    /// Stamp and frame.
    pub header: Header,
    /// x, y, z, w.
    pub orientation: [f64; 4],
    /// Row-major, rad².
    pub orientation_covariance: [f64; 9],
    /// rad/s.
    pub angular_velocity: Vector3,
    /// `[-1, 0, …]`: not measured.
    pub angular_velocity_covariance: [f64; 9],
    /// m/s².
    pub linear_acceleration: Vector3,
    /// `[-1, 0, …]`: not measured.
    pub linear_acceleration_covariance: [f64; 9],
}

impl Imu {
    /// CDR.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        header(&mut w, &self.header);
        for v in self.orientation {
            w.f64(v);
        }
        for v in self
            .orientation_covariance
            .iter()
            .chain(&self.angular_velocity)
            .chain(&self.angular_velocity_covariance)
            .chain(&self.linear_acceleration)
            .chain(&self.linear_acceleration_covariance)
        {
            w.f64(*v);
        }
        w.finish()
    }
}

/// `sensor_msgs/msg/FluidPressure`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FluidPressure {
    /// Stamp and frame.
    pub header: Header,
    /// Pa.
    pub fluid_pressure: f64,
    /// Pa² (0: unknown).
    pub variance: f64,
}

impl FluidPressure {
    /// CDR.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        header(&mut w, &self.header);
        w.f64(self.fluid_pressure).f64(self.variance);
        w.finish()
    }
}

/// `diagnostic_msgs/msg/DiagnosticStatus` (in a [`DiagnosticArray`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DiagnosticStatus {
    /// 0 OK, 1 WARN, 2 ERROR, 3 STALE.
    pub level: u8,
    /// What this status is about.
    pub name: String,
    /// One line.
    pub message: String,
    /// The device.
    pub hardware_id: String,
    /// Key-value pairs.
    pub values: Vec<(String, String)>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DiagnosticArray {
    /// Stamp and frame.
    pub header: Header,
    /// One per component.
    pub status: Vec<DiagnosticStatus>,
}

impl DiagnosticArray {
    /// CDR.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        header(&mut w, &self.header);
        w.len(self.status.len());
        for s in &self.status {
            w.u8(s.level)
                .string(&s.name)
                .string(&s.message)
                .string(&s.hardware_id)
                .len(s.values.len());
            for (k, v) in &s.values {
                w.string(k).string(v);
            }
        }
        w.finish()
    }
}

/// `std_msgs/msg/Float64MultiArray` with one dimension labelled `label`.
pub fn float64_array(label: &str, data: &[f64]) -> Vec<u8> {
    let mut w = Writer::new();
    let n = u32::try_from(data.len()).unwrap_or(u32::MAX);
    // layout: one MultiArrayDimension {label, size, stride}, data_offset 0
    w.len(1).string(label).u32(n).u32(n).u32(0);
    w.f64_seq(data);
    w.finish()
}

/// `std_msgs/msg/String`.
pub fn string(s: &str) -> Vec<u8> {
    let mut w = Writer::new();
    w.string(s);
    w.finish()
}

/// A `std_msgs/msg/Float64`.
pub fn float64(v: f64) -> Vec<u8> {
    let mut w = Writer::new();
    w.f64(v);
    w.finish()
}

/// A `geometry_msgs/msg/Vector3Stamped`.
pub fn vector3_stamped(h: &Header, v: [f64; 3]) -> Vec<u8> {
    let mut w = Writer::new();
    header(&mut w, h);
    for x in v {
        w.f64(x);
    }
    w.finish()
}

/// A `geometry_msgs/msg/Twist`: m/s and rad/s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    /// x forward, y left, z up.
    pub linear: Vector3,
    /// About x, y, z.
    pub angular: Vector3,
}

impl Twist {
    /// CDR.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        for v in self.linear.iter().chain(&self.angular) {
            w.f64(*v);
        }
        w.finish()
    }

    /// Reads a `Twist`, or a `TwistStamped` when `stamped` (its header is
    /// read and dropped: the link stamps commands on arrival).
    pub fn decode(msg: &[u8], stamped: bool) -> Result<Self, CdrError> {
        let mut r = Reader::new(msg)?;
        if stamped {
            read_header(&mut r)?;
        }
        let mut v = [0.0; 6];
        const NAMES: [&str; 6] = [
            "linear.x",
            "linear.y",
            "linear.z",
            "angular.x",
            "angular.y",
            "angular.z",
        ];
        for (x, what) in v.iter_mut().zip(NAMES) {
            *x = r.f64(what)?;
        }
        Ok(Self {
            linear: [v[0], v[1], v[2]],
            angular: [v[3], v[4], v[5]],
        })
    }
}

/// A `nav_msgs/msg/Path`'s poses as waypoints: x, y of each pose's
/// position (m, the `odom` frame: the daemon's estimate's), and a depth
/// of `−z` where z is below 0 (none at 0 or above). At most `max` poses:
/// more is an error naming the count, as is a pose that is not finite.
pub fn path_waypoints(msg: &[u8], max: usize) -> Result<Vec<anguilla_ipc::Waypoint>, String> {
    let mut r = Reader::new(msg).map_err(|e| e.to_string())?;
    let header = read_header(&mut r).map_err(|e| e.to_string())?;
    let n = r.u32("poses' length").map_err(|e| e.to_string())? as usize;
    if n > max {
        return Err(format!("{n} poses (expected at most {max})"));
    }
    if !matches!(header.frame_id.as_str(), "" | "odom") {
        return Err(format!(
            "frame \"{}\" (expected \"odom\", the daemon's estimate's frame)",
            header.frame_id
        ));
    }
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        read_header(&mut r).map_err(|e| e.to_string())?;
        let mut v = [0.0; 7];
        for x in &mut v {
            *x = r.f64("a pose").map_err(|e| e.to_string())?;
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("pose {i} is not finite"));
        }
        out.push(anguilla_ipc::Waypoint {
            index: i as u32,
            x: v[0],
            y: v[1],
            depth: (v[2] < 0.0).then_some(-v[2]),
        });
    }
    Ok(out)
}

/// A position fix from ROS 2 (`geometry_msgs/msg/PoseStamped` or
/// `nav_msgs/msg/Odometry`): where the robot is, when, and how well known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFix {
    /// The message's stamp (ns since the epoch, ROS time: the sender's
    /// wall clock); 0 when the sender left it unset.
    pub stamp_ns: u64,
    /// x, y (m) in the message's frame.
    pub x: f64,
    /// See `x`.
    pub y: f64,
    /// The horizontal standard deviation the message says (m): an
    /// `Odometry`'s covariance (the larger of x's and y's); none for a
    /// `PoseStamped` or a covariance of 0.
    pub sigma: Option<f64>,
}

/// Reads a `PoseStamped` (or an `Odometry` when `odometry`) whose header
/// names `frame` (an empty frame is taken as it): a position that is not
/// finite, another frame, or a negative covariance is an error naming it.
pub fn pose_fix(msg: &[u8], odometry: bool, frame: &str) -> Result<PoseFix, String> {
    let e = |e: CdrError| e.to_string();
    let mut r = Reader::new(msg).map_err(e)?;
    let header = read_header(&mut r).map_err(e)?;
    if !header.frame_id.is_empty() && header.frame_id != frame {
        return Err(format!(
            "frame \"{}\" (expected \"{frame}\": [link] ros2-pose-frame)",
            header.frame_id
        ));
    }
    if odometry {
        r.string("child_frame_id").map_err(e)?;
    }
    let mut v = [0.0; 7];
    for x in &mut v {
        *x = r.f64("pose").map_err(e)?;
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err("a pose that is not finite".into());
    }
    let mut sigma = None;
    if odometry {
        let mut cov = [0.0; 36];
        for c in &mut cov {
            *c = r.f64("pose.covariance").map_err(e)?;
        }
        let (vx, vy) = (cov[0], cov[7]);
        if !(vx.is_finite() && vy.is_finite() && vx >= 0.0 && vy >= 0.0) {
            return Err(format!(
                "covariance x {vx}, y {vy} (expected finite variances >= 0)"
            ));
        }
        sigma = (vx.max(vy) > 0.0).then(|| vx.max(vy).sqrt());
    }
    let stamp_ns = u64::try_from(header.stamp.sec)
        .map_err(|_| format!("stamp {} s (expected >= 0)", header.stamp.sec))?
        * 1_000_000_000
        + u64::from(header.stamp.nanosec);
    Ok(PoseFix {
        stamp_ns,
        x: v[0],
        y: v[1],
        sigma,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path of two poses (the second 1.5 m down) reads as two waypoints;
    /// a truncated one, another frame and too many poses are refused.
    #[test]
    fn a_path_reads_as_waypoints() {
        let path = |frame: &str, poses: &[[f64; 3]]| {
            let mut w = Writer::new();
            w.i32(1).u32(2).string(frame).u32(poses.len() as u32);
            for p in poses {
                w.i32(1).u32(2).string(frame);
                for x in p.iter().chain(&[0.0, 0.0, 0.0, 1.0]) {
                    w.f64(*x);
                }
            }
            w.finish()
        };
        let msg = path("odom", &[[0.0, 0.0, 0.0], [10.0, 2.0, -1.5]]);
        let w = path_waypoints(&msg, 64).expect("a path");
        assert_eq!(w.len(), 2);
        assert_eq!(
            (w[1].index, w[1].x, w[1].y, w[1].depth),
            (1, 10.0, 2.0, Some(1.5))
        );
        assert_eq!(w[0].depth, None);
        let e = path_waypoints(&msg[..msg.len() - 4], 64).unwrap_err();
        assert!(e.contains("ends before"), "{e}");
        let e = path_waypoints(&path("map", &[[0.0; 3]]), 64).unwrap_err();
        assert!(e.contains("frame \"map\""), "{e}");
        let e = path_waypoints(&msg, 1).unwrap_err();
        assert!(e.contains("2 poses"), "{e}");
    }

    /// A `PoseStamped` and an `Odometry` read as fixes (the odometry's
    /// σ from its covariance); another frame, a NaN, a negative variance
    /// or a truncated message are refused with what was wrong.
    #[test]
    fn poses_read_as_fixes() {
        let msg = |odometry: bool, frame: &str, p: [f64; 3], var: f64| {
            let mut w = Writer::new();
            w.i32(1_700_000_000).u32(250_000_000).string(frame);
            if odometry {
                w.string("base_link");
            }
            for x in p.iter().chain(&[0.0, 0.0, 0.0, 1.0]) {
                w.f64(*x);
            }
            if odometry {
                for i in 0..36 {
                    w.f64(if i == 0 || i == 7 { var } else { 0.0 });
                }
                for _ in 0..42 {
                    w.f64(0.0);
                }
            }
            w.finish()
        };
        let f = pose_fix(&msg(false, "odom", [1.5, -2.0, 0.0], 0.0), false, "odom").unwrap();
        assert_eq!(
            f,
            PoseFix {
                stamp_ns: 1_700_000_000_250_000_000,
                x: 1.5,
                y: -2.0,
                sigma: None
            }
        );
        let f = pose_fix(&msg(true, "world", [3.0, 4.0, -1.0], 0.0004), true, "world").unwrap();
        assert_eq!((f.x, f.y), (3.0, 4.0));
        assert!((f.sigma.unwrap() - 0.02).abs() < 1e-12, "{f:?}");
        let bad = [
            (msg(false, "map", [0.0; 3], 0.0), false, "frame \"map\""),
            (
                msg(false, "odom", [f64::NAN, 0.0, 0.0], 0.0),
                false,
                "not finite",
            ),
            (msg(true, "odom", [0.0; 3], -1.0), true, "covariance"),
        ];
        for (m, odometry, want) in bad {
            let e = pose_fix(&m, odometry, "odom").unwrap_err();
            assert!(e.contains(want), "{e}");
        }
        let m = msg(true, "odom", [0.0; 3], 0.0);
        let e = pose_fix(&m[..100], true, "odom").unwrap_err();
        assert!(e.contains("ends before"), "{e}");
    }

    #[test]
    fn dds_names_follow_rmw_zenoh() {
        assert_eq!(
            JOINT_STATE.dds_name(),
            "sensor_msgs::msg::dds_::JointState_"
        );
        for t in ALL {
            assert!(
                t.hash.starts_with("RIHS01_") && t.hash.len() == 7 + 64,
                "{}",
                t.name
            );
        }
    }

    #[test]
    fn a_twist_reads_back_stamped_or_not_and_short_ones_are_named() {
        let t = Twist {
            linear: [0.3, 0.0, -0.1],
            angular: [0.0, 0.0, 0.5],
        };
        assert_eq!(Twist::decode(&t.encode(), false), Ok(t));
        let mut w = Writer::new();
        header(
            &mut w,
            &Header {
                stamp: Time::from_ns(1_500_000_000),
                frame_id: "base_link".into(),
            },
        );
        for v in t.linear.iter().chain(&t.angular) {
            w.f64(*v);
        }
        assert_eq!(Twist::decode(&w.finish(), true), Ok(t));
        let short = &t.encode()[..40];
        assert_eq!(
            Twist::decode(short, false),
            Err(CdrError::Short { what: "angular.y" })
        );
    }
}
