//! Answering a service call: the call waiting for the daemon's reply, and
//! its `Trigger` response with rmw_zenoh's attachment.

use std::time::{Instant, SystemTime, UNIX_EPOCH};

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
