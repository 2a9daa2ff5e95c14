//! Gamepad translation of `anguilla joy`: raw evdev events to commands.
//!
//! [`Joy`] is a pure state machine: it is fed [`JoyInput`]s (made from
//! evdev events by [`JoyInput::from_evdev`]) and a steady [`Joy::tick`],
//! and returns the commands to send. It never touches a device, so it is
//! tested here without one.
//!
//! Rules (after teleop_twist_joy, see `PEERS.md`):
//! - nothing but E-stop is sent unless the **deadman** button is held;
//!   pressing it takes control;
//! - while it is held, the sticks' gait is sent at the steady rate (a
//!   keep-alive while the speed stick is centred; one stop when it returns
//!   to the centre during a swim);
//! - on its release (or when the pad disappears) **one** stop is sent,
//!   then nothing: the daemon's command timeout is the backstop;
//! - the E-stop button works at any time;
//! - with the deadman held, the hold buttons toggle heading and depth hold
//!   (capturing the estimate); while a heading is held the turn stick moves
//!   the held heading at up to [`HEADING_RATE`], while a depth is held the
//!   pitch stick moves the held depth at up to [`DEPTH_RATE`]. The rate is
//!   integrated here and sent as absolute targets ([`Joy::hold_update`]).

use core::str::FromStr;

use anguilla_ipc::{Command, Hold, StateSnapshot, SwimParams};
use evdev::{AbsoluteAxisCode, EventSummary, InputEvent, KeyCode};

use crate::app::Limits;
use crate::hold::{DEPTH_RATE, HEADING_RATE, HoldIntent, swim_ended_by_daemon};
use crate::operator::STEADY_PERIOD;

/// What is wrong with a gamepad mapping.
#[derive(Debug, thiserror::Error)]
pub enum JoyError {
    /// The mapping file is not valid TOML of the expected shape.
    #[error("gamepad mapping: {0}")]
    Toml(#[from] toml::de::Error),
    /// A button name is not a kernel key code.
    #[error(
        "gamepad mapping: {field} = {name:?} is not a button code (expected e.g. \"BTN_TL\", \"BTN_SOUTH\")"
    )]
    Button {
        /// The field.
        field: &'static str,
        /// The name given.
        name: String,
    },
    /// An axis name is not a kernel absolute axis code.
    #[error(
        "gamepad mapping: {field} = {name:?} is not an axis code (expected e.g. \"ABS_X\", \"ABS_RY\")"
    )]
    Axis {
        /// The field.
        field: &'static str,
        /// The name given.
        name: String,
    },
    /// A number is outside its range.
    #[error("gamepad mapping: {field} = {value} is out of range (expected {range})")]
    Range {
        /// The field.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The accepted range.
        range: &'static str,
    },
}

/// One stick axis of the mapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisMap {
    /// The kernel axis code.
    pub code: AbsoluteAxisCode,
    /// Negate the axis (kernel sticks read negative when pushed up or left).
    pub invert: bool,
}

/// Which buttons and axes do what. The defaults use the kernel's standard
/// gamepad codes (`Documentation/input/gamepad.rst`), so common pads work
/// without setup.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoyMapping {
    /// Must be held for anything but E-stop (default left shoulder, `BTN_TL`).
    pub deadman: KeyCode,
    /// Emergency stop (default east face button, `BTN_EAST`: B / circle).
    pub estop: KeyCode,
    /// Enable (default `BTN_START`).
    pub enable: KeyCode,
    /// Disable (default north face button, `BTN_NORTH`: Y / triangle).
    pub disable: KeyCode,
    /// Reset after a fault or E-stop (default `BTN_SELECT`).
    pub reset: KeyCode,
    /// Heading hold on / off (default west face button, `BTN_WEST`: X / □).
    pub heading_hold: KeyCode,
    /// Depth hold on / off (default south face button, `BTN_SOUTH`: A / ✕).
    pub depth_hold: KeyCode,
    /// Speed: amplitude from the stick pushed forward (default left stick
    /// vertical, `ABS_Y`, inverted).
    pub speed: AxisMap,
    /// Turn: positive (left) curvature from the stick pushed left (default
    /// right stick horizontal, `ABS_RX`, inverted).
    pub turn: AxisMap,
    /// Dive: positive pitch curvature from the stick pushed forward
    /// (default right stick vertical, `ABS_RY`, inverted).
    pub pitch: AxisMap,
    /// Fraction of each axis' half-range around the centre read as zero (0..1).
    pub deadzone: f64,
    /// Undulation frequency while swimming (Hz); the speed stick sets the amplitude.
    pub frequency: f64,
}

