//! `anguilla ctl`: the scriptable operator, and the reference client.
//!
//! Each call is one client session (one iceoryx2 client port, so one
//! identity for the daemon). A command that needs control takes it, waits
//! until the daemon reports the outcome, and releases it; a swim is kept
//! alive by resending it within the daemon's command timeout. The outcome
//! is a [`CtlError`] whose [`CtlError::exit_code`] scripts test:
//! 0 done, 1 refused (the daemon's reason), 2 no daemon reachable.
//!
//! ```no_run
//! use anguilla_teleop::ctl::{Ctl, Outcome};
//! use std::time::Duration;
//! let mut ctl = Ctl::connect("anguilla")?;
//! ctl.enable()?;                      // takes control, waits for Ready, releases
//! let swim = anguilla_ipc::SwimParams { amplitude: 0.5, frequency: 1.0, turn: 0.0, pitch: 0.0 };
//! ctl.swim(swim, Some(Duration::from_secs(3)), &|| false)?;
//! # Ok::<(), anguilla_teleop::ctl::CtlError>(())
//! ```

use std::time::{Duration, Instant};

use anguilla_ipc::{
    Cause, Client, Command, CommandReply, FaultSet, Hold, IpcError, Mode, Session, StateSnapshot,
    SwimParams,
};

/// How long `ctl` waits for the daemon's first state, and for each reply.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(2);
/// How long `ctl` waits for an outcome (Ready after enable, stop, ...).
pub const OUTCOME_TIMEOUT: Duration = Duration::from_secs(15);

/// Why a `ctl` call did not do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum CtlError {
    /// The daemon refused, or the outcome was not the one asked for.
    #[error("{0}")]
    Refused(String),
    /// No daemon could be reached.
    #[error("{0}")]
    NoDaemon(String),
}

impl CtlError {
    /// The process exit status: 1 refused, 2 no daemon reachable.
    pub fn exit_code(&self) -> i32 {
        match self {
            CtlError::Refused(_) => 1,
            CtlError::NoDaemon(_) => 2,
        }
    }
}

impl From<IpcError> for CtlError {
    fn from(e: IpcError) -> Self {
        CtlError::NoDaemon(e.to_string())
    }
}

/// The hold of `ctl swim --heading DEG --depth M`, checked: a heading is
/// any finite number of degrees (taken modulo 360, counter-clockwise seen
/// from above), a depth a finite number of metres at or below the surface.
/// The daemon checks the depth against its `max-depth`.
pub fn hold_from_args(heading: Option<f64>, depth: Option<f64>) -> Result<Hold, CtlError> {
    let shown = |v: f64| {
        if v.abs() >= 1e6 {
            format!("{v:e}")
        } else {
            format!("{v}")
        }
    };
    if let Some(h) = heading
        && !h.is_finite()
    {
        return Err(CtlError::Refused(format!(
            "--heading {} is invalid (expected degrees, a finite number: 0 ..< 360, \
             counter-clockwise seen from above; others are taken modulo 360)",
            shown(h)
        )));
    }
    if let Some(d) = depth
        && !(d.is_finite() && d >= 0.0)
    {
        return Err(CtlError::Refused(format!(
            "--depth {} is invalid (expected metres below the surface, a finite number >= 0, \
             at most the daemon's [autopilot] max-depth)",
            shown(d)
        )));
    }
    Ok(Hold {
        heading: heading.map(crate::hold::wrap_heading),
        depth,
    })
}

/// What a successful call reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// The mode the daemon reported at the end.
    pub mode: Mode,
}

/// How an E-stop went out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EStopReport {
    /// Sent on the out-of-band path ([`EStopReport::path`]).
    pub socket: bool,
    /// The out-of-band path's name: the E-stop socket, or the link's key.
    pub path: String,
    /// Accepted as a command too.
    pub command: bool,
    /// The daemon's state showed E-stop afterwards (`None`: state not readable).
    pub confirmed: Option<bool>,
    /// What failed along the way (informational when the E-stop went out).
    pub notes: Vec<String>,
}

