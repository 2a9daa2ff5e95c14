//! The loop's logger thread and the rate-limited log lines it and the
//! helpers write: refusals summed per interval, a helper's repeated
//! failure, the machine-overloaded notice, node error bits in words.

use std::time::Duration;

use anguilla_protocol::message::ErrorBits;
use crossbeam_channel::Receiver;

use anguilla_ipc::CommandReply;
use anguilla_ipc::vocabulary::{Cause, FaultSet, Mode};

/// What the loop tells the logger. `Copy`, so sending it never allocates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The mode changed.
    Mode {
        /// Previous mode.
        from: Mode,
        /// New mode.
        to: Mode,
        /// Why it changed.
        cause: Cause,
        /// The faults that put it in Fault or EStop (none otherwise: faults
        /// latched while limp do not explain a later change).
        faults: FaultSet,
    },
    /// A command was refused; the reply carries the reason.
    Refused {
        /// The client port it came on.
        origin: u128,
        /// The answer sent.
        reply: CommandReply,
    },
    /// The client holding control is gone, its control released.
    HolderGone {
        /// Its process was seen dead (else its node left the registry:
        /// the process ended, or died and was cleaned up by another).
        crashed: bool,
    },
    /// The bus changed state (a `BusSnapshot::state` code: 2 bus-off,
    /// 3 adapter gone, 0 back to normal).
    Bus {
        /// The new state's code.
        state: u8,
    },
    /// A drive's notice (configuration done or failed).
    Drive(crate::drive::Notice),
    /// The loop overran (periods skipped).
    Overrun {
        /// Periods skipped this time.
        skipped: u64,
    },
    /// A hold state, the surfacing or the position's health changed
    /// (`NavSnapshot::heading_hold`, `depth_hold`, `surfaced`,
    /// `position_health`): `was` the four before, `nav` now.
    Nav {
        /// Heading hold, depth hold, surfaced and position health codes
        /// before.
        was: [u8; 4],
        /// The snapshot's nav now.
        nav: anguilla_ipc::NavSnapshot,
    },
    /// The path's state or leg changed (`StateSnapshot::guide`): `was`
    /// before, `guide` now.
    Guide {
        /// Before.
        was: anguilla_ipc::GuideSnapshot,
        /// Now.
        guide: anguilla_ipc::GuideSnapshot,
    },
    /// Joints' drives report errors they did not report before (one event
    /// per code: twelve joints latching the same E-stop are one line).
    NodeErrors {
        /// The joints (bit 0 = the head end's).
        joints: u64,
        /// Its family's code (`JointSnapshot::node_errors`): anguilla error
        /// bits, a CiA 402 EMCY code or an ODrive axis error.
        code: u32,
        /// Whether `code` holds anguilla error bits.
        anguilla: bool,
    },
}

/// Refused commands are logged as one summary line per interval at most.
pub const REFUSAL_LOG_INTERVAL: Duration = Duration::from_secs(1);

/// A helper thread's repeated failure (publishing the state, taking
/// commands): every failure counted, logged at most once per
/// [`REFUSAL_LOG_INTERVAL`] for as long as it lasts, with the count since
/// the last line and how many of those were not logged; its end logged once,
/// when successes have lasted a whole interval with no failure between. A
/// success between failures resets nothing (a flood that fails every other
/// request once logged two lines per failure: 882 lines in 24 s).
#[derive(Debug, Default)]
pub struct ErrorLog {
    last_line: Option<std::time::Instant>,
    since_line: u64,
    total: u64,
    /// The first success since the last failure.
    ok_since: Option<std::time::Instant>,
}

impl ErrorLog {
    /// A failure at `now`: returns the line to log, if one is due.
    pub fn failed(
        &mut self,
        now: std::time::Instant,
        what: &str,
        e: &dyn std::fmt::Display,
    ) -> Option<String> {
        self.total += 1;
        self.since_line += 1;
        self.ok_since = None;
        match self.last_line {
            Some(t) if now.duration_since(t) < REFUSAL_LOG_INTERVAL => None,
            _ => {
                let n = core::mem::take(&mut self.since_line);
                self.last_line = Some(now);
                Some(if n > 1 {
                    format!(
                        "{what} failed {n} times since the last report ({} more suppressed): {e}",
                        n - 1
                    )
                } else {
                    format!("{what} failed: {e}")
                })
            }
        }
    }

