//! The operator's intent: the gait the operator wants, stepped by keys and
//! clamped to the daemon's ranges, the holds the autopilot should keep, and
//! the commands they turn into.

use anguilla_ipc::{Command, Hold, LimitsSnapshot, NavSnapshot, SwimParams};

use crate::hold::{DEPTH_STEP, HEADING_STEP, HoldIntent};

/// The daemon's accepted ranges for swim parameters (`[gait]` in its
/// configuration, published in its state); commands outside them would be
/// refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest frequency (Hz).
    pub max_frequency: f64,
    /// Largest turn curvature magnitude (1/m).
    pub max_turn: f64,
    /// Largest pitch curvature magnitude (1/m).
    pub max_pitch: f64,
}

impl Limits {
    /// The limits a daemon publishes in its state.
    pub fn from_snapshot(l: &LimitsSnapshot) -> Self {
        Self {
            max_frequency: l.max_frequency as f64,
            max_turn: l.max_turn as f64,
            max_pitch: l.max_pitch as f64,
        }
    }
}

impl Default for Limits {
    /// The daemon's default configuration's (2 Hz, 2 /m, 1 /m; a system
    /// test checks they agree): used where no daemon is asked.
    fn default() -> Self {
        Self {
            max_frequency: 2.0,
            max_turn: 2.0,
            max_pitch: 1.0,
        }
    }
}

/// What an operator can ask for, whatever the input device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Action {
    /// More amplitude (starts swimming from ready).
    Faster,
    /// Less amplitude (stops the swim at zero).
    Slower,
    /// Higher undulation frequency.
    FrequencyUp,
    /// Lower undulation frequency.
    FrequencyDown,
    /// Turn more to the left; while a heading is held, move the target
    /// [`HEADING_STEP`] to the left (the heading increases).
    TurnLeft,
    /// Turn more to the right; while a heading is held, move the target
    /// [`HEADING_STEP`] to the right.
    TurnRight,
    /// Pitch down more (positive pitch curvature); while a depth is held,
    /// move the target [`DEPTH_STEP`] deeper.
    Dive,
    /// Pitch up more; while a depth is held, move the target
    /// [`DEPTH_STEP`] shallower (never above the surface).
    Climb,
    /// Heading hold on (capturing the estimated heading) or off.
    HoldHeading,
    /// Depth hold on (capturing the estimated depth) or off.
    HoldDepth,
    /// Zero turn and pitch.
    Straighten,
    /// Stop swimming smoothly.
    Stop,
    /// Emergency stop (accepted from any client).
    EStop,
    /// Enable the actuators.
    Enable,
    /// Disable the actuators.
    Disable,
    /// Clear a fault or an E-stop.
    Reset,
    /// Take control authority.
    TakeControl,
    /// Release control authority (the daemon stops a swim).
    ReleaseControl,
    /// Follow the path given to the tool (`--path`); while following,
    /// pause it (swim on straight, by hand); after a pause, resume it on
    /// its leg. The driver sends it ([`crate::operator::Driver`]).
    Follow,
    /// Leave the tool (stops the swim and releases control first).
    Quit,
}

/// Amplitude step of [`Action::Faster`] / [`Action::Slower`] (fraction of maximum).
pub const AMPLITUDE_STEP: f64 = 0.1;
/// Frequency step (Hz).
pub const FREQUENCY_STEP: f64 = 0.1;
/// Turn curvature step (1/m).
pub const TURN_STEP: f64 = 0.25;
/// Pitch curvature step (1/m).
pub const PITCH_STEP: f64 = 0.25;
/// Frequency a new session starts with (Hz).
pub const DEFAULT_FREQUENCY: f64 = 1.0;

/// The operator's intent: target gait, whether the robot should swim, and
/// what the autopilot should hold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intent {
    limits: Limits,
    params: SwimParams,
    swimming: bool,
    hold: HoldIntent,
}

