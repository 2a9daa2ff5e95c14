//! `anguilla config`, `replay` and `export` (`anguilla run` is the
//! library's [`anguilla::daemon_cli`], shared with `anguillad`).

use crate::output::{out, outln};
use std::path::PathBuf;

use anguilla::config::{Config, default_toml, robot_toml};
use anguilla_daemon::config::{BUS_BUILTIN, BUS_UNSET};
use anyhow::Context;

/// `anguilla config ...`.
#[derive(clap::Subcommand, Debug)]
pub enum ConfigCmd {
    /// Print the whole default configuration, commented.
    Default {
        /// The file a robot's tether computer starts from instead (the
        /// Debian package's /etc/anguilla/anguilla.toml): the bus left to
        /// set, SCHED_FIFO and locked memory, recordings bounded for a 32 GB
        /// card.
        #[arg(long)]
        robot: bool,
    },
    /// Check a configuration file and say what is wrong with it.
    Check {
        /// The file.
        file: PathBuf,
    },
    /// Name the robot's bus in a configuration file (`[bus] spec`), keeping
    /// its comments and every other line; checks the result before writing.
    SetBus {
        /// The bus, e.g. `socketcan:can0` or `slcan:/dev/serial/by-id/...@1000000`
        /// (`builtin`: the built-in simulated robot).
        spec: String,
        /// The file to change.
        #[arg(long, value_name = "FILE", default_value = anguilla_daemon::config::SYSTEM_FILE)]
        file: PathBuf,
    },
}

pub fn config(cmd: ConfigCmd) -> anyhow::Result<()> {
    match cmd {
        ConfigCmd::Default { robot: false } => {
            out!("{}", default_toml())
        }
        ConfigCmd::Default { robot: true } => {
            out!("{}", robot_toml())
        }
        ConfigCmd::SetBus { spec, file } => set_bus(&file, &spec),
        ConfigCmd::Check { file } => {
            let cfg = Config::load(&file)?;
            let tls = !cfg.link.ca.is_empty();
            for e in cfg
                .link
                .listen
                .iter()
                .filter(|e| *e != anguilla_link::LOCAL)
            {
                anguilla_link::Endpoint::parse_form(e, tls)
                    .and_then(|ep| ep.listenable(cfg.link.insecure_loopback))
                    .map_err(|e| anyhow::anyhow!("{}: link.listen: {e}", file.display()))?;
            }
            // The configuration the daemon would run: for the built-in
            // robot, with its head sensor and relaxed timeouts (one
            // computation, Config::fit_builtin, so the rate is the daemon's).
            let mut cfg = cfg.daemon;
            let builtin = cfg.bus.spec.is_empty() || cfg.bus.spec == BUS_BUILTIN;
            let sensor = if builtin {
                cfg.fit_builtin().sensor
            } else {
                None
            };
            let period = anguilla_daemon::control::period_ns(&cfg);
            outln!(
                "{}: valid; {} joints, control rate {:.1} Hz, bus {}",
                file.display(),
                cfg.robot.joints,
                1e9 / period.as_nanos() as f64,
                if builtin {
                    match sensor {
                        Some(id) => {
                            format!("built-in simulated robot (with its head sensor as node {id})")
                        }
                        None => "built-in simulated robot".to_owned(),
                    }
                } else if cfg.bus.spec == BUS_UNSET {
                    "NOT SET: the daemon refuses to start until [bus] spec names the robot's \
                     bus (`anguilla config set-bus SPEC`)"
                        .to_owned()
                } else {
                    cfg.bus.spec.clone()
                }
            )
        }
    }
}

