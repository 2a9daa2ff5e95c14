//! `anguilla calibrate`'s work (docs/calibration.md), for the binary and
//! for tests: read the sessions and check them, fit the model's
//! hydrodynamic coefficients ([`anguilla_model::identify`]) to them, judge
//! the result on the fitted and the held-out sessions, and write the
//! identified coefficients into a configuration's `[model]` with a note of
//! what was not written and why ([`calibrate`]). The sessions are read by
//! [`anguilla_daemon::mcap_log::swim`].
//!
//! It lives in this crate, not the daemon's, because writing checks the
//! whole configuration file ([`crate::config`]) and replaces it the way
//! every user file is replaced ([`crate::user_file`]), both of this crate.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anguilla_daemon::config::Config;
use anguilla_daemon::mcap_log::swim::{self, ReadSwim};
use anguilla_model::identify::{
    self, Coefficient, Evaluation, FitOptions, IDENTIFIED_WITHIN, MAX_CORRELATION, check,
};
use anyhow::{Context, bail};

/// What to calibrate on and what to do with the result (`anguilla
/// calibrate`'s options).
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Sessions to fit (a session directory or its `session.mcap`); at
    /// least one.
    pub sessions: Vec<PathBuf>,
    /// Sessions to test the fitted coefficients on, not fitted.
    pub holdout: Vec<PathBuf>,
    /// The coefficients to fit, comma-separated
    /// ([`identify::parse_coefficients`]).
    pub fit: String,
    /// The nose's track per session, in the sessions' order (CSV
    /// `time_s,x_m,y_m`).
    pub tracking: Vec<PathBuf>,
    /// The configuration whose `[model]` is the prior (`None`: the first
    /// session's `config.toml`, else the default).
    pub config: Option<PathBuf>,
    /// Write the identified coefficients into this configuration file's
    /// `[model]`.
    pub write: Option<PathBuf>,
    /// Fit even when a check of the recordings failed (never with
    /// `write`).
    pub ignore_checks: bool,
    /// The largest session or tracking file read (MiB).
    pub max_size: u64,
}

/// What a calibration that went through decided.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The identified coefficients and their values: what
    /// [`Options::write`] writes.
    pub identified: Vec<(Coefficient, f64)>,
    /// `[model]`'s drive-inertia, drive-friction and drive-lag written
    /// (the fit's when physical, else the present configuration's).
    pub drive: [f64; 3],
    /// The file written, as the report names it (`None`: no
    /// [`Options::write`]).
    pub wrote: Option<String>,
}

/// The largest configuration read as the prior (bytes).
const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// Reads the regular file `path` of at most `max` bytes as text (a named
/// pipe or a device is refused at once, [`swim::open_regular`]).
fn read_text(path: &Path, max: u64, what: &str) -> anyhow::Result<String> {
    use std::io::Read as _;
    let (f, len) = swim::open_regular(path, max, what).map_err(anyhow::Error::msg)?;
    let mut text = String::with_capacity(len as usize);
    f.take(max)
        .read_to_string(&mut text)
        .with_context(|| format!("reading {}", path.display()))?;
    Ok(text)
}

/// The daemon's part of the configuration `path` (a regular file; the
/// whole file checked).
fn load_config(path: &Path) -> anyhow::Result<Config> {
    let text = read_text(path, MAX_CONFIG_BYTES, "a configuration file")?;
    Ok(crate::config::Config::from_toml(&text, &path.display().to_string())?.daemon)
}

fn read_all(paths: &[PathBuf], tracking: &[PathBuf], max: u64) -> anyhow::Result<Vec<ReadSwim>> {
    paths
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let track = match tracking.get(i) {
                Some(f) => {
                    let text = read_text(f, max, "a tracking CSV file")
                        .with_context(|| format!("--tracking {}", f.display()))?;
                    Some(
                        swim::parse_tracking(&text, &f.display().to_string())
                            .map_err(anyhow::Error::msg)?,
                    )
                }
                None => None,
            };
            swim::read_limited(p, track, max).map_err(anyhow::Error::msg)
        })
        .collect()
}

