//! The operator's side of the autopilot (docs/autopilot.md): which heading and depth
//! the operator wants held, moved by keys (steps) or sticks (rates), and
//! the [`Command::Hold`] that tells the daemon.
//!
//! Shared by the keyboard ([`crate::app::Intent`]) and the gamepad
//! ([`crate::joy::Joy`]). The tool always sends **absolute** targets: a
//! stick's rate is integrated here, so a tool that dies leaves a fixed
//! target, never a rate running.
//!
//! A hold belongs to a swim (the daemon ends it with the swim), so a hold
//! is sent only while the tool swims: toggled at rest it is *armed*, and
//! goes out right after the swim that starts next.
//!
//! ```
//! use anguilla_ipc::{Command, Hold, NavSnapshot};
//! use anguilla_teleop::hold::HoldIntent;
//!
//! let mut h = HoldIntent::default();
//! h.observe_nav(&NavSnapshot { sensor: 1, samples: 10, heading_deg: 358.0, ..Default::default() });
//! h.toggle_heading();
//! h.nudge_heading(5.0); // a left step: 358 + 5 wraps to 3
//! assert_eq!(h.update(true), Some(Command::Hold(Hold { heading: Some(3.0), depth: None })));
//! assert_eq!(h.update(true), None, "sent once");
//! ```

use anguilla_ipc::{Cause, Command, Hold, Mode, NavSnapshot, hold_bits};

/// Heading step of one key press while a heading is held (deg).
pub const HEADING_STEP: f64 = 5.0;
/// Depth step of one key press while a depth is held (m).
pub const DEPTH_STEP: f64 = 0.1;
/// Target heading rate at full stick while a heading is held (deg/s).
pub const HEADING_RATE: f64 = 30.0;
/// Target depth rate at full stick while a depth is held (m/s).
pub const DEPTH_RATE: f64 = 0.2;

pub use anguilla_ipc::wrap_heading;

/// Whether the snapshot carries an estimate: a sensor is configured and
/// has sent at least one sample.
pub fn has_estimate(nav: &NavSnapshot) -> bool {
    nav.sensor != 0 && nav.samples > 0
}

/// What the daemon holds now, by the snapshot's bits and targets.
pub fn held(nav: &NavSnapshot) -> Hold {
    Hold {
        heading: (nav.hold & hold_bits::HEADING != 0).then_some(nav.heading_target_deg as f64),
        depth: (nav.hold & hold_bits::DEPTH != 0).then_some(nav.depth_target_m as f64),
    }
}

/// The holds an operator wants, and what was last sent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HoldIntent {
    wanted: Hold,
    sent: Hold,
    nav: NavSnapshot,
}

impl HoldIntent {
    /// What the operator wants held.
    pub fn wanted(&self) -> Hold {
        self.wanted
    }

    /// The newest estimate seen.
    pub fn nav(&self) -> &NavSnapshot {
        &self.nav
    }

    /// Follows the daemon's estimate (targets are captured from it).
    pub fn observe_nav(&mut self, nav: &NavSnapshot) {
        self.nav = *nav;
    }

    /// Heading hold on (capturing the estimated heading) or off.
    pub fn toggle_heading(&mut self) {
        self.wanted.heading = match self.wanted.heading {
            Some(_) => None,
            None => Some(wrap_heading(self.nav.heading_deg as f64)),
        };
    }

    /// Depth hold on (capturing the estimated depth, at least 0) or off.
    pub fn toggle_depth(&mut self) {
        self.wanted.depth = match self.wanted.depth {
            Some(_) => None,
            None => Some(round_depth(self.nav.depth_m as f64)),
        };
    }

    /// Moves the held heading by `deg` (positive left), wrapping at 360;
    /// nothing when no heading is held.
    pub fn nudge_heading(&mut self, deg: f64) {
        if let Some(h) = &mut self.wanted.heading {
            *h = wrap_heading(*h + deg);
        }
    }

    /// Moves the held depth by `m` (positive deeper), never above the
    /// surface; nothing when no depth is held.
    pub fn nudge_depth(&mut self, m: f64) {
        if let Some(d) = &mut self.wanted.depth {
            *d = round_depth(*d + m);
        }
    }

    /// The hold to send now, if the tool swims and the daemon was not yet
    /// told what is wanted; it then counts as sent.
    pub fn update(&mut self, swimming: bool) -> Option<Command> {
        if !swimming || self.wanted == self.sent {
            return None;
        }
        self.sent = self.wanted;
        Some(Command::Hold(self.wanted))
    }

    /// The swim ended: the daemon ended its hold, and so does the tool.
    pub fn clear(&mut self) {
        self.wanted = Hold::MANUAL;
        self.sent = Hold::MANUAL;
    }

    /// The daemon refused a hold: it kept what it held, which the tool
    /// adopts (the snapshot's bits and targets).
    pub fn refused(&mut self) {
        self.wanted = held(&self.nav);
        self.sent = self.wanted;
    }
}

fn round_depth(m: f64) -> f64 {
    ((m * 1000.0).round() / 1000.0).max(0.0)
}