/// `anguilla config set-bus`: `[bus] spec = SPEC` in `file`, every other
/// byte as it was (comments and layout; the file is parsed as TOML, so a
/// `[bus]` inside a multi-line string is left alone). The spec must parse
/// (or be `builtin`) and the new file must check; it replaces the old one
/// at once, keeping its mode, owner and group, through
/// [`anguilla::user_file`] (a random name beside it, renamed over it), so a
/// failure leaves the old file and nothing planted beside it is followed.
/// A symlinked file is written through to the file it names.
fn set_bus(file: &std::path::Path, spec: &str) -> anyhow::Result<()> {
    let shown = file.display();
    if spec != BUS_BUILTIN {
        anguilla_drivers::BusSpec::parse(spec)?;
    }
    let (target, meta) = anguilla::user_file::resolve(file)?;
    if meta.is_none() {
        anyhow::bail!(
            "reading {shown}: no such file (expected a configuration: `anguilla config default \
             --robot > FILE` writes one)"
        );
    }
    let text = std::fs::read_to_string(&target).with_context(|| format!("reading {shown}"))?;
    let new = with_bus_spec(&text, spec).with_context(|| shown.to_string())?;
    Config::from_toml(&new, &shown.to_string())
        .and_then(|c| c.validate().map(|()| c))
        .with_context(|| format!("{shown} with [bus] spec = {spec:?}"))?;
    let written = anguilla::user_file::replace(file, new.as_bytes())?;
    if written == file {
        outln!("{shown}: [bus] spec = {spec:?}")
    } else {
        outln!(
            "{shown} (the symlink's target {}): [bus] spec = {spec:?}",
            written.display()
        )
    }
}

