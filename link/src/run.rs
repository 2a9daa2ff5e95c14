//! `anguilla link`'s run ([`run`]), for the binary and for tests: the
//! `[link]` section and the command line's overrides ([`RunOptions`])
//! checked and made into the bridge's [`LinkSettings`] (the TLS files
//! together or not at all, each endpoint listenable, the local socket's
//! directory prepared, the rates in range), the bridge opened (waiting for
//! the daemon), run until told to stop, and what it did ([`Report`]).
//!
//! What this crate does not own comes through [`Host`]: the model's
//! steady speeds (the daemon's) for ROS 2's `cmd_vel`, where position
//! fixes go (the daemon's `[sensor.usbl]`), the stop request (the
//! process's signals) and the wait for the daemon.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::Ordering::Relaxed;
use std::time::{Duration, Instant};

use crate::config::LinkConfig;
use crate::ros2::node::{PoseSettings, PoseStats, Ros2Settings, SPEED_RUNGS, SpeedTable};
use crate::{Bridge, Endpoint, LinkError, LinkSettings, Tls};

/// What `anguilla link` runs with: the prefix, the configuration's
/// `[link]`, and the command line's overrides of it.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The daemon's prefix.
    pub prefix: String,
    /// `[link]` of the configuration.
    pub config: LinkConfig,
    /// Endpoints to listen on instead of `[link] listen` (empty: those).
    pub listen: Vec<String>,
    /// Accept plain `tcp/` on loopback (or `[link] insecure-loopback`).
    pub insecure_loopback: bool,
    /// The robot's CA certificate, instead of `[link] ca`.
    pub ca: Option<PathBuf>,
    /// The robot's certificate, instead of `[link] cert`.
    pub cert: Option<PathBuf>,
    /// The robot's private key, instead of `[link] key`.
    pub key: Option<PathBuf>,
    /// Most states a second, instead of `[link] state-rate`.
    pub state_rate: Option<f64>,
    /// Stop after this many seconds (`None`: when [`Host::running`] says).
    pub duration: Option<f64>,
    /// The robot the daemon drives, for ROS 2's `tf` and limits.
    pub robot: Robot,
}

/// What the link needs of the daemon's configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Robot {
    /// `[robot] joints`.
    pub joints: usize,
    /// `[limits] angle`, `velocity`, `torque`.
    pub limits: [f64; 3],
    /// `[gait] max-frequency` (Hz).
    pub max_frequency: f64,
}

/// What [`run`] asks of the process that runs it.
pub trait Host {
    /// The model's steady speed at each amplitude rung at `frequency`
    /// (`anguilla_daemon::speed::steady_speeds`), for ROS 2's `cmd_vel`;
    /// asked only with `[link] ros2`. An error's whole text.
    fn steady_speeds(&self, frequency: f64) -> Result<[f64; SPEED_RUNGS], String>;
    /// Where ROS 2's position fixes go (the daemon's `[sensor.usbl]` udp:
    /// source); asked only with `[link] ros2` and `ros2-pose`. An error's
    /// whole text.
    fn pose_fix_target(&self) -> Result<SocketAddr, String>;
    /// The test the bridge runs while it holds: no stop requested and
    /// less than `duration` seconds (if any) since this call (which may
    /// install the stop signals' handlers).
    fn running(&self, duration: Option<f64>) -> Box<dyn Fn() -> bool>;
    /// Calls `open` until it succeeds or `running` ends, again while its
    /// error says the daemon is not up yet ([`LinkError::Ipc`]).
    /// Default: once.
    fn open_when_up(
        &self,
        running: &dyn Fn() -> bool,
        open: &mut dyn FnMut() -> Result<Bridge, LinkError>,
    ) -> Result<Bridge, LinkError> {
        let _ = running;
        open()
    }
    /// One line for the operator (default: standard error).
    fn say(&self, line: &str) {
        eprintln!("{line}");
    }
}