impl Default for JoyMapping {
    fn default() -> Self {
        Self {
            deadman: KeyCode::BTN_TL,
            estop: KeyCode::BTN_EAST,
            enable: KeyCode::BTN_START,
            disable: KeyCode::BTN_NORTH,
            reset: KeyCode::BTN_SELECT,
            heading_hold: KeyCode::BTN_WEST,
            depth_hold: KeyCode::BTN_SOUTH,
            speed: AxisMap {
                code: AbsoluteAxisCode::ABS_Y,
                invert: true,
            },
            turn: AxisMap {
                code: AbsoluteAxisCode::ABS_RX,
                invert: true,
            },
            pitch: AxisMap {
                code: AbsoluteAxisCode::ABS_RY,
                invert: true,
            },
            deadzone: 0.15,
            frequency: 1.0,
        }
    }
}

#[derive(Debug, Default, serde::Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct MappingFile {
    deadman: Option<String>,
    estop: Option<String>,
    enable: Option<String>,
    disable: Option<String>,
    reset: Option<String>,
    heading_hold: Option<String>,
    depth_hold: Option<String>,
    speed_axis: Option<String>,
    turn_axis: Option<String>,
    pitch_axis: Option<String>,
    invert_speed: Option<bool>,
    invert_turn: Option<bool>,
    invert_pitch: Option<bool>,
    deadzone: Option<f64>,
    frequency: Option<f64>,
}

impl JoyMapping {
    /// Reads a mapping from TOML; every key is optional (see
    /// [`JoyMapping::to_toml`] for the keys and the defaults).
    pub fn from_toml(text: &str, limits: Limits) -> Result<Self, JoyError> {
        let f: MappingFile = toml::from_str(text)?;
        let mut m = Self::default();
        let button = |field: &'static str, v: &Option<String>, d: KeyCode| match v {
            None => Ok(d),
            Some(name) => KeyCode::from_str(name).map_err(|_| JoyError::Button {
                field,
                name: name.clone(),
            }),
        };
        let axis = |field: &'static str, v: &Option<String>, inv: Option<bool>, d: AxisMap| {
            let code = match v {
                None => d.code,
                Some(name) => AbsoluteAxisCode::from_str(name).map_err(|_| JoyError::Axis {
                    field,
                    name: name.clone(),
                })?,
            };
            Ok::<_, JoyError>(AxisMap {
                code,
                invert: inv.unwrap_or(d.invert),
            })
        };
        m.deadman = button("deadman", &f.deadman, m.deadman)?;
        m.estop = button("estop", &f.estop, m.estop)?;
        m.enable = button("enable", &f.enable, m.enable)?;
        m.disable = button("disable", &f.disable, m.disable)?;
        m.reset = button("reset", &f.reset, m.reset)?;
        m.heading_hold = button("heading-hold", &f.heading_hold, m.heading_hold)?;
        m.depth_hold = button("depth-hold", &f.depth_hold, m.depth_hold)?;
        m.speed = axis("speed-axis", &f.speed_axis, f.invert_speed, m.speed)?;
        m.turn = axis("turn-axis", &f.turn_axis, f.invert_turn, m.turn)?;
        m.pitch = axis("pitch-axis", &f.pitch_axis, f.invert_pitch, m.pitch)?;
        if let Some(d) = f.deadzone {
            if !(0.0..0.95).contains(&d) {
                return Err(JoyError::Range {
                    field: "deadzone",
                    value: d,
                    range: "0 ..< 0.95",
                });
            }
            m.deadzone = d;
        }
        if let Some(fr) = f.frequency {
            if !(fr > 0.0 && fr <= limits.max_frequency) {
                return Err(JoyError::Range {
                    field: "frequency",
                    value: fr,
                    range: "> 0 Hz and at most the daemon's max-frequency",
                });
            }
            m.frequency = fr;
        }
        Ok(m)
    }

    /// The mapping as a commented TOML file that [`JoyMapping::from_toml`] reads.
    pub fn to_toml(&self) -> String {
        format!(
            "# anguilla joy: gamepad mapping (kernel codes, see linux/input-event-codes.h)\n\
             # Hold to drive; on release one stop is sent.\n\
             deadman = \"{:?}\"\n\
             estop = \"{:?}\"\n\
             enable = \"{:?}\"\n\
             disable = \"{:?}\"\n\
             reset = \"{:?}\"\n\
             # Heading / depth hold on or off (the estimate now is the target); while\n\
             # held, the turn stick moves the heading (30 deg/s at full stick), the\n\
             # pitch stick the depth (0.2 m/s).\n\
             heading-hold = \"{:?}\"\n\
             depth-hold = \"{:?}\"\n\
             # Stick pushed forward: amplitude 0..1.\n\
             speed-axis = \"{:?}\"\n\
             invert-speed = {}\n\
             # Stick pushed left: turn left (positive curvature).\n\
             turn-axis = \"{:?}\"\n\
             invert-turn = {}\n\
             # Stick pushed forward: dive (positive pitch curvature).\n\
             pitch-axis = \"{:?}\"\n\
             invert-pitch = {}\n\
             # Fraction of each half-range read as zero.\n\
             deadzone = {}\n\
             # Undulation frequency while swimming (Hz).\n\
             frequency = {}\n",
            self.deadman,
            self.estop,
            self.enable,
            self.disable,
            self.reset,
            self.heading_hold,
            self.depth_hold,
            self.speed.code,
            self.speed.invert,
            self.turn.code,
            self.turn.invert,
            self.pitch.code,
            self.pitch.invert,
            self.deadzone,
            self.frequency,
        )
    }
}