/// `text` (a TOML configuration) with its `[bus]` table's `spec` set to
/// `spec`: its value replaced (its comment kept), or the key added to
/// `[bus]`, or a `[bus]` table appended.
fn with_bus_spec(text: &str, spec: &str) -> anyhow::Result<String> {
    anguilla::user_file::set_toml(text, "bus", &[("spec", spec.into())])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_bus_changes_the_spec_line_and_nothing_else() {
        let robot = robot_toml();
        let new = with_bus_spec(&robot, "socketcan:can0").unwrap();
        let mut cfg = Config::from_toml(&new, "t").unwrap();
        assert_eq!(cfg.daemon.bus.spec, "socketcan:can0");
        let mut want = anguilla::config::robot_config();
        want.daemon.bus.spec = "socketcan:can0".into();
        // (the daemon keeps `[link]` and `[foxglove]` unread beside its own)
        cfg.daemon.other_sections.clear();
        assert_eq!(cfg, want);
        // Only one line differs, and the comments stay.
        let diff: Vec<_> = robot
            .lines()
            .zip(new.lines())
            .filter(|(a, b)| a != b)
            .collect();
        assert_eq!(diff, [("spec = \"unset\"", "spec = \"socketcan:can0\"")]);
        assert_eq!(robot.lines().count(), new.lines().count());
        // A quote or a backslash in a path stays a string.
        let odd = with_bus_spec(&robot, "slcan:/dev/a\"b\\c@1000000").unwrap();
        assert_eq!(
            Config::from_toml(&odd, "t").unwrap().daemon.bus.spec,
            "slcan:/dev/a\"b\\c@1000000"
        );
    }

    #[test]
    fn set_bus_adds_a_missing_spec_or_table() {
        let no_table = "[realtime]\nlock-memory = true\n";
        let c = Config::from_toml(&with_bus_spec(no_table, "socketcan:can1").unwrap(), "t")
            .unwrap()
            .daemon;
        assert_eq!(c.bus.spec, "socketcan:can1");
        assert!(c.realtime.lock_memory);
        let no_spec = "[bus]\nfd = true\n[realtime]\ncpu = 1\n";
        let c = Config::from_toml(&with_bus_spec(no_spec, "socketcan:can1").unwrap(), "t")
            .unwrap()
            .daemon;
        assert_eq!(
            (c.bus.spec.as_str(), c.bus.fd, c.realtime.cpu),
            ("socketcan:can1", true, 1)
        );
        // A header with a comment after it is the bus's too.
        let commented = "[realtime]\ncpu = 1\n[bus] # the robot's\nfd = true\n";
        let new = with_bus_spec(commented, "socketcan:can1").unwrap();
        assert!(
            new.contains("[bus] # the robot's\nfd = true\nspec = \"socketcan:can1\"\n"),
            "{new}"
        );
        let last = "[bus]\nfd = true\n";
        let c = Config::from_toml(&with_bus_spec(last, "socketcan:can1").unwrap(), "t")
            .unwrap()
            .daemon;
        assert_eq!(c.bus.spec, "socketcan:can1");
        // `spec` of another table is not the bus's.
        let other = "[link]\n\n[bus]\nspec = \"mem:x\"\n";
        let c = Config::from_toml(&with_bus_spec(other, "socketcan:can1").unwrap(), "t")
            .unwrap()
            .daemon;
        assert_eq!(c.bus.spec, "socketcan:can1");
    }

    /// The text of `key` in `table` of the TOML `text`.
    fn string_at(text: &str, table: &str, key: &str) -> String {
        let t: toml::Table = toml::from_str(text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        t[table][key].as_str().unwrap().to_string()
    }

    /// Issue 45: headers and keys inside multi-line strings, comments,
    /// quoted and spaced headers, a multi-line spec, an inline table and
    /// dotted keys are what TOML says they are, not what a line looks like.
    #[test]
    fn set_bus_reads_the_file_as_toml_not_as_lines() {
        let set = |text: &str| with_bus_spec(text, "socketcan:can1").unwrap();
        // `[bus]` and `spec =` inside another table's multi-line strings
        // (basic and literal) are that string's text.
        for quote in ["\"\"\"", "'''"] {
            let text = format!(
                "[link]\nnote = {quote}\n[bus]\nspec = \"mem:x\"\n{quote}\n\n[bus]\nspec = \"unset\"\n"
            );
            let new = set(&text);
            assert_eq!(
                string_at(&new, "link", "note"),
                "[bus]\nspec = \"mem:x\"\n",
                "{new}"
            );
            assert_eq!(string_at(&new, "bus", "spec"), "socketcan:can1", "{new}");
            assert_eq!(new, text.replace("\"unset\"", "\"socketcan:can1\""));
        }
        // ... and inside the bus's own table, before its spec.
        let text = "[bus]\nnote = '''\nspec = \"mem:x\"\n'''\nspec = \"unset\"\n";
        let new = set(text);
        assert_eq!(string_at(&new, "bus", "note"), "spec = \"mem:x\"\n");
        assert_eq!(string_at(&new, "bus", "spec"), "socketcan:can1");
        // A spec written as a multi-line string is replaced whole.
        let new = set("[bus]\nspec = \"\"\"\nunset\"\"\"\nfd = true\n");
        assert_eq!(new, "[bus]\nspec = \"socketcan:can1\"\nfd = true\n");
        // Comments are neither headers nor keys, and a value's comment stays.
        let text =
            "# [bus]\n# spec = \"x\"\n[bus]\n#spec = \"old\"\nspec = \"unset\" # the robot's\n";
        assert_eq!(set(text), text.replace("\"unset\"", "\"socketcan:can1\""));
        // Spaced and quoted headers, an inline table, dotted keys.
        for text in [
            "[ bus ]\nspec = \"unset\"\n",
            "[\"bus\"]\nspec = \"unset\"\n",
            "bus = { spec = \"unset\", fd = true }\n",
            "bus.spec = \"unset\"\n",
        ] {
            assert_eq!(set(text), text.replace("\"unset\"", "\"socketcan:can1\""));
        }
        // `bus` that is not a table, and a file that is not TOML, are named.
        for (text, why) in [
            (
                "[[bus]]\nspec = \"x\"\n",
                "its `bus` is not a table but array of tables",
            ),
            ("bus = 3\n", "its `bus` is not a table but integer"),
            ("[bus\nspec = 1\n", "not a TOML file"),
            ("x = '''\n[bus]\n", "not a TOML file"),
        ] {
            let e = with_bus_spec(text, "socketcan:can1")
                .unwrap_err()
                .to_string();
            assert!(e.contains(why), "{text:?}: {e}");
        }
    }
}

/// `anguilla replay`'s exit status for a recording that is cut short but
/// matches as far as it goes.
pub const REPLAY_TRUNCATED: i32 = 3;

/// Arguments of `anguilla replay`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Exit status: 0 identical (a recording the recorder stopped early and said \
    why, at [recording] min-free, included: the output says so), 1 a difference (or an \
    unreadable recording), 3 a recording cut short (no end line) whose periods all match."
)]
pub struct ReplayArgs {
    /// A session directory written by `anguilla run` with `recording.dir` set.
    dir: PathBuf,
}

/// Arguments of `anguilla export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// A session directory written by `anguilla run` with `recording.dir` set.
    dir: PathBuf,
    /// Write the new MCAP file here: a file that does not exist (export
    /// never replaces a file). Default: a new name in DIR, export.mcap
    /// (export-2.mcap, ... if taken); the recording's own files are kept.
    #[arg(long, value_name = "FILE", num_args = 0..=1, default_missing_value = "")]
    mcap: Option<PathBuf>,
    /// Instead of writing the MCAP file from state.bin, copy DIR's own
    /// session.mcap into a complete new file (DIR/session.repaired.mcap,
    /// or --mcap FILE): a daemon killed mid-recording leaves it without
    /// summary and index, which indexed readers refuse. Every message
    /// readable before the cut is kept, on every channel; session.mcap is
    /// left as it was.
    #[arg(long)]
    repair: bool,
    /// Write a rosbag2 MCAP for ROS 2 tools instead (a new
    /// DIR/session.ros2.mcap, or --mcap FILE): the topics of `anguilla
    /// link`'s ROS 2 node (`[link] ros2-*` of the session's configuration:
    /// namespace, rates), from state.bin (docs/ros2.md).
    #[arg(long, conflicts_with = "repair")]
    ros2: bool,
}