/// Rounds to a multiple of a thousandth so repeated steps do not drift
/// (0.1 + 0.1 + 0.1 stays 0.3), then clamps.
fn step(value: f64, by: f64, min: f64, max: f64) -> f64 {
    (((value + by) * 1000.0).round() / 1000.0).clamp(min, max)
}

impl Intent {
    /// At rest, with `limits` and [`DEFAULT_FREQUENCY`] (clamped).
    pub fn new(limits: Limits) -> Self {
        Self {
            limits,
            params: SwimParams {
                frequency: DEFAULT_FREQUENCY.min(limits.max_frequency),
                ..SwimParams::REST
            },
            swimming: false,
            hold: HoldIntent::default(),
        }
    }

    /// The limits in use.
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// The target gait.
    pub fn params(&self) -> SwimParams {
        self.params
    }

    /// Whether the operator wants the robot to swim.
    pub fn swimming(&self) -> bool {
        self.swimming
    }

    /// What the operator wants the autopilot to hold (sent while swimming;
    /// armed for the next swim at rest).
    pub fn hold(&self) -> Hold {
        self.hold.wanted()
    }

    /// The hold to send now, if any: after a swim started with a hold
    /// armed (see [`HoldIntent::update`]). [`Intent::apply`] returns the
    /// holds its actions change.
    pub fn hold_update(&mut self) -> Option<Command> {
        self.hold.update(self.swimming)
    }

    /// Applies `action`; returns the command to send at once, if any.
    /// [`Action::Quit`] returns `None`: the caller runs its quit sequence.
    pub fn apply(&mut self, action: Action) -> Option<Command> {
        let l = self.limits;
        let p = &mut self.params;
        match action {
            Action::Faster => {
                p.amplitude = step(p.amplitude, AMPLITUDE_STEP, 0.0, 1.0);
                if p.amplitude > 0.0 && p.frequency > 0.0 {
                    self.swimming = true;
                    return Some(Command::Swim(*p));
                }
                None
            }
            Action::Slower => {
                p.amplitude = step(p.amplitude, -AMPLITUDE_STEP, 0.0, 1.0);
                self.gait_changed()
            }
            Action::FrequencyUp => {
                p.frequency = step(p.frequency, FREQUENCY_STEP, 0.0, l.max_frequency);
                self.gait_changed()
            }
            Action::FrequencyDown => {
                p.frequency = step(p.frequency, -FREQUENCY_STEP, 0.0, l.max_frequency);
                self.gait_changed()
            }
            Action::TurnLeft | Action::TurnRight if self.hold.wanted().heading.is_some() => {
                let sign = if action == Action::TurnLeft {
                    1.0
                } else {
                    -1.0
                };
                self.hold.nudge_heading(sign * HEADING_STEP);
                self.hold_update()
            }
            Action::Dive | Action::Climb if self.hold.wanted().depth.is_some() => {
                let sign = if action == Action::Dive { 1.0 } else { -1.0 };
                self.hold.nudge_depth(sign * DEPTH_STEP);
                self.hold_update()
            }
            Action::TurnLeft => {
                p.turn = step(p.turn, TURN_STEP, -l.max_turn, l.max_turn);
                self.gait_changed()
            }
            Action::TurnRight => {
                p.turn = step(p.turn, -TURN_STEP, -l.max_turn, l.max_turn);
                self.gait_changed()
            }
            Action::Dive => {
                p.pitch = step(p.pitch, PITCH_STEP, -l.max_pitch, l.max_pitch);
                self.gait_changed()
            }
            Action::Climb => {
                p.pitch = step(p.pitch, -PITCH_STEP, -l.max_pitch, l.max_pitch);
                self.gait_changed()
            }
            // Toggling a hold on or off zeroes the curvature it takes over:
            // a hold let go leaves the robot swimming straight.
            Action::HoldHeading => {
                self.hold.toggle_heading();
                p.turn = 0.0;
                self.hold_update()
            }
            Action::HoldDepth => {
                self.hold.toggle_depth();
                p.pitch = 0.0;
                self.hold_update()
            }
            Action::Straighten => {
                p.turn = 0.0;
                p.pitch = 0.0;
                self.gait_changed()
            }
            Action::Stop => {
                self.rest();
                Some(Command::Stop)
            }
            Action::EStop => {
                self.rest();
                Some(Command::EStop)
            }
            Action::Enable => Some(Command::Enable),
            Action::Disable => {
                self.rest();
                Some(Command::Disable)
            }
            Action::Reset => {
                self.rest();
                Some(Command::Reset)
            }
            Action::TakeControl => Some(Command::TakeControl),
            Action::ReleaseControl => {
                self.rest();
                Some(Command::ReleaseControl)
            }
            Action::Quit | Action::Follow => None,
        }
    }