/// A gamepad event the translator cares about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JoyInput {
    /// A button changed (`pressed` false on release; auto-repeat is ignored).
    Button {
        /// The key code.
        code: KeyCode,
        /// Pressed or released.
        pressed: bool,
    },
    /// An absolute axis moved.
    Axis {
        /// The axis code.
        code: AbsoluteAxisCode,
        /// The raw value.
        value: i32,
    },
}

impl JoyInput {
    /// The input of an evdev event, if it is a button or an absolute axis.
    pub fn from_evdev(ev: InputEvent) -> Option<Self> {
        match ev.destructure() {
            EventSummary::Key(_, code, 0) => Some(Self::Button {
                code,
                pressed: false,
            }),
            EventSummary::Key(_, code, 1) => Some(Self::Button {
                code,
                pressed: true,
            }),
            EventSummary::AbsoluteAxis(_, code, value) => Some(Self::Axis { code, value }),
            _ => None,
        }
    }
}

/// Raw range of an axis (from the device's `absinfo`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisRange {
    /// Smallest raw value.
    pub min: i32,
    /// Largest raw value.
    pub max: i32,
}

impl Default for AxisRange {
    /// The common 16-bit stick range.
    fn default() -> Self {
        Self {
            min: -32768,
            max: 32767,
        }
    }
}

impl AxisRange {
    /// `raw` mapped to -1..=1 (centre of the range is 0).
    pub fn normalize(&self, raw: i32) -> f64 {
        let span = (self.max as f64 - self.min as f64).max(1.0);
        (2.0 * (raw as f64 - self.min as f64) / span - 1.0).clamp(-1.0, 1.0)
    }
}

/// `x` (-1..=1) with `deadzone` around 0 removed and the rest rescaled to
/// reach ±1 at full deflection.
pub fn apply_deadzone(x: f64, deadzone: f64) -> f64 {
    let a = x.abs();
    if a <= deadzone {
        0.0
    } else {
        x.signum() * ((a - deadzone) / (1.0 - deadzone)).min(1.0)
    }
}

/// The gamepad translator (see the module documentation).
#[derive(Debug, Clone)]
pub struct Joy {
    mapping: JoyMapping,
    limits: Limits,
    ranges: [AxisRange; 3],
    /// Speed, turn, pitch: after deadzone and inversion, -1..=1.
    sticks: [f64; 3],
    deadman: bool,
    swimming: bool,
    hold: HoldIntent,
}

impl Joy {
    /// A translator with the deadman released and the sticks centred.
    pub fn new(mapping: JoyMapping, limits: Limits) -> Self {
        Self {
            mapping,
            limits,
            ranges: [AxisRange::default(); 3],
            sticks: [0.0; 3],
            deadman: false,
            swimming: false,
            hold: HoldIntent::default(),
        }
    }

