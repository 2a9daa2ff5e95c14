//! `anguilla`: the one user-facing binary. It parses the command line and
//! hands the work to the library crates; it holds no model maths, frame
//! layouts or control logic of its own.

mod protocol_cmd;
mod sim_cmd;

use clap::{Parser, Subcommand};

mod swim;

/// Software for eel-like swimming robots.
#[derive(Parser, Debug)]
#[command(name = "anguilla", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the swimming model on a gait of the paper (CSV, SVG plot, JSON, paper table).
    Swim(swim::SwimArgs),
    /// The vertebra CAN protocol: bus budget, DBC file.
    Protocol {
        #[command(subcommand)]
        cmd: protocol_cmd::ProtocolCmd,
    },
    /// Run the simulated robot on a bus (or behind an emulated SLCAN adapter) in real time.
    Sim(sim_cmd::SimArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        None => {
            use clap::CommandFactory;
            Cli::command().print_help()?;
            Ok(())
        }
        Some(Command::Swim(args)) => swim::run(&args),
        Some(Command::Protocol { cmd }) => protocol_cmd::run(cmd),
        Some(Command::Sim(args)) => sim_cmd::run(&args),
    }
}
