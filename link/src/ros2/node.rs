//! The ROS 2 node `anguilla link` runs on its Zenoh session when `[link]
//! ros2 = true` (docs/ros2.md): its liveliness tokens, and the daemon's
//! state as ROS 2 topics.
//!
//! | topic | type | from the state |
//! |---|---|---|
//! | `joint_states` | `sensor_msgs/msg/JointState` | `joint<i>_pitch`, `joint<i>_yaw`: measured angle, rate, torque |
//! | `imu` | `sensor_msgs/msg/Imu` | the body's attitude (REP 103: yaw anticlockwise from the earth frame's x, as the daemon's heading; frame `head`); rates and accelerations marked unknown (covariance −1) |
//! | `pressure` | `sensor_msgs/msg/FluidPressure` | the head's depth as absolute pressure (fresh water, 1 atm at the surface) |
//! | `feedforward` | `std_msgs/msg/Float64MultiArray` | the model's predicted torques, the axes in `joint_states`' order |
//! | `torque_residual` | `std_msgs/msg/Float64MultiArray` | the normalised torque residuals, the same order |
//! | `diagnostics` | `diagnostic_msgs/msg/DiagnosticArray` | mode, cause, faults, bus, each joint's drive |
//!
//! Every topic is under the node's namespace. The stamps are the tether
//! computer's wall clock at publication (ROS 2 tools expect wall time;
//! the daemon's loop clock is monotonic).
//!
//! **Driving** (when the link's `inbound` allows it): `cmd_vel`
//! (`geometry_msgs/msg/Twist` or `TwistStamped`) becomes swim commands
//! ([`swim_of`]), and `~/take_control`, `~/release_control`, `~/enable`,
//! `~/disable`, `~/stop` and `~/estop` (`std_srvs/srv/Trigger`) the
//! daemon's commands, answered with its reply. The ROS 2 side is one
//! client of the daemon, so one operator session: it holds control only
//! by `~/take_control`, and the daemon's deadman stops the swim when the
//! twists stop. `~/estop` goes through the E-stop socket first.

use std::time::{Instant, SystemTime, UNIX_EPOCH};

use std::collections::HashMap;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::time::Duration;

use anguilla_ipc::vocabulary::{Cause, Command, FaultKind, Mode, SwimParams};
use anguilla_ipc::{Client, StateSnapshot};
use zenoh::Wait as _;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::query::{Query, Queryable};

use super::graph::{Kind, NodeId, Qos, attachment, qualified, read_attachment};
use super::msgs::{self, MsgType};
use crate::{LinkError, zenoh_err};

/// Where and how often the node publishes.
#[derive(Debug, Clone, PartialEq)]
pub struct Ros2Settings {
    /// `ROS_DOMAIN_ID` (0..=232).
    pub domain: u32,
    /// `/` or `/name`.
    pub namespace: String,
    /// The node's name.
    pub node: String,
    /// Most messages a second (Hz) of each of [`TOPICS`], in its order.
    pub rates: [f64; 6],
    /// Humble: `TypeHashNotSupported` in keys and tokens.
    pub humble: bool,
    /// `cmd_vel` and the control services are served (the link's
    /// `inbound` has `command`).
    pub allow_command: bool,
    /// `~/estop` is served (the link's `inbound` has `estop`).
    pub allow_estop: bool,
    /// The forward speed `cmd_vel` asks for at full amplitude (m/s).
    pub max_speed: f64,
    /// The undulation frequency `cmd_vel` swims at (Hz).
    pub frequency: f64,
}

/// The services, `~/<name>` (std_srvs/srv/Trigger), and what each sends
/// the daemon. `estop` also goes through the out-of-band E-stop socket
/// first, as every tool's does.
pub const SERVICES: [(&str, Command); 6] = [
    ("take_control", Command::TakeControl),
    ("release_control", Command::ReleaseControl),
    ("enable", Command::Enable),
    ("disable", Command::Disable),
    ("stop", Command::Stop),
    ("estop", Command::EStop),
];

/// What arrives from ROS 2 nodes, queued for the link's loop.
enum Inbound {
    Twist(msgs::Twist),
    Service(usize, Query),
}

/// A service call waiting for the daemon's reply.
struct Call {
    query: Query,
    attachment: Vec<u8>,
    sent: Instant,
}

struct Topic {
    publisher: Publisher<'static>,
    gid: [u8; 16],
    sequence: i64,
    rate: f64,
    last: Option<Instant>,
}

impl Topic {
    fn put(&mut self, payload: Vec<u8>, now_ns: i64) -> Result<(), LinkError> {
        self.sequence += 1;
        self.publisher
            .put(payload)
            .attachment(attachment(self.sequence, now_ns, &self.gid).to_vec())
            .wait()
            .map_err(zenoh_err("ROS 2 put"))
    }
}

