//! `anguilla calibrate`: fits the model's hydrodynamic coefficients to
//! recorded sessions (docs/calibration.md).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anguilla_daemon::config::Config;
use anguilla_daemon::mcap_log::swim::{self, ReadSwim};
use anguilla_model::identify::{
    self, Coefficient, Evaluation, FitOptions, IDENTIFIED_WITHIN, MAX_CORRELATION,
};
use anyhow::{Context, bail};
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
    /// [model] (created if missing; its other keys are kept, its comments
    /// are not).
    #[arg(long, value_name = "FILE")]
    write: Option<PathBuf>,
}

fn read_all(paths: &[PathBuf], tracking: &[PathBuf]) -> anyhow::Result<Vec<ReadSwim>> {
    paths
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let track = match tracking.get(i) {
                Some(f) => {
                    let text = std::fs::read_to_string(f)
                        .with_context(|| format!("--tracking {}", f.display()))?;
                    Some(
                        swim::parse_tracking(&text, &f.display().to_string())
                            .map_err(anyhow::Error::msg)?,
                    )
                }
                None => None,
            };
            swim::read(p, track).map_err(anyhow::Error::msg)
        })
        .collect()
}

fn prior_config(args: &CalibrateArgs) -> anyhow::Result<(Config, String)> {
    if let Some(c) = &args.config {
        return Ok((Config::load(c)?, c.display().to_string()));
    }
    let first = &args.sessions[0];
    let dir = if first.is_dir() {
        first.clone()
    } else {
        first.parent().map(Path::to_path_buf).unwrap_or_default()
    };
    let recorded = dir.join("config.toml");
    if recorded.exists() {
        Ok((Config::load(&recorded)?, recorded.display().to_string()))
    } else {
        Ok((Config::default(), "the default configuration".into()))
    }
}

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:+.1} %", 100.0 * v)
    } else {
        "n/a".into()
    }
}

fn errors(o: &mut String, label: &str, ev: &Evaluation) {
    let f = |v: f64, unit: &str| {
        if v.is_finite() {
            format!("{v:.4} {unit}")
        } else {
            "n/a".into()
        }
    };
    let _ = writeln!(
        o,
        "  {label:<22} speed {}, turn rate {}, depth rate {}, head sway {}, torque {} RMS",
        f(ev.rms[0], "m/s"),
        f(ev.rms[1], "rad/s"),
        f(ev.rms[2], "m/s"),
        f(ev.rms[3], "rad"),
        f(ev.rms[4], "N·m")
    );
    for s in &ev.swims {
        let _ = writeln!(
            o,
            "    {}: mean speed {:.3} m/s, the model's {:.3} m/s ({}); torque RMS error {:.4} N·m",
            s.name,
            s.speed,
            s.model_speed,
            pct(s.speed_error()),
            s.torque_rms
        );
    }
}

