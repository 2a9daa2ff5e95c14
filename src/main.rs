//! `anguilla`: the one user-facing binary. It parses the command line and
//! hands the work to the library crates; it holds no model maths, frame
//! layouts or control logic of its own.

mod calibrate_cmd;
mod conform_cmd;
mod ctl_cmd;
mod dump_cmd;
#[cfg(feature = "foxglove")]
mod foxglove_cmd;
#[cfg(feature = "remote")]
mod link_cmd;
mod manual_cmd;
mod plain;
mod protocol_cmd;
mod run_cmd;
mod sim_cmd;
mod teleop_cmd;

use anguilla::{daemon_cli, output, signals};
use clap::{CommandFactory as _, Parser, Subcommand};

mod swim;

/// Software for eel-like swimming robots.
#[derive(Parser, Debug)]
// Without a subcommand: the help on stderr, exit status 2 (a usage error).
#[command(name = "anguilla", version, about, long_about = None, arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the daemon: against the built-in simulated robot, or the bus named
    /// with --bus (real hardware is driven only then).
    Run(daemon_cli::RunArgs),
    /// Rerun the control loop on a recorded session (simulated clock) and
    /// check that its output matches the recording bit for bit.
    Replay(run_cmd::ReplayArgs),
    /// Write a recorded session's MCAP file (Foxglove, Lichtblick,
    /// PlotJuggler) from its state.bin and config.toml.
    Export(run_cmd::ExportArgs),
    /// Fit the model's hydrodynamic coefficients to recorded sessions
    /// (docs/calibration.md): each with its uncertainty, the fit residual,
    /// the held-out error, and a [model] fragment.
    Calibrate(calibrate_cmd::CalibrateArgs),
    /// Configuration: print the commented default, check a file.
    Config {
        #[command(subcommand)]
        cmd: run_cmd::ConfigCmd,
    },
    /// Run the swimming model on a gait of the paper (CSV, SVG plot, JSON, paper table).
    Swim(swim::SwimArgs),
    /// The vertebra CAN protocol: bus budget, DBC file.
    Protocol {
        #[command(subcommand)]
        cmd: protocol_cmd::ProtocolCmd,
    },
    /// Check a node against the protocol: drive it through every row of the
    /// transition table and report each disagreement.
    Conform(conform_cmd::ConformArgs),
    /// Print a bus's frames live, decoded with the anguilla protocol (and
    /// optionally log them in candump -l format), or decode a candump log
    /// offline (--file).
    Dump(dump_cmd::DumpArgs),
    /// Run the simulated robot on a bus (or behind an emulated SLCAN adapter) in real time.
    Sim(sim_cmd::SimArgs),
    /// Drive the robot from the keyboard (terminal UI).
    Teleop(teleop_cmd::TeleopArgs),
    /// Drive the robot with a gamepad (Linux evdev; hold the deadman button).
    Joy(teleop_cmd::JoyArgs),
    /// Watch the robot (read-only): terminal view with plots, or --json lines.
    Monitor(teleop_cmd::MonitorArgs),
    /// Serve the robot live to Foxglove and Lichtblick (Foxglove WebSocket
    /// protocol): the channels of the session's MCAP file, read-only.
    #[cfg(feature = "foxglove")]
    Foxglove(foxglove_cmd::FoxgloveArgs),
    /// Not in this build (the `foxglove` feature).
    #[cfg(not(feature = "foxglove"))]
    #[command(hide = true)]
    Foxglove(NotBuilt),
    /// Operate from other computers: bridge the daemon's state, commands and
    /// E-stop to Zenoh (`--connect` on the tools); `link certs` makes the
    /// robot's CA and certificates.
    #[cfg(feature = "remote")]
    Link(link_cmd::LinkArgs),
    /// Not in this build (the `remote` feature).
    #[cfg(not(feature = "remote"))]
    #[command(hide = true)]
    Link(NotBuilt),
    /// One operator command per call, for scripts: status, estop, enable,
    /// disable, reset, stop, swim (exit 0 done, 1 refused, 2 no daemon).
    Ctl(ctl_cmd::CtlArgs),
    /// Print the shell completion script for bash, zsh, fish, elvish or
    /// powershell (e.g. `anguilla completions bash >
    /// ~/.local/share/bash-completion/completions/anguilla`).
    Completions(manual_cmd::CompletionsArgs),
    /// Write the man pages, one per subcommand (anguilla.1, anguilla-run.1,
    /// ...), into a directory (e.g. `anguilla man /usr/local/share/man/man1`).
    Man(manual_cmd::ManArgs),
}

fn main() -> std::process::ExitCode {
    anguilla::exit_code(run(Cli::parse()))
}

/// The arguments of a command this build leaves out (it says so).
#[derive(clap::Args, Debug)]
struct NotBuilt {
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, hide = true)]
    _args: Vec<String>,
}

