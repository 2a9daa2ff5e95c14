//! The gamepad session of `anguilla joy`: a [`PadSource`] (evdev devices,
//! or a script in tests) feeding the [`Joy`] translator, hot-plug, and the
//! connection to the daemon.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anguilla_ipc::IpcError;
use anguilla_ipc::{Command, CommandKind};
use evdev::{AbsoluteAxisCode, KeyCode};

use crate::joy::{AxisRange, Joy, JoyInput, JoyMapping};
use crate::operator::{Operator, Refused, STEADY_PERIOD};

/// The pad went away (unplugged, or the device failed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PadGone;

/// Why no pad could be opened.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NoPad {
    /// No event device has the mapping's deadman button and speed axis.
    #[error("no readable /dev/input/event* device with a {deadman:?} button and a {speed:?} axis")]
    NotFound {
        /// The mapping's deadman button.
        deadman: KeyCode,
        /// The mapping's speed axis.
        speed: AbsoluteAxisCode,
    },
    /// The device given cannot be opened (absent, or no permission).
    #[error("cannot open {}: {}", .path.display(), open_words(*.kind))]
    CannotOpen {
        /// The device given.
        path: PathBuf,
        /// Why.
        kind: std::io::ErrorKind,
    },
    /// The device given is not a gamepad the mapping can drive with (its
    /// event node now belongs to another device, or it is the wrong one).
    #[error("{} is {name:?}, which has no {missing}", .path.display())]
    NotAGamepad {
        /// The device given.
        path: PathBuf,
        /// The device's name.
        name: String,
        /// What it lacks, e.g. `BTN_TL button`.
        missing: String,
    },
}

/// Why an event device did not open, in words with the likely fix
/// (`std::io::ErrorKind`'s own words are "entity not found").
fn open_words(kind: std::io::ErrorKind) -> String {
    match kind {
        std::io::ErrorKind::NotFound => {
            "no such device (is the pad plugged in? `ls -l /dev/input/by-id/` lists them)".into()
        }
        std::io::ErrorKind::PermissionDenied => {
            "permission denied (join the group that owns it, usually `input`, or add a udev \
             rule)"
                .into()
        }
        other => other.to_string(),
    }
}

/// Where gamepad inputs come from.
pub trait PadSource {
    /// Looks for a pad and opens it; its name when one is open, else why not.
    fn open(&mut self) -> Result<String, NoPad>;
    /// The raw ranges of the open pad's axes.
    fn ranges(&self) -> Vec<(AbsoluteAxisCode, AxisRange)>;
    /// Waits up to `timeout` for inputs of the open pad and appends them
    /// to `out`; `Err` when the pad is gone (it is then closed).
    fn read(&mut self, timeout: Duration, out: &mut Vec<JoyInput>) -> Result<(), PadGone>;
}

/// Gamepads through Linux evdev: the device given, or the first one under
/// `/dev/input` with the mapping's deadman button and speed axis.
///
/// The device given is opened again by its path after an unplug, so give a
/// path that follows the pad (udev's `/dev/input/by-id/*-event-joystick`):
/// a replugged pad may get another `eventN`, and its old node may go to
/// another device, which is then refused ([`NoPad::NotAGamepad`]). Without
/// a device, `/dev/input` is scanned again, wherever the pad reappears.
pub struct EvdevPads {
    device: Option<PathBuf>,
    mapping: JoyMapping,
    open: Option<evdev::Device>,
}

impl std::fmt::Debug for EvdevPads {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EvdevPads")
            .field("device", &self.device)
            .field("open", &self.open.is_some())
            .finish()
    }
}

impl EvdevPads {
    /// Pads matching `mapping`, or only `device` if given.
    pub fn new(device: Option<PathBuf>, mapping: JoyMapping) -> Self {
        Self {
            device,
            mapping,
            open: None,
        }
    }
}

/// What `dev` lacks to be driven with `m` (its deadman button or its
/// speed axis), if anything.
fn lacks(dev: &evdev::Device, m: &JoyMapping) -> Option<String> {
    if !dev.supported_keys().is_some_and(|k| k.contains(m.deadman)) {
        Some(format!("{:?} button", m.deadman))
    } else if !dev
        .supported_absolute_axes()
        .is_some_and(|a| a.contains(m.speed.code))
    {
        Some(format!("{:?} axis", m.speed.code))
    } else {
        None
    }
}