    /// After a gait change: the new swim while swimming, a stop when the
    /// amplitude or frequency reached zero, nothing when not swimming.
    fn gait_changed(&mut self) -> Option<Command> {
        if !self.swimming {
            return None;
        }
        if self.params.amplitude <= 0.0 || self.params.frequency <= 0.0 {
            self.swimming = false;
            self.params.amplitude = 0.0;
            self.hold.clear();
            return Some(Command::Stop);
        }
        Some(Command::Swim(self.params))
    }

    /// Amplitude zero, straight, not swimming, nothing held (frequency
    /// kept): the daemon ends a hold with the swim.
    fn rest(&mut self) {
        self.swimming = false;
        self.params.amplitude = 0.0;
        self.params.turn = 0.0;
        self.params.pitch = 0.0;
        self.hold.clear();
    }

    /// What the holder sends at its steady rate: the swim while swimming,
    /// otherwise a keep-alive.
    pub fn steady(&self) -> Command {
        if self.swimming {
            Command::Swim(self.params)
        } else {
            Command::KeepAlive
        }
    }

    /// The gait a path is followed at: the target's amplitude and
    /// frequency, or F1 (amplitude 1, [`DEFAULT_FREQUENCY`]) at rest.
    pub fn follow_gait(&self) -> SwimParams {
        let p = self.params;
        SwimParams {
            amplitude: if p.amplitude > 0.0 { p.amplitude } else { 1.0 },
            frequency: if p.frequency > 0.0 {
                p.frequency
            } else {
                DEFAULT_FREQUENCY.min(self.limits.max_frequency)
            },
            turn: 0.0,
            pitch: 0.0,
        }
    }

    /// A path started: the guidance steers, so the steady command is a
    /// keep-alive (a swim would end the path) and nothing is held by hand.
    pub fn follow_started(&mut self) {
        self.params = SwimParams {
            turn: 0.0,
            pitch: 0.0,
            ..self.follow_gait()
        };
        self.swimming = false;
        self.hold.clear();
    }

    /// The operator takes over from a path (its pause): swim on at the
    /// path's gait, straight, by hand. Returns the swim to send.
    pub fn take_over(&mut self) -> Command {
        self.params = self.follow_gait();
        self.swimming = true;
        self.hold.clear();
        Command::Swim(self.params)
    }

    /// The daemon refused a swim (no control, wrong mode, out of range):
    /// the intent drops to rest, so taking control later does not start a
    /// swim the operator asked for before.
    pub fn swim_refused(&mut self) {
        if self.swimming {
            self.rest();
        }
    }

    /// Follows the daemon: when it left the swim on its own (fault, E-stop
    /// from any tool, reset, the operator's silence, the head sensor's
    /// loss), the intent drops to rest, so the steady sender never
    /// restarts a swim by itself. `mode` and `cause` are the snapshot's
    /// codes.
    pub fn observe(&mut self, mode: u8, cause: u8) {
        if self.swimming && crate::hold::swim_ended_by_daemon(mode, cause) {
            self.rest();
        }
    }

    /// Follows the daemon's estimate: a hold toggled on captures it.
    pub fn observe_nav(&mut self, nav: &NavSnapshot) {
        self.hold.observe_nav(nav);
    }

