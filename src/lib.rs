//! The `anguilla` binaries' wiring that is more than argument handling,
//! as a library: the system tests start what `anguilla run` starts instead
//! of a copy of it ([`builtin_sim`], the simulated robot the daemon drives
//! when no bus is named), and the two binaries share it: `anguilla` (every
//! command) and `anguillad` (the daemon alone, the robot's service:
//! [`daemon_cli`]). [`config`] is the whole configuration file: the
//! daemon's sections and the other processes' (`[link]`, `[foxglove]`).
//! The commands whose work is more than a call into one crate have it here,
//! for their tests to call: [`calibrate`] (it writes the whole file) and,
//! with the `foxglove` feature, `foxglove` (the live view's server). The
//! link's run is its crate's (`anguilla_link::run`).

pub mod builtin_sim;
pub mod calibrate;
pub mod config;
pub mod daemon_cli;
pub mod family_arg;
#[cfg(feature = "foxglove")]
pub mod foxglove;
pub mod output;
pub mod signals;
pub mod user_file;

/// The exit status of a command that returned `result`, its error on
/// stderr: 0 done; 0 too when standard output was closed (`anguilla ... |
/// head`: the reader has what it wanted); 128 + the signal when a stop
/// signal (Ctrl-C, SIGTERM, SIGHUP) ended it before it could finish, the
/// user's own stop and not an error (130 for SIGINT); [`EXIT_CONFIG`] for a
/// configuration that cannot run; else 1.
pub fn exit_code(result: anyhow::Result<()>) -> std::process::ExitCode {
    use std::process::ExitCode;
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if output::closed_pipe(&e) => ExitCode::SUCCESS,
        Err(_) if signals::received().is_some() => {
            ExitCode::from(128 + signals::received().unwrap_or(2) as u8)
        }
        Err(e) => {
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "Error: {}", output::error_text(&e));
            if e.downcast_ref::<daemon_cli::Unrunnable>().is_some() {
                ExitCode::from(EXIT_CONFIG)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// The exit status of a daemon whose configuration cannot run (sysexits'
/// `EX_CONFIG`): a file that does not parse or check, a bus left unset. The
/// systemd unit does not restart on it (`RestartPreventExitStatus=78`):
/// trying again every 2 s would only fill the journal.
pub const EXIT_CONFIG: u8 = 78;