/// Sends an E-stop to the daemon at `prefix` by every path there is: the
/// reserved socket first (nothing can block it), then the command service,
/// and confirms it in the state when the state can be read. Fails only when
/// no path reached the daemon.
pub fn estop(prefix: &str) -> Result<EStopReport, CtlError> {
    estop_by(
        &format!("prefix '{prefix}'"),
        "the e-stop socket",
        || anguilla_ipc::estop::send(prefix).map_err(|e| e.to_string()),
        || {
            Client::new(prefix, &format!("anguilla-ctl-{}", std::process::id()))
                .map(|c| Box::new(c) as Box<dyn Session>)
        },
    )
}

/// [`estop`] by any pair of paths: `out_of_band` (named `path`), which no
/// capacity limit blocks, first; then a session opened with `open`, whose
/// E-stop command is accepted from any client and whose state confirms it.
/// `target` names the daemon in messages.
pub fn estop_by(
    target: &str,
    path: &str,
    out_of_band: impl FnOnce() -> Result<(), String>,
    open: impl FnOnce() -> Result<Box<dyn Session>, IpcError>,
) -> Result<EStopReport, CtlError> {
    let mut report = EStopReport {
        socket: false,
        path: path.to_string(),
        command: false,
        confirmed: None,
        notes: Vec::new(),
    };
    match out_of_band() {
        Ok(()) => report.socket = true,
        Err(e) => report.notes.push(format!("{path}: {e}")),
    }
    match open() {
        Ok(mut c) => {
            match c.request(Command::EStop, REPLY_TIMEOUT) {
                Ok(r) if r.accepted == 1 => report.command = true,
                Ok(r) => report
                    .notes
                    .push(format!("e-stop command refused: {}", r.reason())),
                Err(e) => report.notes.push(format!("e-stop command: {e}")),
            }
            let deadline = Instant::now() + REPLY_TIMEOUT;
            while Instant::now() < deadline {
                if let Ok(Some(s)) = c.wait_state(Duration::from_millis(50))
                    && s.mode == Mode::EStop as u8
                {
                    report.confirmed = Some(true);
                    break;
                }
                report.confirmed = Some(false);
            }
        }
        Err(e) => report.notes.push(format!("operator interface: {e}")),
    }
    if report.confirmed == Some(false) {
        // It went out, yet the daemon whose state is read does not show it.
        Err(CtlError::Refused(format!(
            "the e-stop was sent ({}) but the daemon at {target} does not report \
             e-stop after {REPLY_TIMEOUT:?}",
            report.notes.join("; ")
        )))
    } else if report.socket || report.command {
        Ok(report)
    } else {
        Err(CtlError::NoDaemon(format!(
            "the e-stop reached no daemon at {target}: {}",
            report.notes.join("; ")
        )))
    }
}

/// One `ctl` session with the daemon.
pub struct Ctl {
    client: Box<dyn Session>,
    state: StateSnapshot,
    holding: bool,
}

impl Ctl {
    /// Connects to the daemon at `prefix` and reads its state.
    pub fn connect(prefix: &str) -> Result<Self, CtlError> {
        let client = Client::new(prefix, &format!("anguilla-ctl-{}", std::process::id()))?;
        Self::over(Box::new(client))
    }

    /// A `ctl` session over an open session, local or remote; reads the state.
    pub fn over(mut client: Box<dyn Session>) -> Result<Self, CtlError> {
        let state = client.wait_state(REPLY_TIMEOUT)?.ok_or_else(|| {
            CtlError::NoDaemon(format!(
                "no state from the daemon at {} within {REPLY_TIMEOUT:?}",
                client.describe()
            ))
        })?;
        Ok(Self {
            client,
            state,
            holding: false,
        })
    }

    /// The newest state read.
    pub fn state(&self) -> &StateSnapshot {
        &self.state
    }

    /// Who holds control now, in words (`ctl (user alice, pid 4242)`);
    /// `None` when nobody does or the session cannot tell.
    pub fn holder_text(&self) -> Option<String> {
        if self.state.holder() == Some(self.client.id()) {
            return Some("this ctl".into());
        }
        self.client.who(self.state.holder()?)
    }