/// A progress bar on standard error for work of `total` steps, when it is
/// a terminal (none in pipes, logs and CI); `None` otherwise.
fn progress_bar(what: &str, total: u64) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal as _;
    if !std::io::stderr().is_terminal() || total < 2 * anguilla_daemon::replay::PROGRESS_EVERY {
        return None;
    }
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{what} [{{bar:40}}] {{pos}}/{{len}} {{msg}} ({{elapsed}}, {{eta}} left)"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(bar)
}

/// A progress callback that drives a bar made on the first report.
fn progress(what: &'static str) -> (impl FnMut(u64, u64), impl FnOnce()) {
    let bar: std::rc::Rc<std::cell::RefCell<Option<indicatif::ProgressBar>>> = Default::default();
    let (b, done) = (bar.clone(), bar);
    let mut made = false;
    let report = move |n: u64, total: u64| {
        if !made {
            made = true;
            *b.borrow_mut() = progress_bar(what, total);
        }
        if let Some(bar) = b.borrow().as_ref() {
            bar.set_position(n);
        }
    };
    let finish = move || {
        if let Some(bar) = done.borrow_mut().take() {
            bar.finish_and_clear();
        }
    };
    (report, finish)
}

/// The new file an export writes: `--mcap FILE`, or the first free name
/// `STEM.mcap`, `STEM-2.mcap`... in the session directory; made with
/// [`anguilla::user_file::Replacement::create`], so that nothing that
/// exists (the recording's files, an earlier export) is ever replaced.
fn new_output(
    args: &ExportArgs,
    stem: &str,
) -> anyhow::Result<(PathBuf, anguilla::user_file::Replacement)> {
    let out = match &args.mcap {
        Some(p) if !p.as_os_str().is_empty() => p.clone(),
        _ => anguilla::user_file::free_name(&args.dir, stem, "mcap")?,
    };
    let file = anguilla::user_file::Replacement::create(&out).with_context(|| {
        format!(
            "export writes a new file and never replaces one (a recording's, or an earlier \
             export): choose another with --mcap FILE, or leave --mcap out for a new name in \
             {} ({stem}.mcap, {stem}-2.mcap, ...)",
            args.dir.display()
        )
    })?;
    Ok((out, file))
}

pub fn export(args: ExportArgs) -> anyhow::Result<()> {
    if args.repair {
        return repair(args);
    }
    if args.ros2 {
        return export_ros2(args);
    }
    // the session's own errors before any file is made
    anguilla_daemon::config::Config::load(&args.dir.join("config.toml"))
        .with_context(|| format!("exporting {}", args.dir.display()))?;
    let (out, replacement) = new_output(&args, "export")?;
    let (mut report, finish) = progress("exporting");
    let done = anguilla_daemon::mcap_log::export_into(
        &args.dir,
        replacement.try_clone_file()?,
        &mut report,
    );
    finish();
    let done = done.with_context(|| format!("exporting {}", args.dir.display()))?;
    replacement.commit()?;
    outln!(
        "{}: {} snapshots{}",
        out.display(),
        done.snapshots,
        if done.partial_bytes > 0 {
            format!(
                " ({} bytes at the end of state.bin were not a whole snapshot: the recording was cut short)",
                done.partial_bytes
            )
        } else {
            String::new()
        }
    )?;
    Ok(())
}

