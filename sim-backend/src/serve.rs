//! A simulated robot served on a bus until told to stop: what `anguilla
//! sim` runs once its options are checked ([`serve`]). The robot goes on
//! a named bus, or behind emulated SLCAN adapters on pseudo-terminals
//! (several on one simulated wire, or those alone without a robot); a
//! scenario, sensors off the bus and a recorder of the ground truth may
//! run beside it. What happens is told line by line to the caller.

use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::slcan::emulator::{EmulatorConfig, SlcanEmulator};
use anguilla_drivers::{Clock, MonotonicClock};

use crate::offbus::{SimSensorConfig, SimSensors};
use crate::robot::{RobotConfig, RunningSim, SimRobot, Truth};

/// Where the robot is served.
#[derive(Debug, Clone, PartialEq)]
pub enum Wire {
    /// A bus by its spec (`socketcan:IFACE`, `slcan:DEVICE@BITRATE`,
    /// `mem:NAME`).
    Bus(String),
    /// Emulated SLCAN adapters, each on its own pseudo-terminal, on one
    /// simulated wire.
    Adapters {
        /// How many (1..=8).
        count: usize,
        /// The wire's nominal bit rate (bit/s).
        bitrate: u32,
        /// CAN FD's data-phase bit rate (bit/s); `None` for classic CAN.
        data_bitrate: Option<u32>,
    },
}

/// A scenario file's name (for its errors) and its text.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioText {
    /// Its path, as the user gave it.
    pub name: String,
    /// Its lines (sim-backend/README.md).
    pub text: String,
}

/// Where the ground truth goes, 20 times a second, on a thread of its own
/// (`anguilla sim --truth`: an MCAP file stamped with the machine's
/// monotonic clock).
pub trait TruthSink: Send {
    /// Where it goes (a file's path), as the lines name it.
    fn name(&self) -> String;
    /// Writes one sample.
    fn write(&mut self, t: &Truth) -> io::Result<()>;
    /// Makes what is written so far survive a kill.
    fn flush(&mut self) -> io::Result<()>;
    /// Closes the record.
    fn finish(self: Box<Self>) -> io::Result<()>;
}

/// What to serve.
pub struct Serve {
    /// The robot; `None`: the adapters' wire alone (tools on different
    /// adapters talk to each other), only with [`Wire::Adapters`].
    pub robot: Option<RobotConfig>,
    /// Where.
    pub wire: Wire,
    /// Timed faults.
    pub scenario: Option<ScenarioText>,
    /// Sensors off the bus (a USBL, a DVL), sending what the body's
    /// truth gives.
    pub off_bus: Vec<SimSensorConfig>,
    /// Where the ground truth is recorded.
    pub truth: Option<Box<dyn TruthSink>>,
}

/// How [`serve`] waits between its status lines: sleeps until the
/// instant given (or is woken earlier) and says whether to stop (a
/// signal, the duration asked for, a test's flag).
pub type Wait<'a> = &'a dyn Fn(Instant) -> bool;

/// What went wrong: its text names what and why.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ServeError(String);

fn fail(what: impl std::fmt::Display, e: impl std::fmt::Display) -> ServeError {
    ServeError(format!("{what}: {e}"))
}

/// How often the ground truth is recorded (ns): the daemon's rate.
pub const TRUTH_PERIOD: Duration = Duration::from_millis(50);