pub use super::TOPICS;

/// `cmd_vel`'s types: a `Twist`, or a `TwistStamped` (Jazzy's
/// `teleop_twist_joy` publishes those), each on its own key.
pub const CMD_VEL: [MsgType; 2] = [msgs::TWIST, msgs::TWIST_STAMPED];

/// Inbound messages and calls queued at most (beyond: dropped, a call
/// answered with an error).
const INBOX: usize = 64;
/// A call the daemon has not answered in this long is answered with an
/// error.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// The running node.
pub struct Ros2Node {
    settings: Ros2Settings,
    prefix: String,
    id: NodeId,
    topics: Vec<Topic>,
    _tokens: Vec<LivelinessToken>,
    _subscribers: Vec<Subscriber<()>>,
    _queryables: Vec<Queryable<()>>,
    inbox: Receiver<Inbound>,
    /// The ROS 2 side's own client of the daemon: one operator session.
    client: Option<Client>,
    calls: HashMap<u32, Call>,
    limits: Option<anguilla_ipc::LimitsSnapshot>,
    /// Messages published.
    pub published: u64,
    /// `cmd_vel` messages turned into swim commands.
    pub twists: u64,
    /// Inbound messages dropped (a full queue, or not CDR of their type).
    pub dropped: u64,
}

/// The service's name under the node: `/<namespace>/<node>/<name>`.
pub fn service_name(namespace: &str, node: &str, name: &str) -> String {
    qualified(&qualified(namespace, node), name)
}

/// The swim a `cmd_vel` asks for (docs/ros2.md): `linear.x` (m/s) as the
/// amplitude, `linear.x / max_speed` (an eel does not swim backwards: 0
/// below 0); `angular.z` (rad/s, left positive) as the turn curvature
/// `angular.z / v` (1/m), with `v` the speed asked for but at least 0.1
/// m/s; `linear.z` (m/s, up positive) as the pitch curvature `−linear.z /
/// v` (1/m, the daemon's is dive positive); at `frequency`. Each is
/// clamped to the daemon's limits when known. Not finite: `None`.
pub fn swim_of(
    t: &msgs::Twist,
    max_speed: f64,
    frequency: f64,
    limits: Option<&anguilla_ipc::LimitsSnapshot>,
) -> Option<SwimParams> {
    let (x, z, wz) = (t.linear[0], t.linear[2], t.angular[2]);
    if ![x, z, wz].iter().all(|v| v.is_finite()) {
        return None;
    }
    let v = x.max(0.1);
    let clamp = |value: f64, max: Option<f32>| match max {
        Some(m) if m > 0.0 => value.clamp(-f64::from(m), f64::from(m)),
        _ => value,
    };
    Some(SwimParams {
        amplitude: (x / max_speed).clamp(0.0, 1.0),
        frequency: clamp(frequency, limits.map(|l| l.max_frequency)),
        turn: clamp(wz / v, limits.map(|l| l.max_turn)),
        pitch: clamp(-z / v, limits.map(|l| l.max_pitch)),
    })
}

fn wall_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

