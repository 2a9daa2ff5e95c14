//! `anguilla conform`: the node-conformance suite (`anguilla-conform`)
//! against a node on a bus, or against the built-in simulated node.

use std::time::Duration;

use anguilla_conform::{BusWire, Options, Report};
use anguilla_drivers::mem::MemBus;
use anguilla_protocol::message::{NodeId, Variant};
use anguilla_sim::{RobotConfig, SimRobot};
use anyhow::{Context, bail};
use clap::Args;

use crate::output::out;

/// Options of `anguilla conform`.
#[derive(Args, Debug)]
#[command(after_help = "\
Examples:
  anguilla conform --bus socketcan:can0 --node 3
  anguilla conform --bus slcan:/dev/ttyACM0@1000000 --node 1 --fd
  anguilla conform --node 2          # the built-in simulated node

The node is driven through every (state, input) row of the transition table
of protocol/README.md: it is enabled (holding where it is), E-stopped, made
to fault by its watchdog and configured. Run it on a bench, one node under
test, with the joint free to move. Exit status 0: every row agrees; 1: a row
disagrees or a state could not be reached (each is listed).")]
pub struct ConformArgs {
    /// Bus the node is on: socketcan:IFACE, slcan:DEVICE@BITRATE or
    /// mem:NAME. Without it, the built-in simulated robot's node, in real
    /// time.
    #[arg(long, value_name = "SPEC")]
    bus: Option<String>,
    /// The node under test, 1..=63.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=63))]
    node: u8,
    /// CAN FD (setpoint groups) instead of classic CAN.
    #[arg(long)]
    fd: bool,
    /// How long to watch the node after each input, ms (200..=5000: at
    /// least two heartbeat periods).
    #[arg(long, default_value_t = 250, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(200..=5000))]
    window_ms: u64,
    /// A state change must be announced by a heartbeat within this many
    /// ms of the input (1..=window; the protocol says "at once").
    #[arg(long, default_value_t = 50, value_name = "MS",
          value_parser = clap::value_parser!(u64).range(1..=5000))]
    prompt_ms: u64,
}

/// Runs the suite and prints the report; an error if the node does not
/// conform.
pub fn run(args: ConformArgs) -> anyhow::Result<()> {
    let node = NodeId::new(args.node).context("--node")?;
    let variant = if args.fd {
        Variant::Fd
    } else {
        Variant::Classic
    };
    if args.prompt_ms > args.window_ms {
        bail!(
            "--prompt-ms {} is longer than --window-ms {} (expected 1 ..= window)",
            args.prompt_ms,
            args.window_ms
        );
    }
    let opts = Options {
        window: Duration::from_millis(args.window_ms),
        prompt: Duration::from_millis(args.prompt_ms),
        ..Options::new(node, variant)
    };
    let report = match &args.bus {
        Some(spec) => {
            let bus = anguilla_drivers::open(spec).with_context(|| format!("opening {spec}"))?;
            anguilla_conform::run(&mut BusWire::new(bus), &opts)
                .with_context(|| format!("node {} on {spec}", args.node))?
        }
        None => against_builtin(&opts)?,
    };
    out!("{report}")?;
    verdict(&report)
}

fn verdict(report: &Report) -> anyhow::Result<()> {
    let (_, disagree, unreached, _) = report.counts();
    if report.conforms() {
        Ok(())
    } else {
        bail!(
            "node {} does not conform to protocol/README.md: {disagree} rows disagree, \
             {unreached} not reached",
            report.node.get()
        )
    }
}

/// The simulated robot (nodes 1..=N) on an in-process bus at 1 Mbit/s, on
/// its own thread in real time, as `anguilla run` starts it.
fn against_builtin(opts: &Options) -> anyhow::Result<Report> {
    let bus = MemBus::builder(&format!("anguilla-conform-{}", std::process::id()))
        .bitrate(1_000_000)
        .build();
    let host = bus.participant();
    let cfg = RobotConfig {
        variant: opts.variant,
        boot_time: Duration::from_millis(50),
        ..RobotConfig::with_joints(opts.node.get() as usize)
    };
    let clock = bus.clock();
    let robot = SimRobot::on_mem(cfg, bus.participant(), clock.now())
        .map_err(|e| anyhow::anyhow!("{e}"))
        .context("building the simulated robot")?;
    let running = robot
        .spawn(clock)
        .context("starting the simulated robot's thread")?;
    let report =
        anguilla_conform::run(&mut BusWire::new(host), opts).context("the built-in simulated node");
    let _ = running.stop();
    report
}