    /// The daemon refused a hold: the intent adopts what it holds.
    pub fn hold_refused(&mut self) {
        self.hold.refused();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_ipc::{Cause, Mode};

    fn swim_of(c: Option<Command>) -> SwimParams {
        match c {
            Some(Command::Swim(p)) => p,
            other => panic!("expected a swim, got {other:?}"),
        }
    }

    #[test]
    fn faster_starts_the_swim_and_slower_to_zero_stops_it() {
        let mut i = Intent::new(Limits::default());
        assert_eq!(i.steady(), Command::KeepAlive);
        let p = swim_of(i.apply(Action::Faster));
        assert_eq!(p.amplitude, 0.1);
        assert_eq!(p.frequency, 1.0);
        assert!(i.swimming());
        assert!(matches!(i.steady(), Command::Swim(_)));
        assert_eq!(i.apply(Action::Slower), Some(Command::Stop));
        assert!(!i.swimming());
        assert_eq!(i.steady(), Command::KeepAlive);
        // Slower at rest sends nothing.
        assert_eq!(i.apply(Action::Slower), None);
    }

    #[test]
    fn steps_are_clamped_to_the_daemons_ranges_and_do_not_drift() {
        let l = Limits::default();
        let mut i = Intent::new(l);
        for _ in 0..30 {
            i.apply(Action::Faster);
            i.apply(Action::FrequencyUp);
            i.apply(Action::TurnLeft);
            i.apply(Action::Dive);
        }
        let p = i.params();
        assert_eq!(p.amplitude, 1.0);
        assert_eq!(p.frequency, l.max_frequency);
        assert_eq!(p.turn, l.max_turn);
        assert_eq!(p.pitch, l.max_pitch);
        for _ in 0..60 {
            i.apply(Action::TurnRight);
            i.apply(Action::Climb);
        }
        assert_eq!(i.params().turn, -l.max_turn);
        assert_eq!(i.params().pitch, -l.max_pitch);
        let mut j = Intent::new(l);
        for _ in 0..3 {
            j.apply(Action::Faster);
        }
        assert_eq!(j.params().amplitude, 0.3);
    }

    #[test]
    fn turn_and_dive_at_rest_only_set_the_target() {
        let mut i = Intent::new(Limits::default());
        assert_eq!(i.apply(Action::TurnLeft), None);
        assert_eq!(i.apply(Action::Dive), None);
        let p = swim_of(i.apply(Action::Faster));
        assert_eq!((p.turn, p.pitch), (0.25, 0.25));
        let p = swim_of(i.apply(Action::TurnRight));
        assert_eq!(p.turn, 0.0);
        let p = swim_of(i.apply(Action::Straighten));
        assert_eq!((p.turn, p.pitch), (0.0, 0.0));
    }

    #[test]
    fn stop_estop_and_release_rest_the_intent() {
        for (a, c) in [
            (Action::Stop, Command::Stop),
            (Action::EStop, Command::EStop),
            (Action::ReleaseControl, Command::ReleaseControl),
        ] {
            let mut i = Intent::new(Limits::default());
            i.apply(Action::Faster);
            i.apply(Action::TurnLeft);
            assert_eq!(i.apply(a), Some(c));
            assert!(!i.swimming());
            assert_eq!(i.params().amplitude, 0.0);
            assert_eq!(i.params().turn, 0.0);
        }
        let mut i = Intent::new(Limits::default());
        assert_eq!(i.apply(Action::Enable), Some(Command::Enable));
        assert_eq!(i.apply(Action::TakeControl), Some(Command::TakeControl));
        assert_eq!(i.apply(Action::Quit), None);
    }

    #[test]
    fn a_stop_by_the_daemon_is_never_undone_by_the_steady_sender() {
        let mut i = Intent::new(Limits::default());
        i.apply(Action::Faster);
        i.observe(Mode::Ready as u8, 1); // just sent: not yet swimming
        assert!(i.swimming());
        i.observe(Mode::Swimming as u8, 1);
        i.observe(Mode::Stopping as u8, 1); // a stop of ours would be fine
        assert!(i.swimming());
        for (mode, cause) in [
            (Mode::EStop as u8, 1),
            (Mode::Fault as u8, 3),
            (Mode::Stopping as u8, 2),
            (Mode::Idle as u8, 1),
        ] {
            let mut j = i;
            j.observe(mode, cause);
            assert!(!j.swimming(), "mode {mode} cause {cause}");
            assert_eq!(j.steady(), Command::KeepAlive);
        }
    }

    #[test]
    fn a_refused_swim_is_forgotten() {
        let mut i = Intent::new(Limits::default());
        i.apply(Action::Faster);
        i.swim_refused();
        assert!(!i.swimming());
        assert_eq!(i.steady(), Command::KeepAlive);
        assert_eq!(i.params().amplitude, 0.0);
    }

    #[test]
    fn frequency_zero_while_swimming_stops() {
        let mut i = Intent::new(Limits::default());
        i.apply(Action::Faster);
        let sent: Vec<_> = (0..12).map(|_| i.apply(Action::FrequencyDown)).collect();
        let stops = sent.iter().filter(|c| **c == Some(Command::Stop)).count();
        assert_eq!(stops, 1, "stopped once: {sent:?}");
        assert_eq!(sent[11], None, "then nothing");
        assert!(!i.swimming());
        // Faster with frequency 0 does not start a swim the daemon would refuse to move.
        assert_eq!(i.apply(Action::Faster), None);
    }

    fn hold_of(c: Option<Command>) -> Hold {
        match c {
            Some(Command::Hold(h)) => h,
            other => panic!("expected a hold, got {other:?}"),
        }
    }

    fn nav(heading: f32, depth: f32) -> NavSnapshot {
        NavSnapshot {
            sensor: 1,
            samples: 500,
            heading_deg: heading,
            depth_m: depth,
            ..Default::default()
        }
    }

    #[test]
    fn hold_keys_capture_the_estimate_and_the_steering_keys_move_the_targets() {
        let mut i = Intent::new(Limits::default());
        i.observe_nav(&nav(357.0, 0.25));
        i.apply(Action::Faster);
        i.apply(Action::TurnLeft);
        i.apply(Action::Dive);
        let h = hold_of(i.apply(Action::HoldHeading));
        assert_eq!(h.heading, Some(357.0));
        assert_eq!(h.depth, None);
        assert_eq!(i.params().turn, 0.0, "the hold takes the turn over");
        assert_eq!(i.params().pitch, 0.25, "the pitch is still the operator's");
        // ← moves the held heading 5° to the left (it increases), across 360.
        let h = hold_of(i.apply(Action::TurnLeft));
        assert_eq!(h.heading, Some(2.0));
        assert_eq!(i.params().turn, 0.0, "the curvature is not stepped");
        let h = hold_of(i.apply(Action::TurnRight));
        assert_eq!(h.heading, Some(357.0));
        let h = hold_of(i.apply(Action::HoldDepth));
        assert_eq!(
            h,
            Hold {
                heading: Some(357.0),
                depth: Some(0.25)
            }
        );
        assert_eq!(i.params().pitch, 0.0);
        // s climbs 0.1 m a press, never above the surface.
        let h = hold_of(i.apply(Action::Climb));
        assert_eq!(h.depth, Some(0.15));
        for _ in 0..5 {
            i.apply(Action::Climb);
        }
        assert_eq!(i.hold().depth, Some(0.0));
        let h = hold_of(i.apply(Action::Dive));
        assert_eq!(h.depth, Some(0.1));
        // Off again: manual, and the keys steer the gait again.
        assert_eq!(hold_of(i.apply(Action::HoldHeading)).heading, None);
        assert_eq!(hold_of(i.apply(Action::HoldDepth)), Hold::MANUAL);
        let p = swim_of(i.apply(Action::TurnLeft));
        assert_eq!(p.turn, 0.25);
        // The steady command stays the swim: holds go out once.
        assert!(matches!(i.steady(), Command::Swim(_)));
    }

    #[test]
    fn a_hold_toggled_at_rest_is_armed_and_sent_after_the_swim_starts() {
        let mut i = Intent::new(Limits::default());
        i.observe_nav(&nav(45.0, 1.5));
        assert_eq!(i.apply(Action::HoldHeading), None, "armed");
        assert_eq!(i.apply(Action::TurnLeft), None, "armed target moved");
        assert_eq!(i.hold_update(), None, "nothing while at rest");
        assert!(matches!(i.apply(Action::Faster), Some(Command::Swim(_))));
        let h = hold_of(i.hold_update());
        assert_eq!(h.heading, Some(50.0));
        assert_eq!(i.hold_update(), None, "once");
    }

    #[test]
    fn holds_end_with_the_swim_and_a_refusal_adopts_the_daemons() {
        let mut i = Intent::new(Limits::default());
        i.observe_nav(&nav(10.0, 2.0));
        i.apply(Action::Faster);
        i.apply(Action::HoldDepth);
        assert_eq!(i.apply(Action::Stop), Some(Command::Stop));
        assert_eq!(i.hold(), Hold::MANUAL);
        // Lost sensor: the daemon stops the swim, the intent rests.
        i.apply(Action::Faster);
        i.apply(Action::HoldHeading);
        i.observe(Mode::Stopping as u8, Cause::SensorLost.code());
        assert!(!i.swimming());
        assert_eq!(i.hold(), Hold::MANUAL);
        // Refused (no sensor): the daemon holds nothing, nor does the intent.
        i.observe_nav(&NavSnapshot::default());
        i.apply(Action::Faster);
        let h = hold_of(i.apply(Action::HoldHeading));
        assert_eq!(h.heading, Some(0.0));
        i.hold_refused();
        assert_eq!(i.hold(), Hold::MANUAL);
        assert_eq!(i.hold_update(), None, "not resent");
        let p = swim_of(i.apply(Action::TurnLeft));
        assert_eq!(p.turn, 0.25, "the arrows steer again");
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        fn action() -> impl Strategy<Value = Action> {
            use Action::*;
            proptest::sample::select(vec![
                Faster,
                Slower,
                FrequencyUp,
                FrequencyDown,
                TurnLeft,
                TurnRight,
                Dive,
                Climb,
                Straighten,
                HoldHeading,
                HoldDepth,
                Stop,
                EStop,
                Enable,
                Disable,
                Reset,
                TakeControl,
                ReleaseControl,
            ])
        }

        proptest! {
            // Any key sequence: every swim sent is one the daemon accepts
            // (in range, moving), and the steady command matches the state.
            #[test]
            fn every_swim_is_in_the_daemons_ranges(
                actions in proptest::collection::vec(action(), 1..300)
            ) {
                let l = Limits::default();
                let mut i = Intent::new(l);
                i.observe_nav(&nav(358.0, 0.05));
                for a in actions {
                    let sent = i.apply(a);
                    for c in [sent, Some(i.steady())].into_iter().flatten() {
                        if let Command::Swim(p) = c {
                            prop_assert!(p.amplitude > 0.0 && p.amplitude <= 1.0);
                            prop_assert!(p.frequency > 0.0 && p.frequency <= l.max_frequency);
                            prop_assert!(p.turn.abs() <= l.max_turn);
                            prop_assert!(p.pitch.abs() <= l.max_pitch);
                        }
                    }
                    prop_assert_eq!(i.swimming(), matches!(i.steady(), Command::Swim(_)));
                    // Holds: in range, only while swimming.
                    for c in [sent, i.hold_update()].into_iter().flatten() {
                        if let Command::Hold(h) = c {
                            prop_assert!(i.swimming());
                            prop_assert!(h.heading.is_none_or(|d| (0.0..360.0).contains(&d)));
                            prop_assert!(h.depth.is_none_or(|d| d >= 0.0 && d.is_finite()));
                        }
                    }

                }
            }
        }
    }
}
