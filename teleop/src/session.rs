//! The sessions of `anguilla teleop` and `anguilla monitor`, like
//! [`crate::pad::JoySession`] for `joy`: everything but the terminal. The
//! binary reads keys, draws the [`ViewModel`] a session gives and writes
//! the lines a [`JsonPacer`] lets through; the rest (the steady sender,
//! the provenance check, the status line, the plots' history, the pace of
//! `--json` lines) is here and tested without a terminal.

use std::time::{Duration, Instant};

use anguilla_ipc::{IpcError, StateSnapshot};

use crate::app::Action;
use crate::history::History;
use crate::operator::{Driver, Operator};
use crate::view::{Map, ViewModel};

/// How often a session checks that the state it shows comes from the
/// daemon that takes its commands.
pub const PROVENANCE_EVERY: Duration = Duration::from_secs(2);

/// The status line of `teleop`: a provenance warning first, else who holds
/// control.
pub fn teleop_status(prefix: &str, provenance: Option<&str>, holds_control: bool) -> String {
    match provenance {
        Some(p) => format!("WARNING: {p}"),
        None if holds_control => {
            format!("prefix '{prefix}' · you hold control: sending your command at 10 Hz")
        }
        None => format!("prefix '{prefix}' · watching: press t to take control"),
    }
}

/// The keyboard operator's session.
#[derive(Debug)]
pub struct TeleopSession {
    /// The driver: connection, intent, steady sender.
    pub driver: Driver,
    prefix: String,
    provenance: Option<String>,
    checked: Instant,
    status: String,
    map: Map,
}

impl TeleopSession {
    /// A session over `driver`, for the daemon at `prefix`.
    pub fn new(driver: Driver, prefix: &str) -> Self {
        let provenance = driver.op.provenance_problem();
        // The path as the daemon will be sent it (in the estimate's
        // frame); a path "here" is drawn once sent, from where it starts.
        let map = driver
            .path
            .as_ref()
            .and_then(|p| Some((p.placed(None).ok()?, p.looped)))
            .map_or_else(Map::default, |(w, looped)| {
                let pts: Vec<(f64, f64)> = w.iter().map(|w| (w.x, w.y)).collect();
                Map::with_path(&pts, looped)
            });
        let mut s = Self {
            driver,
            prefix: prefix.to_string(),
            provenance,
            checked: Instant::now(),
            status: String::new(),
            map,
        };
        s.refresh_status();
        s
    }

    fn refresh_status(&mut self) {
        self.status = teleop_status(
            &self.prefix,
            self.provenance.as_deref(),
            self.driver.op.holds_control(),
        );
    }

    /// Reads the daemon, sends what is due, re-checks provenance every
    /// [`PROVENANCE_EVERY`]; returns when the next send is due.
    pub fn pump(&mut self, now: Instant) -> Result<Instant, IpcError> {
        let next = self.driver.pump(now)?;
        if let Some(s) = self.driver.op.state() {
            self.map.update(s);
        }
        if now.saturating_duration_since(self.checked) >= PROVENANCE_EVERY {
            self.provenance = self.driver.op.provenance_problem();
            self.checked = now;
        }
        self.refresh_status();
        Ok(next)
    }

    /// Applies a key's action.
    pub fn act(&mut self, a: Action) -> Result<(), IpcError> {
        let r = self.driver.act(a).map(|_| ());
        if let Some((path, looped)) = self.driver.placed.take() {
            self.map.set_path(&path, looped);
        }
        r
    }

    /// What the view shows now.
    pub fn view(&self) -> ViewModel<'_> {
        ViewModel {
            title: "anguilla teleop",
            state: self.driver.op.state(),
            me: Some(self.driver.op.id()),
            intent: Some(&self.driver.intent),
            refused: self.driver.op.last_refused(),
            history: None,
            map: Some(&self.map),
            status: &self.status,
        }
    }
}

/// The read-only monitor's session: the state and the plots' history.
#[derive(Debug)]
pub struct MonitorSession {
    /// The connection (it never sends a command).
    pub op: Operator,
    window: f64,
    joint: Option<usize>,
    history: History,
    map: Map,
    started: bool,
    status: String,
}

impl MonitorSession {
    /// A monitor of the daemon at `prefix` over `op`, plotting `window`
    /// seconds of joint `joint` (0-based; the tail-most without one).
    pub fn new(op: Operator, prefix: &str, window: f64, joint: Option<usize>) -> Self {
        Self {
            op,
            window,
            joint,
            history: History::new(window, 0),
            map: Map::default(),
            started: false,
            status: format!("prefix '{prefix}' · read-only monitor · q quits"),
        }
    }