fn run(cli: Cli) -> anyhow::Result<()> {
    // A tool that talks to the daemon, run as root on the packaged layout,
    // runs as the service's user: the daemon can open only that user's
    // iceoryx2 files (anguilla_ipc::service_user). Before any thread starts.
    if matches!(
        cli.command,
        Command::Ctl(_)
            | Command::Teleop(_)
            | Command::Joy(_)
            | Command::Monitor(_)
            | Command::Link(_)
            | Command::Foxglove(_)
    ) && let Some(note) =
        anguilla_ipc::service_user::adopt(anguilla_ipc::service_user::Keep::Nothing)?
    {
        eprintln!("anguilla: {note}");
    }
    match cli.command {
        Command::Run(args) => daemon_cli::run(args),
        Command::Config { cmd } => run_cmd::config(cmd),
        Command::Replay(args) => run_cmd::replay(args),
        Command::Export(args) => run_cmd::export(args),
        Command::Calibrate(args) => calibrate_cmd::run(args),
        Command::Swim(args) => swim::run(&args),
        Command::Protocol { cmd } => protocol_cmd::run(cmd),
        Command::Sim(args) => sim_cmd::run(&args),
        Command::Dump(args) => dump_cmd::run(args),
        Command::Conform(args) => conform_cmd::run(args),
        Command::Teleop(args) => teleop_cmd::teleop(args),
        Command::Joy(args) => teleop_cmd::joy(args),
        Command::Monitor(args) => teleop_cmd::monitor(args),
        Command::Ctl(args) => ctl_cmd::run(args),
        Command::Completions(args) => manual_cmd::completions(&args, Cli::command()),
        Command::Man(args) => manual_cmd::man(&args, Cli::command()),
        #[cfg(feature = "foxglove")]
        Command::Foxglove(args) => foxglove_cmd::run(args),
        #[cfg(not(feature = "foxglove"))]
        Command::Foxglove(_) => anyhow::bail!(
            "anguilla foxglove: this anguilla was built without the live view: build it with \
             `--features foxglove` (or `--all-features`, everything)"
        ),
        #[cfg(feature = "remote")]
        Command::Link(args) => link_cmd::run(args),
        #[cfg(not(feature = "remote"))]
        Command::Link(_) => anyhow::bail!("anguilla link: {}", teleop_cmd::NOT_REMOTE),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every subcommand path of `cmd`'s tree (`["ctl", "swim"]`), hidden
    /// ones and clap's `help` left out.
    fn paths(cmd: &clap::Command, prefix: &[String], out: &mut Vec<Vec<String>>) {
        for sub in cmd.get_subcommands() {
            if sub.is_hide_set() || sub.get_name() == "help" {
                continue;
            }
            let mut p = prefix.to_vec();
            p.push(sub.get_name().to_owned());
            out.push(p.clone());
            paths(sub, &p, out);
        }
    }

    /// Whether the first cell of a docs/cli.md table row names `path`: a
    /// command in backticks starting with its first word, and each later
    /// word a word of the cell (`ctl enable\|disable` names `ctl disable`).
    fn names(cell: &str, path: &[String]) -> bool {
        let words: Vec<&str> = cell
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .filter(|w| !w.is_empty())
            .collect();
        let starts = cell.split('`').skip(1).step_by(2).any(|code| {
            code.split_whitespace().next() == Some(&path[0])
                || code.starts_with(&format!("anguilla {}", path[0]))
        });
        starts && path[1..].iter().all(|w| words.contains(&w.as_str()))
    }

    /// The CLI reference cannot drift from the code (issue 46: docs/cli.md
    /// lacked `calibrate` and `ctl calibrate-swim`): every subcommand of
    /// clap's tree is named in the first column of docs/cli.md's table.
    #[test]
    fn every_subcommand_is_in_docs_cli_md() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/cli.md");
        let doc = std::fs::read_to_string(path).unwrap();
        let cells: Vec<&str> = doc
            .lines()
            .filter(|l| l.starts_with("| `"))
            .filter_map(|l| l.split(" | ").next())
            .collect();
        let mut all = Vec::new();
        paths(&Cli::command(), &[], &mut all);
        assert!(all.len() > 20, "{all:?}");
        let missing: Vec<String> = all
            .iter()
            .filter(|p| !cells.iter().any(|c| names(c, p)))
            .map(|p| p.join(" "))
            .collect();
        assert!(
            missing.is_empty(),
            "docs/cli.md's table names no `{}` (add a row, or the word to its command's row)",
            missing.join("`, `")
        );
    }

    /// Every `--drive` option lists every family of `Family::ALL` in its
    /// help, from the one parser (issue 46: `sim --help` and `protocol dbc
    /// --help` listed anguilla, cia402 and odrive, not mit).
    #[test]
    fn every_drive_option_lists_every_family() {
        fn visit(cmd: &mut clap::Command, path: &str, seen: &mut Vec<String>) {
            let here = format!("{path} {}", cmd.get_name());
            if cmd.get_arguments().any(|a| a.get_long() == Some("drive")) {
                let help = cmd.render_long_help().to_string();
                for f in anguilla_protocol::Family::ALL {
                    assert!(
                        help.contains(&format!("- {}:", f.name())),
                        "{here} --help does not list {}:\n{help}",
                        f.name()
                    );
                }
                seen.push(here.clone());
            }
            for sub in cmd.get_subcommands_mut() {
                visit(sub, &here, seen);
            }
        }
        let mut cmd = Cli::command();
        cmd.build();
        let mut seen = Vec::new();
        visit(&mut cmd, "", &mut seen);
        for want in ["sim", "dump", "protocol budget", "protocol dbc"] {
            assert!(
                seen.iter().any(|s| s.ends_with(&format!(" {want}"))),
                "{want} has no --drive: {seen:?}"
            );
        }
    }
}