    /// A success at `now`: returns the line that says the failures ended,
    /// once successes have lasted [`REFUSAL_LOG_INTERVAL`] without a
    /// failure (with the failures not yet reported).
    pub fn succeeded(&mut self, now: std::time::Instant, what: &str) -> Option<String> {
        if self.total == 0 {
            return None;
        }
        let since = *self.ok_since.get_or_insert(now);
        if now.duration_since(since) < REFUSAL_LOG_INTERVAL {
            return None;
        }
        let line = if self.since_line > 0 {
            format!(
                "{what} works again after {} failure(s) ({} suppressed since the last report)",
                self.total, self.since_line
            )
        } else {
            format!("{what} works again after {} failure(s)", self.total)
        };
        *self = Self::default();
        Some(line)
    }
}

/// Sums up refusals: the first of an interval is logged whole, the rest
/// are counted and reported in one line when the interval ends.
#[derive(Debug, Default)]
struct RefusalLog {
    since: Option<std::time::Instant>,
    suppressed: u64,
    latest: Option<(u128, CommandReply)>,
}

impl RefusalLog {
    fn refused(&mut self, now: std::time::Instant, origin: u128, reply: CommandReply) {
        match self.since {
            Some(t) if now.duration_since(t) < REFUSAL_LOG_INTERVAL => {
                self.suppressed += 1;
                self.latest = Some((origin, reply));
            }
            _ => {
                self.flush(now);
                self.since = Some(now);
                tracing::info!(
                    "refused command {} from client {origin:032x}: {}",
                    reply.sequence,
                    reply.reason()
                );
            }
        }
    }

    fn flush(&mut self, now: std::time::Instant) {
        if self.suppressed > 0
            && let Some((origin, reply)) = self.latest
        {
            tracing::info!(
                "refused {} more command(s) in {:.1} s; latest from client {origin:032x}: {}",
                self.suppressed,
                self.since
                    .map_or(0.0, |t| now.duration_since(t).as_secs_f64()),
                reply.reason()
            );
        }
        self.suppressed = 0;
        self.latest = None;
        self.since = None;
    }

    fn due(&self, now: std::time::Instant) -> bool {
        self.since
            .is_some_and(|t| now.duration_since(t) >= REFUSAL_LOG_INTERVAL)
    }
}

/// "joint 3", "joints 1–12", "joints 2, 5": 1-based, runs as ranges.
fn joint_list(joints: u64) -> String {
    let ids: Vec<u32> = (0..64)
        .filter(|j| joints & (1 << j) != 0)
        .map(|j| j + 1)
        .collect();
    let mut runs: Vec<String> = Vec::new();
    let mut i = 0;
    while i < ids.len() {
        let mut k = i;
        while k + 1 < ids.len() && ids[k + 1] == ids[k] + 1 {
            k += 1;
        }
        runs.push(match k - i {
            0 => ids[i].to_string(),
            1 => format!("{}, {}", ids[i], ids[k]),
            _ => format!("{}–{}", ids[i], ids[k]),
        });
        i = k + 1;
    }
    let plural = if ids.len() == 1 { "joint" } else { "joints" };
    format!("{plural} {}", runs.join(", "))
}

fn report(joints: u64) -> &'static str {
    if joints.count_ones() == 1 {
        "reports"
    } else {
        "report"
    }
}

/// Overruns, told to the operator as an overloaded machine: the first at
/// once, with what to do; then a count every [`OVERLOAD_LOG_INTERVAL`]
/// while they last.
#[derive(Debug, Default)]
struct OverloadLog {
    /// When the last line was logged.
    last_line: Option<std::time::Instant>,
    /// Periods missed since then.
    missed: u64,
    /// Overruns since then.
    overruns: u64,
}

impl OverloadLog {
    /// An overrun that skipped `skipped` periods at `now`: the line to
    /// log, if one is due.
    fn overran(&mut self, now: std::time::Instant, skipped: u64) -> Option<String> {
        self.missed += skipped;
        self.overruns += 1;
        if self.last_line.is_none() {
            self.last_line = Some(now);
            (self.missed, self.overruns) = (0, 0);
            Some(format!(
                "machine overloaded: the control loop missed {skipped} period(s); \
                 other work is taking its CPU (on a robot, give the loop a core and \
                 a real-time priority: [realtime] cpu, fifo-priority)"
            ))
        } else {
            self.tick(now)
        }
    }

    /// Time passing: the summary line, if one is due.
    fn tick(&mut self, now: std::time::Instant) -> Option<String> {
        let t = self.last_line?;
        if now.duration_since(t) < OVERLOAD_LOG_INTERVAL {
            return None;
        }
        let line = (self.overruns > 0).then(|| {
            format!(
                "machine overloaded: the control loop missed {} period(s) in {} overrun(s) \
                 in the last {:.0} s",
                self.missed,
                self.overruns,
                now.duration_since(t).as_secs_f64()
            )
        });
        // A quiet interval makes the next overrun news again.
        self.last_line = line.is_some().then_some(now);
        (self.missed, self.overruns) = (0, 0);
        line
    }
}