/// Serves `s` until `wait` says stop, telling each line (the adapters'
/// devices, a status line a second, the end) to `say`.
pub fn serve(s: Serve, wait: Wait, say: &mut dyn FnMut(&str)) -> Result<(), ServeError> {
    let Serve {
        robot,
        wire,
        scenario,
        off_bus,
        truth,
    } = s;
    let mut emulators = Vec::new();
    let Some(cfg) = robot else {
        let Wire::Adapters {
            count,
            bitrate,
            data_bitrate,
        } = wire
        else {
            return Err(ServeError(
                "no robot: only emulated adapters can be served alone".into(),
            ));
        };
        let bus = wire_bus(bitrate, data_bitrate);
        emulators = start_adapters(&bus, count, bitrate, data_bitrate, say)?;
        return adapters_alone(emulators, bitrate, data_bitrate.is_some(), wait, say);
    };
    let joints = cfg.node_ids.len();
    let (fd, family) = (
        cfg.variant == anguilla_protocol::message::Variant::Fd,
        cfg.drive,
    );
    let (mut robot, clock): (SimRobot, Arc<dyn Clock>) = match &wire {
        Wire::Adapters {
            count,
            bitrate,
            data_bitrate,
        } => {
            let bus = wire_bus(*bitrate, *data_bitrate);
            emulators = start_adapters(&bus, *count, *bitrate, *data_bitrate, say)?;
            let clock = bus.clock();
            let robot = SimRobot::on_mem(cfg, bus.participant(), clock.now())
                .map_err(|e| fail("building the simulated robot", e))?;
            (robot, clock)
        }
        Wire::Bus(spec) => {
            let robot = crate::open_robot(cfg, spec)
                .map_err(|e| fail(format_args!("opening the bus {spec}"), e))?;
            let clock: Arc<dyn Clock> = match robot.mem_bus() {
                Some(b) => b.clock(),
                None => Arc::new(MonotonicClock::new()),
            };
            (robot, clock)
        }
    };
    if let Some(sc) = &scenario {
        robot
            .load_scenario(&sc.text)
            .map_err(|e| fail(format_args!("in the scenario file {}", sc.name), e))?;
    }
    // A joint is one node, or two drives (pitch:yaw), as the family says.
    let drives = if family.drive_per_axis() {
        let pairs: Vec<String> = (0..joints)
            .map(|j| {
                let [p, y] = robot.config().drive_ids(j);
                format!("{p}:{y}")
            })
            .collect();
        format!("{family} drives {}", pairs.join(","))
    } else if robot.config().observed.is_empty() {
        format!("nodes 1..={joints}")
    } else {
        let real: Vec<String> = robot.config().observed.iter().map(u8::to_string).collect();
        format!(
            "nodes 1..={joints} but {} (real ones on the bus, heard)",
            real.join(",")
        )
    };
    say(&format!(
        "simulated robot: {joints} joints ({} CAN), {drives}, on {}; Ctrl-C stops",
        if fd { "FD" } else { "classic" },
        robot.bus().spec()
    ));
    let running = robot
        .spawn(clock)
        .map_err(|e| fail("starting the simulation thread", e))?;
    // The sensors beside it, stopped when dropped at the end of this
    // function; the robot stopped if one cannot start.
    let _beside = match SimSensors::beside(&off_bus, &running) {
        Ok(b) => b,
        Err((c, e)) => {
            let _ = running.stop();
            return Err(fail(c.describe(), e));
        }
    };
    let truth_name = truth.as_ref().map(|t| t.name()).unwrap_or_default();
    let stop_truth = AtomicBool::new(false);
    let recorded = std::thread::scope(|scope| {
        let recorder = truth.map(|f| scope.spawn(|| record_truth(f, &running, &stop_truth)));
        each_second(wait, |_| {
            let t = running.truth();
            let s = running.status();
            say(&format!(
                "t {:7.1} s  speed {:+.3} m/s  heading {:5.1} deg  depth {:.2} m  nodes boot/disabled/enabled/fault/estop {:?}  frames in {} out {}  send errors {}  slipped {:.2} s",
                t.time.as_secs_f64(),
                t.forward_speed + 0.0, // no "-0.000" at rest
                t.heading.to_degrees().rem_euclid(360.0),
                t.depth + 0.0,
                s.states,
                s.stats.frames_in,
                s.stats.frames_out,
                s.stats.send_errors,
                s.stats.slipped.as_secs_f64(),
            ));
        });
        stop_truth.store(true, Ordering::Release);
        recorder.map(|r| {
            r.join()
                .unwrap_or_else(|_| (0, Some("the recorder panicked".into())))
        })
    });
    match recorded {
        Some((n, None)) => say(&format!(
            "ground truth: {n} samples of /sim/truth in {truth_name}"
        )),
        Some((n, Some(e))) => say(&format!(
            "ground truth LOST after {n} samples in {truth_name}: {e}"
        )),
        None => {}
    }
    let robot = running
        .stop()
        .ok_or_else(|| ServeError("the simulation thread stopped unexpectedly".into()))?;
    let s = robot.stats();
    say(&format!(
        "stopped at t {:.1} s: {} ticks, {} frames in, {} out, {} send errors, {} model errors, {} scenario events, {:.2} s slipped behind real time",
        robot.time().as_secs_f64(),
        s.ticks,
        s.frames_in,
        s.frames_out,
        s.send_errors,
        s.model_errors,
        s.events,
        s.slipped.as_secs_f64()
    ));
    drop(emulators);
    Ok(())
}

/// The simulated wire behind the emulated adapters: the nominal bit rate,
/// and the data phase's for CAN FD (at the nominal rate, a CAN FD robot's
/// traffic overloads it).
fn wire_bus(bitrate: u32, data_bitrate: Option<u32>) -> MemBus {
    let b = MemBus::builder("anguilla-sim-slcan").bitrate(bitrate);
    match data_bitrate {
        Some(d) => b.data_bitrate(d),
        None => b,
    }
    .build()
}

