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
//! | `diagnostics` | `diagnostic_msgs/msg/DiagnosticArray` | mode, cause, faults, bus, the path (cross-track error, estimated current), each joint's drive |
//! | `tf` | `tf2_msgs/msg/TFMessage` | `odom` → `head`, and each joint's links |
//! | `cross_track_error` | `std_msgs/msg/Float64` | the path's cross-track error (m, left of the leg positive); NaN when no path is followed |
//! | `current` | `geometry_msgs/msg/Vector3Stamped` | the estimated water current in `odom` (m/s; z 0) |
//!
//! Every topic is under the node's namespace. The stamps are the tether
//! computer's wall clock at publication (ROS 2 tools expect wall time;
//! the daemon's loop clock is monotonic).
//!
//! **Driving** (when the link's `inbound` allows it): `cmd_vel`
//! (`geometry_msgs/msg/Twist` or `TwistStamped`) becomes swim commands
//! ([`swim_of`]), and `~/take_control`, `~/release_control`, `~/enable`,
//! `~/disable`, `~/stop` and `~/estop` (`std_srvs/srv/Trigger`) the
//! daemon's commands, answered with its reply; `path`
//! (`nav_msgs/msg/Path`) is kept, `~/follow_path` follows it and
//! `~/resume_path` resumes it ([`PATH_SERVICES`]). The ROS 2 side is one
//! client of the daemon, so one operator session: it holds control only
//! by `~/take_control`, and the daemon's deadman stops the swim when the
//! twists stop. `~/estop` goes through the E-stop socket first.

use std::time::Instant;

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::time::Duration;

use anguilla_ipc::vocabulary::{Command, Mode};
use anguilla_ipc::{Client, StateSnapshot};
use zenoh::Wait as _;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::query::{Query, Queryable};
use zenoh_ext::{
    AdvancedPublisher, AdvancedPublisherBuilderExt as _, CacheConfig, MissDetectionConfig,
};

use super::graph::{Kind, NodeId, Qos, attachment, qualified};
use super::msgs::{self, MsgType};
use super::state;
use crate::{LinkError, zenoh_err};

mod cmd_vel;
mod latest;
mod path;
mod pose;
mod reply;

pub use cmd_vel::{SPEED_RUNGS, SpeedTable, TwistSwim, swim_of};
use latest::Latest;
pub use path::PATH_SERVICES;
use path::{KeepAlive, PathSlot};
pub use pose::{POSE_TOPICS, PoseSettings, PoseStats};
use reply::{Call, EStopCall, answer, reply_err, wall_ns};

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
    pub rates: [f64; super::N_TOPICS],
    /// The body, for `tf` and `robot_description`.
    pub geometry: state::Geometry,
    /// Humble: `TypeHashNotSupported` in keys and tokens.
    pub humble: bool,
    /// `cmd_vel` and the control services are served (the link's
    /// `inbound` has `command`).
    pub allow_command: bool,
    /// `~/estop` is served (the link's `inbound` has `estop`).
    pub allow_estop: bool,
    /// The body's steady forward speed against amplitude at `frequency`
    /// (the model's, `anguilla_daemon::speed`): `cmd_vel`'s `linear.x`
    /// becomes the amplitude that swims it.
    pub speeds: SpeedTable,
    /// The fastest `cmd_vel` may ask for (m/s, `[link] ros2-max-speed`):
    /// faster is clamped to it, and reported.
    pub max_speed: f64,
    /// The undulation frequency `cmd_vel` swims at (Hz).
    pub frequency: f64,
    /// Position fixes taken on [`POSE_TOPICS`] and handed to the daemon
    /// (`[link] ros2-pose`), when some.
    pub pose: Option<PoseSettings>,
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

/// A service call, queued for the link's loop: the service's index in
/// [`SERVICES`] (then [`PATH_SERVICES`]), the query, and for `~/estop` what relaying it to the
/// E-stop socket gave (done at once, on Zenoh's thread).
struct Inbound(usize, Query, Option<Result<(), String>>);

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

pub use super::{LATCHED, TOPICS};

/// `cmd_vel`'s types: a `Twist`, or a `TwistStamped` (Jazzy's
/// `teleop_twist_joy` publishes those), each on its own key.
pub const CMD_VEL: [MsgType; 2] = [msgs::TWIST, msgs::TWIST_STAMPED];