impl PadSource for EvdevPads {
    fn open(&mut self) -> Result<String, NoPad> {
        let m = self.mapping;
        let (path, dev) = match &self.device {
            Some(p) => {
                let cannot = |e: std::io::Error| NoPad::CannotOpen {
                    path: p.clone(),
                    kind: e.kind(),
                };
                let dev = evdev::Device::open(p).map_err(cannot)?;
                if let Some(missing) = lacks(&dev, &m) {
                    return Err(NoPad::NotAGamepad {
                        path: p.clone(),
                        name: dev.name().unwrap_or("unnamed device").to_string(),
                        missing,
                    });
                }
                dev.set_nonblocking(true).map_err(cannot)?;
                (p.clone(), dev)
            }
            None => evdev::enumerate()
                .filter(|(_, d)| lacks(d, &m).is_none())
                .find(|(_, d)| d.set_nonblocking(true).is_ok())
                .ok_or(NoPad::NotFound {
                    deadman: m.deadman,
                    speed: m.speed.code,
                })?,
        };
        let name = format!(
            "{} ({})",
            dev.name().unwrap_or("unnamed device"),
            path.display()
        );
        self.open = Some(dev);
        Ok(name)
    }

    fn ranges(&self) -> Vec<(AbsoluteAxisCode, AxisRange)> {
        let Some(dev) = &self.open else {
            return vec![];
        };
        dev.get_absinfo()
            .map(|it| {
                it.map(|(code, info)| {
                    (
                        code,
                        AxisRange {
                            min: info.minimum(),
                            max: info.maximum(),
                        },
                    )
                })
                .collect()
            })
            .unwrap_or_default()
    }

    fn read(&mut self, timeout: Duration, out: &mut Vec<JoyInput>) -> Result<(), PadGone> {
        use std::os::fd::AsRawFd;
        let Some(dev) = &mut self.open else {
            return Err(PadGone);
        };
        let mut pfd = libc::pollfd {
            fd: dev.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd for the duration of the call.
        unsafe { libc::poll(&mut pfd, 1, timeout.as_millis().min(1000) as libc::c_int) };
        let hung_up = pfd.revents & (libc::POLLERR | libc::POLLHUP | libc::POLLNVAL) != 0;
        let gone = match dev.fetch_events() {
            Ok(evs) => {
                out.extend(evs.filter_map(JoyInput::from_evdev));
                false
            }
            Err(e) => e.kind() != std::io::ErrorKind::WouldBlock || hung_up,
        };
        if gone {
            self.open = None;
            return Err(PadGone);
        }
        Ok(())
    }
}

/// A deadman release this recent when the pad goes counts as its stop: the
/// kernel releases a disappearing device's held buttons microseconds before
/// reading it fails; a second covers a loaded machine, and a stop that
/// recent is worth reporting anyway.
const RELEASED_AT_UNPLUG: Duration = Duration::from_secs(1);

/// What a [`JoySession`] tells its user.
#[derive(Debug, Clone, PartialEq)]
pub enum JoyNotice {
    /// No pad found; waiting for one (said once per wait, and again
    /// when the reason changes).
    Waiting(NoPad),
    /// A pad was opened (its name).
    Connected(String),
    /// The pad disappeared; `stop_sent` if it was driving.
    Disconnected {
        /// One stop was sent: at the disconnection (the deadman was held),
        /// or for the deadman's release just before it. A real device's
        /// held buttons are released by the kernel as it goes (before
        /// reading it fails), so a pad unplugged while driving usually
        /// ends with a release; either way only one stop goes out.
        stop_sent: bool,
    },
    /// The daemon's mode changed (snapshot code).
    Mode(u8),
    /// What the autopilot holds changed, or it let go: its description
    /// (e.g. "heading 090.0°", "manual (let go: silent)").
    Autopilot(String),
    /// A command was refused.
    Refused(Refused),
}

/// The autopilot as a line for the operator: what it holds and its
/// targets, or manual and why it last let go.
pub fn autopilot_text(nav: &anguilla_ipc::NavSnapshot) -> String {
    let h = crate::hold::held(nav);
    let words = nav.hold_words();
    match crate::view::hold_text(&h) {
        Some(t) if !words.is_empty() => format!("{t} ({})", words.join("; ")),
        Some(t) => t,
        None if nav.hold_exit != 0 => format!(
            "manual (let go: {})",
            crate::view::sensor_name(nav.hold_exit)
        ),
        None => "manual".to_string(),
    }
}

/// A gamepad driving the daemon: hot-plug, the translator, the steady sender.
pub struct JoySession<P: PadSource> {
    /// The connection to the daemon.
    pub op: Operator,
    /// The translator.
    pub joy: Joy,
    /// The pads.
    pub pads: P,
    connected: bool,
    said_waiting: Option<NoPad>,
    /// When the deadman's release last sent a stop.
    release_stop: Option<Instant>,
    next_look: Instant,
    next_tick: Instant,
    mode: Option<u8>,
    autopilot: Option<(u8, u8, u8, u8)>,
    refused: Option<Refused>,
    inputs: Vec<JoyInput>,
}

impl<P: PadSource> std::fmt::Debug for JoySession<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JoySession")
            .field("op", &self.op)
            .field("connected", &self.connected)
            .finish()
    }
}