    /// Records a state in the plots; the first one fixes the joint plotted
    /// (clamped to the robot's joints).
    pub fn record(&mut self, s: &StateSnapshot) {
        if !self.started {
            let last = (s.joint_count as usize).max(1) - 1;
            self.history = History::new(self.window, self.joint.unwrap_or(last).min(last));
            self.started = true;
        }
        self.history.push(s);
        self.map.update(s);
    }

    /// Waits up to `timeout` for a new state and records it.
    pub fn poll(&mut self, timeout: Duration) -> Result<(), IpcError> {
        if let Some(s) = self.op.wait_state(timeout)?.copied() {
            self.record(&s);
        }
        Ok(())
    }

    /// The plots' history.
    pub fn history(&self) -> &History {
        &self.history
    }

    /// What the view shows now.
    pub fn view(&self) -> ViewModel<'_> {
        ViewModel {
            title: "anguilla monitor",
            state: self.op.state(),
            me: None,
            intent: None,
            refused: None,
            history: Some(&self.history),
            map: Some(&self.map),
            status: &self.status,
        }
    }
}

/// What `monitor --json` does with a state or a silence.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Paced {
    /// Print this line.
    Line(String),
    /// Nothing to print now.
    Skip,
    /// Tell the user (once) that no state arrives.
    Silent(String),
}

/// The pace of `monitor --json`: each state once (by its sequence number),
/// at most `rate` lines per second, a warning once after 2 s of silence.
#[derive(Debug)]
pub struct JsonPacer {
    prefix: String,
    min_gap: Option<Duration>,
    last_line: Option<Instant>,
    last_seq: Option<u64>,
    silent_since: Instant,
    warned: bool,
}

impl JsonPacer {
    /// A pacer for the daemon at `prefix`, at most `rate` lines per second.
    pub fn new(prefix: &str, rate: Option<f64>, now: Instant) -> Self {
        Self {
            prefix: prefix.to_string(),
            min_gap: rate.map(|r| Duration::from_secs_f64(1.0 / r)),
            last_line: None,
            last_seq: None,
            silent_since: now,
            warned: false,
        }
    }

    /// What to do with the newest state (`None`: none arrived) at `now`.
    pub fn offer(&mut self, s: Option<&StateSnapshot>, now: Instant) -> Paced {
        let Some(s) = s.filter(|s| Some(s.sequence) != self.last_seq) else {
            if !self.warned
                && now.saturating_duration_since(self.silent_since) > Duration::from_secs(2)
            {
                self.warned = true;
                return Paced::Silent(format!(
                    "no state from a daemon at prefix '{}' yet: is it running? (waiting)",
                    self.prefix
                ));
            }
            return Paced::Skip;
        };
        self.silent_since = now;
        if let (Some(gap), Some(t)) = (self.min_gap, self.last_line)
            && now.saturating_duration_since(t) < gap
        {
            return Paced::Skip;
        }
        self.last_seq = Some(s.sequence);
        self.last_line = Some(now);
        Paced::Line(crate::json::snapshot_json(s).to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(seq: u64) -> StateSnapshot {
        StateSnapshot {
            sequence: seq,
            ..StateSnapshot::default()
        }
    }

    #[test]
    fn json_lines_are_paced_once_each_and_silence_is_told_once() {
        let t0 = Instant::now();
        let ms = |n| t0 + Duration::from_millis(n);
        let mut p = JsonPacer::new("x", Some(10.0), t0);
        assert!(matches!(p.offer(Some(&state(1)), ms(0)), Paced::Line(_)));
        assert_eq!(p.offer(Some(&state(1)), ms(200)), Paced::Skip, "same state");
        assert_eq!(
            p.offer(Some(&state(2)), ms(50)),
            Paced::Skip,
            "10 Hz at most"
        );
        assert!(
            matches!(p.offer(Some(&state(3)), ms(150)), Paced::Line(l) if l.contains("\"sequence\":3"))
        );
        assert_eq!(p.offer(None, ms(2000)), Paced::Skip);
        assert!(matches!(p.offer(None, ms(2200)), Paced::Silent(w) if w.contains("prefix 'x'")));
        assert_eq!(p.offer(None, ms(5000)), Paced::Skip, "told once");
        let mut unpaced = JsonPacer::new("x", None, t0);
        for k in 1..5 {
            assert!(matches!(
                unpaced.offer(Some(&state(k)), ms(0)),
                Paced::Line(_)
            ));
        }
    }

    #[test]
    fn the_status_line_warns_first() {
        assert_eq!(
            teleop_status("p", Some("another daemon"), true),
            "WARNING: another daemon"
        );
        assert!(teleop_status("p", None, true).contains("you hold control"));
        assert!(teleop_status("p", None, false).contains("press t to take control"));
    }
}
