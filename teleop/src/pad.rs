//! The gamepad session of `anguilla joy`: a [`PadSource`] (evdev devices,
//! or a script in tests) feeding the [`Joy`] translator, hot-plug, and the
//! connection to the daemon.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anguilla_ipc::Command;
use anguilla_ipc::IpcError;
use evdev::AbsoluteAxisCode;

use crate::joy::{AxisRange, Joy, JoyInput, JoyMapping};
use crate::operator::{Operator, Refused, STEADY_PERIOD};

/// The pad went away (unplugged, or the device failed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PadGone;

/// Where gamepad inputs come from.
pub trait PadSource {
    /// Looks for a pad and opens it; its name when one is open.
    fn open(&mut self) -> Option<String>;
    /// The raw ranges of the open pad's axes.
    fn ranges(&self) -> Vec<(AbsoluteAxisCode, AxisRange)>;
    /// Waits up to `timeout` for inputs of the open pad and appends them
    /// to `out`; `Err` when the pad is gone (it is then closed).
    fn read(&mut self, timeout: Duration, out: &mut Vec<JoyInput>) -> Result<(), PadGone>;
}

/// Gamepads through Linux evdev: the device given, or the first one under
/// `/dev/input` with the mapping's deadman button and speed axis.
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

impl PadSource for EvdevPads {
    fn open(&mut self) -> Option<String> {
        let m = self.mapping;
        let (path, dev) = match &self.device {
            Some(p) => (p.clone(), evdev::Device::open(p).ok()?),
            None => evdev::enumerate().find(|(_, d)| {
                d.supported_keys().is_some_and(|k| k.contains(m.deadman))
                    && d.supported_absolute_axes()
                        .is_some_and(|a| a.contains(m.speed.code))
            })?,
        };
        dev.set_nonblocking(true).ok()?;
        let name = format!(
            "{} ({})",
            dev.name().unwrap_or("unnamed device"),
            path.display()
        );
        self.open = Some(dev);
        Some(name)
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

/// What a [`JoySession`] tells its user.
#[derive(Debug, Clone, PartialEq)]
pub enum JoyNotice {
    /// No pad found; waiting for one (said once per wait).
    Waiting,
    /// A pad was opened (its name).
    Connected(String),
    /// The pad disappeared; `stop_sent` if it was driving.
    Disconnected {
        /// One stop was sent (the deadman was held).
        stop_sent: bool,
    },
    /// The daemon's mode changed (snapshot code).
    Mode(u8),
    /// A command was refused.
    Refused(Refused),
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
    said_waiting: bool,
    next_look: Instant,
    next_tick: Instant,
    mode: Option<u8>,
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
            said_waiting: false,
            next_look: now,
            next_tick: now,
            mode: None,
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

    /// One turn (at most about 20 ms): look for a pad every second while
    /// none is open, read and translate its inputs, send the steady
    /// command when due, collect replies and state; `notice` hears what
    /// the operator should be told.
    pub fn step(&mut self, mut notice: impl FnMut(JoyNotice)) -> Result<(), IpcError> {
        let now = Instant::now();
        if !self.connected && now >= self.next_look {
            self.next_look = now + Duration::from_secs(1);
            match self.pads.open() {
                Some(name) => {
                    for (code, r) in self.pads.ranges() {
                        self.joy.set_range(code, r);
                    }
                    self.connected = true;
                    self.said_waiting = false;
                    notice(JoyNotice::Connected(name));
                }
                None if !self.said_waiting => {
                    self.said_waiting = true;
                    notice(JoyNotice::Waiting);
                }
                None => {}
            }
        }
        if self.connected {
            let mut inputs = std::mem::take(&mut self.inputs);
            inputs.clear();
            let read = self.pads.read(Duration::from_millis(10), &mut inputs);
            for i in inputs.drain(..) {
                if let Some(c) = self.joy.handle(i) {
                    self.send(c)?;
                }
            }
            self.inputs = inputs;
            if read.is_err() {
                self.connected = false;
                self.next_look = Instant::now() + Duration::from_millis(200);
                let stop = self.joy.disconnected();
                if let Some(c) = stop {
                    self.send(c)?;
                }
                notice(JoyNotice::Disconnected {
                    stop_sent: stop.is_some(),
                });
            }
        } else {
            self.op.wait_state(Duration::from_millis(20))?;
        }
        if Instant::now() >= self.next_tick {
            if let Some(c) = self.joy.tick() {
                self.op.send(c)?;
            }
            self.next_tick = Instant::now() + STEADY_PERIOD;
        }
        self.op.poll()?;
        if let Some(s) = self.op.state()
            && self.mode != Some(s.mode)
        {
            self.mode = Some(s.mode);
            notice(JoyNotice::Mode(s.mode));
        }
        if self.op.last_refused() != self.refused.as_ref() {
            self.refused = self.op.last_refused().cloned();
            if let Some(r) = &self.refused {
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
