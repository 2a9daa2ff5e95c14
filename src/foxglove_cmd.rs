//! `anguilla foxglove`: the live view for Foxglove and Lichtblick (issue
//! 17). Its own process, reading the daemon's state over iceoryx2 like any
//! operator tool (read-only: it never sends a command), so the real-time
//! daemon never links a WebSocket stack. It serves the channels of the
//! session's MCAP file (`anguilla_daemon::mcap_log`) over the Foxglove
//! WebSocket protocol.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use anguilla_daemon::mcap_log::{Scene, TOPICS, schemas};
use anyhow::Context as _;

use crate::output::outln;
use crate::teleop_cmd::DaemonArgs;

/// Arguments of `anguilla foxglove`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Open Foxglove or Lichtblick, 'Open connection', Foxglove WebSocket, \
    ws://127.0.0.1:8765; deploy/foxglove-layout.json is a dashboard for it. \
    The server has no authentication and no TLS: anyone who reaches the port sees the robot \
    (read-only). Bind beyond loopback only on a network you trust, or tunnel it (ssh -L)."
)]
pub struct FoxgloveArgs {
    #[command(flatten)]
    daemon: DaemonArgs,
    /// Listen on ADDR:PORT.
    #[arg(long, value_name = "ADDR:PORT", default_value = "127.0.0.1:8765")]
    bind: String,
    /// At most this many states per second to the viewers (the daemon
    /// publishes one a control period).
    #[arg(long, value_name = "HZ", default_value_t = 30.0)]
    rate: f64,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    duration: Option<f64>,
}

/// Runs `anguilla foxglove`.
pub fn run(args: FoxgloveArgs) -> anyhow::Result<()> {
    let addr: SocketAddr = args.bind.parse().map_err(|_| {
        anyhow::anyhow!(
            "--bind {}: expected ADDR:PORT (e.g. 127.0.0.1:8765 or [::1]:8765)",
            args.bind
        )
    })?;
    anyhow::ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate {} is invalid (expected states per second > 0)",
        args.rate
    );
    if let Some(d) = args.duration {
        anyhow::ensure!(
            d.is_finite() && d > 0.0,
            "--duration {d} is invalid (expected seconds > 0)"
        );
    }
    if !addr.ip().is_loopback() {
        eprintln!(
            "warning: --bind {addr}: not loopback; anyone who reaches this port sees the robot \
             (no authentication, no TLS)"
        );
    }
    let cfg = args.daemon.at.config()?;
    let prefix = args.daemon.prefix()?;
    let ctx = foxglove::Context::new();
    let server = foxglove::WebSocketServer::new()
        .name("anguilla")
        .bind(addr.ip().to_string(), addr.port())
        .context(&ctx)
        .start_blocking()
        .with_context(|| format!("serving on {addr}"))?;
    let mut channels = Vec::new();
    for (i, (name, data)) in schemas().into_iter().enumerate() {
        channels.push(
            ctx.channel_builder(TOPICS[i])
                .message_encoding("json")
                .schema(foxglove::Schema::new(name, "jsonschema", data))
                .build_raw()
                .with_context(|| format!("channel {}", TOPICS[i]))?,
        );
    }
    outln!(
        "anguilla foxglove: ws://{}:{} serving the robot at prefix '{prefix}' (Ctrl-C stops)",
        addr.ip(),
        server.port()
    )?;
    crate::signals::install();
    let start = Instant::now();
    let running = || {
        !crate::signals::requested()
            && args
                .duration
                .is_none_or(|d| start.elapsed().as_secs_f64() < d)
    };
    // The viewer may start before the daemon: it serves, and asks again
    // every half second (absolute deadlines; a stop signal cuts the wait).
    let mut next = anguilla_daemon::rt::monotonic_ns();
    let mut said = false;
    let mut op = loop {
        match args.daemon.operator(&prefix, "anguilla-foxglove", false) {
            Ok(op) => break op,
            Err(e) if running() => {
                if !said {
                    eprintln!("anguilla foxglove: waiting for the daemon ({e})");
                    said = true;
                }
                next += 500_000_000;
                crate::signals::sleep_until_ns(next);
            }
            Err(e) => {
                return Err(e);
            }
        }
    };
    let mut scene = Scene::new(&cfg);
    let every = Duration::from_secs_f64(1.0 / args.rate);
    let mut last = None::<Instant>;
    while running() {
        let Some(s) = op.wait_state(Duration::from_millis(100))?.copied() else {
            continue;
        };
        if last.is_some_and(|t| t.elapsed() < every) {
            continue;
        }
        last = Some(Instant::now());
        for (i, v) in scene.messages(&s) {
            channels[i].log(v.to_string().as_bytes());
        }
    }
    server.stop().wait_blocking();
    Ok(())
}