    /// What the operator wants the autopilot to hold.
    pub fn hold(&self) -> Hold {
        self.hold.wanted()
    }

    /// The hold to send now, if any (after a hold button, a swim that
    /// started with a hold armed, or a tick that moved a held target).
    pub fn hold_update(&mut self) -> Option<Command> {
        self.hold.update(self.swimming)
    }

    /// Follows the daemon: its estimate (a hold captures it), and the end
    /// of a swim it decided (the hold ends with it).
    pub fn observe(&mut self, s: &StateSnapshot) {
        self.hold.observe_nav(&s.nav);
        if swim_ended_by_daemon(s.mode, s.cause) {
            self.hold.clear();
        }
    }

    /// The daemon refused a hold: adopt what it holds.
    pub fn hold_refused(&mut self) {
        self.hold.refused();
    }

    /// The mapping in use.
    pub fn mapping(&self) -> &JoyMapping {
        &self.mapping
    }

    /// Sets the raw range of `code` (from the device), if it is a mapped axis.
    pub fn set_range(&mut self, code: AbsoluteAxisCode, range: AxisRange) {
        for (i, a) in self.axes().into_iter().enumerate() {
            if a.code == code {
                self.ranges[i] = range;
            }
        }
    }

    fn axes(&self) -> [AxisMap; 3] {
        [self.mapping.speed, self.mapping.turn, self.mapping.pitch]
    }

    /// Whether the deadman button is held.
    pub fn deadman(&self) -> bool {
        self.deadman
    }

    /// The gait the sticks ask for now (no turn while a heading is held,
    /// no pitch while a depth is held: those sticks move the targets).
    pub fn params(&self) -> SwimParams {
        let [speed, turn, pitch] = self.sticks;
        let h = self.hold.wanted();
        SwimParams {
            amplitude: speed.max(0.0),
            frequency: self.mapping.frequency.min(self.limits.max_frequency),
            turn: if h.heading.is_some() {
                0.0
            } else {
                turn * self.limits.max_turn
            },
            pitch: if h.depth.is_some() {
                0.0
            } else {
                pitch * self.limits.max_pitch
            },
        }
    }

    /// Feeds one input; returns the command to send at once, if any.
    pub fn handle(&mut self, input: JoyInput) -> Option<Command> {
        let m = self.mapping;
        match input {
            JoyInput::Button { code, pressed } => {
                if code == m.estop && pressed {
                    self.end_swim();
                    return Some(Command::EStop);
                }
                if code == m.deadman {
                    if pressed && !self.deadman {
                        self.deadman = true;
                        return Some(Command::TakeControl);
                    }
                    if !pressed && self.deadman {
                        return self.release();
                    }
                    return None;
                }
                if !pressed || !self.deadman {
                    return None;
                }
                if code == m.enable {
                    Some(Command::Enable)
                } else if code == m.disable {
                    self.end_swim();
                    Some(Command::Disable)
                } else if code == m.reset {
                    self.end_swim();
                    Some(Command::Reset)
                } else if code == m.heading_hold {
                    self.hold.toggle_heading();
                    self.hold_update()
                } else if code == m.depth_hold {
                    self.hold.toggle_depth();
                    self.hold_update()
                } else {
                    None
                }
            }
            JoyInput::Axis { code, value } => {
                for (i, a) in self.axes().into_iter().enumerate() {
                    if a.code == code {
                        let x = self.ranges[i].normalize(value);
                        let x = if a.invert { -x } else { x };
                        self.sticks[i] = apply_deadzone(x, m.deadzone);
                    }
                }
                None
            }
        }
    }

    /// Not swimming, nothing held (the daemon ends a hold with the swim).
    fn end_swim(&mut self) {
        self.swimming = false;
        self.hold.clear();
    }

    fn release(&mut self) -> Option<Command> {
        self.deadman = false;
        self.end_swim();
        Some(Command::Stop)
    }

    /// The pad disappeared: like a deadman release (one stop, then nothing),
    /// and the sticks are forgotten. `None` if the deadman was not held.
    pub fn disconnected(&mut self) -> Option<Command> {
        self.sticks = [0.0; 3];
        if self.deadman { self.release() } else { None }
    }

