//! `anguillad`: the daemon alone, the robot's service binary (the systemd
//! unit's `ExecStart`). The same daemon as `anguilla run`, with the same
//! flags, in a binary that holds nothing else: no terminal UI, no network
//! stack (no Zenoh, tokio, rustls or Foxglove server), so that it is small
//! and `[realtime] lock-memory` locks little (docs/performance.md).

use clap::Parser;

/// The anguilla daemon (the robot's service): `anguilla run` alone.
#[derive(Parser, Debug)]
#[command(name = "anguillad", version, long_about = None)]
struct Cli {
    #[command(flatten)]
    run: anguilla::daemon_cli::RunArgs,
}

fn main() -> std::process::ExitCode {
    anguilla::exit_code(anguilla::daemon_cli::run(Cli::parse().run))
}
