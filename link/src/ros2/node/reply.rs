//! Answering a service call: the call waiting for the daemon's reply, and
//! its `Trigger` response with rmw_zenoh's attachment.

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anguilla_ipc::vocabulary::Mode;

use zenoh::Wait as _;
use zenoh::query::Query;

use crate::ros2::graph::{attachment, read_attachment};
use crate::ros2::msgs;

/// A service call waiting for the daemon's reply.
pub(super) struct Call {
    pub(super) query: Query,
    pub(super) attachment: Vec<u8>,
    pub(super) sent: Instant,
    /// A path service's: its success starts the keep-alive.
    pub(super) path: bool,
}

impl Call {
    /// The call of `query`, now (`path`: a path service's).
    pub(super) fn of(query: Query, path: bool) -> Self {
        let attachment = query
            .attachment()
            .map(|a| a.to_bytes().into_owned())
            .unwrap_or_default();
        Self {
            query,
            attachment,
            sent: Instant::now(),
            path,
        }
    }
}

/// The wall clock (ns since the epoch): ROS 2 stamps.
pub(super) fn wall_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// Answers a service call: a `Trigger` response, with rmw_zenoh's
/// attachment (the request's sequence number and GID, which the caller
/// matches the reply by).
pub(super) fn answer(call: &Call, success: bool, message: &str) {
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

pub(super) fn reply_err(q: &Query, text: &str) {
    if let Err(e) = q.reply_err(text.to_string()).wait() {
        tracing::debug!("ROS 2 service error reply: {e}");
    }
}

/// An `~/estop` call waiting for the state to say e-stop.
pub(super) struct EStopCall {
    pub(super) call: Call,
    /// What was relayed, and how: for the answer.
    pub(super) relayed: String,
}

/// Answers the `~/estop` calls, the state showing `mode`: success once it
/// says e-stop; a failure naming what was relayed when it has not within
/// `timeout`.
pub(super) fn answer_estops(estops: &mut Vec<EStopCall>, mode: Option<u8>, timeout: Duration) {
    let stopped = mode == Some(Mode::EStop as u8);
    estops.retain(|e| {
        if stopped {
            answer(
                &e.call,
                true,
                &format!("e-stopped: the robot's state says e-stop ({})", e.relayed),
            );
            return false;
        }
        if e.call.sent.elapsed() < timeout {
            return true;
        }
        let shown = mode
            .and_then(Mode::from_code)
            .map_or("none read", Mode::name);
        answer(
            &e.call,
            false,
            &format!(
                "NOT confirmed: {}, but the robot's state does not say e-stop after {:?} \
                 (mode {shown})",
                e.relayed, timeout
            ),
        );
        false
    });
}