/// Service calls queued at most (beyond, a call is answered "busy" at
/// once; an `~/estop` has been relayed to the E-stop socket by then).
const INBOX: usize = 64;
/// A call the daemon has not answered in this long is answered with an
/// error; an `~/estop` whose effect the state has not shown in this long
/// is answered a failure, naming what was relayed.
pub const CALL_TIMEOUT: Duration = Duration::from_secs(2);
/// The control period assumed until the first state says it.
const DEFAULT_PERIOD: Duration = Duration::from_millis(10);

/// The running node.
pub struct Ros2Node {
    settings: Ros2Settings,
    prefix: String,
    id: NodeId,
    topics: Vec<Topic>,
    _tokens: Vec<LivelinessToken>,
    _subscribers: Vec<Subscriber<()>>,
    _queryables: Vec<Queryable<()>>,
    _latched: Vec<AdvancedPublisher<'static>>,
    conv: state::RosState,
    inbox: Receiver<Inbound>,
    twist: Arc<Latest<msgs::Twist>>,
    path: Arc<PathSlot>,
    /// Position fixes to the daemon (`[link] ros2-pose`).
    pose: Option<pose::PoseInput>,
    /// While the ROS 2 side's path is followed: control kept alive.
    following: KeepAlive,
    /// The newest path state the daemon showed.
    guide: anguilla_ipc::GuideSnapshot,
    /// The ROS 2 side's own client of the daemon: one operator session.
    client: Option<Client>,
    calls: HashMap<u32, Call>,
    estops: Vec<EStopCall>,
    limits: Option<anguilla_ipc::LimitsSnapshot>,
    /// The daemon's control period (from its state).
    period: Duration,
    /// The newest mode the state showed.
    mode: Option<u8>,
    /// When the last swim went to the daemon, and its sequence number
    /// while unanswered.
    last_swim: Option<Instant>,
    swim_in_flight: Option<u32>,
    /// Messages published.
    pub published: u64,
    /// `cmd_vel` messages turned into swim commands.
    pub twists: u64,
    /// Twists dropped: not finite, or the daemon away.
    pub dropped: u64,
    /// Twists whose speed was beyond reach, clamped.
    pub clamped: u64,
    /// The last twist was clamped (a run of them is said once).
    clamping: bool,
}

/// The service's name under the node: `/<namespace>/<node>/<name>`.
pub fn service_name(namespace: &str, node: &str, name: &str) -> String {
    qualified(&qualified(namespace, node), name)
}