/// How often an overloaded machine is reported while it lasts.
pub const OVERLOAD_LOG_INTERVAL: Duration = Duration::from_secs(5);

pub(super) fn logger(rx: Receiver<Event>, bus_spec: String) {
    let mut refusals = RefusalLog::default();
    let mut overload = OverloadLog::default();
    loop {
        let ev = match rx.recv_timeout(REFUSAL_LOG_INTERVAL / 4) {
            Ok(ev) => Some(ev),
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => None,
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
        };
        let now = std::time::Instant::now();
        if refusals.due(now) {
            refusals.flush(now);
        }
        if let Some(line) = overload.tick(now) {
            tracing::warn!("{line}");
        }
        match ev {
            None => {}
            Some(Event::Mode {
                from,
                to,
                cause,
                faults,
            }) if faults.is_empty() => {
                tracing::info!("mode {from} -> {to}: {}", cause.words())
            }
            Some(Event::Mode {
                from,
                to,
                cause,
                faults,
            }) => tracing::warn!("mode {from} -> {to}: {} ({faults})", cause.words()),
            Some(Event::Refused { origin, reply }) => refusals.refused(now, origin, reply),
            Some(Event::HolderGone { crashed: true }) => {
                tracing::warn!("the client holding control died; control released")
            }
            Some(Event::HolderGone { crashed: false }) => tracing::warn!(
                "the client holding control left without releasing it; control released"
            ),
            Some(Event::Bus { state: 3 }) => tracing::error!(
                "adapter gone: {bus_spec}; nothing is sent until it is back (reconnecting)"
            ),
            Some(Event::Bus { state }) => {
                tracing::warn!("bus {bus_spec}: {}", anguilla_ipc::bus_state_name(state))
            }
            Some(Event::Overrun { skipped }) => {
                if let Some(line) = overload.overran(now, skipped) {
                    tracing::warn!("{line}")
                }
            }
            Some(Event::NodeErrors {
                joints,
                code,
                anguilla: true,
            }) => tracing::warn!(
                "{} {}: {}",
                joint_list(joints),
                report(joints),
                ErrorBits(code as u16)
            ),
            Some(Event::NodeErrors { joints, code, .. }) => tracing::warn!(
                "{} {} error code {code:#010x} (docs/drives.md)",
                joint_list(joints),
                report(joints)
            ),
            Some(Event::Drive(n @ crate::drive::Notice::Configured { .. })) => {
                tracing::info!("{n}")
            }
            Some(Event::Drive(n @ crate::drive::Notice::SaturatedReply { .. })) => {
                tracing::warn!("{n}")
            }
            Some(Event::Drive(n)) => tracing::error!("{n}"),
            Some(Event::Guide { was, guide }) => match anguilla_view::guide_line(&guide, &was) {
                Some((level, line)) if level >= 4 => tracing::error!("{line}"),
                Some((level, line)) if level >= 3 => tracing::warn!("{line}"),
                Some((_, line)) => tracing::info!("{line}"),
                None => {}
            },
            Some(Event::Nav { was, nav }) => {
                let holds = [
                    (nav.heading_hold, was[0], nav.heading_words()),
                    (nav.depth_hold, was[1], nav.depth_words()),
                ];
                let lines = holds
                    .into_iter()
                    .filter_map(|(now, was, words)| anguilla_view::hold_line(now, was, words))
                    .chain(
                        (nav.surfaced != was[2])
                            .then(|| anguilla_view::surface_line(nav.surfaced != 0, nav.depth_m)),
                    )
                    .chain({
                        let before = anguilla_ipc::NavSnapshot {
                            position_health: was[3],
                            ..nav
                        };
                        anguilla_view::position_line(&nav, &before)
                    });
                for (level, line) in lines {
                    if level >= 4 {
                        tracing::error!("{line}")
                    } else if level >= 3 {
                        tracing::warn!("{line}")
                    } else {
                        tracing::info!("{line}")
                    }
                }
            }
        }
    }
    refusals.flush(std::time::Instant::now());
}