fn prior_config(opts: &Options) -> anyhow::Result<(Config, String)> {
    if let Some(c) = &opts.config {
        return Ok((load_config(c)?, c.display().to_string()));
    }
    let first = &opts.sessions[0];
    let dir = if first.is_dir() {
        first.clone()
    } else {
        first.parent().map(Path::to_path_buf).unwrap_or_default()
    };
    let recorded = dir.join("config.toml");
    if recorded.exists() {
        Ok((load_config(&recorded)?, recorded.display().to_string()))
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

/// Checks session `r` before the fit ([`check::check`]), writing what was
/// found; a session with no swim (fitted or held out) is an error. Returns
/// its seconds of swimming and how many checks refuse the fit (a held-out
/// session's findings are warnings: it is scored all the same).
fn check_session(
    o: &mut String,
    limit: f64,
    r: &ReadSwim,
    fitted: bool,
) -> anyhow::Result<(f64, usize)> {
    let (moving, found) = check::check(&r.swim, limit)
        .map_err(|e| anyhow::anyhow!("{}{e}", if fitted { "" } else { "--holdout " }))?;
    let _ = writeln!(
        o,
        "  checked: {moving:.1} s of swimming{}",
        if found.is_empty() {
            "; no gap, no saturated or outlying torque"
        } else {
            ""
        }
    );
    let mut refused = 0;
    for f in &found {
        let tag = match (f.refuse, fitted) {
            (true, true) => {
                refused += 1;
                "refused"
            }
            (true, false) => {
                "warning (held out: scored all the same, and its errors below are \
                              partly this)"
            }
            (false, _) => "warning",
        };
        let _ = writeln!(o, "  {tag}: {f}");
    }
    Ok((moving, refused))
}

/// Calibrates as `opts` asks: the report goes to `out` as it is made (what
/// was read and checked before the fit, which takes minutes), then the
/// fit's. An error says why nothing (more) was done; a file named by
/// [`Options::write`] is untouched unless the result is `Ok` with
/// [`Outcome::wrote`].
pub fn calibrate(
    opts: &Options,
    out: &mut dyn FnMut(&str) -> anyhow::Result<()>,
) -> anyhow::Result<Outcome> {
    if opts.sessions.is_empty() {
        bail!("no session to fit");
    }
    let fit = identify::parse_coefficients(&opts.fit).map_err(|e| anyhow::anyhow!("--fit: {e}"))?;
    if opts.tracking.len() > opts.sessions.len() {
        bail!(
            "--tracking given {} times for {} sessions (expected at most one per session)",
            opts.tracking.len(),
            opts.sessions.len()
        );
    }
    let (cfg, prior_from) = prior_config(opts)?;
    let prior = cfg.model.body();
    let max = opts.max_size.saturating_mul(1 << 20);
    let read = read_all(&opts.sessions, &opts.tracking, max)?;
    let holdout = read_all(&opts.holdout, &[], max)?;
    let mut o = String::new();
    let limit = cfg
        .limits
        .torque
        .min(anguilla_protocol::message::TORQUE_LIMIT);
    let (mut swum, mut failed) = (0.0, 0usize);
    for (i, r) in read.iter().chain(&holdout).enumerate() {
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
        if r.dropped.any() {
            let _ = writeln!(o, "  not taken: {}", r.dropped);
        }
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
        let fitted = i < read.len();
        match check_session(&mut o, limit, r, fitted) {
            Ok((moving, refused)) => {
                if fitted {
                    swum += moving;
                }
                failed += refused;
            }
            Err(e) => {
                // what was read so far, then why not
                out(&o)?;
                return Err(e);
            }
        }
    }
    if swum < check::MIN_SWIMMING {
        failed += 1;
        let _ = writeln!(
            o,
            "refused: the fitted sessions swim {swum:.1} s (the joints moving), fewer than the \
             {} s a fit needs (`anguilla ctl calibrate-swim` swims 50 s of its 59; on 10 s the \
             nose's drag came out ±250 %)",
            check::MIN_SWIMMING
        );
    }
    // what was read and checked, before the fit (which takes minutes)
    out(&o)?;
    o.clear();
    if failed > 0 && !opts.ignore_checks {
        bail!(
            "refused to fit: {failed} check(s) of the recordings failed (above, 'refused'); \
             their coefficients would be the recording's faults, not the water's \
             (--ignore-checks fits them all the same, without --write)"
        );
    }
    if failed > 0 && opts.write.is_some() {
        bail!("--write refused: {failed} check(s) of the recordings failed (above)");
    }
    let swims: Vec<_> = read.into_iter().map(|r| r.swim).collect();
    let fitting = FitOptions {
        fit,
        ..FitOptions::default()
    };
    let start = Instant::now();
    let result = identify::fit(&prior, &swims, &fitting).map_err(|e| anyhow::anyhow!("{e}"))?;
    let took = start.elapsed().as_secs_f64();
    let _ = writeln!(
        o,
        "\nprior: [model] of {prior_from}; fitted {} in {took:.1} s ({} replays of the sessions, {} iterations)\n",
        opts.fit, result.simulations, result.iterations
    );
    let _ = writeln!(o, "coefficient    prior   estimate ± 1σ        kept");
    for e in &result.estimates {
        let _ = writeln!(
            o,
            "{:<10} {:>8.4} {:>10.4} ± {:<8.4} {:>8.4}  {}",
            e.coefficient.name(),
            e.prior,
            e.estimate,
            e.std_error,
            e.value,
            if e.identified {
                "identified".to_string()
            } else {
                format!("NOT {}", not_identified(e))
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
    // what the fit cannot stand behind: a torque it does not explain, a
    // drive's term below zero
    let mut refusals: Vec<String> = check::unexplained_torque(&result.after)
        .into_iter()
        .map(|(name, f)| format!("{name}: {f}"))
        .collect();
    refusals.extend(check::impossible_drive(result.after.actuator));
    for r in &refusals {
        let _ = writeln!(o, "refused: {r}");
    }
    // what --write writes: the identified coefficients, the others kept
    // at the present configuration's values, each with its reason
    let written: Vec<(Coefficient, f64)> = result
        .estimates
        .iter()
        .filter(|e| e.identified)
        .map(|e| (e.coefficient, e.value))
        .collect();
    let notes: Vec<(Coefficient, String)> = result
        .estimates
        .iter()
        .filter(|e| !e.identified)
        .map(|e| (e.coefficient, not_identified(e)))
        .collect();
    let mut written_body = prior.clone();
    for &(c, v) in &written {
        c.set(&mut written_body, v);
    }
    // the drives' terms the daemon's feed-forward takes ([model] drive-*):
    // the present file's, and the fit's (written when physical)
    let m = &cfg.model;
    let present_drive = [m.drive_inertia, m.drive_friction, m.drive_lag];
    let drive = result.after.actuator;
    let written_drive = if check::impossible_drive(drive).is_none() {
        drive
    } else {
        present_drive
    };
    // each model with the drives' inertia, friction and lag it is given,
    // not refitted to the sessions it is judged on
    let judge = |body: &anguilla_model::Body, actuator: [f64; 3], on: &[identify::Swim]| {
        let judged = FitOptions {
            actuator: Some(actuator),
            ..fitting.clone()
        };
        identify::compare(&[body], on, &judged)
            .map_err(|e| anyhow::anyhow!("{e}"))
            .map(|mut v| v.remove(0))
    };
    // what the daemon predicts, its feed-forward the model's torque plus
    // the drives' terms: with the present file and with the written one
    let now = judge(&prior, present_drive, &swims)?;
    let then = judge(&written_body, written_drive, &swims)?;
    let _ = writeln!(
        o,
        "\nthe daemon's predictions on the fitted sessions (its feed-forward: the model's torque \
         and the drives' {:.4} kg·m², {:.4} N·m·s/rad, {:.1} ms):",
        written_drive[0],
        written_drive[1],
        1e3 * written_drive[2]
    );
    errors(&mut o, "with the present [model]:", &now);
    errors(&mut o, "with what --write writes:", &then);
    let mut verdict = Ok(());
    if !holdout.is_empty() {
        let hs: Vec<_> = holdout.into_iter().map(|r| r.swim).collect();
        let b = judge(&prior, present_drive, &hs)?;
        let a = judge(&result.body, result.after.actuator, &hs)?;
        let w = judge(&written_body, written_drive, &hs)?;
        let _ = writeln!(o, "\nheld-out sessions (not fitted):");
        errors(&mut o, "the present [model]:", &b);
        errors(&mut o, "fitted coefficients:", &a);
        errors(&mut o, "what --write writes:", &w);
        for (name, f) in check::unexplained_torque(&w) {
            let _ = writeln!(
                o,
                "  warning (held out: scored all the same, and its errors above are partly \
                 this): {name}: {f}"
            );
        }
        verdict = held_out_verdict(&b, &w);
    }
    let _ = writeln!(
        o,
        "\n# [model] fragment (the identified coefficients; the others keep their values):"
    );
    let _ = writeln!(o, "[model]");
    let _ = write!(o, "{}", notes_block(&written, &notes));
    for (c, v) in &written {
        let _ = writeln!(o, "{} = {v:.5}", c.key());
    }
    for (k, v) in DRIVE_KEYS.iter().zip(written_drive) {
        let _ = writeln!(o, "{k} = {v:.5}");
    }
    if !refusals.is_empty() {
        out(&o)?;
        bail!(
            "the fit is refused ({} finding(s) above, 'refused'): its coefficients would carry \
             what the model lacks{}",
            refusals.len(),
            opts.write
                .as_ref()
                .map(|p| format!("; {} is untouched", p.display()))
                .unwrap_or_default()
        );
    }
    let mut wrote = None;
    if let Some(path) = &opts.write {
        out(&o)?;
        o.clear();
        if written.is_empty() {
            bail!(
                "--write refused: no coefficient identified (above), nothing to write; {} is \
                 untouched",
                path.display()
            );
        }
        if let Err(why) = verdict {
            bail!("--write refused: {why}; {} is untouched", path.display());
        }
        let shown = write_model(path, &written, Some(written_drive), &notes)?;
        wrote = Some(shown.clone());
        let _ = writeln!(
            o,
            "\nwrote {} identified coefficient(s) into {shown}{}",
            written.len(),
            if opts.holdout.is_empty() {
                " (no --holdout: not checked on a session it was not fitted to)"
            } else {
                ", which predicts the held-out sessions no worse than the present one"
            }
        );
    }
    out(&o)?;
    Ok(Outcome {
        identified: written,
        drive: written_drive,
        wrote,
    })
}

/// Why `e` was not identified, and what became of it.
fn not_identified(e: &identify::Estimate) -> String {
    let c = e.coefficient;
    let scale = e.estimate.abs().max(c.floor());
    let with = e
        .correlated
        .map(|(o, r)| format!("; correlated {r:+.2} with {}", o.name()))
        .unwrap_or_default();
    format!(
        "identified (95 % interval ±{:.0} % of {:.3}, more than {:.0} %){with}; {}: {}",
        200.0 * e.std_error / scale,
        scale,
        100.0 * IDENTIFIED_WITHIN,
        match (e.fitted, e.confounded) {
            (true, _) => "fitted all the same, standing in for the coefficients left at the \
                          prior, so not written"
                .to_string(),
            (false, Some((o, r))) => format!(
                "left at the prior, the swims telling only its combination with {} \
                 (correlated {r:+.2}, beyond {MAX_CORRELATION}; the prior knowing it better)",
                o.name()
            ),
            (false, None) => {
                "left at the prior, the swims knowing less of it than the prior".to_string()
            }
        },
        c.needs()
    )
}

/// The comment `--write` puts under `[model]`: what it wrote, and every
/// coefficient it did not write with its reason. Each line starts `# `.
fn notes_block(written: &[(Coefficient, f64)], notes: &[(Coefficient, String)]) -> String {
    let mut b = format!(
        "{NOTE_MARK} wrote {}",
        if written.is_empty() {
            "nothing".to_string()
        } else {
            written
                .iter()
                .map(|(c, _)| c.key())
                .collect::<Vec<_>>()
                .join(", ")
        }
    );
    if notes.is_empty() {
        b.push('\n');
    } else {
        b.push_str("; not written (their values here kept):\n");
        for (c, why) in notes {
            let _ = writeln!(b, "#   {}: not {why}", c.key());
        }
    }
    b
}

/// `[model]`'s keys of the drives' inertia, friction and torque lag, in
/// [`Evaluation::actuator`]'s order.
const DRIVE_KEYS: [&str; 3] = ["drive-inertia", "drive-friction", "drive-lag"];

/// The first words of the comment `--write` leaves (a later write
/// replaces it).
const NOTE_MARK: &str = "# anguilla calibrate:";

/// Whether the configuration `--write` would write (`written`) predicts
/// the held-out sessions no worse than the present one (`present`): its
/// weighted cost (the fit's objective) and its speed error no larger.
fn held_out_verdict(present: &Evaluation, written: &Evaluation) -> Result<(), String> {
    let worse_speed = written.rms[0] > present.rms[0] * (1.0 + 1e-9);
    if written.cost > present.cost * (1.0 + 1e-9) || worse_speed {
        return Err(format!(
            "on the held-out sessions the configuration it would write predicts worse than the \
             present one (cost {:.4} against {:.4}; speed error {:.4} against {:.4} m/s RMS): \
             the swims fitted do not carry to those held out (too short, too few gaits, or a \
             robot that changed between them)",
            written.cost, present.cost, written.rms[0], present.rms[0]
        ));
    }
    Ok(())
}

/// Sets `values` in `path`'s `[model]` (a new file if missing), every
/// other byte kept, checking the whole result before it replaces the file
/// ([`crate::user_file`]: mode, owner and group kept; a symlink written
/// through). Returns what was written, for the report.
/// Above `[model]` goes [`notes_block`]: what was written and why the
/// others were not (an earlier such comment replaced).
fn write_model(
    path: &Path,
    values: &[(Coefficient, f64)],
    drive: Option<[f64; 3]>,
    notes: &[(Coefficient, String)],
) -> anyhow::Result<String> {
    let shown = path.display();
    let (target, meta) = crate::user_file::resolve(path).context("--write")?;
    let text = match meta {
        Some(_) => read_text(&target, MAX_CONFIG_BYTES, "a configuration file")
            .with_context(|| format!("--write {shown}"))?,
        None => String::new(),
    };
    let entries: Vec<_> = values
        .iter()
        .map(|(c, v)| (c.key(), toml_edit::Value::from(*v)))
        .chain(drive.into_iter().flat_map(|d| {
            DRIVE_KEYS
                .into_iter()
                .zip(d)
                .map(|(k, v)| (k, toml_edit::Value::from(v)))
        }))
        .collect();
    let out = crate::user_file::set_toml(&text, "model", &entries)
        .with_context(|| format!("--write {shown}"))?;
    let out = with_notes(&out, &notes_block(values, notes))
        .with_context(|| format!("--write {shown}"))?;
    crate::config::Config::from_toml(&out, &shown.to_string()).with_context(|| {
        format!("--write {shown}: the result would not be a valid configuration")
    })?;
    let written = crate::user_file::replace(path, out.as_bytes()).context("--write")?;
    Ok(if written == path {
        shown.to_string()
    } else {
        format!("{shown} (the symlink's target {})", written.display())
    })
}

/// `text` (a TOML file with a `[model]` table) with `block` just above
/// `[model]`, an earlier [`NOTE_MARK`] block there removed.
fn with_notes(text: &str, block: &str) -> anyhow::Result<String> {
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .map_err(|e| anyhow::anyhow!("not a TOML file: {e}"))?;
    let Some(t) = doc.get_mut("model").and_then(toml_edit::Item::as_table_mut) else {
        bail!("no [model] table to note what was written");
    };
    let before = t
        .decor()
        .prefix()
        .and_then(|p| p.as_str())
        .unwrap_or("")
        .to_string();
    // the user's lines kept, ours (the mark and its indented lines) replaced
    let mut kept = String::new();
    let mut ours = false;
    for line in before.split_inclusive('\n') {
        if line.starts_with(NOTE_MARK) {
            ours = true;
            continue;
        }
        if ours && line.starts_with("#   ") {
            continue;
        }
        ours = false;
        kept.push_str(line);
    }
    t.decor_mut().set_prefix(format!("{kept}{block}"));
    Ok(doc.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use anguilla_testkit::sessions::joints_session;
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _, symlink};

    /// Issue 45: `--write` wrote in place (a reader saw half a file),
    /// through any symlink, dropping comments. Now a planted symlink is not
    /// followed, the file's comments, mode, owner and group stay, and a
    /// symlinked configuration is written through.
    #[test]
    fn write_keeps_comments_owner_and_mode_and_follows_no_planted_symlink() {
        let d = std::env::temp_dir().join(format!("anguilla-cal-write-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("robots")).unwrap();
        let real = d.join("robots").join("eel.toml");
        let text = "# the eel's\n[model]\n# fitted 2026-11\nc2 = 1.98 # from the tank\n";
        std::fs::write(&real, text).unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        // SAFETY: geteuid cannot fail.
        if (unsafe { libc::geteuid() }) == 0 {
            std::os::unix::fs::chown(&real, Some(1234), Some(1234)).unwrap();
        }
        let owner = std::fs::metadata(&real)
            .map(|m| (m.uid(), m.gid()))
            .unwrap();
        let link = d.join("anguilla.toml");
        symlink("robots/eel.toml", &link).unwrap();
        let victim = d.join("victim");
        std::fs::write(&victim, "secret\n").unwrap();
        for planted in [".eel.toml.tmp", "eel.toml.tmp", ".eel.toml.write"] {
            symlink(&victim, d.join("robots").join(planted)).unwrap();
        }
        let shown = write_model(
            &link,
            &[(Coefficient::C2, 2.5), (Coefficient::C3, 0.4)],
            None,
            &[],
        )
        .unwrap();
        assert!(shown.contains("the symlink's target"), "{shown}");
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "secret\n");
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(
            std::fs::read_to_string(&real).unwrap(),
            "# the eel's\n# anguilla calibrate: wrote c2, c3\n[model]\n# fitted 2026-11\nc2 = 2.5 # from the tank\nc3 = 0.4\n"
        );
        let m = std::fs::metadata(&real).unwrap();
        assert_eq!((m.mode() & 0o7777, (m.uid(), m.gid())), (0o640, owner));
        // A result that would not check leaves the file as it was.
        std::fs::write(&real, "[model]\nc2 = 1.0\nbogus = 1\n").unwrap();
        let e = format!(
            "{:#}",
            write_model(&link, &[(Coefficient::C2, 2.5)], None, &[]).unwrap_err()
        );
        assert!(e.contains("would not be a valid configuration"), "{e}");
        assert_eq!(
            std::fs::read_to_string(&real).unwrap(),
            "[model]\nc2 = 1.0\nbogus = 1\n"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// Issue 46, finding 3: `--write` wrote coefficients it called "not
    /// identified" as bare numbers. Now only the identified ones are
    /// written; every other is a comment with its reason, and a later
    /// write replaces that comment (the user's own kept).
    #[test]
    fn write_writes_the_identified_and_comments_the_others_with_their_reason() {
        let d = std::env::temp_dir().join(format!("anguilla-cal-notes-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("anguilla.toml");
        std::fs::write(&f, "# mine\n[model]\nc-p = 0.036\n").unwrap();
        let notes = [(
            Coefficient::CP,
            "identified (95 % interval ±250 %)".to_string(),
        )];
        write_model(&f, &[(Coefficient::C2, 2.5)], None, &notes).unwrap();
        let text = std::fs::read_to_string(&f).unwrap();
        assert_eq!(
            text,
            "# mine\n# anguilla calibrate: wrote c2; not written (their values here kept):\n\
             #   c-p: not identified (95 % interval ±250 %)\n[model]\nc-p = 0.036\nc2 = 2.5\n"
        );
        write_model(
            &f,
            &[(Coefficient::C3, 0.4)],
            Some([0.02, 0.05, 0.001]),
            &[],
        )
        .unwrap();
        assert_eq!(
            std::fs::read_to_string(&f).unwrap(),
            "# mine\n# anguilla calibrate: wrote c3\n[model]\nc-p = 0.036\nc2 = 2.5\nc3 = 0.4\n\
             drive-inertia = 0.02\ndrive-friction = 0.05\ndrive-lag = 0.001\n"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// Issue 46, finding 3: a configuration whose held-out lines predict
    /// worse than the present one's is refused, by its cost or its speed.
    #[test]
    fn a_configuration_that_predicts_the_held_out_worse_is_refused() {
        let ev = |cost: f64, speed: f64| Evaluation {
            cost,
            rms: [speed, 0.0, 0.0, 0.0, 0.0],
            ..Evaluation::default()
        };
        assert!(held_out_verdict(&ev(1.0, 0.02), &ev(0.5, 0.01)).is_ok());
        let e = held_out_verdict(&ev(1.0, 0.02), &ev(1.3, 0.01)).unwrap_err();
        assert!(
            e.contains("predicts worse than the present one (cost 1.3000 against 1.0000"),
            "{e}"
        );
        assert!(held_out_verdict(&ev(1.0, 0.02), &ev(0.9, 0.03)).is_err());
    }

    /// [`calibrate`] called as a library: a swim too short to fit is
    /// refused before the fit, its report saying why; with
    /// `ignore_checks` and `write` the write is refused all the same and
    /// the file keeps every byte; more `tracking` files than sessions are
    /// refused before anything is read.
    #[test]
    fn calibrate_refuses_a_short_swim_and_leaves_the_file_to_write_unchanged() {
        let d = std::env::temp_dir().join(format!("anguilla-cal-lib-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let short = d.join("short.mcap");
        joints_session(&short, 10.0, 0.3);
        let target = d.join("anguilla.toml");
        let before = "# mine\n[model]\nc2 = 1.98\n";
        std::fs::write(&target, before).unwrap();
        let mut opts = Options {
            sessions: vec![short.clone()],
            fit: "c2,c3".into(),
            max_size: 64,
            ..Options::default()
        };
        let mut report = String::new();
        let e = calibrate(&opts, &mut |t| {
            report.push_str(t);
            Ok(())
        })
        .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("refused to fit: 1 check(s) of the recordings failed"),
            "{e}"
        );
        assert!(
            report.contains("refused: the fitted sessions swim 10.0 s (the joints moving)"),
            "{report}"
        );
        opts.ignore_checks = true;
        opts.write = Some(target.clone());
        let e = calibrate(&opts, &mut |_| Ok(())).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--write refused: 1 check(s) of the recordings failed (above)"
        );
        assert_eq!(std::fs::read_to_string(&target).unwrap(), before);
        opts.tracking = vec![d.join("a.csv"), d.join("b.csv")];
        let e = calibrate(&opts, &mut |_| panic!("nothing read")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--tracking given 2 times for 1 sessions"),
            "{e}"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }
}