    /// When the state does not come from the process serving commands.
    pub fn provenance_problem(&self) -> Option<String> {
        self.client.provenance_problem()
    }

    fn mode(&self) -> Mode {
        Mode::from_code(self.state.mode).unwrap_or(Mode::Fault)
    }

    fn refresh(&mut self, timeout: Duration) -> Result<(), CtlError> {
        if let Some(s) = self.client.wait_state(timeout)? {
            self.state = s;
        }
        Ok(())
    }

    fn request(&mut self, cmd: Command) -> Result<CommandReply, CtlError> {
        let r = self.client.request(cmd, REPLY_TIMEOUT)?;
        if r.accepted == 0 {
            return Err(CtlError::Refused(format!(
                "'{}' refused: {}",
                cmd.name(),
                r.reason()
            )));
        }
        Ok(r)
    }

    fn take_control(&mut self) -> Result<(), CtlError> {
        self.request(Command::TakeControl)?;
        self.holding = true;
        Ok(())
    }

    fn release(&mut self) {
        if std::mem::take(&mut self.holding) {
            let _ = self.client.request(Command::ReleaseControl, REPLY_TIMEOUT);
        }
    }

    /// Waits until `done` holds of the mode (keeping control alive), or a
    /// fault or E-stop ends the wait, or [`OUTCOME_TIMEOUT`] passes.
    ///
    /// States can arrive late (through the link, on a loaded machine), so
    /// one that shows the fault or E-stop the daemon was in before the
    /// command may predate it: such a state ends the wait only once a state
    /// has shown another mode (the command's effect, or a later change);
    /// until then the wait goes on, and the mode still shown at its
    /// deadline is the error. (A reset after `ctl estop` through a lagging
    /// link was judged by the E-stop state published before it.)
    fn wait_mode(&mut self, what: &str, done: impl Fn(Mode) -> bool) -> Result<Outcome, CtlError> {
        let deadline = Instant::now() + OUTCOME_TIMEOUT;
        let mut last_keep = Instant::now();
        // The state already read may predate the command: judge only states
        // published two periods after the reply.
        self.refresh(Duration::ZERO)?;
        let fresh_from = self.state.sequence + 2;
        let before = self.mode();
        let mut moved = false;
        loop {
            let m = self.mode();
            moved |= m != before;
            if self.state.sequence < fresh_from {
                self.refresh(Duration::from_millis(50))?;
                if Instant::now() >= deadline {
                    return Err(CtlError::NoDaemon(format!(
                        "{what}: no new state from the daemon within {OUTCOME_TIMEOUT:?}"
                    )));
                }
                continue;
            }
            if done(m) {
                return Ok(Outcome { mode: m });
            }
            let ended = matches!(m, Mode::Fault | Mode::EStop);
            if ended && moved {
                return Err(CtlError::Refused(format!(
                    "{what}: the daemon went to {m} ({})",
                    self.faults()
                )));
            }
            if Instant::now() >= deadline {
                return Err(CtlError::Refused(if ended {
                    format!(
                        "{what}: the daemon is still in {m} after {OUTCOME_TIMEOUT:?} ({})",
                        self.faults()
                    )
                } else {
                    format!("{what}: still {m} after {OUTCOME_TIMEOUT:?}")
                }));
            }
            if self.holding && last_keep.elapsed() >= self.keep_period() {
                self.request(Command::KeepAlive)?;
                last_keep = Instant::now();
            }
            self.refresh(Duration::from_millis(50))?;
        }
    }

    fn faults(&self) -> FaultSet {
        FaultSet {
            kinds: self.state.fault_kinds,
            nodes: self.state.fault_nodes,
        }
    }

    /// A third of the daemon's command timeout: three chances per timeout.
    fn keep_period(&self) -> Duration {
        let ms = self.state.limits.command_timeout_ms.max(30);
        Duration::from_millis(u64::from(ms) / 3)
    }

