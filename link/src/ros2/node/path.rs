//! Following a path from ROS 2 (docs/ros2.md, "Following a path"): the
//! `path` subscription (`nav_msgs/msg/Path`), the path services'
//! declarations, a path's load, and the keep-alive while the ROS 2 side's
//! path is followed. The node (`super`) answers the calls.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anguilla_ipc::vocabulary::{Command, Follow, SwimParams, Waypoint};
use anguilla_ipc::{Client, IpcError};
use zenoh::Wait as _;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};

use crate::ros2::graph::{Kind, NodeId, Qos, qualified};
use crate::ros2::msgs;
use crate::{LinkError, zenoh_err};

/// The path services, `~/<name>` (std_srvs/srv/Trigger): `follow_path`
/// follows the last `nav_msgs/msg/Path` received on `path` (its poses
/// loaded as waypoints one a request, then the follow, at full amplitude
/// and the `cmd_vel` frequency), `resume_path` resumes the path an
/// operator's command interrupted on its leg. While the ROS 2 side's path
/// is followed the node keeps control alive; `~/stop` stops it.
pub const PATH_SERVICES: [&str; 2] = ["follow_path", "resume_path"];

/// How often the node keeps control alive while its path is followed.
pub(super) const KEEP_ALIVE: Duration = Duration::from_millis(200);

/// The last path received on `path`: its waypoints, or why it was
/// refused (written by Zenoh's threads).
#[derive(Default)]
pub(super) struct PathSlot {
    latest: Mutex<Option<Result<Vec<Waypoint>, String>>>,
}

impl PathSlot {
    /// The last path received, or why it was refused; `None` before one.
    pub(super) fn latest(&self) -> Option<Result<Vec<Waypoint>, String>> {
        self.latest
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}

/// Where the node declares the path's entities.
pub(super) struct Declared<'a> {
    /// The node's subscribers.
    pub subscribers: &'a mut Vec<Subscriber<()>>,
    /// Its queryables.
    pub queryables: &'a mut Vec<Queryable<()>>,
    /// Its liveliness tokens.
    pub tokens: &'a mut Vec<LivelinessToken>,
}

/// Declares the `path` subscription (kept in `slot`) and the path
/// services under `namespace`/`node`, a call of the `k`-th handed to
/// `on_call` with `k`; returns the next entity number after `entity`.
pub(super) fn declare(
    session: &zenoh::Session,
    id: &NodeId,
    (namespace, node): (&str, &str),
    slot: &Arc<PathSlot>,
    on_call: impl Fn(usize, Query) + Clone + Send + Sync + 'static,
    to: Declared<'_>,
    mut entity: u32,
) -> Result<u32, LinkError> {
    let token = |key: String| {
        session
            .liveliness()
            .declare_token(key)
            .wait()
            .map_err(zenoh_err("ROS 2 liveliness token"))
    };
    let name = qualified(namespace, "path");
    let kept = slot.clone();
    to.subscribers.push(
        session
            .declare_subscriber(id.data_key(&name, &msgs::PATH))
            .callback(move |sample| {
                let p =
                    msgs::path_waypoints(&sample.payload().to_bytes(), anguilla_ipc::MAX_WAYPOINTS);
                if let Err(e) = &p {
                    tracing::warn!("ROS 2 path refused: {e}");
                }
                *kept.latest.lock().unwrap_or_else(|p| p.into_inner()) = Some(p);
            })
            .wait()
            .map_err(zenoh_err("ROS 2 path subscriber"))?,
    );
    to.tokens.push(token(id.token(
        entity,
        Kind::Subscription,
        &name,
        &msgs::PATH,
        &Qos::reliable(10),
    ))?);
    entity += 1;
    for (k, svc) in PATH_SERVICES.iter().enumerate() {
        let name = qualified(&qualified(namespace, node), svc);
        let on_call = on_call.clone();
        to.queryables.push(
            session
                .declare_queryable(id.data_key(&name, &msgs::TRIGGER))
                .complete(true)
                .callback(move |q| on_call(k, q))
                .wait()
                .map_err(zenoh_err("ROS 2 service"))?,
        );
        to.tokens.push(token(id.token(
            entity,
            Kind::Service,
            &name,
            &msgs::TRIGGER,
            &Qos::reliable(10),
        ))?);
        entity += 1;
    }
    Ok(entity)
}

/// The follow of a path service: a resume of the interrupted path of
/// `count` waypoints, or a new path of `count`, at full amplitude and
/// `frequency`.
pub(super) fn follow(resume: bool, count: u32, frequency: f64) -> Command {
    Command::Follow(Follow {
        swim: SwimParams {
            amplitude: 1.0,
            frequency,
            turn: 0.0,
            pitch: 0.0,
        },
        count,
        looped: false,
        from_here: false,
        resume,
    })
}

/// Loads `waypoints` one a request, each answered (within `timeout`)
/// before the next: the daemon keeps a few unanswered requests per
/// client (`MAX_REQUESTS_PER_CLIENT`), not a path's worth. Then sends
/// `follow`: its sequence number, or the first waypoint's refusal.
pub(super) fn load(
    client: &mut Client,
    waypoints: &[Waypoint],
    follow: Command,
    timeout: Duration,
) -> Result<Result<u32, String>, IpcError> {
    for w in waypoints {
        let r = client.request(Command::Waypoint(*w), timeout)?;
        if r.accepted == 0 {
            return Ok(Err(r.reason().to_string()));
        }
    }
    Ok(Ok(client.send(follow)?))
}

/// The keep-alive of the ROS 2 side's path: from an accepted follow until
/// the daemon shows the path no longer followed (after `grace`, its state
/// catching up).
#[derive(Debug, Default)]
pub(super) struct KeepAlive {
    since: Option<(Instant, Instant)>,
}

impl KeepAlive {
    /// A follow was accepted.
    pub(super) fn start(&mut self) {
        let now = Instant::now();
        self.since = Some((now, now));
    }

    /// Stops keeping alive.
    pub(super) fn stop(&mut self) {
        self.since = None;
    }

    /// Whether a keep-alive is due now, the daemon showing the path
    /// `followed` or not.
    pub(super) fn due(&mut self, followed: bool, grace: Duration) -> bool {
        let Some((started, kept)) = self.since else {
            return false;
        };
        let now = Instant::now();
        if !followed && now.duration_since(started) > grace {
            self.since = None;
            return false;
        }
        if now.duration_since(kept) < KEEP_ALIVE {
            return false;
        }
        self.since = Some((started, now));
        true
    }
}