    /// The command of one steady period ([`STEADY_PERIOD`]): nothing
    /// without the deadman; the swim while the speed stick is pushed; one
    /// stop when it came back to the centre during a swim; otherwise a
    /// keep-alive. While swimming, a held target moves by its stick's
    /// rate over one period (a late tick moves it less, never more).
    pub fn tick(&mut self) -> Option<Command> {
        if !self.deadman {
            return None;
        }
        let p = self.params();
        if p.amplitude > 0.0 {
            self.swimming = true;
            let dt = STEADY_PERIOD.as_secs_f64();
            let [_, turn, pitch] = self.sticks;
            self.hold.nudge_heading(turn * HEADING_RATE * dt);
            self.hold.nudge_depth(pitch * DEPTH_RATE * dt);
            Some(Command::Swim(p))
        } else if self.swimming {
            self.end_swim();
            Some(Command::Stop)
        } else {
            Some(Command::KeepAlive)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use evdev::EventType;

    fn joy() -> Joy {
        Joy::new(JoyMapping::default(), Limits::default())
    }

    fn button(code: KeyCode, pressed: bool) -> JoyInput {
        JoyInput::Button { code, pressed }
    }

    fn axis(code: AbsoluteAxisCode, value: i32) -> JoyInput {
        JoyInput::Axis { code, value }
    }

    #[test]
    fn evdev_events_become_inputs() {
        let ev = InputEvent::new(EventType::KEY.0, KeyCode::BTN_TL.code(), 1);
        assert_eq!(
            JoyInput::from_evdev(ev),
            Some(button(KeyCode::BTN_TL, true))
        );
        let ev = InputEvent::new(EventType::KEY.0, KeyCode::BTN_TL.code(), 0);
        assert_eq!(
            JoyInput::from_evdev(ev),
            Some(button(KeyCode::BTN_TL, false))
        );
        // Auto-repeat (2) and sync events are not inputs.
        let ev = InputEvent::new(EventType::KEY.0, KeyCode::BTN_TL.code(), 2);
        assert_eq!(JoyInput::from_evdev(ev), None);
        let ev = InputEvent::new(EventType::SYNCHRONIZATION.0, 0, 0);
        assert_eq!(JoyInput::from_evdev(ev), None);
        let ev = InputEvent::new(EventType::ABSOLUTE.0, AbsoluteAxisCode::ABS_RY.0, -500);
        assert_eq!(
            JoyInput::from_evdev(ev),
            Some(axis(AbsoluteAxisCode::ABS_RY, -500))
        );
    }

    #[test]
    fn nothing_but_estop_without_the_deadman() {
        let mut j = joy();
        assert_eq!(j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768)), None);
        assert_eq!(j.tick(), None, "stick pushed, deadman not held: silent");
        assert_eq!(j.handle(button(KeyCode::BTN_START, true)), None);
        assert_eq!(j.handle(button(KeyCode::BTN_SELECT, true)), None);
        assert_eq!(
            j.handle(button(KeyCode::BTN_EAST, true)),
            Some(Command::EStop)
        );
        assert_eq!(j.handle(button(KeyCode::BTN_EAST, false)), None);
    }

