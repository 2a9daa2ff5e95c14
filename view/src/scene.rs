//! The [`Scene`]: snapshots turned into the channels' messages, and the
//! body's links posed from the measured joint angles.

use anguilla_ipc::StateSnapshot;
use anguilla_model::Body;
use nalgebra::{UnitQuaternion, Vector3};
use serde_json::Value;

use crate::changes::log_lines;
use crate::foxglove::{
    self, Color, FrameTransform, FrameTransforms, Log, Quaternion, SceneEntity, SceneUpdate,
    SpherePrimitive, Time,
};
use crate::guide::GuideTrail;
use crate::message::{Joints, Sensors, State, finite};
use crate::pose::{HeadTrack, Pose};
use crate::to_json;
use crate::truth::GroundTruth;

fn quaternion(q: &UnitQuaternion<f64>) -> Quaternion {
    Quaternion {
        x: q.i,
        y: q.j,
        z: q.k,
        w: q.w,
    }
}

fn vector3(v: &Vector3<f64>) -> foxglove::Vector3 {
    foxglove::Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// One link of the body, posed in the head frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Its centre (m).
    pub centre: Vector3<f64>,
    /// Its axes: x along the link towards the tail.
    pub orientation: UnitQuaternion<f64>,
    /// Its length (m).
    pub length: f64,
    /// Its semi-axes across: (left, up) (m).
    pub semi_axes: (f64, f64),
}

/// The body's links of a robot of `joints` joints, head first: the body
/// cut into `joints + 1` equal parts, each one's length
/// and its semi-axes (width, height) at its middle (m). The recording's
/// `/body` and the ROS 2 node's URDF draw these.
pub fn segments(joints: usize) -> Vec<(f64, f64, f64)> {
    let body = Body::paper();
    let n = joints + 1;
    let l = body.length / n as f64;
    (0..n)
        .map(|k| {
            let (a, b) = body.semi_axes((k as f64 + 0.5) / n as f64);
            (l, a, b)
        })
        .collect()
}

/// Turns snapshots into the channels' messages (the MCAP file's and the
/// live server's): keeps what needs the snapshots before (the predicted
/// head's dead reckoning, the changes logged, the path's legs drawn) and
/// the simulated robot's ground truth given since the last snapshot.
#[derive(Debug, Clone)]
pub struct Scene {
    last: Option<StateSnapshot>,
    /// The head's track (the daemon's estimate, or the predicted head
    /// integrated in the plane without a head sensor).
    track: HeadTrack,
    /// Each link's length and its semi-axes (m), head first.
    links: Vec<(f64, f64, f64)>,
    /// `/body`'s guide entity: the legs seen ([`crate::GUIDE_LEGS`]).
    guide: GuideTrail,
    /// The newest ground truth not yet on `/tf`, and its time (ns).
    truth: Option<(u64, GroundTruth)>,
}

impl Scene {
    /// The scene of a robot of `joints` joints.
    pub fn new(joints: usize) -> Self {
        Self {
            last: None,
            track: HeadTrack::default(),
            links: segments(joints),
            guide: GuideTrail::new(),
            truth: None,
        }
    }

    /// Takes the simulated robot's ground truth at daemon time `ns`: the
    /// next snapshot's `/tf` carries it once, as the frame `truth`
    /// ([`GroundTruth::head_pose`]) stamped `ns` (of several given between
    /// two snapshots, the newest). A truth whose values are not finite is
    /// left out.
    pub fn truth(&mut self, ns: u64, t: &GroundTruth) {
        self.truth = Some((ns, *t));
    }

