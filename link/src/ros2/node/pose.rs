//! Position fixes from ROS 2 (docs/ros2.md, "Position fixes"): a tank's
//! motion capture (`mocap4r2`, `vrpn_mocap`) or any localisation publishes
//! `pose_fix` (`geometry_msgs/msg/PoseStamped`) or `odom_fix`
//! (`nav_msgs/msg/Odometry`); the node hands the newest to the daemon's
//! `[sensor.usbl]` as a `$ANFIX` sentence
//! ([`anguilla_protocol::position_fix`]) over UDP, with its age from the
//! message's stamp, so the estimate takes it at the time it was measured.
//!
//! Latest wins: the node's loop sends at most one fix a turn, the newest
//! (a 200 Hz motion capture is not queued behind itself). A message that
//! is not a fix (another frame, not finite, not its type's CDR) is
//! refused and counted, the first said on the log; a fix older
//! than [`MAX_AGE`] is stale and dropped; a stamp ahead of the wall clock
//! (the clocks disagree) is sent without an age and counted.

use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::Ordering;

use anguilla_protocol::position_fix::{Fix, MAX_AGE};
use zenoh::Wait as _;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;

use super::latest::Latest;
use crate::ros2::graph::{Kind, NodeId, Qos, qualified};
use crate::ros2::msgs::{self, MsgType, PoseFix};
use crate::{LinkError, zenoh_err};

/// The fix topics and their types, under the node's namespace.
pub const POSE_TOPICS: [(&str, MsgType); 2] = [
    ("pose_fix", msgs::POSE_STAMPED),
    ("odom_fix", msgs::ODOMETRY),
];

/// A stamp this far ahead of the wall clock (s) says the clocks disagree.
const AHEAD: f64 = 0.5;

/// Where and how the node hands fixes to the daemon (`[link] ros2-pose`).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSettings {
    /// The daemon's `[sensor.usbl]` source, as a sender reaches it.
    pub to: SocketAddr,
    /// The frame the messages must name.
    pub frame: String,
    /// σ (m) for a message that gives none.
    pub sigma: f64,
}

/// What the fix input has done.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct PoseStats {
    /// Fixes sent to the daemon.
    pub sent: u64,
    /// Messages refused (another frame, not finite, not CDR).
    pub refused: u64,
    /// Fixes replaced by a newer one before they were sent.
    pub superseded: u64,
    /// Fixes older than [`MAX_AGE`], dropped.
    pub stale: u64,
    /// Fixes stamped ahead of the wall clock, sent without an age.
    pub ahead: u64,
    /// Sends that failed (the socket's error said on the log).
    pub failed: u64,
}

/// The fix input: its subscriptions' slot and the socket to the daemon.
pub(super) struct PoseInput {
    settings: PoseSettings,
    slot: Arc<Latest<PoseFix>>,
    socket: UdpSocket,
    stats: PoseStats,
}

impl PoseInput {
    /// Declares `pose_fix` and `odom_fix` under `namespace` (tokens from
    /// `entity` on, into `subscribers` and `tokens`) and opens the socket
    /// to the daemon; returns the input and the next entity number.
    pub(super) fn declare(
        session: &zenoh::Session,
        id: &NodeId,
        namespace: &str,
        settings: PoseSettings,
        (subscribers, tokens): (&mut Vec<Subscriber<()>>, &mut Vec<LivelinessToken>),
        mut entity: u32,
    ) -> Result<(Self, u32), LinkError> {
        let bind: SocketAddr = if settings.to.is_ipv4() {
            ([127, 0, 0, 1], 0).into()
        } else {
            (std::net::Ipv6Addr::LOCALHOST, 0).into()
        };
        let socket = UdpSocket::bind(bind).map_err(|e| {
            LinkError::Socket(format!("ROS 2 position fixes: a UDP socket on {bind}: {e}"))
        })?;
        socket.set_nonblocking(true).map_err(|e| {
            LinkError::Socket(format!("ROS 2 position fixes: a non-blocking socket: {e}"))
        })?;
        let slot = Arc::new(Latest::default());
        for (topic, ty) in POSE_TOPICS {
            let name = qualified(namespace, topic);
            let (kept, frame) = (slot.clone(), settings.frame.clone());
            let odometry = ty == msgs::ODOMETRY;
            subscribers.push(
                session
                    .declare_subscriber(id.data_key(&name, &ty))
                    .callback(move |sample| {
                        match msgs::pose_fix(&sample.payload().to_bytes(), odometry, &frame) {
                            Ok(f) => kept.put(f),
                            Err(e) => {
                                // The first is said; all counted.
                                if kept.refuse() {
                                    tracing::warn!("ROS 2 {topic} refused: {e}");
                                }
                            }
                        }
                    })
                    .wait()
                    .map_err(zenoh_err("ROS 2 position-fix subscriber"))?,
            );
            tokens.push(
                session
                    .liveliness()
                    .declare_token(id.token(
                        entity,
                        Kind::Subscription,
                        &name,
                        &ty,
                        &Qos::reliable(10),
                    ))
                    .wait()
                    .map_err(zenoh_err("ROS 2 liveliness token"))?,
            );
            entity += 1;
        }
        Ok((
            Self {
                settings,
                slot,
                socket,
                stats: PoseStats::default(),
            },
            entity,
        ))
    }