    #[test]
    fn deadman_takes_control_drives_and_sends_one_stop_on_release() {
        let mut j = joy();
        assert_eq!(
            j.handle(button(KeyCode::BTN_TL, true)),
            Some(Command::TakeControl)
        );
        assert_eq!(j.tick(), Some(Command::KeepAlive));
        assert_eq!(
            j.handle(button(KeyCode::BTN_START, true)),
            Some(Command::Enable)
        );
        // Full forward on the left stick, full left on the right stick.
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768));
        j.handle(axis(AbsoluteAxisCode::ABS_RX, -32768));
        let Some(Command::Swim(p)) = j.tick() else {
            panic!("expected a swim")
        };
        assert_eq!(p.amplitude, 1.0);
        assert_eq!(p.frequency, 1.0);
        assert_eq!(p.turn, 2.0, "full left is the daemon's max turn, positive");
        assert_eq!(p.pitch, 0.0);
        assert_eq!(
            j.handle(button(KeyCode::BTN_TL, false)),
            Some(Command::Stop)
        );
        for _ in 0..5 {
            assert_eq!(j.tick(), None, "then nothing");
        }
    }

    #[test]
    fn centring_the_speed_stick_stops_once_then_keeps_alive() {
        let mut j = joy();
        j.handle(button(KeyCode::BTN_TL, true));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -20000));
        assert!(matches!(j.tick(), Some(Command::Swim(_))));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, 0));
        assert_eq!(j.tick(), Some(Command::Stop));
        assert_eq!(j.tick(), Some(Command::KeepAlive));
        // Pulling back never means a negative amplitude.
        j.handle(axis(AbsoluteAxisCode::ABS_Y, 32767));
        assert_eq!(j.tick(), Some(Command::KeepAlive));
    }

    #[test]
    fn deadzone_and_ranges() {
        assert_eq!(apply_deadzone(0.1, 0.15), 0.0);
        assert_eq!(apply_deadzone(-0.15, 0.15), 0.0);
        assert_eq!(apply_deadzone(1.0, 0.15), 1.0);
        assert_eq!(apply_deadzone(-1.0, 0.15), -1.0);
        assert!((apply_deadzone(0.575, 0.15) - 0.5).abs() < 1e-12);
        let r = AxisRange { min: 0, max: 255 };
        assert_eq!(r.normalize(0), -1.0);
        assert_eq!(r.normalize(255), 1.0);
        assert!(r.normalize(128).abs() < 0.01);
        assert_eq!(r.normalize(1000), 1.0, "clamped");
        // A pad with 8-bit sticks: set its range, then centre reads zero.
        let mut j = joy();
        j.set_range(AbsoluteAxisCode::ABS_RY, r);
        j.handle(button(KeyCode::BTN_TL, true));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768));
        j.handle(axis(AbsoluteAxisCode::ABS_RY, 128));
        let Some(Command::Swim(p)) = j.tick() else {
            panic!()
        };
        assert_eq!(p.pitch, 0.0, "centre of a 0..255 axis is in the deadzone");
        j.handle(axis(AbsoluteAxisCode::ABS_RY, 0)); // pushed forward
        let Some(Command::Swim(p)) = j.tick() else {
            panic!()
        };
        assert_eq!(p.pitch, 1.0, "forward dives at the daemon's max pitch");
        // Small stick noise inside the deadzone sends a keep-alive, not a swim.
        let mut k = joy();
        k.handle(button(KeyCode::BTN_TL, true));
        k.handle(axis(AbsoluteAxisCode::ABS_Y, -3000));
        assert_eq!(k.tick(), Some(Command::KeepAlive));
    }

    fn nav_state(heading: f32, depth: f32) -> StateSnapshot {
        StateSnapshot {
            mode: anguilla_ipc::Mode::Swimming as u8,
            nav: anguilla_ipc::NavSnapshot {
                sensor: 1,
                samples: 10,
                heading_deg: heading,
                depth_m: depth,
                ..Default::default()
            },
            ..Default::default()
        }
    }

    fn hold_of(c: Option<Command>) -> Hold {
        match c {
            Some(Command::Hold(h)) => h,
            other => panic!("expected a hold, got {other:?}"),
        }
    }

    #[test]
    fn hold_buttons_capture_the_estimate_and_sticks_move_the_targets_at_a_rate() {
        let mut j = joy();
        j.observe(&nav_state(359.0, 0.05));
        // Without the deadman the hold buttons do nothing.
        assert_eq!(j.handle(button(KeyCode::BTN_WEST, true)), None);
        assert_eq!(j.hold(), Hold::MANUAL);
        j.handle(button(KeyCode::BTN_TL, true));
        // At rest: armed, sent once the swim starts.
        assert_eq!(j.handle(button(KeyCode::BTN_WEST, true)), None);
        assert_eq!(j.hold().heading, Some(359.0));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768));
        // Full left on the turn stick: the target moves, the swim does not turn.
        j.handle(axis(AbsoluteAxisCode::ABS_RX, -32768));
        let Some(Command::Swim(p)) = j.tick() else {
            panic!("expected a swim")
        };
        assert_eq!(p.turn, 0.0, "the autopilot steers");
        // One tick of 0.1 s at 30 deg/s to the left: 359 + 3 wraps to 2.
        let h = hold_of(j.hold_update());
        assert_eq!(h.heading, Some(2.0));
        assert_eq!(h.depth, None);
        assert_eq!(j.hold_update(), None, "sent once");
        // Stick centred: the target stays, nothing more is sent.
        j.handle(axis(AbsoluteAxisCode::ABS_RX, 0));
        j.tick();
        assert_eq!(j.hold_update(), None);
        // Depth hold while swimming goes out at once; the pitch stick pulled
        // back climbs at 0.2 m/s, never above the surface.
        let h = hold_of(j.handle(button(KeyCode::BTN_SOUTH, true)));
        assert_eq!(
            h,
            Hold {
                heading: Some(2.0),
                depth: Some(0.05)
            }
        );
        j.handle(axis(AbsoluteAxisCode::ABS_RY, 32767));
        let Some(Command::Swim(p)) = j.tick() else {
            panic!("expected a swim")
        };
        assert_eq!(p.pitch, 0.0);
        assert_eq!(hold_of(j.hold_update()).depth, Some(0.03));
        for _ in 0..5 {
            j.tick();
        }
        assert_eq!(hold_of(j.hold_update()).depth, Some(0.0));
        // Toggled off: manual, the sticks steer again.
        assert_eq!(
            hold_of(j.handle(button(KeyCode::BTN_WEST, true))).heading,
            None
        );
        j.handle(axis(AbsoluteAxisCode::ABS_RX, -32768));
        let Some(Command::Swim(p)) = j.tick() else {
            panic!("expected a swim")
        };
        assert_eq!(p.turn, 2.0);
        // The deadman's release ends the swim and the hold with it.
        assert_eq!(
            j.handle(button(KeyCode::BTN_TL, false)),
            Some(Command::Stop)
        );
        assert_eq!(j.hold(), Hold::MANUAL);
        assert_eq!(j.hold_update(), None);
    }

    #[test]
    fn the_daemon_ending_the_swim_or_refusing_ends_the_hold() {
        let mut j = joy();
        let mut s = nav_state(90.0, 1.0);
        j.observe(&s);
        j.handle(button(KeyCode::BTN_TL, true));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768));
        j.tick();
        assert!(j.handle(button(KeyCode::BTN_WEST, true)).is_some());
        s.mode = anguilla_ipc::Mode::Stopping as u8;
        s.cause = anguilla_ipc::Cause::SensorLost.code();
        j.observe(&s);
        assert_eq!(j.hold(), Hold::MANUAL);
        // A refused hold adopts the daemon's (here: none).
        s.mode = anguilla_ipc::Mode::Swimming as u8;
        j.observe(&s);
        assert!(j.handle(button(KeyCode::BTN_SOUTH, true)).is_some());
        j.hold_refused();
        assert_eq!(j.hold(), Hold::MANUAL);
        assert_eq!(j.hold_update(), None);
    }

    #[test]
    fn disappearing_pad_is_a_release() {
        let mut j = joy();
        assert_eq!(j.disconnected(), None);
        j.handle(button(KeyCode::BTN_TL, true));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768));
        assert!(matches!(j.tick(), Some(Command::Swim(_))));
        assert_eq!(j.disconnected(), Some(Command::Stop));
        assert_eq!(j.tick(), None);
        // Replugged: the old stick position is not remembered.
        j.handle(button(KeyCode::BTN_TL, true));
        assert_eq!(j.tick(), Some(Command::KeepAlive));
    }

    #[test]
    fn mapping_file_round_trips_and_names_bad_fields() {
        let l = Limits::default();
        let m = JoyMapping::default();
        assert_eq!(JoyMapping::from_toml(&m.to_toml(), l).unwrap(), m);
        assert_eq!(JoyMapping::from_toml("", l).unwrap(), m);
        let m2 = JoyMapping::from_toml(
            "deadman = \"BTN_TR\"\nturn-axis = \"ABS_X\"\ninvert-turn = false\ndeadzone = 0.3\n",
            l,
        )
        .unwrap();
        assert_eq!(m2.deadman, KeyCode::BTN_TR);
        assert_eq!(m2.turn.code, AbsoluteAxisCode::ABS_X);
        assert!(!m2.turn.invert);
        assert_eq!(m2.deadzone, 0.3);
        let mut j = Joy::new(m2, l);
        j.handle(button(KeyCode::BTN_TR, true));
        j.handle(axis(AbsoluteAxisCode::ABS_Y, -32768));
        j.handle(axis(AbsoluteAxisCode::ABS_X, -32768));
        let Some(Command::Swim(p)) = j.tick() else {
            panic!()
        };
        assert_eq!(p.turn, -2.0, "not inverted: left is negative");
        let e = JoyMapping::from_toml("deadman = \"BTN_NOPE\"", l).unwrap_err();
        assert!(e.to_string().contains("deadman"), "{e}");
        let e = JoyMapping::from_toml("pitch-axis = \"BTN_TL\"", l).unwrap_err();
        assert!(e.to_string().contains("pitch-axis"), "{e}");
        let e = JoyMapping::from_toml("frequency = 5.0", l).unwrap_err();
        assert!(e.to_string().contains("frequency"), "{e}");
        let e = JoyMapping::from_toml("deadzone = 1.0", l).unwrap_err();
        assert!(e.to_string().contains("deadzone"), "{e}");
        assert!(JoyMapping::from_toml("unknown-key = 1", l).is_err());
        let m3 = JoyMapping::from_toml("heading-hold = \"BTN_THUMBR\"", l).unwrap();
        assert_eq!(m3.heading_hold, KeyCode::BTN_THUMBR);
        assert_eq!(m3.depth_hold, KeyCode::BTN_SOUTH);
        let e = JoyMapping::from_toml("depth-hold = \"ABS_X\"", l).unwrap_err();
        assert!(e.to_string().contains("depth-hold"), "{e}");
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        fn input() -> impl Strategy<Value = JoyInput> {
            let buttons = prop_oneof![
                Just(KeyCode::BTN_TL),
                Just(KeyCode::BTN_EAST),
                Just(KeyCode::BTN_START),
                Just(KeyCode::BTN_NORTH),
                Just(KeyCode::BTN_SELECT),
                Just(KeyCode::BTN_SOUTH),
                Just(KeyCode::BTN_WEST),
            ];
            let axes = prop_oneof![
                Just(AbsoluteAxisCode::ABS_Y),
                Just(AbsoluteAxisCode::ABS_RX),
                Just(AbsoluteAxisCode::ABS_RY),
                Just(AbsoluteAxisCode::ABS_X),
            ];
            prop_oneof![
                (buttons, any::<bool>())
                    .prop_map(|(code, pressed)| JoyInput::Button { code, pressed }),
                (axes, any::<i32>()).prop_map(|(code, value)| JoyInput::Axis { code, value }),
            ]
        }

        proptest! {
            // Whatever the pad does: swims stay in the daemon's ranges;
            // without the deadman only an E-stop or the one release stop
            // goes out; after a release, ticks are silent.
            #[test]
            fn commands_are_in_range_and_need_the_deadman(
                steps in proptest::collection::vec((input(), any::<bool>()), 1..200)
            ) {
                let l = Limits::default();
                let mut j = joy();
                j.observe(&nav_state(358.0, 0.1));
                for (inp, tick) in steps {
                    let held_before = j.deadman();
                    let out = if tick { j.tick() } else { j.handle(inp) };
                    if let Some(Command::Hold(h)) = j.hold_update() {
                        prop_assert!(j.deadman(), "a hold without the deadman");
                        prop_assert!(h.heading.is_none_or(|d| (0.0..360.0).contains(&d)));
                        prop_assert!(h.depth.is_none_or(|d| d >= 0.0));
                    }
                    match out {
                        Some(Command::Swim(p)) => {
                            prop_assert!(j.deadman());
                            prop_assert!((0.0..=1.0).contains(&p.amplitude) && p.amplitude > 0.0);
                            prop_assert!(p.frequency > 0.0 && p.frequency <= l.max_frequency);
                            prop_assert!(p.turn.abs() <= l.max_turn);
                            prop_assert!(p.pitch.abs() <= l.max_pitch);
                        }
                        Some(Command::EStop) => {}
                        Some(Command::Stop) if held_before => {}
                        Some(Command::TakeControl) => prop_assert!(!held_before && j.deadman()),
                        Some(other) => prop_assert!(held_before && j.deadman(), "{other:?} without the deadman"),
                        None => {}
                    }
                    if !j.deadman() {
                        prop_assert_eq!(j.tick(), None);
                    }
                }
            }
        }
    }
}
