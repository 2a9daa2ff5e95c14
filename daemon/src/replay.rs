//! Replaying a recorded session bit for bit: [`replay`] rebuilds the
//! controller from the recording's `config.toml`, feeds it the recorded
//! inputs of `session.log` ([`crate::session`]) on a simulated clock through
//! a bus that plays back the received frames, and compares every frame it
//! sends with the recorded ones.

use std::path::Path;

use anguilla_drivers::{Bus, BusCounters, BusState, Capabilities, Received, TimestampBase};
use anguilla_protocol::frame::Frame;

use crate::config::{Config, ConfigError};
use crate::control::{Controller, SetupError};
use crate::session::{self, Record, SessionError};

/// What is wrong with a recording, or with replaying it.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// `config.toml` is not valid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// `session.log` cannot be read, or a line of it is malformed.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The controller could not be rebuilt.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// `config.toml` is not the configuration the session was recorded with.
    #[error(
        "{path} is not the configuration this session was recorded with (its fingerprint differs \
         from session.log's 'config' line); put the recorded one back to replay"
    )]
    ForeignConfig {
        /// The file.
        path: String,
    },
}

/// The outcome of a replay.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReplayReport {
    /// Periods replayed.
    pub periods: usize,
    /// Frames compared.
    pub frames: usize,
    /// The first difference, if any: (period index, what differed).
    pub mismatch: Option<(usize, String)>,
    /// When the recording has no end (the daemon was killed, the disk
    /// filled): the line it stops at. Its last period may be incomplete,
    /// so it is not compared; every period before it was.
    pub truncated_at: Option<usize>,
    /// When the recorder stopped before the daemon and said why (below
    /// `[recording] min-free`): the reason. Its last period may be
    /// incomplete, so it is not compared; every period before it was.
    pub stopped: Option<String>,
}

impl ReplayReport {
    /// Whether every frame matched bit for bit.
    pub fn identical(&self) -> bool {
        self.mismatch.is_none()
    }
}

/// A bus that replays recorded input and collects output.
struct ReplayBus {
    rx: std::collections::VecDeque<Frame>,
    /// What the recording says was sent, to refuse the same sends.
    expected: Vec<(Frame, bool)>,
    tx: Vec<(Frame, bool)>,
    state: BusState,
}

impl Bus for ReplayBus {
    fn send(&mut self, frame: &Frame) -> anguilla_drivers::Result<()> {
        // Refused where the recorded bus refused this frame at this point.
        let refused = self
            .expected
            .get(self.tx.len())
            .is_some_and(|&(f, sent)| !sent && f == *frame);
        self.tx.push((*frame, !refused));
        if refused {
            Err(anguilla_drivers::LinkError::BusOff)
        } else {
            Ok(())
        }
    }
    fn recv(&mut self, _: std::time::Duration) -> anguilla_drivers::Result<Option<Received>> {
        Ok(self.rx.pop_front().map(|frame| Received {
            frame,
            timestamp: None,
        }))
    }
    fn state(&self) -> BusState {
        self.state
    }
    fn counters(&self) -> BusCounters {
        BusCounters::default()
    }
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            fd: true,
            remote: true,
            timestamps: TimestampBase::None,
            simulated_faults: false,
        }
    }
    fn flush_tx(&mut self) -> anguilla_drivers::Result<()> {
        Ok(())
    }
    fn reopen(&mut self) -> anguilla_drivers::OpenResult<()> {
        Ok(())
    }
    fn spec(&self) -> &str {
        "replay"
    }
}

/// Feeds one recorded input to the controller.
fn apply(ctl: &mut Controller, r: &Record) {
    match *r {
        Record::Command(t, env) => {
            ctl.command(t, &env);
        }
        Record::Dead(t, id) => {
            ctl.node_died(t, id);
        }
        Record::Shutdown(t) => ctl.begin_shutdown(t),
        _ => {}
    }
}

/// Replays the recording in `dir` and compares every frame sent.
pub fn replay(dir: &Path) -> Result<ReplayReport, ReplayError> {
    replay_with(dir, &mut |_, _| {})
}

/// [`replay`], telling `progress(periods done, periods in all)` every
/// [`PROGRESS_EVERY`] periods and at the end (for a progress bar).
pub fn replay_with(
    dir: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<ReplayReport, ReplayError> {
    let cfg_path = dir.join("config.toml");
    let cfg = Config::load(&cfg_path)?;
    let session::Session {
        start,
        mut periods,
        trailing,
        end,
        cut_at,
        stopped,
        config_hash,
    } = session::parse(&dir.join("session.log"))?;
    // The configuration, not its spelling: comments and layout may differ.
    if let Some(h) = config_hash
        && h != session::fnv1a(cfg.to_toml().as_bytes())
    {
        return Err(ReplayError::ForeignConfig {
            path: cfg_path.display().to_string(),
        });
    }
    // A cut or stopped recording's last period may have lost frames: not
    // compared.
    if cut_at.is_some() || stopped.is_some() {
        periods.pop();
    }
    // A sensor off the bus is not replayed: its readings are not among the
    // session's inputs (not recorded yet), and its source may be held by
    // the running daemon (a port in use). A path followed on its fixes
    // therefore differs from the first fix on (README, "Recording and
    // replay").
    let mut live = cfg.clone();
    live.sensor = cfg.sensor.without_off_bus();
    let mut ctl = Controller::new(&live, start)?;
    let mut bus = ReplayBus {
        rx: Default::default(),
        expected: Vec::new(),
        tx: Vec::new(),
        state: BusState::ErrorActive,
    };
    let mut report = ReplayReport {
        periods: 0,
        frames: 0,
        mismatch: None,
        truncated_at: cut_at,
        stopped,
    };
    let compare =
        |k: usize, expected: &[(Frame, bool)], got: &[(Frame, bool)], report: &mut ReplayReport| {
            let how = |sent: bool| if sent { "sent" } else { "refused" };
            for (i, ((e, es), (g, gs))) in expected.iter().zip(got).enumerate() {
                if e != g || es != gs {
                    report.mismatch = Some((
                        k,
                        format!(
                            "frame {i}: recorded {e} ({}), replayed {g} ({})",
                            how(*es),
                            how(*gs)
                        ),
                    ));
                    return;
                }
            }
            if expected.len() != got.len() {
                report.mismatch = Some((
                    k,
                    format!("{} frames recorded, {} replayed", expected.len(), got.len()),
                ));
                return;
            }
            report.frames += expected.len();
        };
    let total = periods.len() as u64;
    for (k, p) in periods.iter().enumerate() {
        if (k as u64).is_multiple_of(PROGRESS_EVERY) {
            progress(k as u64, total);
        }
        for r in &p.before {
            apply(&mut ctl, r);
        }
        bus.rx = p.rx.iter().copied().collect();
        bus.expected.clone_from(&p.tx);
        bus.tx.clear();
        bus.state = p.bus;
        ctl.run_period(p.now, &mut bus);
        report.periods += 1;
        compare(k, &p.tx, &bus.tx, &mut report);
        if report.mismatch.is_some() {
            return Ok(report);
        }
    }
    for r in &trailing {
        apply(&mut ctl, r);
    }
    if let Some(end) = end {
        bus.expected.clone_from(&end);
        bus.tx.clear();
        ctl.disable_all(&mut bus);
        compare(periods.len(), &end, &bus.tx, &mut report);
    }
    progress(total, total);
    Ok(report)
}

/// How many periods (or snapshots) between two progress reports.
pub const PROGRESS_EVERY: u64 = 1000;