impl Ros2Node {
    /// Declares the node, its publishers, `cmd_vel` and its services on
    /// `session`; the ROS 2 side's client of the daemon at `prefix` opens
    /// at the first command.
    pub fn open(
        session: &zenoh::Session,
        prefix: &str,
        settings: Ros2Settings,
    ) -> Result<Self, LinkError> {
        let id = NodeId {
            domain: settings.domain,
            session: session.zid().to_string(),
            node: 0,
            namespace: settings.namespace.clone(),
            name: settings.node.clone(),
            humble: settings.humble,
        };
        let token = |key: String| {
            session
                .liveliness()
                .declare_token(key)
                .wait()
                .map_err(zenoh_err("ROS 2 liveliness token"))
        };
        let mut tokens = vec![token(id.node_token())?];
        let mut topics = Vec::new();
        let zid = session.zid().to_le_bytes();
        for (i, (name, ty)) in TOPICS.iter().enumerate() {
            let entity = 1 + i as u32;
            let name = qualified(&settings.namespace, name);
            let publisher = session
                .declare_publisher(id.data_key(&name, ty))
                .congestion_control(CongestionControl::Drop)
                .wait()
                .map_err(zenoh_err("ROS 2 publisher"))?;
            tokens.push(token(id.token(
                entity,
                Kind::Publisher,
                &name,
                ty,
                &Qos::reliable(10),
            ))?);
            // The GID: the session's id with the entity's number in its
            // last four bytes (unique within the graph, as rmw_zenoh's).
            let mut gid = [0u8; 16];
            gid.copy_from_slice(&zid[..16]);
            gid[12..].copy_from_slice(&entity.to_le_bytes());
            topics.push(Topic {
                publisher,
                gid,
                sequence: 0,
                rate: settings.rates[i],
                last: None,
            });
        }
        let (tx, inbox): (SyncSender<Inbound>, _) = std::sync::mpsc::sync_channel(INBOX);
        let mut entity = 1 + TOPICS.len() as u32;
        let mut subscribers = Vec::new();
        if settings.allow_command {
            let name = qualified(&settings.namespace, "cmd_vel");
            for ty in CMD_VEL {
                let tx = tx.clone();
                let stamped = ty == msgs::TWIST_STAMPED;
                subscribers.push(
                    session
                        .declare_subscriber(id.data_key(&name, &ty))
                        .callback(move |sample| {
                            // A message that is not this type's CDR is
                            // dropped here; a full queue drops too (the
                            // next twist supersedes it).
                            if let Ok(t) =
                                msgs::Twist::decode(&sample.payload().to_bytes(), stamped)
                            {
                                let _ = tx.try_send(Inbound::Twist(t));
                            }
                        })
                        .wait()
                        .map_err(zenoh_err("ROS 2 cmd_vel subscriber"))?,
                );
                tokens.push(token(id.token(
                    entity,
                    Kind::Subscription,
                    &name,
                    &ty,
                    &Qos::reliable(10),
                ))?);
                entity += 1;
            }
        }
        let mut queryables = Vec::new();
        for (i, (svc, cmd)) in SERVICES.iter().enumerate() {
            let allowed = if *cmd == Command::EStop {
                settings.allow_estop
            } else {
                settings.allow_command
            };
            if !allowed {
                continue;
            }
            let name = service_name(&settings.namespace, &settings.node, svc);
            let tx = tx.clone();
            queryables.push(
                session
                    .declare_queryable(id.data_key(&name, &msgs::TRIGGER))
                    .complete(true)
                    .callback(move |q| match tx.try_send(Inbound::Service(i, q)) {
                        Ok(()) => {}
                        Err(TrySendError::Full(Inbound::Service(_, q))) => {
                            reply_err(&q, "the link is busy: call dropped");
                        }
                        Err(_) => {}
                    })
                    .wait()
                    .map_err(zenoh_err("ROS 2 service"))?,
            );
            tokens.push(token(id.token(
                entity,
                Kind::Service,
                &name,
                &msgs::TRIGGER,
                &Qos::reliable(10),
            ))?);
            entity += 1;
        }
        Ok(Self {
            settings,
            prefix: prefix.to_string(),
            id,
            topics,
            _tokens: tokens,
            _subscribers: subscribers,
            _queryables: queryables,
            inbox,
            client: None,
            calls: HashMap::new(),
            limits: None,
            published: 0,
            twists: 0,
            dropped: 0,
        })
    }

    fn client(&mut self) -> Result<&mut Client, LinkError> {
        if self.client.is_none() {
            let name = format!("anguilla-link-ros2-{}", std::process::id());
            self.client = Some(Client::new(&self.prefix, &name)?);
        }
        Ok(self.client.as_mut().expect("opened above"))
    }

    /// Serves what ROS 2 nodes sent: each `cmd_vel` becomes a swim
    /// command (the daemon's deadman stops the swim when they stop), each
    /// service call a command whose reply answers it.
    pub fn serve(&mut self) -> Result<(), LinkError> {
        while let Ok(m) = self.inbox.try_recv() {
            match m {
                Inbound::Twist(t) => {
                    let Some(p) = swim_of(
                        &t,
                        self.settings.max_speed,
                        self.settings.frequency,
                        self.limits.as_ref(),
                    ) else {
                        self.dropped += 1;
                        continue;
                    };
                    self.client()?.send(Command::Swim(p))?;
                    self.twists += 1;
                }
                Inbound::Service(i, q) => self.call(i, q)?,
            }
        }
        if let Some(c) = &mut self.client {
            let calls = &mut self.calls;
            c.replies(|r| {
                if let Some(call) = calls.remove(&r.sequence) {
                    let mode = Mode::from_code(r.mode).map_or("unknown", Mode::name);
                    let text = if r.accepted != 0 {
                        format!("accepted; mode {mode}")
                    } else {
                        format!("refused: {}; mode {mode}", r.reason())
                    };
                    answer(&call, r.accepted != 0, &text);
                }
            })?;
        }
        self.calls.retain(|_, call| {
            let keep = call.sent.elapsed() < CALL_TIMEOUT;
            if !keep {
                answer(call, false, "the daemon did not answer within 2 s");
            }
            keep
        });
        Ok(())
    }