    /// Runs `cmd` under control and waits until `done` holds; releases
    /// control whatever happens.
    fn controlled(
        &mut self,
        cmd: Command,
        what: &str,
        done: impl Fn(Mode) -> bool,
    ) -> Result<Outcome, CtlError> {
        let r = self
            .take_control()
            .and_then(|()| self.request(cmd))
            .and_then(|_| self.wait_mode(what, done));
        self.release();
        r
    }

    /// Enables the actuators and waits for Ready.
    pub fn enable(&mut self) -> Result<Outcome, CtlError> {
        self.controlled(Command::Enable, "enable", |m| m == Mode::Ready)
    }

    /// Disables the actuators and waits for Idle.
    pub fn disable(&mut self) -> Result<Outcome, CtlError> {
        self.controlled(Command::Disable, "disable", |m| m == Mode::Idle)
    }

    /// Clears a fault or an E-stop and waits for Idle.
    pub fn reset(&mut self) -> Result<Outcome, CtlError> {
        self.controlled(Command::Reset, "reset", |m| m == Mode::Idle)
    }

    /// Stops a swim and waits until the robot is at rest (Ready, or Idle if
    /// it was not enabled).
    pub fn stop(&mut self) -> Result<Outcome, CtlError> {
        self.controlled(Command::Stop, "stop", |m| {
            matches!(m, Mode::Ready | Mode::Idle)
        })
    }

    /// Swims with `p` for `duration` (until `interrupted` says so without
    /// one), resending within the command timeout; then stops, waits for
    /// Ready and releases control. A swim ended by the daemon (a fault, an
    /// E-stop, another reason) is an error naming why.
    pub fn swim(
        &mut self,
        p: SwimParams,
        duration: Option<Duration>,
        interrupted: &dyn Fn() -> bool,
    ) -> Result<Outcome, CtlError> {
        self.swim_holding(p, Hold::MANUAL, duration, interrupted)
    }

    /// [`Ctl::swim`] with the autopilot holding `hold` (a heading, a
    /// depth, or both; see [`hold_from_args`]): the hold is sent before
    /// the swim (the daemon takes it in Ready and keeps it as the swim
    /// starts), so the robot never swims unheld in between; a refusal (no
    /// head sensor, an unhealthy one, a depth beyond `max-depth`) is the
    /// error, and the robot does not swim. The daemon keeps the hold for
    /// the swim; if it lets go (the sensor lost), it stops the swim, and
    /// the error says why.
    pub fn swim_holding(
        &mut self,
        p: SwimParams,
        hold: Hold,
        duration: Option<Duration>,
        interrupted: &dyn Fn() -> bool,
    ) -> Result<Outcome, CtlError> {
        let r = self
            .take_control()
            .and_then(|()| self.swim_held(p, hold, duration, interrupted));
        self.stop_and_release(r)
    }

    /// Takes control and swims `legs` one after the other, each for its
    /// time, without stopping between them (`anguilla ctl calibrate-swim`),
    /// calling `each` with a leg's index as it starts; then stops, waits
    /// for ready and releases, as [`Ctl::swim_holding`].
    pub fn swim_legs(
        &mut self,
        legs: &[(SwimParams, Duration)],
        each: &mut dyn FnMut(usize),
        interrupted: &dyn Fn() -> bool,
    ) -> Result<Outcome, CtlError> {
        let r = self.take_control().and_then(|()| {
            for (i, (p, d)) in legs.iter().enumerate() {
                if interrupted() {
                    break;
                }
                each(i);
                self.swim_held(*p, Hold::MANUAL, Some(*d), interrupted)?;
            }
            Ok(())
        });
        self.stop_and_release(r)
    }

