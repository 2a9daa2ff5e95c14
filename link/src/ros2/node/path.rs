//! Following a path from ROS 2 (docs/ros2.md, "Following a path"): the
//! `path` subscription (`nav_msgs/msg/Path`), `~/follow_path` and
//! `~/resume_path`, and the keep-alive while the ROS 2 side's path is
//! followed.

use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anguilla_ipc::vocabulary::Command;
use zenoh::Wait as _;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};

use super::{
    CALL_TIMEOUT, Call, Inbound, Ros2Node, Ros2Settings, SERVICES, answer, reply_err, service_name,
};
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
const KEEP_ALIVE: Duration = Duration::from_millis(200);

/// The last path received on `path`: its waypoints, or why it was
/// refused (written by Zenoh's threads).
#[derive(Default)]
pub(super) struct PathSlot {
    latest: Mutex<Option<Result<Vec<anguilla_ipc::Waypoint>, String>>>,
}

/// Declares the `path` subscription (kept in `path`) and the path services
/// (their calls queued on `tx`), with commands allowed; returns the next
/// entity number.
#[allow(clippy::too_many_arguments)]
pub(super) fn declare(
    session: &zenoh::Session,
    id: &NodeId,
    settings: &Ros2Settings,
    tx: &SyncSender<Inbound>,
    path: &Arc<PathSlot>,
    subscribers: &mut Vec<Subscriber<()>>,
    queryables: &mut Vec<Queryable<()>>,
    tokens: &mut Vec<LivelinessToken>,
    mut entity: u32,
) -> Result<u32, LinkError> {
    if !settings.allow_command {
        return Ok(entity);
    }
    let token = |key: String| {
        session
            .liveliness()
            .declare_token(key)
            .wait()
            .map_err(zenoh_err("ROS 2 liveliness token"))
    };
    let name = qualified(&settings.namespace, "path");
    let slot = path.clone();
    subscribers.push(
        session
            .declare_subscriber(id.data_key(&name, &msgs::PATH))
            .callback(move |sample| {
                let p =
                    msgs::path_waypoints(&sample.payload().to_bytes(), anguilla_ipc::MAX_WAYPOINTS);
                if let Err(e) = &p {
                    tracing::warn!("ROS 2 path refused: {e}");
                }
                *slot.latest.lock().unwrap_or_else(|p| p.into_inner()) = Some(p);
            })
            .wait()
            .map_err(zenoh_err("ROS 2 path subscriber"))?,
    );
    tokens.push(token(id.token(
        entity,
        Kind::Subscription,
        &name,
        &msgs::PATH,
        &Qos::reliable(10),
    ))?);
    entity += 1;
    for (k, svc) in PATH_SERVICES.iter().enumerate() {
        let name = service_name(&settings.namespace, &settings.node, svc);
        let tx = tx.clone();
        let i = SERVICES.len() + k;
        queryables.push(
            session
                .declare_queryable(id.data_key(&name, &msgs::TRIGGER))
                .complete(true)
                .callback(move |q| {
                    if let Err(TrySendError::Full(Inbound(_, q, _))) =
                        tx.try_send(Inbound(i, q, None))
                    {
                        reply_err(&q, "the link is busy: call dropped");
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
    Ok(entity)
}

impl Ros2Node {
    /// A path service's call (`k` its index in [`PATH_SERVICES`]): the
    /// waypoints and the follow sent, the call answered by the follow's
    /// reply (or the first waypoint refused). Loading waits for each
    /// waypoint's reply: a few control periods each.
    pub(super) fn path_call(&mut self, k: usize, q: Query) {
        use anguilla_ipc::{Follow, SwimParams};
        let attachment = q
            .attachment()
            .map(|a| a.to_bytes().into_owned())
            .unwrap_or_default();
        let call = Call {
            query: q,
            attachment,
            sent: Instant::now(),
            path: true,
        };
        let name = PATH_SERVICES[k];
        let resume = name == "resume_path";
        let waypoints = if resume {
            Vec::new()
        } else {
            match self
                .path
                .latest
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .clone()
            {
                Some(Ok(w)) => w,
                Some(Err(e)) => {
                    answer(
                        &call,
                        false,
                        &format!("~/{name}: the last path was refused: {e}"),
                    );
                    return;
                }
                None => {
                    answer(
                        &call,
                        false,
                        &format!("~/{name}: no path received on `path`"),
                    );
                    return;
                }
            }
        };
        let count = if resume {
            u32::from(self.guide.waypoints)
        } else {
            waypoints.len() as u32
        };
        let follow = Command::Follow(Follow {
            swim: SwimParams {
                amplitude: 1.0,
                frequency: self.settings.frequency,
                turn: 0.0,
                pitch: 0.0,
            },
            count,
            looped: false,
            from_here: false,
            resume,
        });
        // One waypoint a request, each answered before the next: the
        // daemon keeps a few unanswered requests per client
        // (`MAX_REQUESTS_PER_CLIENT`), not a path's worth; the first
        // refused ends the load and answers the call.
        let sent = self.client().and_then(|c| {
            for w in &waypoints {
                let r = c.request(Command::Waypoint(*w), CALL_TIMEOUT)?;
                if r.accepted == 0 {
                    return Ok(Err(r.reason().to_string()));
                }
            }
            Ok(Ok(c.send(follow)?))
        });
        match sent {
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

    /// While the ROS 2 side's path is followed, control is kept alive
    /// (the daemon's deadman would stop the swim otherwise); it ends when
    /// the daemon shows the path no longer followed.
    pub(super) fn keep_path_alive(&mut self) {
        let Some((started, kept)) = self.following else {
            return;
        };
        let now = Instant::now();
        let followed = self.guide.guide_state() == Some(anguilla_ipc::GuideState::Following);
        if !followed && now.duration_since(started) > CALL_TIMEOUT {
            self.following = None;
            return;
        }
        if now.duration_since(kept) >= KEEP_ALIVE {
            self.following = Some((started, now));
            if let Err(e) = self.client().and_then(|c| Ok(c.send(Command::KeepAlive)?)) {
                tracing::warn!("ROS 2 path keep-alive: {e}");
                self.client = None;
                self.following = None;
            }
        }
    }
}