/// Writes `running`'s ground truth into `sink` every [`TRUTH_PERIOD`]
/// (flushed once a second) until `stop`; returns the samples written and
/// the error that ended the recording, if one did (the simulation goes on
/// without it).
fn record_truth(
    mut sink: Box<dyn TruthSink>,
    running: &RunningSim,
    stop: &AtomicBool,
) -> (u64, Option<String>) {
    let mut n = 0u64;
    let mut next = Instant::now();
    let mut written = (|| -> io::Result<()> {
        let mut last = None;
        while !stop.load(Ordering::Acquire) {
            let t = running.truth();
            // A simulation starved of the CPU may not have stepped since the
            // last sample: the same state again would say nothing new.
            if last.is_none_or(|l| t.time > l) {
                last = Some(t.time);
                sink.write(&t)?;
                n += 1;
                if n.is_multiple_of(20) {
                    sink.flush()?;
                }
            }
            next += TRUTH_PERIOD;
            std::thread::sleep(next.saturating_duration_since(Instant::now()));
        }
        Ok(())
    })();
    // Finished even after an error: what was written stays readable.
    let finished = sink.finish();
    if written.is_ok() {
        written = finished;
    }
    (n, written.err().map(|e| e.to_string()))
}

/// Starts `n` emulated SLCAN adapters on `bus`, each on its own pty, and
/// says each one's device path.
fn start_adapters(
    bus: &MemBus,
    n: usize,
    bitrate: u32,
    data_bitrate: Option<u32>,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<SlcanEmulator>, ServeError> {
    (0..n)
        .map(|k| {
            let emu = SlcanEmulator::on_pty(
                Box::new(bus.participant()),
                EmulatorConfig {
                    fd: data_bitrate.is_some(),
                    ..EmulatorConfig::default()
                },
            )
            .map_err(|e| {
                fail(
                    format_args!("creating the SLCAN pseudo-terminal of adapter {}", k + 1),
                    e,
                )
            })?;
            let path = emu.path().unwrap_or("?").to_owned();
            say(&match data_bitrate {
                Some(d) => format!(
                    "slcan device: {path} (open it with slcan:{path}@{bitrate}?fd=1; CAN FD, data phase at {d} bit/s)"
                ),
                None => format!("slcan device: {path} (open it with slcan:{path}@{bitrate})"),
            });
            Ok(emu)
        })
        .collect()
}

/// Calls `each` with the time since the start once a second, until
/// `wait` says stop.
fn each_second(wait: Wait, mut each: impl FnMut(Duration)) {
    let start = Instant::now();
    let mut next = start + Duration::from_secs(1);
    while !wait(next) {
        each(next - start);
        next += Duration::from_secs(1);
    }
}

/// The adapters on one simulated bus and nothing else.
fn adapters_alone(
    emulators: Vec<SlcanEmulator>,
    bitrate: u32,
    fd: bool,
    wait: Wait,
    say: &mut dyn FnMut(&str),
) -> Result<(), ServeError> {
    say(&format!(
        "no robot: {} adapter(s) on one simulated {} CAN bus at {bitrate} bit/s; Ctrl-C stops",
        emulators.len(),
        if fd { "FD" } else { "classic" },
    ));
    let started = Instant::now();
    each_second(wait, |el| {
        let (from, to) = frame_counts(&emulators);
        say(&format!(
            "t {:7.1} s  frames from hosts {from:?}  to hosts {to:?}",
            el.as_secs_f64(),
        ));
    });
    let (from, to) = frame_counts(&emulators);
    for e in emulators {
        e.stop();
    }
    say(&format!(
        "stopped after {:.1} s: frames from hosts {from:?}, to hosts {to:?}",
        started.elapsed().as_secs_f64()
    ));
    Ok(())
}

/// Frames each adapter took from its host onto the bus, and gave it.
fn frame_counts(emulators: &[SlcanEmulator]) -> (Vec<u64>, Vec<u64>) {
    let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
    emulators
        .iter()
        .map(|e| {
            (
                get(&e.stats().frames_from_host),
                get(&e.stats().frames_to_host),
            )
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A truth sink that counts, and fails after `fail_after` samples.
    struct Counting {
        n: Arc<AtomicU64>,
        fail_after: u64,
        failed: Arc<AtomicBool>,
        finished: Arc<AtomicBool>,
    }

    impl TruthSink for Counting {
        fn name(&self) -> String {
            "memory".into()
        }
        fn write(&mut self, _: &Truth) -> io::Result<()> {
            if self.n.load(Ordering::Acquire) >= self.fail_after {
                self.failed.store(true, Ordering::Release);
                return Err(io::Error::other("disk full"));
            }
            self.n.fetch_add(1, Ordering::AcqRel);
            Ok(())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
        fn finish(self: Box<Self>) -> io::Result<()> {
            self.finished.store(true, Ordering::Release);
            Ok(())
        }
    }

    /// Serves a 2-joint robot on an in-process bus until its truth sink
    /// has `until` samples or has failed, and gives the lines said.
    fn serve_counting(bus: &str, until: u64, fail_after: u64) -> (Vec<String>, u64, bool) {
        let n = Arc::new(AtomicU64::new(0));
        let finished = Arc::new(AtomicBool::new(false));
        let failed = Arc::new(AtomicBool::new(false));
        let sink = Counting {
            n: n.clone(),
            fail_after,
            failed: failed.clone(),
            finished: finished.clone(),
        };
        let s = Serve {
            robot: Some(RobotConfig::with_joints(2)),
            wire: Wire::Bus(format!("mem:{bus}")),
            scenario: None,
            off_bus: Vec::new(),
            truth: Some(Box::new(sink)),
        };
        // A state, not a time: stop once the sink has what we wait for.
        let give_up = Instant::now() + Duration::from_secs(60);
        let seen = n.clone();
        let wait = move |_: Instant| {
            while seen.load(Ordering::Acquire) < until
                && !failed.load(Ordering::Acquire)
                && Instant::now() < give_up
            {
                std::thread::sleep(Duration::from_millis(10));
            }
            true
        };
        let mut lines = Vec::new();
        serve(s, &wait, &mut |l| lines.push(l.to_string())).unwrap();
        (
            lines,
            n.load(Ordering::Acquire),
            finished.load(Ordering::Acquire),
        )
    }

    #[test]
    fn a_served_robot_says_what_it_is_records_its_truth_and_stops() {
        let (lines, n, finished) = serve_counting("serve-ok", 3, u64::MAX);
        assert!(n >= 3, "{n}");
        assert!(finished);
        assert!(
            lines[0].starts_with("simulated robot: 2 joints (classic CAN), nodes 1..=2, on mem:"),
            "{lines:?}"
        );
        assert!(
            lines
                .iter()
                .any(|l| l == &format!("ground truth: {n} samples of /sim/truth in memory")),
            "{lines:?}"
        );
        assert!(
            lines.last().unwrap().starts_with("stopped at t "),
            "{lines:?}"
        );
    }

    /// A sink that fails (a full disk) ends the record, not the robot: the
    /// loss is said, with the samples kept, and the record is closed.
    #[test]
    fn a_failing_truth_record_is_said_and_the_robot_goes_on() {
        let (lines, n, finished) = serve_counting("serve-full", u64::MAX, 2);
        assert_eq!(n, 2);
        assert!(finished, "closed after the error");
        assert!(
            lines
                .iter()
                .any(|l| l == "ground truth LOST after 2 samples in memory: disk full"),
            "{lines:?}"
        );
        assert!(
            lines.last().unwrap().starts_with("stopped at t "),
            "{lines:?}"
        );
    }

    #[test]
    fn bad_settings_are_named_errors() {
        let never = |_: Instant| true;
        let alone = Serve {
            robot: None,
            wire: Wire::Bus("mem:x".into()),
            scenario: None,
            off_bus: Vec::new(),
            truth: None,
        };
        let e = serve(alone, &never, &mut |_| {}).unwrap_err().to_string();
        assert_eq!(e, "no robot: only emulated adapters can be served alone");
        let bad_scenario = Serve {
            robot: Some(RobotConfig::with_joints(2)),
            wire: Wire::Bus("mem:serve-bad".into()),
            scenario: Some(ScenarioText {
                name: "faults.txt".into(),
                text: "1.0 node 3 sideways\n".into(),
            }),
            off_bus: Vec::new(),
            truth: None,
        };
        let e = serve(bad_scenario, &never, &mut |_| {})
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("in the scenario file faults.txt: "), "{e}");
        let no_bus = Serve {
            robot: Some(RobotConfig::with_joints(2)),
            wire: Wire::Bus("carrier-pigeon:1".into()),
            scenario: None,
            off_bus: Vec::new(),
            truth: None,
        };
        let e = serve(no_bus, &never, &mut |_| {}).unwrap_err().to_string();
        assert!(e.starts_with("opening the bus carrier-pigeon:1: "), "{e}");
    }
}