    /// Takes control, loads `waypoints` one a request, follows them with
    /// `follow` (its count the waypoints'), keeping control alive, until
    /// the daemon reports the path done (then waits for ready and
    /// releases). `progress` is told the state about once a second.
    /// A path the daemon stopped (the fix lost, the geofence), a swim that
    /// ended otherwise, or an interruption is an error naming it; a
    /// looped path ends only by an interruption, which is then its
    /// outcome.
    pub fn follow(
        &mut self,
        waypoints: &[anguilla_ipc::Waypoint],
        follow: anguilla_ipc::Follow,
        progress: &mut dyn FnMut(&StateSnapshot),
        interrupted: &dyn Fn() -> bool,
    ) -> Result<Outcome, CtlError> {
        use anguilla_ipc::GuideState;
        let r = self.take_control().and_then(|()| {
            for w in waypoints {
                self.request(Command::Waypoint(*w))?;
            }
            self.request(Command::Follow(follow))?;
            // The daemon reports the path's state from the period after.
            let fresh_from = self.state.sequence + 2;
            self.wait_mode("follow", |m| m == Mode::Swimming)?;
            let (mut last_keep, mut last_told) = (Instant::now(), Instant::now());
            loop {
                if interrupted() {
                    return if follow.looped {
                        Ok(())
                    } else {
                        Err(CtlError::Refused(format!(
                            "interrupted before the path's end ({})",
                            guide_words(&self.state)
                        )))
                    };
                }
                if last_keep.elapsed() >= self.keep_period() {
                    self.request(Command::KeepAlive)?;
                    last_keep = Instant::now();
                }
                self.refresh(Duration::from_millis(20))?;
                if self.state.sequence < fresh_from {
                    continue;
                }
                if last_told.elapsed() >= Duration::from_secs(1) {
                    progress(&self.state);
                    last_told = Instant::now();
                }
                match self.state.guide.guide_state() {
                    Some(GuideState::Following) if self.mode() == Mode::Swimming => {}
                    Some(GuideState::Done) => {
                        progress(&self.state);
                        return Ok(());
                    }
                    Some(g) if g.failed() => {
                        return Err(CtlError::Refused(format!(
                            "the path {g} ({})",
                            guide_words(&self.state)
                        )));
                    }
                    _ => return Err(CtlError::Refused(swim_ended(&self.state))),
                }
            }
        });
        self.stop_and_release(r)
    }

    /// After a swim that ended with `r`: stop if still holding control,
    /// wait for ready, release; `r`'s error first.
    fn stop_and_release(&mut self, r: Result<(), CtlError>) -> Result<Outcome, CtlError> {
        let stopped = if self.holding {
            self.request(Command::Stop)
                .and_then(|_| self.wait_mode("stop", |m| matches!(m, Mode::Ready | Mode::Idle)))
        } else {
            Ok(Outcome { mode: self.mode() })
        };
        self.release();
        r?;
        stopped
    }

    fn swim_held(
        &mut self,
        p: SwimParams,
        hold: Hold,
        duration: Option<Duration>,
        interrupted: &dyn Fn() -> bool,
    ) -> Result<(), CtlError> {
        let start = Instant::now();
        // One request: the daemon takes the gait and the hold together or
        // neither, so a held swim never starts manual.
        self.request(if hold.is_active() {
            Command::SwimHold(p, hold)
        } else {
            Command::Swim(p)
        })?;
        self.wait_mode("swim", |m| m == Mode::Swimming)?;
        let mut last_send = Instant::now();
        loop {
            if duration.is_some_and(|d| start.elapsed() >= d) {
                // The swim's time is the hold's settle time: a target not
                // reached by then is a failure, named (issue 46).
                return match hold_missed(&self.state, &hold) {
                    Some(missed) => Err(CtlError::Refused(missed)),
                    None => Ok(()),
                };
            }
            if interrupted() {
                return Ok(());
            }
            if last_send.elapsed() >= self.keep_period() {
                self.request(Command::Swim(p))?;
                last_send = Instant::now();
            }
            self.refresh(Duration::from_millis(20))?;
            let m = self.mode();
            if m != Mode::Swimming {
                return Err(CtlError::Refused(swim_ended(&self.state)));
            }
        }
    }
}

/// How far off a hold may end and count as reached: the depth (m), the
/// daemon's tolerance for "holding".
pub const DEPTH_REACHED: f64 = anguilla_ipc::HOLD_DEPTH_TOLERANCE;
/// How far off a hold may end and count as reached: the heading (deg).
pub const HEADING_REACHED: f64 = anguilla_ipc::HOLD_HEADING_TOLERANCE;