/// `export --ros2`: a rosbag2 MCAP of the ROS 2 node's topics.
fn export_ros2(args: ExportArgs) -> anyhow::Result<()> {
    use anguilla_link::ros2::{LATCHED, TOPICS, bag};
    // The session directory's name holds the recorder's start (Unix s):
    // docs/data.md "Time".
    let name = args.dir.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let (start_s, _) = anguilla_daemon::record::session_name(name).with_context(|| {
        format!(
            "{}: expected a session directory named session-<Unix time> (or \
                 session-<Unix time>-<n>), as `anguilla run` writes (its name dates the recording)",
            args.dir.display()
        )
    })?;
    // The whole file: the session's config.toml keeps `[link]` as the
    // robot's file had it.
    let Config {
        daemon: cfg, link, ..
    } = Config::load(&args.dir.join("config.toml"))
        .with_context(|| format!("exporting {}", args.dir.display()))?;
    let l = &link;
    let (out, replacement) = new_output(&args, "session.ros2")?;
    let settings = bag::BagSettings {
        namespace: l.ros2_namespace.clone(),
        rates: TOPICS.map(|(n, _)| l.ros2_rates.get(n).copied().unwrap_or(l.ros2_rate)),
        start_ns: start_s.saturating_mul(1_000_000_000),
        geometry: anguilla_link::ros2::state::Geometry {
            segments: anguilla_view::segments(cfg.robot.joints),
            limits: [cfg.limits.angle, cfg.limits.velocity, cfg.limits.torque],
        },
        humble: l.ros2_distro == "humble",
        file_name: out
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    let mut bag = bag::Bag::from_file(replacement.try_clone_file()?, settings)
        .with_context(|| format!("creating {}", out.display()))?;
    let (_, n, partial) =
        anguilla_daemon::mcap_log::for_each_state(&args.dir, |_, _, s| bag.write(s))
            .with_context(|| format!("exporting {}", args.dir.display()))?;
    let counts = bag
        .finish()
        .with_context(|| format!("writing {}", out.display()))?;
    replacement.commit()?;
    outln!(
        "{}: rosbag2 MCAP from {n} snapshots: {}{}",
        out.display(),
        TOPICS
            .iter()
            .chain(&LATCHED)
            .zip(counts)
            .map(|((t, _), c)| format!("{t} {c}"))
            .collect::<Vec<_>>()
            .join(", "),
        if partial > 0 {
            format!(
                " ({partial} bytes at the end of state.bin were not a whole snapshot: the recording was cut short)"
            )
        } else {
            String::new()
        }
    )?;
    Ok(())
}

/// `export --repair`: DIR/session.mcap copied complete into a new file
/// (DIR/session.repaired.mcap, or `--mcap FILE`); the recording's own file
/// is left as it was.
fn repair(args: ExportArgs) -> anyhow::Result<()> {
    let input = args.dir.join("session.mcap");
    let (out, replacement) = new_output(&args, "session.repaired")?;
    let done = anguilla_daemon::mcap_log::repair_into(&input, replacement.try_clone_file()?)
        .with_context(|| format!("repairing {}", input.display()))?;
    replacement.commit()?;
    let written = out;
    outln!(
        "{}: {} messages on {} channels, with summary and index{}",
        written.display(),
        done.messages,
        done.channels,
        match &done.cut {
            Some(why) => format!(" (the recording was cut there: {why})"),
            None => " (the file was already whole)".to_string(),
        }
    )?;
    Ok(())
}

pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let (mut progress, finish) = progress("replaying");
    let report = anguilla_daemon::replay::replay_with(&args.dir, &mut progress);
    finish();
    let report = report.with_context(|| format!("replaying {}", args.dir.display()))?;
    match (&report.mismatch, report.truncated_at) {
        (None, None) if report.stopped.is_some() => outln!(
            "{}: identical as far as it was recorded: {} periods, {} frames replayed bit for bit; \
             the recorder stopped there while the daemon went on: {}",
            args.dir.display(),
            report.periods,
            report.frames,
            report.stopped.as_deref().unwrap_or_default()
        ),
        (None, None) => outln!(
            "{}: identical: {} periods, {} frames replayed bit for bit",
            args.dir.display(),
            report.periods,
            report.frames
        ),
        (None, Some(line)) => {
            outln!(
                "{}: truncated at line {line} (period {}): the {} periods before it match bit \
                 for bit ({} frames); the recording has no end (the daemon was killed, or the \
                 disk filled; `anguilla export DIR --repair` writes a whole copy of its session.mcap)",
                args.dir.display(),
                report.periods + 1,
                report.periods,
                report.frames
            )?;
            // Distinct from a mismatch (1): what there is matches.
            std::process::exit(REPLAY_TRUNCATED)
        }
        (Some((period, what)), _) => anyhow::bail!(
            "{}: differs at period {period} after {} identical frames: {what}",
            args.dir.display(),
            report.frames
        ),
    }
}