    /// Sends the newest fix, if one came, aged at `wall_ns` (the wall
    /// clock, as the messages' stamps).
    pub(super) fn forward(&mut self, wall_ns: u64) {
        let Some(f) = self.slot.take() else {
            return;
        };
        let Some(fix) = self.fix(f, wall_ns) else {
            return;
        };
        match self
            .socket
            .send_to(fix.sentence().as_bytes(), self.settings.to)
        {
            Ok(_) => self.stats.sent += 1,
            Err(e) => {
                if self.stats.failed == 0 {
                    tracing::warn!(
                        "ROS 2 position fixes: sending to the daemon's [sensor.usbl] at {}: {e}",
                        self.settings.to
                    );
                }
                self.stats.failed += 1;
            }
        }
    }

    /// `f` as the daemon's sentence at `wall_ns`, or none when stale.
    fn fix(&mut self, f: PoseFix, wall_ns: u64) -> Option<Fix> {
        let age = if f.stamp_ns == 0 {
            0.0
        } else if wall_ns >= f.stamp_ns {
            (wall_ns - f.stamp_ns) as f64 * 1e-9
        } else {
            if (f.stamp_ns - wall_ns) as f64 * 1e-9 > AHEAD {
                if self.stats.ahead == 0 {
                    tracing::warn!(
                        "ROS 2 position fixes: a stamp {:.3} s ahead of this machine's clock \
                         (are the clocks synchronised?): sent without its age",
                        (f.stamp_ns - wall_ns) as f64 * 1e-9
                    );
                }
                self.stats.ahead += 1;
            }
            0.0
        };
        if age > MAX_AGE {
            self.stats.stale += 1;
            return None;
        }
        Some(Fix {
            x: f.x,
            y: f.y,
            sigma: f.sigma.unwrap_or(self.settings.sigma),
            age,
        })
    }

    /// What it has done.
    pub(super) fn stats(&self) -> PoseStats {
        PoseStats {
            refused: self.slot.refused.load(Ordering::Relaxed),
            superseded: self.slot.superseded.load(Ordering::Relaxed),
            ..self.stats
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_protocol::position_fix::parse;

    fn input(to: SocketAddr) -> PoseInput {
        PoseInput {
            settings: PoseSettings {
                to,
                frame: "odom".into(),
                sigma: 0.01,
            },
            slot: Arc::new(Latest::default()),
            socket: UdpSocket::bind("127.0.0.1:0").expect("a socket"),
            stats: PoseStats::default(),
        }
    }

    /// The newest fix goes out as a `$ANFIX` aged by its stamp (σ the
    /// configured one when the message gave none); an older one it
    /// replaced is counted, not sent; a stale fix is dropped and a stamp
    /// ahead of the clock is sent without an age, each counted.
    #[test]
    fn the_newest_fix_is_sent_aged_by_its_stamp() {
        let daemon = UdpSocket::bind("127.0.0.1:0").expect("the daemon's side");
        daemon
            .set_read_timeout(Some(std::time::Duration::from_secs(10)))
            .expect("a timeout");
        let mut p = input(daemon.local_addr().expect("its address"));
        let now = 1_700_000_000_000_000_000u64;
        let at = |x: f64, stamp_ns: u64, sigma: Option<f64>| PoseFix {
            stamp_ns,
            x,
            y: -x,
            sigma,
        };
        p.slot.put(at(1.0, now - 300_000_000, None));
        p.slot.put(at(2.0, now - 50_000_000, None));
        p.forward(now);
        p.forward(now);
        let mut buf = [0u8; 128];
        let n = daemon.recv(&mut buf).expect("a fix");
        let f = parse(&buf[..n]).expect("a $ANFIX");
        assert_eq!((f.x, f.y, f.sigma), (2.0, -2.0, 0.01));
        assert!((f.age - 0.05).abs() < 1e-9, "{f:?}");
        p.slot.put(at(3.0, now - 61_000_000_000, Some(0.5)));
        p.forward(now);
        p.slot.put(at(4.0, now + 2_000_000_000, Some(0.5)));
        p.forward(now);
        let n = daemon.recv(&mut buf).expect("a fix");
        let f = parse(&buf[..n]).expect("a $ANFIX");
        assert_eq!((f.x, f.sigma, f.age), (4.0, 0.5, 0.0));
        let s = p.stats();
        assert_eq!(
            (s.sent, s.superseded, s.stale, s.ahead, s.failed),
            (2, 1, 1, 1, 0),
            "{s:?}"
        );
    }
}