/// A publisher's GID: the session's id with the entity's number in its
/// last four bytes (unique within the graph, as rmw_zenoh's).
fn gid(zid: &[u8; 16], entity: u32) -> [u8; 16] {
    let mut gid = *zid;
    gid[12..].copy_from_slice(&entity.to_le_bytes());
    gid
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
            let gid = gid(&zid, entity);
            topics.push(Topic {
                publisher,
                gid,
                sequence: 0,
                rate: settings.rates[i],
                last: None,
            });
        }
        let mut entity = 1 + TOPICS.len() as u32;
        // robot_description and tf_static: transient local, as rmw_zenoh
        // declares such a publisher (an advanced publisher with a cache of
        // one, detected by late subscribers, with heartbeats for their
        // missed-sample recovery); published once, kept in the cache.
        let mut latched = Vec::new();
        let stamp = wall_ns();
        let now = i64::try_from(stamp).unwrap_or(i64::MAX);
        let urdf = state::urdf(&settings.geometry);
        for (name, ty) in LATCHED {
            let name = qualified(&settings.namespace, name);
            let p = session
                .declare_publisher(id.data_key(&name, &ty))
                .cache(CacheConfig::default().max_samples(1))
                .sample_miss_detection(
                    MissDetectionConfig::default().sporadic_heartbeat(Duration::from_millis(500)),
                )
                .publisher_detection()
                .wait()
                .map_err(zenoh_err("ROS 2 transient-local publisher"))?;
            let payload = if ty == msgs::STRING {
                msgs::string(&urdf)
            } else {
                state::tf_static(stamp)
            };
            p.put(payload)
                .attachment(attachment(1, now, &gid(&zid, entity)).to_vec())
                .wait()
                .map_err(zenoh_err("ROS 2 put"))?;
            tokens.push(token(id.token(
                entity,
                Kind::Publisher,
                &name,
                &ty,
                &Qos {
                    best_effort: false,
                    transient_local: true,
                    depth: 1,
                },
            ))?);
            latched.push(p);
            entity += 1;
        }
        let (tx, inbox): (SyncSender<Inbound>, _) = std::sync::mpsc::sync_channel(INBOX);
        let twist = Arc::new(Latest::default());
        let path = Arc::new(PathSlot::default());
        let mut subscribers = Vec::new();
        if settings.allow_command {
            let name = qualified(&settings.namespace, "cmd_vel");
            for ty in CMD_VEL {
                let slot = twist.clone();
                let stamped = ty == msgs::TWIST_STAMPED;
                subscribers.push(
                    session
                        .declare_subscriber(id.data_key(&name, &ty))
                        .callback(move |sample| {
                            // A message that is not this type's CDR is
                            // dropped here, counted; a newer twist
                            // replaces one not yet sent.
                            match msgs::Twist::decode(&sample.payload().to_bytes(), stamped) {
                                Ok(t) => slot.put(t),
                                Err(_) => {
                                    slot.refuse();
                                }
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
            let estop_prefix = (*cmd == Command::EStop).then(|| prefix.to_string());
            queryables.push(
                session
                    .declare_queryable(id.data_key(&name, &msgs::TRIGGER))
                    .complete(true)
                    .callback(move |q| {
                        // The out-of-band path first and at once, as the
                        // link's own e-stop key: no queue lies before it.
                        let relayed = estop_prefix.as_deref().map(|p| {
                            let r = anguilla_ipc::estop::send(p).map_err(|e| e.to_string());
                            match &r {
                                Ok(()) => tracing::warn!(
                                    "ROS 2 ~/estop: relayed to the daemon's e-stop socket"
                                ),
                                Err(e) => tracing::warn!("ROS 2 ~/estop: the e-stop socket: {e}"),
                            }
                            r
                        });
                        match tx.try_send(Inbound(i, q, relayed)) {
                            Ok(()) => {}
                            Err(TrySendError::Full(Inbound(_, q, relayed))) => {
                                let text = match relayed {
                                    Some(Ok(())) => {
                                        "the link is busy: the e-stop was relayed to the \
                                         daemon's e-stop socket, but the link cannot confirm it \
                                         in the state; read the state"
                                    }
                                    Some(Err(_)) => {
                                        "the link is busy and the e-stop socket refused the \
                                         e-stop: it did NOT go out"
                                    }
                                    None => "the link is busy: call dropped",
                                };
                                reply_err(&q, text);
                            }
                            Err(_) => {}
                        }
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
        if settings.allow_command {
            let tx = tx.clone();
            entity = path::declare(
                session,
                &id,
                (&settings.namespace, &settings.node),
                &path,
                move |k, q| {
                    let i = SERVICES.len() + k;
                    if let Err(TrySendError::Full(Inbound(_, q, _))) =
                        tx.try_send(Inbound(i, q, None))
                    {
                        reply_err(&q, "the link is busy: call dropped");
                    }
                },
                path::Declared {
                    subscribers: &mut subscribers,
                    queryables: &mut queryables,
                    tokens: &mut tokens,
                },
                entity,
            )?;
        }
        let mut pose = None;
        if let Some(p) = settings.pose.clone().filter(|_| settings.allow_command) {
            // The last entities: the next number is not needed.
            let (input, _) = pose::PoseInput::declare(
                session,
                &id,
                &settings.namespace,
                p,
                (&mut subscribers, &mut tokens),
                entity,
            )?;
            pose = Some(input);
        }
        let conv = state::RosState::new(settings.geometry.clone());
        Ok(Self {
            settings,
            prefix: prefix.to_string(),
            id,
            topics,
            _tokens: tokens,
            _subscribers: subscribers,
            _queryables: queryables,
            _latched: latched,
            conv,
            inbox,
            twist,
            path,
            pose,
            following: KeepAlive::default(),
            guide: anguilla_ipc::GuideSnapshot::default(),
            client: None,
            calls: HashMap::new(),
            estops: Vec::new(),
            limits: None,
            period: DEFAULT_PERIOD,
            mode: None,
            last_swim: None,
            swim_in_flight: None,
            published: 0,
            twists: 0,
            dropped: 0,
            clamped: 0,
            clamping: false,
        })
    }

    fn client(&mut self) -> Result<&mut Client, LinkError> {
        if self.client.is_none() {
            let name = format!("anguilla-link-ros2-{}", std::process::id());
            self.client = Some(Client::new(&self.prefix, &name)?);
        }
        Ok(self.client.as_mut().expect("opened above"))
    }

    /// Twists replaced by a newer one before they were sent (latest
    /// wins: at most one swim goes out per control period).
    pub fn superseded(&self) -> u64 {
        self.twist.superseded.load(Ordering::Relaxed)
    }

    /// What the position-fix input has done, when it runs.
    pub fn pose_stats(&self) -> Option<PoseStats> {
        self.pose.as_ref().map(pose::PoseInput::stats)
    }

    /// `cmd_vel` messages that were not their type's CDR.
    pub fn undecodable(&self) -> u64 {
        self.twist.refused.load(Ordering::Relaxed)
    }

    /// Serves what ROS 2 nodes sent: the newest `cmd_vel` becomes a swim
    /// command, at most one per control period and none while the last is
    /// unanswered (the daemon's deadman stops the swim when they stop);
    /// each service call a command whose reply answers it; `~/estop` is
    /// answered from the state. Bounded work per call, whatever arrives.
    pub fn serve(&mut self) -> Result<(), LinkError> {
        for _ in 0..INBOX {
            let Ok(Inbound(i, q, relayed)) = self.inbox.try_recv() else {
                break;
            };
            self.call(i, q, relayed)?;
        }
        self.send_twist();
        self.keep_path_alive();
        if let Some(p) = &mut self.pose {
            p.forward(wall_ns());
        }
        if let Some(c) = &mut self.client {
            let calls = &mut self.calls;
            let in_flight = &mut self.swim_in_flight;
            let following = &mut self.following;
            let r = c.replies(|r| {
                if *in_flight == Some(r.sequence) {
                    *in_flight = None;
                }
                if let Some(call) = calls.remove(&r.sequence) {
                    let mode = Mode::from_code(r.mode).map_or("unknown", Mode::name);
                    let text = if r.accepted != 0 {
                        format!("accepted; mode {mode}")
                    } else {
                        format!("refused: {}; mode {mode}", r.reason())
                    };
                    if call.path && r.accepted != 0 {
                        following.start();
                    }
                    answer(&call, r.accepted != 0, &text);
                }
            });
            if let Err(e) = r {
                tracing::warn!("ROS 2 replies: {e}");
                self.client = None;
                self.swim_in_flight = None;
            }
        }
        self.calls.retain(|_, call| {
            let keep = call.sent.elapsed() < CALL_TIMEOUT;
            if !keep {
                answer(call, false, "the daemon did not answer within 2 s");
            }
            keep
        });
        self.answer_estops();
        Ok(())
    }

    /// Sends the newest twist as a swim when one control period has
    /// passed since the last and the daemon has answered it (or not within
    /// [`CALL_TIMEOUT`]): a flood is one swim a period, never a queue that
    /// pushes other requests out of the client.
    fn send_twist(&mut self) {
        let now = Instant::now();
        let due = self.last_swim.is_none_or(|t| {
            let since = now.duration_since(t);
            since >= self.period && (self.swim_in_flight.is_none() || since >= CALL_TIMEOUT)
        });
        if !due {
            return;
        }
        let Some(t) = self.twist.take() else {
            return;
        };
        let Some(swim) = swim_of(
            &t,
            &self.settings.speeds,
            self.settings.max_speed,
            self.settings.frequency,
            self.limits.as_ref(),
        ) else {
            self.dropped += 1;
            return;
        };
        // Beyond reach: clamped, counted, and said once a run of them.
        if swim.clamped() {
            self.clamped += 1;
            if !self.clamping {
                tracing::warn!(
                    "ROS 2 cmd_vel: linear.x {:.3} m/s is beyond reach: swimming at {:.3} m/s \
                     (the body's steady speed at full amplitude at {} Hz is {:.3} m/s; \
                     [link] ros2-max-speed = {} m/s)",
                    swim.speed.0,
                    swim.speed.1,
                    self.settings.frequency,
                    self.settings.speeds.max_speed(),
                    self.settings.max_speed
                );
            }
        }
        self.clamping = swim.clamped();
        let p = swim.params;
        // The daemon away (restarting, stopped): the twist is dropped and
        // the client opened again at the next one; the link keeps serving.
        match self.client().and_then(|c| Ok(c.send(Command::Swim(p))?)) {
            Ok(seq) => {
                self.twists += 1;
                self.last_swim = Some(now);
                self.swim_in_flight = Some(seq);
            }
            Err(e) => {
                self.dropped += 1;
                self.client = None;
                self.swim_in_flight = None;
                tracing::warn!("ROS 2 cmd_vel: {e}");
            }
        }
    }

    /// Answers the `~/estop` calls ([`reply::answer_estops`]).
    fn answer_estops(&mut self) {
        reply::answer_estops(&mut self.estops, self.mode, CALL_TIMEOUT);
    }

    /// A path service's call (`k` its index in [`PATH_SERVICES`]): the
    /// waypoints and the follow sent ([`path::load`]: a few control
    /// periods a waypoint), the call answered by the follow's reply or the
    /// first waypoint refused.
    fn path_call(&mut self, k: usize, q: Query) {
        let call = Call::of(q, true);
        let name = PATH_SERVICES[k];
        let resume = name == "resume_path";
        let waypoints = match (resume, self.path.latest()) {
            (true, _) => Vec::new(),
            (false, Some(Ok(w))) => w,
            (false, Some(Err(e))) => {
                let why = format!("~/{name}: the last path was refused: {e}");
                return answer(&call, false, &why);
            }
            (false, None) => {
                return answer(
                    &call,
                    false,
                    &format!("~/{name}: no path received on `path`"),
                );
            }
        };
        let count = if resume {
            u32::from(self.guide.waypoints)
        } else {
            waypoints.len() as u32
        };
        let follow = path::follow(resume, count, self.settings.frequency);
        match self
            .client()
            .and_then(|c| Ok(path::load(c, &waypoints, follow, CALL_TIMEOUT)?))
        {
            Ok(Ok(seq)) => {
                self.calls.insert(seq, call);
            }
            Ok(Err(why)) => answer(&call, false, &format!("~/{name}: refused: {why}")),
            Err(e) => {
                self.client = None;
                self.swim_in_flight = None;
                answer(&call, false, &format!("~/{name}: {e}"));
            }
        }
    }

    /// Keeps control alive while the ROS 2 side's path is followed (the
    /// daemon's deadman would stop the swim otherwise).
    fn keep_path_alive(&mut self) {
        let followed = self.guide.guide_state() == Some(anguilla_ipc::GuideState::Following);
        if !self.following.due(followed, CALL_TIMEOUT) {
            return;
        }
        if let Err(e) = self.client().and_then(|c| Ok(c.send(Command::KeepAlive)?)) {
            tracing::warn!("ROS 2 path keep-alive: {e}");
            self.client = None;
            self.following.stop();
        }
    }

    fn call(
        &mut self,
        i: usize,
        q: Query,
        relayed: Option<Result<(), String>>,
    ) -> Result<(), LinkError> {
        if i >= SERVICES.len() {
            self.path_call(i - SERVICES.len(), q);
            return Ok(());
        }
        let (name, cmd) = SERVICES[i];
        let call = Call::of(q, false);
        let sent = self.client().and_then(|c| Ok(c.send(cmd)?));
        if let Err(e) = &sent {
            self.client = None;
            self.swim_in_flight = None;
            if cmd != Command::EStop {
                answer(&call, false, &format!("~/{name}: {e}"));
                return Ok(());
            }
        }
        match (cmd, sent) {
            (Command::EStop, sent) => {
                // Both paths, and what each gave; the answer waits for the
                // state (the command's reply may never come: the E-stop
                // acts first through the socket).
                let socket = match relayed {
                    Some(Ok(())) => "relayed to the daemon's e-stop socket".to_string(),
                    Some(Err(e)) => format!("the e-stop socket failed: {e}"),
                    None => "not relayed to the e-stop socket".to_string(),
                };
                let command = match sent {
                    Ok(_) => "sent as a command".to_string(),
                    Err(e) => format!("the command failed: {e}"),
                };
                self.estops.push(EStopCall {
                    call,
                    relayed: format!("{socket}; {command}"),
                });
                self.answer_estops();
            }
            (_, Ok(seq)) => {
                self.calls.insert(seq, call);
            }
            (_, Err(_)) => {}
        }
        Ok(())
    }

    /// The node's place on the graph.
    pub fn id(&self) -> &NodeId {
        &self.id
    }

    /// The settings it was opened with.
    pub fn settings(&self) -> &Ros2Settings {
        &self.settings
    }

    /// Publishes `s` on every topic that is due.
    pub fn publish(&mut self, s: &StateSnapshot) -> Result<(), LinkError> {
        self.limits = Some(s.limits);
        self.mode = Some(s.mode);
        self.guide = s.guide;
        if s.loop_stats.period_ns > 0 {
            self.period = Duration::from_nanos(u64::from(s.loop_stats.period_ns));
        }
        if !self.estops.is_empty() {
            self.answer_estops();
        }
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
            self.conv.advance(s);
            return Ok(());
        }
        let stamp_ns = wall_ns();
        let now_ns = i64::try_from(stamp_ns).unwrap_or(i64::MAX);
        let payloads = self.conv.all(s, stamp_ns);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_service_is_named_under_the_node_and_its_namespace() {
        assert_eq!(
            service_name("/eel", "anguilla", "estop"),
            "/eel/anguilla/estop"
        );
        assert_eq!(service_name("/", "anguilla", "enable"), "/anguilla/enable");
    }
}