/// Why the link did not run, or stopped on an error.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Some of the TLS files given, not all three.
    #[error(
        "the CA, the certificate and the key go together (--ca, --cert, --key or [link] ca, \
         cert, key): give all three for TLS"
    )]
    PartialTls,
    /// An endpoint that does not parse, may not be listened on, or whose
    /// local directory could not be prepared.
    #[error("--listen {0}")]
    Listen(LinkError),
    /// The state rate out of range.
    #[error("--state-rate {0} is invalid (expected 0.1 ..= 1000 states a second)")]
    StateRate(f64),
    /// The duration not a positive number of seconds.
    #[error("--duration {0} is invalid (expected seconds > 0)")]
    Duration(f64),
    /// The model's steady speeds could not be computed ([`Host::steady_speeds`]).
    #[error(
        "the model's steady speeds, for ROS 2 cmd_vel ([model] and [gait] of the \
         configuration): {0}"
    )]
    Speeds(String),
    /// Position fixes have nowhere to go ([`Host::pose_fix_target`]).
    #[error("{0}")]
    Pose(String),
    /// The bridge could not be opened.
    #[error("starting the link for prefix '{prefix}'")]
    Open {
        /// The daemon's prefix.
        prefix: String,
        /// Why.
        #[source]
        source: LinkError,
    },
    /// The link failed (the prefix's socket, the running bridge).
    #[error(transparent)]
    Link(#[from] LinkError),
}

/// What a link that ran did.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Seconds from the start to the stop.
    pub seconds: f64,
    /// States published.
    pub states: u64,
    /// Their payload bytes.
    pub state_bytes: u64,
    /// Commands forwarded to the daemon.
    pub commands: u64,
    /// Commands rejected.
    pub rejected: u64,
    /// E-stops relayed.
    pub estops: u64,
    /// The ROS 2 node's, with `[link] ros2`.
    pub ros2: Option<Ros2Report>,
}

/// What the ROS 2 node did.
#[derive(Debug, Clone, PartialEq)]
pub struct Ros2Report {
    /// Messages published.
    pub published: u64,
    /// Twists sent as swims.
    pub twists: u64,
    /// Twists superseded by a newer one.
    pub superseded: u64,
    /// Twists dropped.
    pub dropped: u64,
    /// Messages that were not CDR.
    pub undecodable: u64,
    /// Twists beyond reach, clamped.
    pub clamped: u64,
    /// The position fixes', with `[link] ros2-pose`.
    pub pose: Option<PoseStats>,
}

/// The TLS files: the flag's, else the configuration's (empty: none).
fn pick(flag: &Option<PathBuf>, key: &str) -> Option<PathBuf> {
    flag.clone()
        .or_else(|| (!key.is_empty()).then(|| PathBuf::from(key)))
}

