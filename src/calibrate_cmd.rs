//! `anguilla calibrate`: fits the model's hydrodynamic coefficients to
//! recorded sessions (docs/calibration.md). The work is
//! [`anguilla::calibrate`]'s; here are its options and the call.

use std::path::PathBuf;

use anguilla::calibrate::{Options, calibrate};
use anguilla_daemon::mcap_log::swim;
use clap::Args;

/// Options of `anguilla calibrate`.
#[derive(Args, Debug)]
#[command(after_help = "\
Examples:
  anguilla calibrate /var/lib/anguilla/session-1795322959
  anguilla calibrate SESSION_A SESSION_B --holdout SESSION_C --write anguilla.toml
  anguilla calibrate session.mcap --fit c2,c3 --tracking mocap.csv

A SESSION is a recorded session directory ([recording] dir) or its
session.mcap. The fit replays each session's recorded joint motion on the
model and adjusts the coefficients until the replayed head swims as the
recorded one (speed, turn rate, depth rate) and the joints need the
recorded torques; docs/calibration.md explains the method and its limits.")]
pub struct CalibrateArgs {
    /// Sessions to fit.
    #[arg(required = true, value_name = "SESSION")]
    sessions: Vec<PathBuf>,
    /// Sessions to test the fitted coefficients on, not fitted.
    #[arg(long, value_name = "SESSION", num_args = 1..)]
    holdout: Vec<PathBuf>,
    /// The coefficients to fit, comma-separated: some of c_p, k, c1, c2,
    /// c3, friction.
    #[arg(long, value_name = "LIST", default_value = "c_p,k,c1,c2,c3,friction")]
    fit: String,
    /// The nose's track (CSV lines time_s,x_m,y_m on the session's clock,
    /// as from motion capture or an overhead camera), for a robot without
    /// a speed sensor; once per session, in the sessions' order. It
    /// replaces a simulated robot's ground truth.
    #[arg(long, value_name = "FILE")]
    tracking: Vec<PathBuf>,
    /// The configuration whose [model] is the prior (default: the first
    /// session's config.toml, the one it was recorded with).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Write the fitted coefficients into this configuration file's
    /// [model] (created if missing; its other keys, comments and layout
    /// are kept, and its mode, owner and group; a symlink is written
    /// through to its target).
    #[arg(long, value_name = "FILE")]
    write: Option<PathBuf>,
    /// Fit even when a check of the recordings before the fit failed (a
    /// session too short, a gap, a saturated or outlying torque): for a
    /// look at what the fit makes of them. `--write` is refused all the
    /// same.
    #[arg(long)]
    ignore_checks: bool,
    /// The largest session (or tracking) file read, in MiB: a bigger one
    /// is refused by name. Sessions are streamed, not read whole.
    #[arg(long, value_name = "MIB", default_value_t = swim::MAX_SESSION_BYTES >> 20)]
    max_size: u64,
}

/// Runs `anguilla calibrate`.
pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let opts = Options {
        sessions: args.sessions,
        holdout: args.holdout,
        fit: args.fit,
        tracking: args.tracking,
        config: args.config,
        write: args.write,
        ignore_checks: args.ignore_checks,
        max_size: args.max_size,
    };
    calibrate(&opts, &mut |text| crate::output::out!("{text}")).map(|_| ())
}