    /// The messages of one snapshot: (index in
    /// [`TOPICS`](crate::TOPICS), JSON), one on every channel but `/log`,
    /// which gets one per change.
    pub fn messages(&mut self, s: &StateSnapshot) -> Vec<(usize, Value)> {
        let ns = s.time_ns;
        let mut out = vec![
            (0, to_json(&State::from(s))),
            (1, to_json(&Joints::from(s))),
        ];
        for (level, message) in log_lines(self.last.as_ref(), s) {
            out.push((2, to_json(&Log::new(ns, level, message))));
        }
        // The head: measured with a head sensor, else predicted; the
        // predicted one integrated in the plane (crate::pose, as ROS 2's tf).
        let (head, predicted) = self.track.update(s);
        let tf = |ns: u64, child: &'static str, p: &Pose| {
            let [x, y, z] = p.translation;
            let [qx, qy, qz, qw] = p.rotation;
            FrameTransform {
                timestamp: Time::from_ns(ns),
                parent_frame_id: "world",
                child_frame_id: child,
                translation: foxglove::Vector3 { x, y, z },
                rotation: Quaternion {
                    x: qx,
                    y: qy,
                    z: qz,
                    w: qw,
                },
            }
        };
        let mut transforms = FrameTransforms {
            transforms: vec![tf(ns, "head", &head), tf(ns, "head_predicted", &predicted)],
        };
        if let Some((t_ns, t)) = self.truth.take()
            && let Some(p) = t.head_pose()
        {
            transforms.transforms.push(tf(t_ns, "truth", &p));
        }
        out.push((3, to_json(&transforms)));
        out.push((4, to_json(&self.scene_update(s, ns))));
        out.push((5, to_json(&Sensors::from(s))));
        self.last = Some(*s);
        out
    }

    /// The links, head first, in the head frame (x forward, y left, z
    /// up): centre, orientation, length and semi-axes, chained from the
    /// nose through the measured joint angles (each joint pitches about y,
    /// then yaws about the pitched z).
    pub fn links(&self, s: &StateSnapshot) -> Vec<Link> {
        // In the model's head frame the body runs along +x (towards the
        // tail); the head frame is the forward one.
        let flip = anguilla_model::forward_turn();
        let mut r = UnitQuaternion::identity();
        let mut p = Vector3::zeros();
        let joints = (s.joint_count as usize).min(s.joints.len());
        let mut out = Vec::with_capacity(self.links.len());
        for (k, &(l, a, b)) in self.links.iter().enumerate() {
            if k > 0 && k - 1 < joints {
                let j = &s.joints[k - 1];
                r = r
                    * UnitQuaternion::from_euler_angles(0.0, finite(j.measured_pitch), 0.0)
                    * UnitQuaternion::from_euler_angles(0.0, 0.0, finite(j.measured_yaw));
            }
            let centre = p + r * Vector3::new(l / 2.0, 0.0, 0.0);
            p += r * Vector3::new(l, 0.0, 0.0);
            out.push(Link {
                centre: flip * centre,
                orientation: flip * r,
                length: l,
                semi_axes: (a, b),
            });
        }
        out
    }

    /// `/body`'s message: the links as ellipsoids, shaded head to tail;
    /// then the guide (crate::guide).
    fn scene_update(&mut self, s: &StateSnapshot, ns: u64) -> SceneUpdate {
        let links = self.links(s);
        let n = links.len();
        let spheres = links
            .iter()
            .enumerate()
            .map(|(k, l)| SpherePrimitive {
                pose: foxglove::Pose {
                    position: vector3(&l.centre),
                    orientation: quaternion(&l.orientation),
                },
                size: foxglove::Vector3 {
                    x: l.length,
                    y: 2.0 * l.semi_axes.0,
                    z: 2.0 * l.semi_axes.1,
                },
                color: Color {
                    r: 0.1,
                    g: 0.35 + 0.5 * k as f64 / n as f64,
                    b: 0.6,
                    a: 1.0,
                },
            })
            .collect();
        let mut entities = Vec::with_capacity(2);
        entities.push(SceneEntity {
            timestamp: Time::from_ns(ns),
            frame_id: "head",
            id: "body",
            lifetime: Time { sec: 0, nsec: 0 },
            frame_locked: true,
            metadata: [],
            arrows: [],
            cubes: [],
            spheres,
            cylinders: Vec::new(),
            lines: Vec::new(),
            triangles: [],
            texts: [],
            models: [],
        });
        entities.extend(self.guide.entity(s, ns));
        SceneUpdate {
            deletions: [],
            entities,
        }
    }
}