/// Runs the link as `opts` says until [`Host::running`] ends it; what it
/// says goes through [`Host::say`]. Every check of the options comes
/// before anything is opened.
pub fn run(opts: &RunOptions, host: &dyn Host) -> Result<Report, RunError> {
    let (l, prefix) = (&opts.config, &opts.prefix);
    let tls = match (
        pick(&opts.ca, &l.ca),
        pick(&opts.cert, &l.cert),
        pick(&opts.key, &l.key),
    ) {
        (Some(ca), Some(cert), Some(key)) => Some(Tls { ca, cert, key }),
        (None, None, None) => None,
        _ => return Err(RunError::PartialTls),
    };
    let texts = if opts.listen.is_empty() {
        &l.listen
    } else {
        &opts.listen
    };
    let listen = texts
        .iter()
        .map(|t| Endpoint::parse_at(t, prefix, tls.as_ref()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(RunError::Listen)?;
    let insecure_loopback = opts.insecure_loopback || l.insecure_loopback;
    for e in listen.iter().filter(|e| e.insecure()) {
        e.listenable(insecure_loopback).map_err(RunError::Listen)?;
        host.say(&format!(
            "anguilla link: WARNING: listening on {} without authentication \
             (insecure-loopback): every local user can drive the robot",
            e.text
        ));
    }
    if listen.iter().any(|e| e.unix) {
        // The socket Zenoh makes must be the group's (the directory, 0770,
        // keeps everyone else out).
        // SAFETY: umask has no preconditions.
        unsafe { libc::umask(0o007) };
    }
    if listen.contains(&Endpoint::local(prefix)?) {
        crate::prepare_local(prefix).map_err(RunError::Listen)?;
    }
    let kinds: Vec<&str> = listen
        .iter()
        .map(|e| match (e.tls, e.unix) {
            (true, _) => "TLS, mutual authentication",
            (false, true) => "Unix socket, the link's user and group only",
            (false, false) => "plain TCP on loopback, INSECURE",
        })
        .collect();
    let state_rate = opts.state_rate.unwrap_or(l.state_rate);
    if !(state_rate.is_finite() && (0.1..=1000.0).contains(&state_rate)) {
        return Err(RunError::StateRate(state_rate));
    }
    if let Some(d) = opts.duration
        && !(d.is_finite() && d > 0.0)
    {
        return Err(RunError::Duration(d));
    }
    // cmd_vel's speeds become amplitudes through the model's steady speed
    // at the frequency it swims (once, here; nothing to compute per twist)
    let speeds = if l.ros2 {
        host.steady_speeds(l.ros2_frequency)
            .map_err(RunError::Speeds)?
    } else {
        [0.0; SPEED_RUNGS]
    };
    // Checked with the configuration: a udp: [sensor.usbl] source.
    let pose_to = (l.ros2 && l.ros2_pose)
        .then(|| host.pose_fix_target().map_err(RunError::Pose))
        .transpose()?;
    let robot = &opts.robot;
    let settings = LinkSettings {
        prefix: prefix.clone(),
        listen,
        tls,
        state_rate,
        max_clients: l.max_clients as usize,
        idle_timeout: Duration::from_secs_f64(l.idle_timeout),
        allow_command: l.inbound.iter().any(|n| n == "command"),
        allow_estop: l.inbound.iter().any(|n| n == "estop"),
        publish_state: l.outbound.iter().any(|n| n == "state"),
        ros2: l.ros2.then(|| Ros2Settings {
            domain: l.ros2_domain,
            namespace: l.ros2_namespace.clone(),
            node: l.ros2_node.clone(),
            rates: crate::ros2::TOPICS
                .map(|(n, _)| l.ros2_rates.get(n).copied().unwrap_or(l.ros2_rate)),
            humble: l.ros2_distro == "humble",
            geometry: crate::ros2::state::Geometry {
                segments: anguilla_view::segments(robot.joints),
                limits: robot.limits,
            },
            allow_command: l.inbound.iter().any(|n| n == "command"),
            allow_estop: l.inbound.iter().any(|n| n == "estop"),
            speeds: SpeedTable::new(speeds),
            max_speed: l.ros2_max_speed,
            frequency: l.ros2_frequency.min(robot.max_frequency),
            pose: pose_to.map(|to| PoseSettings {
                to,
                frame: l.ros2_pose_frame.clone(),
                sigma: l.ros2_pose_sigma,
            }),
        }),
    };
    let start = Instant::now();
    let running = host.running(opts.duration);
    // The link may start before the daemon.
    let mut bridge = host
        .open_when_up(&*running, &mut || Bridge::open(settings.clone()))
        .map_err(|source| RunError::Open {
            prefix: prefix.clone(),
            source,
        })?;
    host.say(&format!(
        "anguilla link: prefix '{prefix}' on {} ({}; state at most {state_rate} Hz; \
         inbound {:?}, outbound {:?})",
        settings
            .listen
            .iter()
            .map(|e| e.text.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        kinds.join("; "),
        l.inbound,
        l.outbound,
    ));
    if let Some(n) = bridge.ros2() {
        let id = n.id();
        host.say(&format!(
            "anguilla link: ROS 2 node {}/{} on domain {} ({}; rmw_zenoh's wire; docs/ros2.md); \
             cmd_vel swims its linear.x through the model's steady speed at {} Hz, up to {:.3} m/s \
             (full amplitude{})",
            id.namespace.trim_end_matches('/'),
            id.name,
            id.domain,
            l.ros2_distro,
            n.settings().frequency,
            n.settings().speeds.max_speed().min(l.ros2_max_speed),
            if l.ros2_max_speed < n.settings().speeds.max_speed() {
                format!(
                    " swims {:.3} m/s; [link] ros2-max-speed caps it",
                    n.settings().speeds.max_speed()
                )
            } else {
                String::new()
            }
        ));
        if let Some(p) = &n.settings().pose {
            host.say(&format!(
                "anguilla link: ROS 2 position fixes: pose_fix and odom_fix in frame {:?} go to \
                 the daemon's [sensor.usbl] at {}, aged by their stamps",
                p.frame, p.to
            ));
        }
    }
    bridge.run(&|| !running())?;
    let st = bridge.stats();
    Ok(Report {
        seconds: start.elapsed().as_secs_f64(),
        states: st.states.load(Relaxed),
        state_bytes: st.state_bytes.load(Relaxed),
        commands: st.commands.load(Relaxed),
        rejected: st.rejected.load(Relaxed),
        estops: st.estops.load(Relaxed),
        ros2: bridge.ros2().map(|n| Ros2Report {
            published: n.published,
            twists: n.twists,
            superseded: n.superseded(),
            dropped: n.dropped,
            undecodable: n.undecodable(),
            clamped: n.clamped,
            pose: n.pose_stats(),
        }),
    })
}

#[cfg(test)]
mod tests {
    use std::cell::RefCell;

    use super::*;

    /// A host that records what is said and is asked nothing else: every
    /// refusal below comes before the link would start.
    #[derive(Default)]
    struct Quiet(RefCell<Vec<String>>);

    impl Host for Quiet {
        fn steady_speeds(&self, _: f64) -> Result<[f64; SPEED_RUNGS], String> {
            panic!("asked for the model's speeds")
        }
        fn pose_fix_target(&self) -> Result<SocketAddr, String> {
            panic!("asked where fixes go")
        }
        fn running(&self, _: Option<f64>) -> Box<dyn Fn() -> bool> {
            panic!("started")
        }
        fn say(&self, line: &str) {
            self.0.borrow_mut().push(line.to_string());
        }
    }

    fn options(listen: &[&str]) -> RunOptions {
        RunOptions {
            prefix: "anguilla-link-run-test".into(),
            config: LinkConfig::default(),
            listen: listen.iter().map(|s| s.to_string()).collect(),
            insecure_loopback: false,
            ca: None,
            cert: None,
            key: None,
            state_rate: None,
            duration: None,
            robot: Robot {
                joints: 4,
                limits: [1.0, 5.0, 2.0],
                max_frequency: 2.0,
            },
        }
    }

    /// [`run`] refuses before it opens anything: plain TCP without
    /// insecure-loopback (named, with what to do), a non-loopback plain
    /// TCP address even with it, half the TLS files, a state rate and a
    /// duration out of range; an accepted insecure endpoint is warned of.
    #[test]
    fn run_refuses_bad_options_by_name_before_opening_anything() {
        let host = Quiet::default();
        let e = run(&options(&["tcp/127.0.0.1:7447"]), &host).unwrap_err();
        assert!(
            matches!(e, RunError::Listen(LinkError::Endpoint { .. })),
            "{e:?}"
        );
        let text = e.to_string();
        assert!(
            text.starts_with(
                "--listen endpoint 'tcp/127.0.0.1:7447': plain TCP has no authentication"
            ),
            "{text}"
        );
        let mut o = options(&["tcp/192.0.2.1:7447"]);
        o.insecure_loopback = true;
        assert!(matches!(run(&o, &host), Err(RunError::Listen(_))));
        let mut o = options(&["tcp/127.0.0.1:7447"]);
        o.ca = Some("ca.pem".into());
        assert!(matches!(run(&o, &host), Err(RunError::PartialTls)));
        let mut o = options(&["tcp/127.0.0.1:7447"]);
        o.insecure_loopback = true;
        o.state_rate = Some(0.0);
        let e = run(&o, &host).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--state-rate 0 is invalid (expected 0.1 ..= 1000 states a second)"
        );
        assert_eq!(host.0.borrow().len(), 1);
        assert!(host.0.borrow()[0].contains("WARNING: listening on tcp/127.0.0.1:7447"));
        o.state_rate = None;
        o.duration = Some(f64::NAN);
        assert!(matches!(run(&o, &host), Err(RunError::Duration(d)) if d.is_nan()));
    }
}