/// Whether the daemon ended the swim on its own, and with it any hold: a
/// mode without a swim, or a stop for the operator's silence or the
/// sensor's loss. `mode` and `cause` are the snapshot's codes.
pub fn swim_ended_by_daemon(mode: u8, cause: u8) -> bool {
    mode == Mode::Idle as u8
        || mode == Mode::Enabling as u8
        || mode == Mode::Fault as u8
        || mode == Mode::EStop as u8
        || (mode == Mode::Stopping as u8
            && matches!(
                Cause::from_code(cause),
                Some(Cause::OperatorSilent | Cause::SensorLost)
            ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nav(heading: f32, depth: f32) -> NavSnapshot {
        NavSnapshot {
            sensor: 1,
            samples: 100,
            heading_deg: heading,
            depth_m: depth,
            ..Default::default()
        }
    }

    fn sent(c: Option<Command>) -> Hold {
        match c {
            Some(Command::Hold(h)) => h,
            other => panic!("expected a hold, got {other:?}"),
        }
    }

    #[test]
    fn headings_wrap_both_ways_without_drift() {
        assert_eq!(wrap_heading(359.0 + 2.0), 1.0);
        assert_eq!(wrap_heading(1.0 - 2.0), 359.0);
        assert_eq!(wrap_heading(-720.0), 0.0);
        assert_eq!(wrap_heading(360.0), 0.0);
        assert_eq!(wrap_heading(-1e-12), 0.0, "not 360");
        let mut h = 0.0;
        for _ in 0..72 {
            h = wrap_heading(h + 5.0);
        }
        assert_eq!(h, 0.0, "72 steps of 5° come back to 0 exactly");
    }

    #[test]
    fn toggles_capture_the_estimate_and_steps_move_the_target() {
        let mut h = HoldIntent::default();
        h.observe_nav(&nav(358.4, 1.234));
        h.toggle_heading();
        h.toggle_depth();
        assert_eq!(h.wanted().heading, Some(wrap_heading(358.4f32 as f64)));
        assert_eq!(h.wanted().depth, Some(1.234));
        h.nudge_heading(HEADING_STEP);
        assert!((h.wanted().heading.unwrap() - 3.4).abs() < 1e-3);
        h.nudge_heading(-2.0 * HEADING_STEP);
        assert!((h.wanted().heading.unwrap() - 353.4).abs() < 1e-3);
        for _ in 0..20 {
            h.nudge_depth(-DEPTH_STEP);
        }
        assert_eq!(h.wanted().depth, Some(0.0), "never above the surface");
        h.nudge_depth(DEPTH_STEP);
        assert_eq!(h.wanted().depth, Some(0.1));
        h.toggle_heading();
        assert_eq!(h.wanted().heading, None);
        // Steps without a hold change nothing.
        h.nudge_heading(5.0);
        assert_eq!(h.wanted().heading, None);
        // A negative depth estimate (waves, a mis-set surface pressure)
        // captures the surface.
        let mut k = HoldIntent::default();
        k.observe_nav(&nav(0.0, -0.3));
        k.toggle_depth();
        assert_eq!(k.wanted().depth, Some(0.0));
    }

    #[test]
    fn holds_are_sent_once_and_only_while_swimming() {
        let mut h = HoldIntent::default();
        h.observe_nav(&nav(90.0, 2.0));
        h.toggle_heading();
        assert_eq!(h.update(false), None, "armed at rest");
        assert_eq!(
            sent(h.update(true)),
            Hold {
                heading: Some(90.0),
                depth: None
            }
        );
        assert_eq!(h.update(true), None);
        h.toggle_heading();
        assert_eq!(sent(h.update(true)), Hold::MANUAL, "off is sent too");
        h.toggle_depth();
        h.clear();
        assert_eq!(h.update(true), None, "a cleared hold sends nothing");
    }

    #[test]
    fn a_refusal_adopts_what_the_daemon_holds() {
        let mut h = HoldIntent::default();
        let mut n = nav(10.0, 3.0);
        n.hold = hold_bits::HEADING;
        n.heading_target_deg = 12.5;
        h.observe_nav(&n);
        h.toggle_depth();
        let _ = h.update(true);
        h.refused();
        assert_eq!(
            h.wanted(),
            Hold {
                heading: Some(12.5),
                depth: None
            }
        );
        assert_eq!(h.update(true), None);
    }

    #[test]
    fn the_daemon_ends_holds_with_the_swim() {
        let code = Cause::code;
        assert!(swim_ended_by_daemon(
            Mode::Stopping as u8,
            code(Cause::SensorLost)
        ));
        assert!(swim_ended_by_daemon(
            Mode::Stopping as u8,
            code(Cause::OperatorSilent)
        ));
        assert!(!swim_ended_by_daemon(
            Mode::Stopping as u8,
            code(Cause::Command)
        ));
        assert!(!swim_ended_by_daemon(Mode::Swimming as u8, 1));
        assert!(swim_ended_by_daemon(Mode::EStop as u8, 1));
    }
}
