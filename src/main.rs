//! `anguilla`: the one user-facing binary. It parses the command line and
//! hands the work to the library crates; it holds no model maths, frame
//! layouts or control logic of its own.

mod protocol_cmd;

use clap::{Parser, Subcommand};

/// Software for eel-like swimming robots.
#[derive(Parser, Debug)]
#[command(name = "anguilla", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The vertebra CAN protocol: bus budget, DBC file.
    Protocol {
        #[command(subcommand)]
        cmd: protocol_cmd::ProtocolCmd,
    },
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        None => {
            use clap::CommandFactory;
            Cli::command().print_help()?;
            Ok(())
        }
        Some(Command::Protocol { cmd }) => protocol_cmd::run(cmd),
    }
}