impl<P: PadSource> JoySession<P> {
    /// A session without a pad yet.
    pub fn new(op: Operator, joy: Joy, pads: P) -> Self {
        let now = Instant::now();
        Self {
            op,
            joy,
            pads,
            connected: false,
            said_waiting: None,
            release_stop: None,
            next_look: now,
            next_tick: now,
            mode: None,
            autopilot: None,
            refused: None,
            inputs: Vec::new(),
        }
    }

    /// Whether a pad is open.
    pub fn connected(&self) -> bool {
        self.connected
    }

    fn send(&mut self, c: Command) -> Result<(), IpcError> {
        self.op.send(c)?;
        self.next_tick = Instant::now() + STEADY_PERIOD;
        Ok(())
    }

    /// Sends the hold the translator wants sent, if any.
    fn send_hold(&mut self) -> Result<(), IpcError> {
        match self.joy.hold_update() {
            Some(h) => self.op.send(h),
            None => Ok(()),
        }
    }

    /// One turn (at most about 20 ms): look for a pad every second while
    /// none is open, read and translate its inputs, send the steady
    /// command when due, collect replies and state; `notice` hears what
    /// the operator should be told.
    pub fn step(&mut self, mut notice: impl FnMut(JoyNotice)) -> Result<(), IpcError> {
        let now = Instant::now();
        if !self.connected && now >= self.next_look {
            self.next_look = now + Duration::from_secs(1);
            match self.pads.open() {
                Ok(name) => {
                    for (code, r) in self.pads.ranges() {
                        self.joy.set_range(code, r);
                    }
                    self.connected = true;
                    self.said_waiting = None;
                    notice(JoyNotice::Connected(name));
                }
                Err(why) if self.said_waiting.as_ref() != Some(&why) => {
                    self.said_waiting = Some(why.clone());
                    notice(JoyNotice::Waiting(why));
                }
                Err(_) => {}
            }
        }
        if self.connected {
            let mut inputs = std::mem::take(&mut self.inputs);
            inputs.clear();
            let read = self.pads.read(Duration::from_millis(10), &mut inputs);
            for i in inputs.drain(..) {
                if let Some(c) = self.joy.handle(i) {
                    if c == Command::Stop {
                        // Only the deadman's release stops from an input.
                        self.release_stop = Some(Instant::now());
                    }
                    self.send(c)?;
                }
                self.send_hold()?;
            }
            self.inputs = inputs;
            if read.is_err() {
                self.connected = false;
                self.next_look = Instant::now() + Duration::from_millis(200);
                let stop = self.joy.disconnected();
                if let Some(c) = stop {
                    self.send(c)?;
                }
                let released = self
                    .release_stop
                    .is_some_and(|t| t.elapsed() < RELEASED_AT_UNPLUG);
                notice(JoyNotice::Disconnected {
                    stop_sent: stop.is_some() || released,
                });
            }
        } else {
            self.op.wait_state(Duration::from_millis(20))?;
        }
        if Instant::now() >= self.next_tick {
            if let Some(c) = self.joy.tick() {
                self.op.send(c)?;
            }
            self.send_hold()?;
            self.next_tick = Instant::now() + STEADY_PERIOD;
        }
        self.op.poll()?;
        if let Some(s) = self.op.state().copied() {
            self.joy.observe(&s);
            if self.mode != Some(s.mode) {
                self.mode = Some(s.mode);
                notice(JoyNotice::Mode(s.mode));
            }
            let ap = (
                s.nav.hold,
                s.nav.hold_exit,
                s.nav.heading_hold,
                s.nav.depth_hold,
            );
            if self.autopilot.is_some_and(|was| was != ap)
                || (self.autopilot.is_none() && ap != (0, 0, 0, 0))
            {
                notice(JoyNotice::Autopilot(autopilot_text(&s.nav)));
            }
            self.autopilot = Some(ap);
        }
        if self.op.last_refused() != self.refused.as_ref() {
            self.refused = self.op.last_refused().cloned();
            if let Some(r) = &self.refused {
                if r.kind == Some(CommandKind::Hold) {
                    self.joy.hold_refused();
                }
                notice(JoyNotice::Refused(r.clone()));
            }
        }
        Ok(())
    }

    /// Leaving: one stop if driving, then, if holding control, stop and
    /// release it (waiting up to `timeout` for each reply).
    pub fn quit(&mut self, timeout: Duration) -> Result<(), IpcError> {
        if let Some(c) = self.joy.disconnected() {
            self.op.send(c)?;
        }
        self.op.poll()?;
        if self.op.holds_control() {
            self.op.request(Command::Stop, timeout)?;
            self.op.request(Command::ReleaseControl, timeout)?;
        }
        Ok(())
    }
}
