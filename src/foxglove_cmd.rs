//! `anguilla foxglove`: the live view for Foxglove and Lichtblick (issue
//! 17). The view is [`anguilla::foxglove`]'s; here are its options, the
//! daemon as the command line names it, and the closing line.

use anguilla::foxglove::{Daemon, Options};
use anguilla_ipc::Session;
use anguilla_teleop::operator::Operator;

use crate::output::outln;
use crate::teleop_cmd::DaemonArgs;

/// Arguments of `anguilla foxglove`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Open Foxglove or Lichtblick, 'Open connection', Foxglove WebSocket, \
    ws://127.0.0.1:8765; deploy/foxglove-layout.json is a dashboard for it. \
    The server has no authentication and no TLS: anyone who reaches the port sees the robot \
    (and, with [foxglove] commands = true, may publish operator commands on /anguilla/command). \
    Bind beyond loopback only on a network you trust, or tunnel it (ssh -L)."
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
    let opts = Options {
        bind: args.bind,
        rate: args.rate,
        duration: args.duration,
    };
    let c = anguilla::foxglove::run(&opts, &args.daemon)?;
    outln!(
        "anguilla foxglove: stopped: {} viewers served, {} refused at [foxglove] max-clients, {} \
         closed for subscribing to nothing",
        c.admitted,
        c.refused,
        c.idle_closed
    )
}

impl Daemon for DaemonArgs {
    fn config(&self) -> anyhow::Result<anguilla::config::Config> {
        self.at.config()
    }

    fn prefix(&self) -> anyhow::Result<String> {
        DaemonArgs::prefix(self)
    }

    fn remote(&self) -> anyhow::Result<bool> {
        Ok(DaemonArgs::remote(self)?.is_some())
    }

    fn open(&self, prefix: &str, tool: &str, commands: bool) -> anyhow::Result<Box<dyn Session>> {
        DaemonArgs::open(self, prefix, tool, commands)
    }

    fn operator(&self, prefix: &str, tool: &str, commands: bool) -> anyhow::Result<Operator> {
        DaemonArgs::operator(self, prefix, tool, commands)
    }
}