    fn call(&mut self, i: usize, q: Query) -> Result<(), LinkError> {
        let (name, cmd) = SERVICES[i];
        let attachment = q
            .attachment()
            .map(|a| a.to_bytes().into_owned())
            .unwrap_or_default();
        let mut call = Call {
            query: q,
            attachment,
            sent: Instant::now(),
        };
        if cmd == Command::EStop {
            // The out-of-band path first, as every tool's E-stop.
            if let Err(e) = anguilla_ipc::estop::send(&self.prefix) {
                tracing::warn!("ROS 2 ~/estop: the e-stop socket: {e}");
            } else {
                tracing::warn!("ROS 2 ~/estop: relayed to the daemon's e-stop socket");
            }
        }
        match self.client().and_then(|c| Ok(c.send(cmd)?)) {
            Ok(seq) => {
                call.sent = Instant::now();
                self.calls.insert(seq, call);
            }
            Err(e) => answer(&call, false, &format!("~/{name}: {e}")),
        }
        Ok(())
    }

    /// The node's place on the graph.
    pub fn id(&self) -> &NodeId {
        &self.id
    }

    /// Publishes `s` on every topic that is due.
    pub fn publish(&mut self, s: &StateSnapshot) -> Result<(), LinkError> {
        self.limits = Some(s.limits);
        let now = Instant::now();
        let due: Vec<bool> = self
            .topics
            .iter()
            .map(|t| {
                t.last
                    .is_none_or(|l| (now - l).as_secs_f64() >= 1.0 / t.rate)
            })
            .collect();
        if !due.contains(&true) {
            return Ok(());
        }
        let stamp_ns = wall_ns();
        let now_ns = i64::try_from(stamp_ns).unwrap_or(i64::MAX);
        let [a, b, c, d, e] = messages(s, stamp_ns);
        let payloads = [a, b, c, d, e, diagnostics(s, stamp_ns).encode()];
        for ((topic, payload), due) in self.topics.iter_mut().zip(payloads).zip(due) {
            if due {
                topic.last = Some(now);
                topic.put(payload, now_ns)?;
                self.published += 1;
            }
        }
        Ok(())
    }
}

/// Answers a service call: a `Trigger` response, with rmw_zenoh's
/// attachment (the request's sequence number and GID, which the caller
/// matches the reply by).
fn answer(call: &Call, success: bool, message: &str) {
    let now = i64::try_from(wall_ns()).unwrap_or(i64::MAX);
    let (seq, gid) = read_attachment(&call.attachment).map_or((0, [0; 16]), |(s, _, g)| (s, g));
    let r = call
        .query
        .reply(
            call.query.key_expr().clone(),
            msgs::trigger_response(success, message),
        )
        .attachment(attachment(seq, now, &gid).to_vec())
        .wait();
    if let Err(e) = r {
        tracing::debug!("ROS 2 service reply: {e}");
    }
}

fn reply_err(q: &Query, text: &str) {
    if let Err(e) = q.reply_err(text.to_string()).wait() {
        tracing::debug!("ROS 2 service error reply: {e}");
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
    fn a_twist_maps_to_a_swim_within_the_daemons_limits() {
        let limits = anguilla_ipc::LimitsSnapshot {
            max_frequency: 2.0,
            max_turn: 1.0,
            max_pitch: 0.5,
            ..Default::default()
        };
        let t = |x: f64, z: f64, wz: f64| msgs::Twist {
            linear: [x, 0.0, z],
            angular: [0.0, 0.0, wz],
        };
        let p = swim_of(&t(0.2, 0.0, 0.1), 0.4, 1.0, Some(&limits)).unwrap();
        assert_eq!(
            (p.amplitude, p.frequency, p.turn, p.pitch),
            (0.5, 1.0, 0.5, 0.0)
        );
        // faster than the maximum, backwards, turning hard on the spot,
        // climbing steeply: each within its range
        let p = swim_of(&t(9.0, 0.0, 0.0), 0.4, 1.0, None).unwrap();
        assert_eq!(p.amplitude, 1.0);
        let p = swim_of(&t(-0.3, 0.2, 1.0), 0.4, 3.0, Some(&limits)).unwrap();
        assert_eq!(
            (p.amplitude, p.frequency, p.turn, p.pitch),
            (0.0, 2.0, 1.0, -0.5)
        );
        for bad in [f64::NAN, f64::INFINITY] {
            assert!(swim_of(&t(bad, 0.0, 0.0), 0.4, 1.0, None).is_none());
            assert!(swim_of(&t(0.1, 0.0, bad), 0.4, 1.0, None).is_none());
        }
        assert_eq!(
            service_name("/eel", "anguilla", "estop"),
            "/eel/anguilla/estop"
        );
        assert_eq!(service_name("/", "anguilla", "enable"), "/anguilla/enable");
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