/// What `hold` missed at the end of a swim, as the daemon judges it in
/// `s` (its hold states, `NavSnapshot::heading_hold` and `depth_hold`:
/// "not converging: depth 2.50 m for 1.20 m"), or `None` if every held
/// quantity is holding (within [`DEPTH_REACHED`] and [`HEADING_REACHED`]).
pub fn hold_missed(s: &StateSnapshot, hold: &Hold) -> Option<String> {
    let n = &s.nav;
    let holding = anguilla_ipc::HoldState::Holding as u8;
    let mut missed = Vec::new();
    for (asked, code, words, what) in [
        (
            hold.heading.is_some(),
            n.heading_hold,
            n.heading_words(),
            "heading",
        ),
        (hold.depth.is_some(), n.depth_hold, n.depth_words(), "depth"),
    ] {
        if asked && code != holding {
            missed.push(words.unwrap_or_else(|| format!("the daemon does not hold the {what}")));
        }
    }
    (!missed.is_empty()).then(|| {
        format!(
            "{} at the end of the swim (the daemon's hold state; within {DEPTH_REACHED} m and {HEADING_REACHED} deg holds)",
            missed.join(", ")
        )
    })
}

/// Where the robot is on the path, in words: "leg 2 of 4 (to 10.00,
/// 3.00 m), 7.10 m along 10.00, cross-track +0.04 m, current (0.00,
/// 0.10) m/s".
pub fn guide_words(s: &StateSnapshot) -> String {
    let g = &s.guide;
    format!(
        "leg to waypoint {} of {} ({:.2}, {:.2}) m, {:.2} m along {:.2}, cross-track {:+.2} m, \
         current ({:.2}, {:.2}) m/s",
        g.leg,
        g.waypoints,
        g.to_x,
        g.to_y,
        g.along_track_m,
        g.leg_length_m,
        g.cross_track_m,
        s.nav.current_x,
        s.nav.current_y
    )
}

/// Why a swim ended, from the daemon's state: its mode, the cause, and
/// the faults or the sensor's health that made the autopilot let go.
pub fn swim_ended(s: &StateSnapshot) -> String {
    let m = Mode::from_code(s.mode).unwrap_or(Mode::Fault);
    let faults = FaultSet {
        kinds: s.fault_kinds,
        nodes: s.fault_nodes,
    };
    match Cause::from_code(s.cause) {
        Some(Cause::SensorLost) => format!(
            "the swim ended: the daemon went to {m} (head sensor lost: the autopilot let go, sensor {})",
            crate::view::sensor_name(s.nav.hold_exit)
        ),
        Some(c @ (Cause::OperatorSilent | Cause::Command)) => {
            format!(
                "the swim ended: the daemon went to {m} ({}; {faults})",
                c.name()
            )
        }
        Some(Cause::Shutdown) => {
            format!("the swim ended: the daemon went to {m} (it is shutting down)")
        }
        Some(c @ (Cause::PathDone | Cause::Fence | Cause::FixLost)) => {
            format!("the swim ended: the daemon went to {m} ({})", c.words())
        }
        _ => format!("the swim ended: the daemon went to {m} ({faults})"),
    }
}

impl Drop for Ctl {
    fn drop(&mut self) {
        self.release();
    }
}

#[cfg(test)]
mod hold_tests {
    use super::*;