/// Runs `anguilla calibrate`.
pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let fit = identify::parse_coefficients(&args.fit).map_err(|e| anyhow::anyhow!("--fit: {e}"))?;
    if args.tracking.len() > args.sessions.len() {
        bail!(
            "--tracking given {} times for {} sessions (expected at most one per session)",
            args.tracking.len(),
            args.sessions.len()
        );
    }
    let (cfg, prior_from) = prior_config(&args)?;
    let prior = cfg.model.body();
    let read = read_all(&args.sessions, &args.tracking)?;
    let holdout = read_all(&args.holdout, &[])?;
    let mut o = String::new();
    for r in read.iter().chain(&holdout) {
        let _ = writeln!(
            o,
            "{}: {:.1} s, {} joint samples; track from {}, heading and depth from {}{}",
            r.swim.name,
            r.swim.duration(),
            r.swim.samples.len(),
            r.track.name(),
            r.attitude.name(),
            if r.missing_torques > 0 {
                format!("; {} samples without every torque", r.missing_torques)
            } else {
                String::new()
            }
        );
        if let [_, Some(step)] = identify::steps(&r.swim)
            && step > identify::COARSE_RATE
        {
            let _ = writeln!(
                o,
                "  warning: its joint rates are recorded in steps of {step:.3} rad/s (classic \
                 CAN's feedback), too coarse for a fit: the estimates are biased by up to tens \
                 of percent. Record calibration swims with [bus] fd = true (docs/calibration.md)"
            );
        }
    }
    let swims: Vec<_> = read.into_iter().map(|r| r.swim).collect();
    let opts = FitOptions {
        fit,
        ..FitOptions::default()
    };
    let start = Instant::now();
    let result = identify::fit(&prior, &swims, &opts).map_err(|e| anyhow::anyhow!("{e}"))?;
    let took = start.elapsed().as_secs_f64();
    let _ = writeln!(
        o,
        "\nprior: [model] of {prior_from}; fitted {} in {took:.1} s ({} replays of the sessions, {} iterations)\n",
        args.fit, result.simulations, result.iterations
    );
    let _ = writeln!(o, "coefficient    prior   estimate ± 1σ        kept");
    for e in &result.estimates {
        let c = e.coefficient;
        let scale = e.estimate.abs().max(c.floor());
        let _ = writeln!(
            o,
            "{:<10} {:>8.4} {:>10.4} ± {:<8.4} {:>8.4}  {}",
            c.name(),
            e.prior,
            e.estimate,
            e.std_error,
            e.value,
            if e.identified {
                "identified".to_string()
            } else {
                let with = e
                    .correlated
                    .map(|(o, r)| format!("; correlated {r:+.2} with {}", o.name()))
                    .unwrap_or_default();
                format!(
                    "NOT identified (95 % interval ±{:.0} % of {:.3}, more than {:.0} %){with}; {}: {}",
                    200.0 * e.std_error / scale,
                    scale,
                    100.0 * IDENTIFIED_WITHIN,
                    match (e.fitted, e.confounded) {
                        (true, _) => "fitted all the same, standing in for the coefficients \
                                      left at the prior"
                            .to_string(),
                        (false, Some((o, r))) => format!(
                            "left at the prior, the swims telling only its combination with {} \
                             (correlated {r:+.2}, beyond {MAX_CORRELATION}; the prior knowing it \
                             better)",
                            o.name()
                        ),
                        (false, None) => {
                            "left at the prior, the swims knowing less of it than the prior"
                                .to_string()
                        }
                    },
                    c.needs()
                )
            }
        );
    }
    let _ = writeln!(
        o,
        "(the swims' head rolled at {:.2} rad/s RMS in the replay; the drives' own inertia, \
         friction and torque lag fitted as {:.4} kg·m², {:.4} N·m·s/rad and {:.1} ms)",
        result.after.roll_rate_rms,
        result.after.actuator[0],
        result.after.actuator[1],
        1e3 * result.after.actuator[2]
    );
    let _ = writeln!(o, "\nfit residual (RMS, fitted sessions):");
    errors(&mut o, "prior coefficients:", &result.before);
    errors(&mut o, "fitted coefficients:", &result.after);
    errors(&mut o, "every estimate:", &result.estimated);
    if !holdout.is_empty() {
        let hs: Vec<_> = holdout.into_iter().map(|r| r.swim).collect();
        // each model with the drives' inertia, friction and lag it was fitted
        // with, not refitted to the held-out sessions
        let judge = |body: &anguilla_model::Body, fitted: &Evaluation| {
            let opts = FitOptions {
                actuator: Some(fitted.actuator),
                ..opts.clone()
            };
            identify::compare(&[body], &hs, &opts)
                .map_err(|e| anyhow::anyhow!("{e}"))
                .map(|mut v| v.remove(0))
        };
        let b = judge(&prior, &result.before)?;
        let a = judge(&result.body, &result.after)?;
        let _ = writeln!(o, "\nheld-out sessions (not fitted):");
        errors(&mut o, "prior coefficients:", &b);
        errors(&mut o, "fitted coefficients:", &a);
    }
    let kept: Vec<_> = result.estimates.iter().filter(|e| e.fitted).collect();
    let _ = writeln!(o, "\n# [model] fragment (the fitted coefficients):");
    let _ = writeln!(o, "[model]");
    if kept.is_empty() {
        let _ = writeln!(o, "# none fitted: keep the current values");
    }
    for e in &kept {
        let _ = writeln!(
            o,
            "{} = {:.5}{}",
            e.coefficient.key(),
            e.value,
            if e.identified {
                ""
            } else {
                "  # not identified: stands in for the coefficients left at the prior"
            }
        );
    }
    if let Some(path) = &args.write {
        write_model(
            path,
            &kept
                .iter()
                .map(|e| (e.coefficient, e.value))
                .collect::<Vec<_>>(),
        )?;
        let _ = writeln!(
            o,
            "\nwrote {} coefficient(s) into {}",
            kept.len(),
            path.display()
        );
    }
    print!("{o}");
    Ok(())
}

/// Sets `values` in `path`'s `[model]` (a new file if missing), checking
/// the whole result before writing it.
fn write_model(path: &Path, values: &[(Coefficient, f64)]) -> anyhow::Result<()> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(e) => return Err(e).with_context(|| format!("--write {}", path.display())),
    };
    let mut table: toml::Table = toml::from_str(&text)
        .with_context(|| format!("--write {}: not a TOML file", path.display()))?;
    let model = table
        .entry("model")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let Some(model) = model.as_table_mut() else {
        bail!("--write {}: its `model` is not a table", path.display());
    };
    for (c, v) in values {
        model.insert(c.key().to_string(), toml::Value::Float(*v));
    }
    let out = toml::to_string(&table)?;
    Config::from_toml(&out, &path.display().to_string()).with_context(|| {
        format!(
            "--write {}: the result would not be a valid configuration",
            path.display()
        )
    })?;
    std::fs::write(path, out).with_context(|| format!("--write {}", path.display()))?;
    Ok(())
}