#[cfg(test)]
mod tests {
    /// The first overrun is told at once with what to do, the next ones
    /// counted every 5 s while they last; after a quiet interval an
    /// overrun is news again.
    #[test]
    fn an_overloaded_machine_is_told_once_then_counted() {
        let t0 = std::time::Instant::now();
        let s = |secs: f64| t0 + std::time::Duration::from_secs_f64(secs);
        let mut log = super::OverloadLog::default();
        let first = log.overran(s(0.0), 3).expect("the first is told");
        assert!(
            first.starts_with("machine overloaded: the control loop missed 3 period(s)"),
            "{first}"
        );
        assert!(first.contains("[realtime] cpu, fifo-priority"), "{first}");
        assert_eq!(log.overran(s(1.0), 2), None);
        assert_eq!(log.overran(s(2.0), 4), None);
        assert_eq!(log.tick(s(4.0)), None);
        let summary = log.tick(s(5.5)).expect("a summary after 5 s");
        assert_eq!(
            summary,
            "machine overloaded: the control loop missed 6 period(s) in 2 overrun(s) in the last 6 s"
        );
        // Quiet for 5 s: nothing, and the next overrun is news.
        assert_eq!(log.tick(s(11.0)), None);
        let again = log.overran(s(12.0), 1).expect("news again");
        assert!(again.contains("other work is taking its CPU"), "{again}");
    }

    #[test]
    fn joints_are_listed_as_ranges() {
        assert_eq!(super::joint_list(1 << 2), "joint 3");
        assert_eq!(super::joint_list((1 << 12) - 1), "joints 1–12");
        assert_eq!(super::joint_list(0b1_0010), "joints 2, 5");
        assert_eq!(super::joint_list(0b1110_0011), "joints 1, 2, 6–8");
        assert_eq!(super::report(1 << 4), "reports");
    }

    use super::*;

    /// A failure must be heard for as long as it lasts (the command thread
    /// once logged its first error and then nothing for ever): a failure that lasts is reported once
    /// a second with its count, and its end once.
    #[test]
    fn a_lasting_failure_is_reported_once_a_second_with_its_count() {
        let t0 = std::time::Instant::now();
        let mut log = ErrorLog::default();
        let mut lines = Vec::new();
        // A failure every 100 ms for 2.5 s.
        for i in 0..25u64 {
            let now = t0 + Duration::from_millis(100 * i);
            lines.extend(log.failed(now, "taking operator commands", &"closed"));
        }
        assert_eq!(
            lines,
            [
                "taking operator commands failed: closed",
                "taking operator commands failed 10 times since the last report (9 more \
                 suppressed): closed",
                "taking operator commands failed 10 times since the last report (9 more \
                 suppressed): closed",
            ]
        );
        // The end is told once successes have lasted a whole interval.
        let t1 = t0 + Duration::from_millis(2500);
        assert_eq!(log.succeeded(t1, "taking operator commands"), None);
        assert_eq!(
            log.succeeded(t1 + REFUSAL_LOG_INTERVAL, "taking operator commands")
                .as_deref(),
            Some(
                "taking operator commands works again after 25 failure(s) (4 suppressed since \
                 the last report)"
            )
        );
        assert_eq!(log.succeeded(t1 + REFUSAL_LOG_INTERVAL, "x"), None);
        // A new failure after the recovery is logged at once.
        assert!(log.failed(t1, "x", &"again").is_some());
    }

    /// Issue 45's flood: a request that fails every other time for 24 s
    /// (a failure, then a success, every 10 ms). One success used to
    /// reset the throttle: two lines per failure. Now a line a second at
    /// most, every failure counted in them, and the end told once.
    #[test]
    fn alternating_failures_and_successes_are_throttled_and_counted() {
        let t0 = std::time::Instant::now();
        let mut log = ErrorLog::default();
        let mut lines = Vec::new();
        let what = "taking operator commands";
        for i in 0..2400u64 {
            let now = t0 + Duration::from_millis(10 * i);
            let line = if i % 2 == 0 {
                log.failed(now, what, &"closed")
            } else {
                log.succeeded(now, what)
            };
            lines.extend(line);
        }
        // The flood over, successes only, for a second and more.
        for i in 0..=110u64 {
            lines.extend(log.succeeded(t0 + Duration::from_millis(24_000 + 10 * i), what));
        }
        // One line a second of the 24 (the first at once), and the end.
        assert!(lines.len() <= 26, "{} lines: {lines:#?}", lines.len());
        assert!(
            lines
                .last()
                .unwrap()
                .contains("works again after 1200 failure(s)")
        );
        // Every failure is in a line: the counts add up to 1200.
        let counted: u64 = lines
            .iter()
            .map(|l| {
                if l.contains(" failed: ") {
                    1
                } else if let Some(rest) = l.split(" failed ").nth(1) {
                    rest.split(' ')
                        .next()
                        .and_then(|n| n.parse().ok())
                        .unwrap_or(1)
                } else if let Some(rest) = l.split("failure(s) (").nth(1) {
                    rest.split(' ')
                        .next()
                        .and_then(|n| n.parse().ok())
                        .unwrap_or(0)
                } else {
                    0
                }
            })
            .sum();
        assert_eq!(counted, 1200, "{lines:#?}");
    }
}