    /// Issue 46: `ctl swim --depth 1.2 --for 30` that ended at 2.5 m
    /// printed "done: ready" and exited 0.
    #[test]
    fn a_hold_that_missed_its_target_is_named() {
        use anguilla_ipc::HoldState;
        let mut s = StateSnapshot::default();
        s.nav.depth_m = 2.5;
        s.nav.depth_target_m = 1.2;
        s.nav.depth_hold = HoldState::NotConverging as u8;
        s.nav.heading_deg = 355.0;
        let depth = Hold {
            heading: None,
            depth: Some(1.2),
        };
        let m = hold_missed(&s, &depth).expect("missed");
        assert!(
            m.contains("not converging: depth 2.50 m for 1.20 m at the end"),
            "{m}"
        );
        // The daemon's judgement, not the tool's: holding is reached.
        s.nav.depth_m = 1.3;
        s.nav.depth_hold = HoldState::Holding as u8;
        assert_eq!(hold_missed(&s, &depth), None);
        // Still converging at the end is not reached either.
        s.nav.depth_hold = HoldState::Converging as u8;
        let m = hold_missed(&s, &depth).expect("missed");
        assert!(m.starts_with("converging: depth 1.30 m for 1.20 m"), "{m}");
        s.nav.depth_hold = HoldState::Surface as u8;
        let m = hold_missed(&s, &depth).expect("missed");
        assert!(m.starts_with("cannot: at the surface: depth"), "{m}");
        let heading = Hold {
            heading: Some(60.0),
            depth: None,
        };
        s.nav.heading_target_deg = 60.0;
        s.nav.heading_hold = HoldState::Limit as u8;
        let m = hold_missed(&s, &heading).expect("missed");
        assert!(
            m.starts_with("cannot: its command at its limit: heading 355.0 deg for 60.0 deg"),
            "{m}"
        );
        s.nav.heading_hold = HoldState::Holding as u8;
        assert_eq!(hold_missed(&s, &heading), None);
        // A hold asked that the daemon does not hold is no arrival.
        s.nav.heading_hold = HoldState::Off as u8;
        let m = hold_missed(&s, &heading).expect("missed");
        assert!(m.contains("the daemon does not hold the heading"), "{m}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_ipc::CommandRequest;

    #[test]
    fn hold_arguments_are_checked_and_named() {
        assert_eq!(hold_from_args(None, None).unwrap(), Hold::MANUAL);
        let h = hold_from_args(Some(-90.0), Some(1.5)).unwrap();
        assert_eq!((h.heading, h.depth), (Some(270.0), Some(1.5)));
        assert_eq!(
            hold_from_args(Some(720.0), None).unwrap().heading,
            Some(0.0)
        );
        assert_eq!(hold_from_args(None, Some(0.0)).unwrap().depth, Some(0.0));
        for (heading, depth, want) in [
            (
                Some(f64::NAN),
                None,
                "--heading NaN is invalid (expected degrees",
            ),
            (Some(f64::INFINITY), None, "--heading inf is invalid"),
            (
                None,
                Some(-1.0),
                "--depth -1 is invalid (expected metres below the surface",
            ),
            (None, Some(f64::NAN), "--depth NaN is invalid"),
            (Some(10.0), Some(-1e300), "--depth -1e300 is invalid"),
        ] {
            let e = hold_from_args(heading, depth).unwrap_err();
            assert!(e.to_string().contains(want), "{e}");
            assert_eq!(e.exit_code(), 1);
        }
    }

    /// A session whose states lag its replies, as a link's can on a
    /// loaded machine: it hands out `states` one per wait, whatever was
    /// asked, and accepts every request.
    struct Lagging {
        states: std::collections::VecDeque<StateSnapshot>,
        replies: Vec<CommandReply>,
        sequence: u32,
        /// Every request's command kind, in the order sent.
        sent: std::sync::Arc<std::sync::Mutex<Vec<anguilla_ipc::CommandKind>>>,
    }

    impl Session for Lagging {
        fn id(&self) -> u128 {
            7
        }
        fn describe(&self) -> String {
            "a lagging link".into()
        }
        fn provenance_problem(&self) -> Option<String> {
            None
        }
        fn send_request(&mut self, req: CommandRequest) -> Result<u32, IpcError> {
            if let Ok(c) = req.command() {
                self.sent.lock().unwrap().push(c.kind());
            }
            self.replies.push(CommandReply::accepted(&req, 0));
            Ok(req.sequence)
        }
        fn replies(&mut self, f: &mut dyn FnMut(&CommandReply)) -> Result<(), IpcError> {
            self.replies.drain(..).for_each(|r| f(&r));
            Ok(())
        }
        fn awaiting(&self) -> usize {
            self.replies.len()
        }
        fn wait_any(&mut self, _: Duration) -> Result<(), IpcError> {
            Ok(())
        }
        fn latest(&mut self) -> Result<Option<StateSnapshot>, IpcError> {
            Ok(self.states.pop_front())
        }
        fn wait_state(&mut self, _: Duration) -> Result<Option<StateSnapshot>, IpcError> {
            Ok(self.states.pop_front())
        }
        fn estop_out_of_band(&mut self) -> Result<(), IpcError> {
            Ok(())
        }
        fn next_sequence(&mut self) -> u32 {
            self.sequence += 1;
            self.sequence
        }
    }

    fn lagging(modes: &[Mode]) -> Ctl {
        lagging_recorded(modes).0
    }

    /// [`lagging`], with the kinds of the requests it will have been sent.
    fn lagging_recorded(
        modes: &[Mode],
    ) -> (
        Ctl,
        std::sync::Arc<std::sync::Mutex<Vec<anguilla_ipc::CommandKind>>>,
    ) {
        let sent = std::sync::Arc::default();
        let states = modes
            .iter()
            .enumerate()
            .map(|(i, m)| StateSnapshot {
                sequence: i as u64,
                mode: *m as u8,
                fault_kinds: if *m == Mode::EStop { 1 << 5 } else { 0 },
                ..Default::default()
            })
            .collect();
        let ctl = Ctl::over(Box::new(Lagging {
            states,
            replies: Vec::new(),
            sequence: 0,
            sent: std::sync::Arc::clone(&sent),
        }))
        .unwrap();
        (ctl, sent)
    }

    /// `ctl swim --heading`: the hold and the swim are one request (issue
    /// 47: two requests had a manual swim between them), which the daemon
    /// takes whole or refuses whole.
    #[test]
    fn a_held_swim_is_one_request() {
        use Mode::*;
        let (mut c, sent) = lagging_recorded(&[
            Ready, Ready, Ready, Swimming, Swimming, Swimming, Swimming, Ready, Ready, Ready, Ready,
        ]);
        let hold = Hold {
            heading: Some(1.0),
            depth: None,
        };
        let p = SwimParams {
            amplitude: 0.5,
            frequency: 1.0,
            turn: 0.0,
            pitch: 0.0,
        };
        // A swim of no time: the hold is judged at once (and not reached:
        // these states hold nothing); what matters here is the order.
        let _ = c.swim_holding(p, hold, Some(Duration::ZERO), &|| false);
        let kinds = sent.lock().unwrap().clone();
        use anguilla_ipc::CommandKind as K;
        let first = kinds.iter().find(|k| !matches!(k, K::TakeControl));
        assert_eq!(first, Some(&K::SwimHold), "{kinds:?}");
        assert!(!kinds.contains(&K::Hold), "{kinds:?}");
    }

    /// Seen in CI through the link: `ctl reset` after `ctl estop` was
    /// judged by E-stop states published before the reset, which a
    /// loaded link delivered after its reply ("reset: the daemon went to
    /// e-stop"). Those now wait for the command's effect; an E-stop after
    /// another mode is still the error at once.
    #[test]
    fn a_late_state_from_before_the_command_is_not_its_outcome() {
        use Mode::*;
        let mut c = lagging(&[EStop, EStop, EStop, EStop, EStop, EStop, EStop, Idle]);
        assert_eq!(c.reset().unwrap().mode, Idle);
        let mut c = lagging(&[Idle, Idle, Idle, Idle, Enabling, EStop, EStop]);
        let e = c.enable().unwrap_err().to_string();
        assert!(e.contains("enable: the daemon went to e-stop"), "{e}");
    }

    #[test]
    fn a_swim_the_daemon_ended_says_why() {
        let mut s = StateSnapshot {
            mode: Mode::Stopping as u8,
            cause: Cause::SensorLost.code(),
            ..Default::default()
        };
        s.nav.hold_exit = anguilla_ipc::SensorHealth::Silent as u8;
        let m = swim_ended(&s);
        assert!(m.contains("head sensor lost"), "{m}");
        assert!(m.contains("sensor silent"), "{m}");
        s.mode = Mode::EStop as u8;
        s.cause = Cause::Fault.code();
        s.fault_kinds = 1 << 5;
        let m = swim_ended(&s);
        assert!(m.contains("e-stop (operator e-stop)"), "{m}");
    }
}
