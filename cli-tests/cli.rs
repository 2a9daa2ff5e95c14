//! The `anguilla` binary: subcommands run, and bad arguments get clear
//! errors naming what was wrong (never a panic).

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};
use std::time::Duration;

use anguilla_testkit::sessions::joints_session;

fn anguilla() -> Command {
    Command::new(env!("CARGO_BIN_EXE_anguilla"))
}

fn anguillad() -> Command {
    Command::new(env!("CARGO_BIN_EXE_anguillad"))
}

fn run(args: &[&str]) -> (bool, String, String) {
    let o = anguilla().args(args).output().expect("runs");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The exit status of `child`, waited for at most `secs` stretched by the
/// patience (anguilla_testkit::poll_until); past it the child is killed and
/// the test fails, naming `what`. A watchdog, not a speed bound.
fn wait_exit(child: &mut std::process::Child, what: &str, secs: u64) -> std::process::ExitStatus {
    let mut killer = KillOnDrop(Some(child));
    let status = anguilla_testkit::poll_until(what, Duration::from_secs(secs), || {
        killer.0.as_mut().and_then(|c| c.try_wait().unwrap())
    });
    killer.0 = None;
    status
}

/// Kills and reaps the child it holds when dropped (a failed wait).
struct KillOnDrop<'a>(Option<&'a mut std::process::Child>);

impl Drop for KillOnDrop<'_> {
    fn drop(&mut self) {
        if let Some(c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// [`run`] for a command that could block for ever (a named pipe for a
/// file): a watchdog kills it after 60 s (times the patience) and fails the
/// test, naming it. Not a speed bound: a command that works ends at once.
fn run_watched(args: &[&str]) -> (bool, String, String) {
    let mut child = anguilla()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let read = |r: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut r) = r {
                let _ = r.read_to_string(&mut s);
            }
            s
        })
    };
    let out = read(child.stdout.take().map(|s| Box::new(s) as _));
    let err = read(child.stderr.take().map(|s| Box::new(s) as _));
    let status = wait_exit(&mut child, &format!("anguilla {args:?} (blocked?)"), 60);
    (status.success(), out.join().unwrap(), err.join().unwrap())
}

#[test]
fn config_default_round_trips_through_check() {
    let (ok, out, _) = run(&["config", "default"]);
    assert!(ok);
    let path = std::env::temp_dir().join(format!("anguilla-cli-{}.toml", std::process::id()));
    std::fs::write(&path, &out).unwrap();
    let (ok, out, err) = run(&["config", "check", path.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(
        out.contains("valid; 12 joints, control rate 160.8 Hz, bus built-in simulated robot (with its head sensor as node 13)"),
        "{out}"
    );
    std::fs::write(&path, "[limits]\ntorque = 9.0\n").unwrap();
    let (ok, _, err) = run(&["config", "check", path.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        err.contains("'limits.torque' = 9 is out of range (expected 0 ..= 5 N·m)"),
        "{err}"
    );
    let _ = std::fs::remove_file(&path);
}

/// `[link]` and `[foxglove]` belong to `anguilla link` and `anguilla
/// foxglove`: `config check` reads them and names a bad key; the daemon
/// starts on a file that has them, reading neither, and still refuses a
/// section nobody reads.
#[test]
fn config_check_reads_the_other_processes_sections_and_the_daemon_passes_them_over() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-others-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("anguilla.toml");
    let file = path.to_str().unwrap();
    for (text, want) in [
        (
            "[link]\nstate-rate = 0.0\n",
            "'link.state-rate' = 0 is out of range",
        ),
        (
            "[foxglove]\nmax-clients = 0\n",
            "'foxglove.max-clients' = 0 is out of range",
        ),
        ("[link]\nlisten-on = []\n", "unknown field `listen-on`"),
        ("[nonsense]\n", "unknown field `nonsense`"),
    ] {
        std::fs::write(&path, text).unwrap();
        let (ok, _, err) = run(&["config", "check", file]);
        assert!(!ok, "{text}");
        assert!(err.contains(want), "{text}: {err}");
    }
    std::fs::write(
        &path,
        format!(
            "[ipc]\nprefix = \"cli-others-{}\"\n[link]\nros2 = true\nstate-rate = 25.0\n\
             [foxglove]\nmax-clients = 4\n",
            std::process::id()
        ),
    )
    .unwrap();
    let (ok, _, err) = run(&["config", "check", file]);
    assert!(ok, "{err}");
    let o = anguillad()
        .args(["--config", file, "--duration", "0.5"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("control loop at "), "{err}");
    std::fs::write(&path, "[nonsense]\n").unwrap();
    let o = anguillad()
        .args(["--config", file, "--duration", "0.5"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(78), "{err}");
    assert!(err.contains("unknown field `nonsense`"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `config check` prints the control rate the daemon runs (issue 46: it
/// printed 176.8 Hz for the default file while the daemon ran 160.8 Hz, the
/// built-in robot's head sensor taking bus time the check did not count):
/// the rate in the check's line is the one in the daemon's "control loop
/// at" line, for the defaults and for a file that sets the sensor itself.
#[test]
fn config_check_prints_the_rate_the_daemon_runs() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-rate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rate_in = |text: &str, before: &str| -> String {
        let line = text
            .lines()
            .find(|l| l.contains(before))
            .unwrap_or_else(|| panic!("no '{before}' in {text}"));
        let rest = &line[line.find(before).unwrap() + before.len()..];
        rest.split_whitespace().next().unwrap().to_owned()
    };
    for (tag, extra) in [
        ("defaults", ""),
        ("own-sensor", "[sensor]\nnode = 20\nrate-hz = 200\n"),
    ] {
        let path = dir.join(format!("{tag}.toml"));
        std::fs::write(
            &path,
            format!(
                "[ipc]\nprefix = \"cli-rate-{tag}-{}\"\n{extra}",
                std::process::id()
            ),
        )
        .unwrap();
        let (ok, out, err) = run(&["config", "check", path.to_str().unwrap()]);
        assert!(ok, "{err}");
        let checked = rate_in(&out, "control rate ");
        let (ok, _, err) = run_watched(&[
            "run",
            "--config",
            path.to_str().unwrap(),
            "--duration",
            "0.5",
        ]);
        assert!(ok, "{tag}: {err}");
        let ran = rate_in(&err, "control loop at ");
        assert_eq!(
            checked, ran,
            "{tag}: check said {out}; the daemon logged {err}"
        );
        eprintln!("{tag}: {checked} Hz");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_robots_file_runs_nothing_until_its_bus_is_set() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-robot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("anguilla.toml");
    let (ok, robot, _) = run(&["config", "default", "--robot"]);
    assert!(ok);
    // The package's conffile is exactly this file.
    let shipped = include_str!("../deploy/anguilla.toml");
    assert_eq!(robot, shipped);
    // Recordings in a scratch place, not /var/lib/anguilla.
    let robot = robot.replace("/var/lib/anguilla/recordings", "");
    std::fs::write(&path, &robot).unwrap();
    let file = path.to_str().unwrap();
    let (ok, out, err) = run(&["config", "check", file]);
    assert!(ok, "{err}");
    assert!(out.contains("bus NOT SET"), "{out}");
    // Both binaries refuse it, naming the file and what to do, exit 78.
    for bin in [
        env!("CARGO_BIN_EXE_anguilla"),
        env!("CARGO_BIN_EXE_anguillad"),
    ] {
        let mut c = Command::new(bin);
        if bin.ends_with("anguilla") {
            c.arg("run");
        }
        let o = c
            .args(["--config", file, "--duration", "1"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(78), "{bin}: {err}");
        assert!(
            err.contains(&format!("{file}: [bus] spec is \"unset\"")) && err.contains("set-bus"),
            "{bin}: {err}"
        );
    }
    // A bad spec is refused by name and the file is left as it was.
    let (ok, _, err) = run(&["config", "set-bus", "cann0", "--file", file]);
    assert!(!ok);
    assert!(err.contains("bad bus spec 'cann0'"), "{err}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), robot);
    // A file that is not there is named.
    let (ok, _, err) = run(&[
        "config",
        "set-bus",
        "socketcan:can0",
        "--file",
        "/nonexistent/a.toml",
    ]);
    assert!(!ok);
    assert!(err.contains("reading /nonexistent/a.toml"), "{err}");
    // A good one changes that line only, and the daemon takes it.
    let (ok, out, err) = run(&["config", "set-bus", "builtin", "--file", file]);
    assert!(ok, "{err}");
    assert!(out.contains("[bus] spec = \"builtin\""), "{out}");
    let new = std::fs::read_to_string(&path).unwrap();
    assert_eq!(new, robot.replace("spec = \"unset\"", "spec = \"builtin\""));
    assert!(!dir.join(".anguilla.toml.set-bus").exists());
    let (ok, out, err) = run(&["config", "check", file]);
    assert!(ok && out.contains("built-in simulated robot"), "{out}{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 45: `config set-bus`, run as root on a file in a directory another
/// user can write, follows no symlink planted beside the file (the old
/// `.NAME.set-bus` made root overwrite and chmod any file), keeps the
/// file's owner, group and mode (a `root:anguilla 0640` file stayed
/// readable to the daemon only so), and writes a symlinked configuration
/// through to its target, leaving the symlink.
#[test]
fn set_bus_follows_no_planted_symlink_and_keeps_owner_group_and_mode() {
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _, symlink};
    let dir = std::env::temp_dir().join(format!("anguilla-cli-setbus-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("anguilla.toml");
    let (ok, robot, _) = run(&["config", "default", "--robot"]);
    assert!(ok);
    let robot = robot.replace("/var/lib/anguilla/recordings", "");
    std::fs::write(&path, &robot).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
    // SAFETY: geteuid cannot fail.
    let root = (unsafe { libc::geteuid() }) == 0;
    if root {
        std::os::unix::fs::chown(&path, Some(1234), Some(1234)).unwrap();
    } else {
        eprintln!("not root: the owner kept is the caller's (CI runs this as root: 1234:1234)");
    }
    let owner = std::fs::metadata(&path)
        .map(|m| (m.uid(), m.gid()))
        .unwrap();
    let victim = dir.join("victim");
    std::fs::write(&victim, "secret\n").unwrap();
    std::fs::set_permissions(&victim, std::fs::Permissions::from_mode(0o600)).unwrap();
    symlink(&victim, dir.join(".anguilla.toml.set-bus")).unwrap();
    let file = path.to_str().unwrap();
    let (ok, out, err) = run(&["config", "set-bus", "builtin", "--file", file]);
    assert!(ok, "{err}");
    assert!(out.contains("[bus] spec = \"builtin\""), "{out}");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "secret\n");
    let v = std::fs::metadata(&victim).unwrap();
    assert_eq!(v.mode() & 0o7777, 0o600, "the victim's mode");
    let m = std::fs::metadata(&path).unwrap();
    assert_eq!(
        (m.mode() & 0o7777, (m.uid(), m.gid())),
        (0o640, owner),
        "the configuration's mode, owner and group"
    );
    assert_eq!(
        std::fs::read_to_string(&path).unwrap(),
        robot.replace("spec = \"unset\"", "spec = \"builtin\"")
    );
    // Nothing new beside it: the planted symlink, the victim, the file.
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, [".anguilla.toml.set-bus", "anguilla.toml", "victim"]);
    // A symlinked configuration is written through; the symlink stays.
    std::fs::create_dir(dir.join("robots")).unwrap();
    let real = dir.join("robots").join("eel.toml");
    std::fs::rename(&path, &real).unwrap();
    symlink("robots/eel.toml", &path).unwrap();
    let (ok, out, err) = run(&["config", "set-bus", "socketcan:can0", "--file", file]);
    assert!(ok, "{err}");
    assert!(
        out.contains("(the symlink's target ") && out.contains("robots/eel.toml"),
        "{out}"
    );
    assert!(
        std::fs::symlink_metadata(&path)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    let m = std::fs::metadata(&real).unwrap();
    assert_eq!((m.mode() & 0o7777, (m.uid(), m.gid())), (0o640, owner));
    assert!(
        std::fs::read_to_string(&real)
            .unwrap()
            .contains("spec = \"socketcan:can0\""),
    );
    // A symlink to nothing and a named pipe are refused by name (reading
    // a pipe would wait for a writer for ever).
    let dangling = dir.join("dangling.toml");
    symlink("nowhere.toml", &dangling).unwrap();
    let fifo = dir.join("fifo.toml");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    for (f, why) in [
        (&dangling, "nowhere.toml, which does not exist"),
        (&fifo, "fifo.toml: not a regular file"),
    ] {
        let (ok, _, err) = run_watched(&[
            "config",
            "set-bus",
            "builtin",
            "--file",
            f.to_str().unwrap(),
        ]);
        assert!(!ok && err.contains(why), "{err}");
    }
    assert!(!dir.join("nowhere.toml").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A session.mcap of 10 samples of one joint with 3 unreadable ones.
fn damaged_session(path: &std::path::Path) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(file)
        .unwrap();
    let ch = w
        .add_channel(0, "/anguilla/joints", "json", &Default::default())
        .unwrap();
    for i in 0..13u64 {
        let data = if i % 4 == 3 {
            "{\"measured_pitch\": [0.0]}".to_string()
        } else {
            format!(
                "{{\"measured_pitch\": [0.0], \"measured_yaw\": [{}], \
                 \"measured_pitch_velocity\": [0.0], \"measured_yaw_velocity\": [0.1], \
                 \"measured_pitch_torque\": [0.0], \"measured_yaw_torque\": [0.01]}}",
                0.01 * i as f64
            )
        };
        let header = mcap::records::MessageHeader {
            channel_id: ch,
            sequence: i as u32,
            log_time: i * 10_000_000,
            publish_time: i * 10_000_000,
        };
        w.write_to_known_channel(&header, data.as_bytes()).unwrap();
    }
    w.finish().unwrap();
}

/// Issue 45: `calibrate` refuses a named pipe at once (it read it whole,
/// waiting for a writer for ever), names a file over --max-size, and says
/// how many samples it could not read.
#[test]
fn calibrate_refuses_a_named_pipe_and_counts_what_it_drops() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-cal-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe.mcap");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let (ok, _, err) = run_watched(&["calibrate", fifo.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        err.contains(
            "pipe.mcap: a named pipe, not a regular file (expected a recorded session.mcap)"
        ),
        "{err}"
    );
    // The same for a tracking file and a prior configuration.
    let session = dir.join("session.mcap");
    damaged_session(&session);
    let s = session.to_str().unwrap();
    let (ok, _, err) = run_watched(&["calibrate", s, "--tracking", fifo.to_str().unwrap()]);
    assert!(!ok && err.contains("pipe.mcap: a named pipe"), "{err}");
    let (ok, _, err) = run_watched(&["calibrate", s, "--config", fifo.to_str().unwrap()]);
    assert!(!ok && err.contains("pipe.mcap: a named pipe"), "{err}");
    let (ok, _, err) = run(&["calibrate", s, "--max-size", "0"]);
    assert!(
        !ok && err.contains("bytes, more than the 0 read at most (--max-size"),
        "{err}"
    );
    // Three unreadable samples are counted aloud (the fit itself may
    // refuse so short a swim: the count is printed before it).
    let (_, out, err) = run(&["calibrate", s]);
    assert!(
        out.contains("not taken: 3 unreadable joint samples (/anguilla/joints)"),
        "{out}{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 46, finding 3: `calibrate` on a session with no swim (the
/// README's recipe when `ctl enable` lost the race: the daemon recorded,
/// the joints never moved) printed "none fitted" and exited 0. Now it is
/// an error naming the session and what to do; a short swim is refused
/// before the fit, by its length.
#[test]
fn calibrate_refuses_a_session_with_no_swim_and_a_short_one() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-idle-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let idle = dir.join("idle.mcap");
    joints_session(&idle, 20.0, 0.0);
    let (ok, out, err) = run(&["calibrate", idle.to_str().unwrap()]);
    assert!(!ok, "{out}");
    assert!(
        err.contains("idle.mcap: no swim in it: over its 20.0 s the joints never moved 0.05 rad")
            && err.contains("anguilla ctl calibrate-swim"),
        "{err}"
    );
    // held out, the same
    let short = dir.join("short.mcap");
    joints_session(&short, 10.0, 0.3);
    let (ok, _, err) = run(&[
        "calibrate",
        short.to_str().unwrap(),
        "--holdout",
        idle.to_str().unwrap(),
    ]);
    assert!(
        !ok && err.contains("--holdout") && err.contains("no swim in it"),
        "{err}"
    );
    let (ok, out, err) = run(&["calibrate", short.to_str().unwrap()]);
    assert!(!ok, "{out}");
    assert!(
        out.contains(
            "refused: the fitted sessions swim 10.0 s (the joints moving), fewer than the 30 s"
        ),
        "{out}"
    );
    assert!(err.contains("refused to fit: 1 check(s)"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 45: `dump --log` never replaces a file (a recording, or anything
/// a symlink planted at that name points to).
#[test]
fn dump_log_never_replaces_a_file() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-dumplog-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let old = dir.join("old.log");
    std::fs::write(&old, "recorded\n").unwrap();
    let link = dir.join("link.log");
    std::os::unix::fs::symlink(&old, &link).unwrap();
    for f in [&old, &link] {
        let bus = format!("mem:cli-dumplog-{}", std::process::id());
        let (ok, _, err) = run_watched(&[
            "dump",
            "--bus",
            &bus,
            "--log",
            f.to_str().unwrap(),
            "--count",
            "1",
        ]);
        assert!(
            !ok && err.contains("already exists (a recording is never replaced"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read_to_string(&old).unwrap(), "recorded\n");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 46 (finding 6): no command rewrites or deletes a recording's
/// files. Every command that writes into a session directory (`export`,
/// `--ros2`, `--repair`, `calibrate --write`, `config set-bus`, `dump
/// --log`) is run against a recorded session, with its default output and
/// aimed at the recording's own files (directly and through a symlink):
/// afterwards every file that was there is byte for byte and mode for
/// mode what it was, the exports are new files beside them, and each
/// refusal names the file and how to choose another.
#[test]
fn no_command_rewrites_a_recordings_files() {
    use std::os::unix::fs::MetadataExt as _;
    let base = std::env::temp_dir().join(format!("anguilla-cli-export-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let cfg = base.with_extension("toml");
    std::fs::write(
        &cfg,
        format!(
            "[ipc]\nprefix = \"anguilla-cli/export-{}\"\n[recording]\ndir = {:?}\n",
            std::process::id(),
            base.display().to_string()
        ),
    )
    .unwrap();
    let (ok, _, err) = run(&[
        "run",
        "--quiet",
        "--duration",
        "1",
        "--config",
        cfg.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let session = std::fs::read_dir(&base)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let s = session.to_str().unwrap().to_string();
    let at = |f: &str| session.join(f).display().to_string();
    // What was recorded: every file's bytes and mode.
    let snapshot = || {
        let mut v: Vec<(String, Vec<u8>, u32)> = std::fs::read_dir(&session)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                let m = std::fs::symlink_metadata(e.path()).unwrap();
                let bytes = if m.file_type().is_symlink() {
                    std::fs::read_link(e.path())
                        .unwrap()
                        .into_os_string()
                        .into_encoded_bytes()
                } else {
                    std::fs::read(e.path()).unwrap()
                };
                (
                    e.file_name().into_string().unwrap(),
                    bytes,
                    m.mode() & 0o7777,
                )
            })
            .collect();
        v.sort();
        v
    };
    let recorded = snapshot();
    let names: Vec<&str> = recorded.iter().map(|(n, _, _)| n.as_str()).collect();
    for f in [
        "config.toml",
        "session.mcap",
        "state.bin",
        "session.log",
        "bus.log",
    ] {
        assert!(names.contains(&f), "{f} recorded: {names:?}");
    }
    // a symlink beside the recording to its session.mcap, as a user might make
    std::os::unix::fs::symlink("session.mcap", session.join("latest.mcap")).unwrap();
    let recorded = snapshot();
    let mut made = Vec::new();
    // (arguments, Ok(the new file it writes) or Err(its refusal names this))
    let cases: Vec<(Vec<String>, Result<&str, &str>)> = vec![
        (vec!["export".into(), s.clone()], Ok("export.mcap")),
        (vec!["export".into(), s.clone()], Ok("export-2.mcap")),
        (
            vec![
                "export".into(),
                s.clone(),
                "--mcap".into(),
                at("session.mcap"),
            ],
            Err("session.mcap: already exists"),
        ),
        (
            vec![
                "export".into(),
                s.clone(),
                "--mcap".into(),
                at("latest.mcap"),
            ],
            Err("latest.mcap: already exists"),
        ),
        (
            vec!["export".into(), s.clone(), "--mcap".into(), at("state.bin")],
            Err("state.bin: already exists"),
        ),
        (
            vec!["export".into(), s.clone(), "--ros2".into()],
            Ok("session.ros2.mcap"),
        ),
        (
            vec!["export".into(), s.clone(), "--ros2".into()],
            Ok("session.ros2-2.mcap"),
        ),
        (
            vec![
                "export".into(),
                s.clone(),
                "--ros2".into(),
                "--mcap".into(),
                at("config.toml"),
            ],
            Err("config.toml: already exists"),
        ),
        (
            vec!["export".into(), s.clone(), "--repair".into()],
            Ok("session.repaired.mcap"),
        ),
        (
            vec!["export".into(), s.clone(), "--repair".into()],
            Ok("session.repaired-2.mcap"),
        ),
        (
            vec![
                "export".into(),
                s.clone(),
                "--repair".into(),
                "--mcap".into(),
                at("session.mcap"),
            ],
            Err("session.mcap: already exists"),
        ),
        (
            vec![
                "calibrate".into(),
                s.clone(),
                "--write".into(),
                at("config.toml"),
            ],
            Err(""),
        ),
        (
            vec![
                "config".into(),
                "set-bus".into(),
                "builtin".into(),
                "--file".into(),
                at("config.toml"),
            ],
            Err("config.toml: a file of the recording"),
        ),
        (
            vec![
                "dump".into(),
                "--bus".into(),
                format!("mem:cli-export-{}", std::process::id()),
                "--log".into(),
                at("bus.log"),
                "--count".into(),
                "1".into(),
            ],
            Err("bus.log: already exists"),
        ),
    ];
    for (args, want) in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (ok, out, err) = run_watched(&args);
        match want {
            Ok(file) => {
                assert!(ok, "{args:?}: {out}{err}");
                assert!(out.contains(&at(file)), "{args:?} names its output: {out}");
                assert!(std::fs::metadata(session.join(file)).unwrap().len() > 0);
                made.push(file.to_string());
            }
            // calibrate may stop before writing (a session with no swim):
            // what matters is below, that the recording is unchanged
            Err(_) if args[0] == "calibrate" => {}
            Err(text) => {
                assert!(!ok, "{args:?} refused: {out}{err}");
                assert!(err.contains(text), "{args:?}: {err}");
                assert!(!err.contains("panicked"), "{args:?}: {err}");
            }
        }
        if args[0] == "export" && !ok {
            assert!(
                err.contains("never replaces one") && err.contains("--mcap FILE"),
                "{args:?} says how to choose an output: {err}"
            );
        }
        let now = snapshot();
        for (name, bytes, mode) in &recorded {
            let same = now.iter().find(|(n, _, _)| n == name);
            assert!(same.is_some(), "{args:?} deleted {name}");
            let (_, b, m) = same.unwrap();
            assert!(b == bytes, "{args:?} rewrote {name}");
            assert_eq!(m, mode, "{args:?} changed {name}'s mode");
        }
        let mut want_names: Vec<String> = recorded.iter().map(|(n, _, _)| n.clone()).collect();
        want_names.extend(made.iter().cloned());
        want_names.sort();
        let now_names: Vec<String> = now.iter().map(|(n, _, _)| n.clone()).collect();
        assert_eq!(
            now_names, want_names,
            "{args:?}: nothing else left in the session"
        );
    }
    let _ = std::fs::remove_dir_all(&base);
    let _ = std::fs::remove_file(&cfg);
}

#[test]
fn anguillad_is_the_daemon_alone() {
    let o = anguillad().arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for flag in ["--config", "--bus", "--duration", "--quiet"] {
        assert!(help.contains(flag), "{help}");
    }
    // No subcommands: the tools are `anguilla`'s.
    assert!(
        !help.contains("teleop") && !help.contains("Commands:"),
        "{help}"
    );
    let o = anguillad().args(["--duration", "0"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--duration 0 is invalid"));
}

#[test]
fn bad_arguments_are_errors_that_name_them() {
    let (ok, _, err) = run(&["run", "--duration=-1"]);
    assert!(!ok);
    assert!(err.contains("--duration -1 is invalid"), "{err}");
    let (ok, _, err) = run(&["run", "--bus", "carrier-pigeon:1"]);
    assert!(!ok);
    assert!(err.contains("carrier-pigeon"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let (ok, _, err) = run(&[
        "dump",
        "--bus",
        "slcan:/dev/does-not-exist@1000000",
        "--count",
        "1",
    ]);
    assert!(!ok);
    assert!(err.contains("/dev/does-not-exist"), "{err}");
    let (ok, _, err) = run(&["replay", "/nonexistent/session"]);
    assert!(!ok);
    assert!(err.contains("/nonexistent/session"), "{err}");
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--dt", "0.5"]);
    assert!(!ok);
    assert!(err.contains("--dt 0.5: expected"), "{err}");
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--model-nodes", "1"]);
    assert!(!ok);
    assert!(err.contains("--model-nodes 1: expected"), "{err}");
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--head-sensor", "3"]);
    assert!(!ok);
    assert!(
        err.contains("--head-sensor 3: 3 is a vertebra's node id"),
        "{err}"
    );
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--head-sensor", "64"]);
    assert!(!ok);
    assert!(err.contains("--head-sensor 64: 64 outside 1..=63"), "{err}");
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--sensor", "usbl=127.0.0.1:9@2"]);
    assert!(!ok);
    assert!(
        err.contains("--sensor usbl=127.0.0.1:9@2: simulated USBL")
            && err.contains("latency shorter than a reading's period"),
        "{err}"
    );
    let (ok, _, err) = run(&[
        "sim",
        "--slcan-pty",
        "--sensor",
        "usbl=127.0.0.1:9",
        "--sensor",
        "dvl=127.0.0.1:9@0.5",
    ]);
    assert!(!ok);
    assert!(
        err.contains("--sensor dvl=127.0.0.1:9@0.5: simulated DVL: rate 5 Hz"),
        "{err}"
    );
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--sensor", "usbl=nowhere"]);
    assert!(!ok);
    assert!(err.contains("'nowhere' is not ADDRESS:PORT"), "{err}");
    for (skip, says) in [
        ("1,x", "--skip 1,x: 'x' is not a node id"),
        ("13", "--skip 13: node 13 is not one of the robot's"),
        ("2,2", "--skip 2,2: node 2 named twice"),
    ] {
        let (ok, _, err) = run(&["sim", "--slcan-pty", "--skip", skip]);
        assert!(!ok && err.contains(says), "{err}");
    }
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--drive", "mit", "--skip", "1"]);
    assert!(!ok && err.contains("mit drives are all simulated"), "{err}");
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--sensor", "sonar=127.0.0.1:9"]);
    assert!(!ok);
    assert!(
        err.contains("no simulated sensor 'sonar'") && err.contains("usbl, dvl"),
        "{err}"
    );
}

#[test]
fn protocol_dbc_writes_the_odrive_dbc_for_the_ids_given_and_refuses_cia402() {
    let (ok, out, err) = run(&["protocol", "dbc", "--drive", "odrive"]);
    assert!(ok, "{err}");
    assert_eq!(
        out,
        include_str!("../protocol/odrive.dbc"),
        "the default is the committed DBC (axes 1..=24)"
    );
    let (ok, out, err) = run(&["protocol", "dbc", "--drive", "odrive", "--node-ids", "0,9"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("BU_: Master ODrive_Axis0 ODrive_Axis9\n"),
        "{out}"
    );
    assert!(
        out.contains("BO_ 300 Axis9_Set_Input_Pos: 8 Master"),
        "{out}"
    );
    assert_eq!(out.matches("\nBO_ ").count(), 14, "7 messages × 2 axes");
    let (ok, out, err) = run(&["protocol", "dbc", "--drive", "odrive", "--nodes", "2"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("BU_: Master ODrive_Axis1 ODrive_Axis2\n"),
        "{out}"
    );
    for (args, says) in [
        (&["--drive", "cia402"][..], "EDS files"),
        (&["--drive", "odrive", "--fd"][..], "--fd does not apply"),
        (
            &["--drive", "odrive", "--node-ids", "64"][..],
            "expected 0..=63",
        ),
        (
            &["--drive", "odrive", "--node-ids", "3,3"][..],
            "3 given twice",
        ),
        (
            &["--node-ids", "1,2"][..],
            "--node-ids applies to families with a drive per axis",
        ),
    ] {
        let (ok, _, err) = run(&[&["protocol", "dbc"][..], args].concat());
        assert!(!ok, "{args:?}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

/// `anguilla sim --slcan-pty ARGS` started, and the device path it prints.
fn sim_behind_a_pty(args: &[&str]) -> (std::process::Child, String) {
    let mut sim = anguilla()
        .args(["sim", "--slcan-pty"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("sim starts");
    let mut lines = BufReader::new(sim.stdout.take().unwrap()).lines();
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(15));
    let mut device = None;
    while device.is_none() && !deadline.passed() {
        match lines.next() {
            Some(Ok(l)) => {
                device = l
                    .split_whitespace()
                    .find(|w| w.starts_with("/dev/"))
                    .map(|s| s.trim_end_matches(')').to_string())
            }
            _ => break,
        }
    }
    let device = device.expect("the sim prints its device path");
    (sim, device)
}

/// `anguilla sim --slcan-pty ARGS` started, and the device paths of its
/// `n` adapters, in the order printed.
fn sim_adapters(args: &[&str], n: usize) -> (std::process::Child, Vec<String>) {
    let mut sim = anguilla()
        .args(["sim", "--slcan-pty"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("sim starts");
    let mut lines = BufReader::new(sim.stdout.take().unwrap()).lines();
    let mut devices = Vec::new();
    while devices.len() < n {
        match lines.next() {
            Some(Ok(l)) if l.starts_with("slcan device: ") => devices.extend(
                l.split_whitespace()
                    .find(|w| w.starts_with("/dev/"))
                    .map(str::to_string),
            ),
            Some(Ok(_)) => {}
            _ => break,
        }
    }
    assert_eq!(devices.len(), n, "the sim prints {n} device paths");
    (sim, devices)
}

#[test]
fn sim_adapters_share_one_bus_and_bad_counts_are_named() {
    for (args, expect) in [
        (
            &["sim", "--slcan-pty", "--adapters", "9"][..],
            "--adapters 9: expected 1..=8",
        ),
        (
            &["sim", "--bus", "mem:x", "--adapters", "2"],
            "--adapters: only with --slcan-pty",
        ),
        (
            &["sim", "--bus", "mem:x", "--joints", "0"],
            "--joints 0: expected 1..=63",
        ),
        (
            &["sim", "--slcan-pty", "--joints", "0", "--scenario", "x"],
            "--scenario: needs a robot",
        ),
        (
            &["sim", "--slcan-pty", "--data-bitrate", "2000000"],
            "--data-bitrate 2000000: only with --fd",
        ),
        (
            &["sim", "--bus", "mem:x", "--fd", "--data-bitrate", "2000000"],
            "--data-bitrate 2000000: the simulated wire's, behind --slcan-pty",
        ),
        (
            &["sim", "--slcan-pty", "--fd", "--data-bitrate", "500000"],
            "--data-bitrate 500000: data bit rate 500000",
        ),
    ] {
        let (ok, _, err) = run(args);
        assert!(!ok, "{args:?}");
        assert!(err.contains(expect), "{args:?}: {err}");
    }

    // No robot (--joints 0): what one adapter's host sends, the other's
    // host receives, and nothing else is on the bus.
    let (mut sim, devices) =
        sim_adapters(&["--adapters", "2", "--joints", "0", "--duration", "30"], 2);
    assert_ne!(devices[0], devices[1]);
    let open = |d: &str| anguilla_drivers::open(&format!("slcan:{d}@1000000")).expect("opens");
    let (mut a, mut b) = (open(&devices[0]), open(&devices[1]));
    let id = anguilla_protocol::Id::standard_literal(0x123);
    for k in 0..3u8 {
        let sent = anguilla_protocol::Frame::new(id, &[k, 0xA5, 0x5A]).unwrap();
        a.send(&sent).expect("sends");
        let got = b
            .recv(Duration::from_secs(5))
            .expect("receives")
            .expect("a frame within 5 s");
        assert_eq!(got.frame, sent);
    }
    assert!(
        b.recv(Duration::from_millis(200)).unwrap().is_none(),
        "only what was sent"
    );
    // And the other way round.
    let back = anguilla_protocol::Frame::new(id, &[9]).unwrap();
    b.send(&back).expect("sends");
    let got = a
        .recv(Duration::from_secs(5))
        .unwrap()
        .expect("a frame within 5 s");
    assert_eq!(got.frame, back);
    let _ = sim.kill();
    let _ = sim.wait();
}

#[test]
fn dump_decodes_the_simulated_robot_behind_an_slcan_pty_and_logs_it() {
    let (mut sim, device) = sim_behind_a_pty(&["--duration", "20"]);
    let log = std::env::temp_dir().join(format!("anguilla-dump-{}.log", std::process::id()));
    let (ok, out, err) = run(&[
        "dump",
        "--bus",
        &format!("slcan:{device}@1000000"),
        "--count",
        "12",
        "--duration",
        "10",
        "--log",
        log.to_str().unwrap(),
    ]);
    let _ = sim.kill();
    let _ = sim.wait();
    assert!(ok, "{err}");
    // Heartbeats of the twelve nodes, decoded.
    assert!(out.contains("heartbeat node="), "{out}");
    let text = std::fs::read_to_string(&log).unwrap();
    let entries: Vec<_> = anguilla_protocol::candump::Reader::new(text.as_bytes()).collect();
    assert_eq!(entries.len(), 12);
    for e in entries {
        let e = e.expect("a valid candump line");
        // A serial adapter's frames carry the name slcand would give it,
        // not the device's basename ("1" for /dev/pts/1).
        assert_eq!(e.interface.as_str(), "slcan0");
    }
    // Decoded offline, the log prints what the live dump printed.
    let (ok, offline, err) = run(&["dump", "--file", log.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert_eq!(offline, out);
    assert!(err.contains("12 frames"), "{err}");
    let _ = std::fs::remove_file(&log);
}

#[test]
fn conform_passes_the_simulated_node_behind_an_slcan_pty() {
    // The firmware author's path: another process's node, over a real bus
    // driver (SLCAN on a pseudo-terminal), in real time.
    let (mut sim, device) = sim_behind_a_pty(&["--joints", "3", "--duration", "120"]);
    let (ok, out, err) = run(&[
        "conform",
        "--bus",
        &format!("slcan:{device}@1000000"),
        "--node",
        "2",
        // Real time on a shared machine: the "heartbeat at once" bound and
        // the window are widened so that a scheduling stall is not taken
        // for the node's fault (the 50 ms default is tested on simulated
        // time in conform/tests/suite.rs).
        "--prompt-ms",
        "300",
        "--window-ms",
        "400",
    ]);
    let _ = sim.kill();
    let _ = sim.wait();
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains(
            "node 2: 35 rows: 28 agree, 0 disagree, 0 not reached, 7 not checked — conforms"
        ),
        "{out}"
    );
    assert!(out.contains("ok        Fault × Enable: BAD_FRAME"), "{out}");
    // A node id outside 1..=63 is named.
    for (args, want) in [
        (&["--node", "0"][..], "--node"),
        (&["--node", "1", "--window-ms", "10"], "--window-ms"),
        (
            &["--node", "1", "--prompt-ms", "900", "--window-ms", "300"],
            "--prompt-ms 900 is longer than --window-ms 300",
        ),
    ] {
        let (ok, _, err) = run(&[&["conform", "--bus", "mem:x"][..], args].concat());
        assert!(!ok, "{args:?} accepted");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn ctl_without_a_daemon_exits_2_naming_the_prefix_and_bad_arguments_are_named() {
    let prefix = format!("anguilla-cli/nobody-{}", std::process::id());
    for cmd in [
        &["status"][..],
        &["estop"],
        &["enable"],
        &["swim", "--amplitude", "0.5", "--frequency", "1"],
    ] {
        let o = anguilla()
            .args(["ctl", "--prefix", &prefix])
            .args(cmd)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "ctl {cmd:?}: {err}");
        assert!(err.contains(&prefix), "ctl {cmd:?} names the prefix: {err}");
    }
    let o = anguilla()
        .args(["ctl", "--prefix", "a b", "status"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("--prefix 'a b' is not valid"), "{err}");
    let o = anguilla()
        .args([
            "ctl",
            "--prefix",
            &prefix,
            "swim",
            "--amplitude",
            "0.5",
            "--frequency",
            "1",
            "--for",
            "1e300",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--for 1e300 is invalid (expected seconds, 0 < S <= 86400)"),
        "{err}"
    );
}

#[test]
fn ctl_swim_hold_targets_are_checked_before_any_daemon_is_asked() {
    let prefix = format!("anguilla-cli/nobody-hold-{}", std::process::id());
    for (flags, want) in [
        (
            &["--heading", "NaN"][..],
            "--heading NaN is invalid (expected degrees, a finite number: 0 ..< 360",
        ),
        (&["--heading", "inf"], "--heading inf is invalid"),
        (
            &["--heading", "90", "--depth", "-1"],
            "--depth -1 is invalid (expected metres below the surface, a finite number >= 0",
        ),
        (&["--depth", "NaN"], "--depth NaN is invalid"),
    ] {
        let o = anguilla()
            .args(["ctl", "--prefix", &prefix, "swim"])
            .args(["--amplitude", "0.5", "--frequency", "1"])
            .args(flags)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{flags:?}: {err}");
        assert!(err.contains(want), "{flags:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // Good targets pass the checks and reach for the daemon: none runs.
    let o = anguilla()
        .args(["ctl", "--prefix", &prefix, "swim"])
        .args(["--amplitude", "0.5", "--frequency", "1"])
        .args(["--heading", "-90", "--depth", "1.5"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(&prefix), "{err}");
}

/// A pipe whose reading end is already closed: every write gets EPIPE.
fn closed_pipe() -> Stdio {
    use std::os::fd::{FromRawFd, OwnedFd};
    let mut fds = [0; 2];
    // SAFETY: pipe() fills two new descriptors; each is owned once below.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    drop(unsafe { OwnedFd::from_raw_fd(fds[0]) });
    Stdio::from(unsafe { OwnedFd::from_raw_fd(fds[1]) })
}

fn dev_full() -> Stdio {
    Stdio::from(
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap(),
    )
}

#[test]
fn a_full_or_closed_stdout_is_an_error_or_a_quiet_end_never_a_panic() {
    let cfg = std::env::temp_dir().join(format!("anguilla-cli-out-{}.toml", std::process::id()));
    std::fs::write(&cfg, "").unwrap();
    let cfg = cfg.to_str().unwrap().to_owned();
    let commands: [&[&str]; 7] = [
        &["config", "default"],
        &["config", "check", &cfg],
        &["swim", "--gait", "F1", "--duration", "0.2"],
        &["protocol", "layout"],
        &["protocol", "budget"],
        &["protocol", "dbc"],
        &["joy", "--print-mapping"],
    ];
    for args in commands {
        let o = anguilla().args(args).stdout(dev_full()).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{args:?} > /dev/full: {err}");
        assert_eq!(o.status.code(), Some(1), "{args:?} > /dev/full: {err}");
        assert!(
            err.contains("writing to standard output"),
            "{args:?}: {err}"
        );
        let o = anguilla()
            .args(args)
            .stdout(closed_pipe())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{args:?} | closed: {err}");
        assert_eq!(o.status.code(), Some(0), "{args:?} | closed: {err}");
        assert!(err.is_empty(), "a closed pipe ends quietly: {err}");
    }
}

#[test]
fn the_daemon_and_the_simulator_outlive_their_stdout() {
    let cfg =
        std::env::temp_dir().join(format!("anguilla-cli-outlive-{}.toml", std::process::id()));
    let prefix = format!("anguilla-cli/outlive-{}", std::process::id());
    std::fs::write(&cfg, format!("[ipc]\nprefix = \"{prefix}\"\n")).unwrap();
    for out in [closed_pipe(), dev_full()] {
        let o = anguilla()
            .args(["run", "--duration", "2", "--config", cfg.to_str().unwrap()])
            .stdout(out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(o.status.code(), Some(0), "run: {err}");
        assert!(
            err.contains("mode idle") || err.contains("control loop"),
            "{err}"
        );
    }
    let o = anguilla()
        .args(["sim", "--bus", "mem:cli-sim-out", "--duration", "1.5"])
        .stdout(dev_full())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(0), "sim: {err}");
    assert!(err.contains("no more status lines"), "{err}");
}

#[test]
fn sighup_stops_the_daemon_smoothly() {
    let prefix = format!("anguilla-cli/hup-{}", std::process::id());
    let cfg = std::env::temp_dir().join(format!("anguilla-cli-hup-{}.toml", std::process::id()));
    std::fs::write(&cfg, format!("[ipc]\nprefix = \"{prefix}\"\n")).unwrap();
    let mut child = anguilla()
        .args(["run", "--config", cfg.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the first status line: the daemon is up.
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let first = lines.next().expect("a status line").unwrap();
    assert!(first.starts_with("t="), "{first}");
    unsafe { libc::kill(child.id() as i32, libc::SIGHUP) };
    let status = wait_exit(&mut child, "the daemon stopping on SIGHUP", 20);
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert_eq!(status.code(), Some(0), "{rest:?}");
    assert!(
        rest.iter().any(|l| l.starts_with("stopped in mode idle")),
        "a clean stop: {rest:?}"
    );
    // The signal is logged, with what it does.
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert!(err.contains("SIGHUP received: stopping"), "{err}");
}

/// Ctrl-C while a tool waits for the daemon is the user's own stop: exit
/// 130 (the shell's code for SIGINT), no error message.
#[test]
fn ctrl_c_while_waiting_for_the_daemon_exits_130_quietly() {
    let prefix = format!("anguilla-cli/ctrl-c-{}", std::process::id());
    let mut child = anguilla()
        .args(["link", "--prefix", &prefix])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // It says that it waits, then waits.
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    while !line.contains("waiting for the daemon") {
        line.clear();
        assert!(err.read_line(&mut line).unwrap() > 0, "link ended: {line}");
    }
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let status = child.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(!rest.contains("Error"), "{rest}");
}

#[test]
fn numbers_a_user_types_are_bounded_and_named() {
    for (args, want) in [
        (
            &["swim", "--gait", "F1", "--dt", "1e-300"][..],
            "--dt 1e-300 is out of range (expected 0.00001 ..= 0.05 s)",
        ),
        (
            &["swim", "--gait", "F1", "--duration", "1e300"],
            "--duration 1e300 is out of range (expected 0 < S <= 3600 s)",
        ),
        (
            &["sim", "--bus", "mem:x", "--bitrate", "0"],
            "--bitrate: nominal bit rate 0 bit/s (expected 10000..=1000000)",
        ),
        (
            &["sim", "--bus", "mem:x", "--duration", "1e300"],
            "--duration 1e300: expected seconds, 0 < S <= 1e6",
        ),
        (
            &["sim", "--slcan-pty", "--ballast", "0.5"],
            "`ballast` must be within 0 ..= 0.05 m",
        ),
        (
            &["foxglove", "--bind", "localhost"],
            "--bind localhost: expected ADDR:PORT",
        ),
        (
            &["foxglove", "--rate", "0"],
            "--rate 0 is invalid (expected states per second > 0)",
        ),
        (
            &["export", "/nonexistent-session"],
            "cannot read configuration file /nonexistent-session/config.toml",
        ),
        (
            &["sim", "--slcan-pty", "--body", "/nonexistent-body.toml"],
            "--body /nonexistent-body.toml: cannot read configuration file",
        ),
        (
            &["run", "--sim-body", "/nonexistent-body.toml"],
            "--sim-body /nonexistent-body.toml: cannot read",
        ),
        (
            &[
                "run",
                "--bus",
                "mem:x",
                "--sim-body",
                "/nonexistent-body.toml",
            ],
            "--sim-body is for the built-in simulated robot; a bus was named",
        ),
        (
            &["run", "--sim-depth", "-1"],
            "--sim-depth -1 is invalid (expected metres below the surface, > 0 and at most [autopilot] max-depth 10)",
        ),
        (&["run", "--sim-depth", "0"], "--sim-depth 0 is invalid"),
        (&["run", "--sim-depth", "NaN"], "--sim-depth NaN is invalid"),
        (
            &["run", "--sim-depth", "10.5"],
            "--sim-depth 10.5 is invalid",
        ),
        (
            &["run", "--bus", "mem:x", "--sim-depth", "3"],
            "--sim-depth is for the built-in simulated robot; a bus was named",
        ),
        (
            &["ctl", "calibrate-swim", "--min-depth", "-0.5"],
            "--min-depth -0.5 is invalid (expected metres below the surface, >= 0)",
        ),
        (
            &["run", "--scenario", "/nonexistent-scenario.txt"],
            "--scenario /nonexistent-scenario.txt: cannot read",
        ),
        (
            &["run", "--bus", "mem:x", "--scenario", "/dev/null"],
            "--scenario is for the built-in simulated robot; a bus was named",
        ),
    ] {
        let (ok, _, err) = run(args);
        assert!(!ok, "{args:?} accepted");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(
            !err.contains("panicked") && !err.contains("backtrace"),
            "{err}"
        );
    }
}

#[test]
fn sim_speaks_the_chosen_drive_family_and_bad_drive_ids_are_named() {
    for (args, want) in [
        (
            &["sim", "--bus", "mem:x", "--drive", "canopen"][..],
            "unknown drive family \"canopen\" (expected one of \"anguilla\", \"cia402\", \"odrive\"",
        ),
        (
            &["sim", "--bus", "mem:x", "--drive", "odrive", "--fd"],
            "--fd: odrive drives speak classic CAN",
        ),
        (
            &["sim", "--bus", "mem:x", "--axis-ids", "1:2"],
            "--axis-ids: only with --drive cia402, odrive, mit",
        ),
        (
            &[
                "sim",
                "--bus",
                "mem:x",
                "--drive",
                "odrive",
                "--joints",
                "2",
                "--axis-ids",
                "1:2,3",
            ],
            "--axis-ids 1:2,3: joint 2 is \"3\", expected PITCH:YAW",
        ),
        (
            &[
                "sim",
                "--bus",
                "mem:x",
                "--drive",
                "odrive",
                "--joints",
                "2",
                "--axis-ids",
                "1:2,3:64",
            ],
            "--axis-ids 1:2,3:64: joint 2 yaw id 64 outside odrive's 0..=63",
        ),
        (
            &[
                "sim",
                "--bus",
                "mem:x",
                "--drive",
                "odrive",
                "--joints",
                "2",
                "--axis-ids",
                "1:2,2:3",
            ],
            "id 2 appears twice (joint 2 pitch)",
        ),
        (
            &[
                "sim",
                "--bus",
                "mem:x",
                "--drive",
                "odrive",
                "--joints",
                "3",
                "--axis-ids",
                "1:2",
            ],
            "1 pairs for 3 joints",
        ),
        (
            &[
                "sim", "--bus", "mem:x", "--drive", "odrive", "--joints", "32",
            ],
            "--joints 32: joint 32 yaw id 64 outside odrive's 0..=63",
        ),
    ] {
        let (ok, _, err) = run(args);
        assert!(!ok, "{args:?} accepted");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let (ok, out, err) = run(&[
        "sim",
        "--bus",
        "mem:cli-sim-odrive",
        "--drive",
        "odrive",
        "--joints",
        "2",
        "--axis-ids",
        "10:11,20:21",
        "--duration",
        "1.2",
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("odrive drives 10:11,20:21"), "{out}");
    // Booted ODrive axes are idle: the joints are Disabled.
    assert!(out.contains("[0, 2, 0, 0, 0]"), "{out}");
}

#[test]
fn bare_anguilla_is_a_usage_error_with_the_help() {
    let o = anguilla().output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("Usage: anguilla") && err.contains("ctl"),
        "{err}"
    );
}

#[test]
fn replay_tells_a_cut_recording_from_a_different_one() {
    let base = std::env::temp_dir().join(format!("anguilla-cli-rec-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let cfg = base.with_extension("toml");
    std::fs::write(
        &cfg,
        format!(
            "[ipc]\nprefix = \"anguilla-cli/rec-{}\"\n[recording]\ndir = {:?}\n",
            std::process::id(),
            base.display().to_string()
        ),
    )
    .unwrap();
    let (ok, _, err) = run(&[
        "run",
        "--quiet",
        "--duration",
        "1",
        "--config",
        cfg.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let session = std::fs::read_dir(&base)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let (ok, out, err) = run(&["replay", session.to_str().unwrap()]);
    assert!(ok && out.contains("identical"), "{out} {err}");
    // Cut as a SIGKILL or a full disk would leave it.
    let log = session.join("session.log");
    let text = std::fs::read_to_string(&log).unwrap();
    std::fs::write(&log, &text[..text.len() / 2]).unwrap();
    let o = anguilla()
        .args(["replay", session.to_str().unwrap()])
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(3), "{out}");
    assert!(
        out.contains("truncated at line") && out.contains("match bit for bit"),
        "{out}"
    );
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
#[ignore = "needs root (mounts a small tmpfs): CI runs it as root (.ci/run, --ignored)"]
fn a_full_disk_loses_the_recording_not_the_daemon_and_says_so() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-full-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A 64 kB file system fills within a second of recording.
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&dir)
        .status()
        .is_ok_and(|s| s.success());
    anguilla_testkit::require(mounted, || {
        "full disk: cannot mount a small tmpfs here (needs root)".to_owned()
    });
    struct Unmount<'a>(&'a std::path::Path);
    impl Drop for Unmount<'_> {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg(self.0).status();
            let _ = std::fs::remove_dir(self.0);
        }
    }
    let _unmount = Unmount(&dir);
    let cfg = std::env::temp_dir().join(format!("anguilla-cli-full-{}.toml", std::process::id()));
    std::fs::write(
        &cfg,
        format!(
            // min-free off: this is the disk filling unguarded
            "[ipc]\nprefix = \"anguilla-cli/full-{}\"\n[recording]\ndir = {:?}\nmin-free = 0\n",
            std::process::id(),
            dir.display().to_string()
        ),
    )
    .unwrap();
    let (ok, out, err) = run(&["run", "--duration", "3", "--config", cfg.to_str().unwrap()]);
    assert!(ok, "the daemon goes on: {err}");
    assert!(err.contains("failed"), "the failure is logged: {err}");
    assert!(
        out.contains("RECORDING LOST"),
        "the status line says so: {out}"
    );
    assert!(
        out.contains("the recording lost"),
        "the run report says so: {out}"
    );
    // What reached the disk replays as far as it goes.
    let session = std::fs::read_dir(&dir)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let o = anguilla()
        .args(["replay", session.to_str().unwrap()])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(3),
        "{said} {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(said.contains("truncated at line"), "{said}");
}

/// The `min-free` stop is an end, not a kill: the recorder writes why it
/// stopped at the end of `session.log`, and replay says so (exit 0), not
/// "truncated".
#[test]
#[ignore = "needs root (mounts a small tmpfs): CI runs it as root (.ci/run, --ignored)"]
fn a_recording_stopped_at_min_free_replays_as_stopped_with_its_reason() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-minfree-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=16m", "tmpfs"])
        .arg(&dir)
        .status()
        .is_ok_and(|s| s.success());
    anguilla_testkit::require(mounted, || {
        "min-free stop: cannot mount a small tmpfs here (needs root)".to_owned()
    });
    struct Unmount<'a>(&'a std::path::Path);
    impl Drop for Unmount<'_> {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg(self.0).status();
            let _ = std::fs::remove_dir(self.0);
        }
    }
    let _unmount = Unmount(&dir);
    let cfg = dir.with_extension("toml");
    std::fs::write(
        &cfg,
        format!(
            "[ipc]\nprefix = \"anguilla-cli/minfree-{}\"\n[recording]\ndir = {:?}\nmin-free = 4\n",
            std::process::id(),
            dir.display().to_string()
        ),
    )
    .unwrap();
    let mut child = anguilla()
        .args(["run", "--quiet", "--duration", "600", "--config"])
        .arg(&cfg)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A watchdog, not a bound: each takes about a second.
    let wait = |what: &str, f: &mut dyn FnMut() -> bool| {
        anguilla_testkit::wait_until(what, Duration::from_secs(120), f)
    };
    let session = dir.join("session-");
    let mut found = None;
    wait("a session directory", &mut || {
        found = std::fs::read_dir(&dir).ok().and_then(|mut it| {
            it.find_map(|e| {
                let p = e.ok()?.path();
                (p.to_string_lossy().starts_with(&*session.to_string_lossy())
                    && p.join("config.toml").exists())
                .then_some(p)
            })
        });
        found.is_some()
    });
    let session = found.unwrap();
    // The loop's first record on disk (it starts after the recorder: a
    // disk filled before it would stop a recording of nothing).
    let log = session.join("session.log");
    wait("the session's start line", &mut || {
        std::fs::read_to_string(&log).is_ok_and(|t| t.contains("\nstart "))
    });
    // Fill the disk to 1 MB short of min-free's 4.
    let free = {
        let c = std::ffi::CString::new(dir.to_str().unwrap()).unwrap();
        let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
        assert_eq!(unsafe { libc::statvfs(c.as_ptr(), &mut st) }, 0);
        st.f_bavail * st.f_frsize
    };
    std::fs::write(dir.join("filler"), vec![0u8; (free - 3_000_000) as usize]).unwrap();
    wait("the stopped line", &mut || {
        std::fs::read_to_string(&log).is_ok_and(|t| t.contains("\nstopped "))
    });
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert!(status.success(), "{err}");
    assert!(err.contains("recording ended"), "{err}");
    let text = std::fs::read_to_string(&log).unwrap();
    let last = text.lines().last().unwrap();
    assert!(
        last.starts_with("stopped min-free: ")
            && last.contains("below [recording] min-free (4 MB)"),
        "{last}"
    );
    let o = anguilla().arg("replay").arg(&session).output().unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{said} {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        said.contains("identical as far as it was recorded")
            && said.contains("the recorder stopped there while the daemon went on: min-free:")
            && !said.contains("truncated"),
        "{said}"
    );
    let _ = std::fs::remove_file(&cfg);
}

fn corpus(name: &str) -> String {
    format!(
        "{}/protocol/tests/data/candump-corpus/{name}",
        env!("CARGO_MANIFEST_DIR")
    )
}

#[test]
fn dump_file_decodes_can_utils_and_python_can_logs_error_frames_included() {
    for (name, lines) in [("can-utils.log", 14), ("python-can.log", 13)] {
        let (ok, out, err) = run(&["dump", "--file", &corpus(name)]);
        assert!(ok, "{name}: {err}");
        assert_eq!(out.lines().count(), lines, "{out}");
        assert!(err.contains(&format!("{lines} frames")), "{err}");
        assert!(
            out.lines().any(|l| l.contains("20000080#0000000000000000")
                && l.ends_with("error frame: bus-error")),
            "{out}"
        );
    }
    // The protocol's own frames decode: a SYNC from python-can's log.
    let (_, out, _) = run(&["dump", "--file", &corpus("python-can.log")]);
    assert!(
        out.contains("040#0700") && out.contains("sync counter=7"),
        "{out}"
    );

    // Standard input, and a count.
    let text = std::fs::read_to_string(corpus("can-utils.log")).unwrap();
    let mut child = anguilla()
        .args(["dump", "--file", "-", "--count", "3"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(text.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 3);
}

#[test]
fn dump_decodes_each_drive_family() {
    let path = std::env::temp_dir().join(format!("anguilla-families-{}.log", std::process::id()));
    // A CANopen SDO write of 0x6060 = 8 to node 5, a boot-up, an ODrive
    // Set_Input_Pos to axis 1 (the odrive module's doc example).
    std::fs::write(
        &path,
        "(1.0) can0 605#2F60600008000000\n(1.1) can0 705#00\n(1.2) can0 02C#0000803FF40106FF\n",
    )
    .unwrap();
    let file = path.to_str().unwrap();
    let (ok, out, err) = run(&["dump", "--drive", "cia402", "--file", file]);
    assert!(ok, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert!(
        lines[0]
            .contains("sdo request node=5 sdo=Download sdo.object.index=24672 sdo.object.sub=0"),
        "{out}"
    );
    assert!(lines[1].contains("heartbeat node=5 state=BootUp"), "{out}");
    assert!(lines[2].contains("(not ours: COB-ID 0x02C"), "{out}");
    let (ok, out, _) = run(&["dump", "--drive", "odrive", "--file", file]);
    assert!(ok);
    assert!(
        out.lines()
            .nth(2)
            .unwrap()
            .contains("body=SetInputPos body.input_pos=1.0 body.vel_ff=0.5 body.torque_ff=-0.25"),
        "{out}"
    );
    let (ok, _, err) = run(&["dump", "--drive", "odrive", "--fd", "--file", file]);
    assert!(!ok && err.contains("classic CAN"), "{err}");
    let (ok, _, err) = run(&["dump", "--drive", "canopen", "--file", file]);
    assert!(
        !ok && err.contains("expected one of \"anguilla\", \"cia402\", \"odrive\""),
        "{err}"
    );
    let _ = std::fs::remove_file(&path);
}

#[test]
fn dump_decodes_head_sensor_frames() {
    let path = std::env::temp_dir().join(format!("anguilla-head-{}.log", std::process::id()));
    // The hand-derived frames of protocol/tests/codec.rs: sensor 63's
    // rates and depth on classic CAN, a whole sample on CAN FD.
    std::fs::write(
        &path,
        "(1.0) can0 2BF#01F401FFFF5C44\n(1.1) can0 33F#02CD8B010E063F01\n",
    )
    .unwrap();
    let file = path.to_str().unwrap();
    let (ok, out, err) = run(&["dump", "--file", file]);
    assert!(ok, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert!(
        lines[0].contains("head rates node=63 sample=1 xyz=[1.0, -0.002, 35.0]"),
        "{out}"
    );
    assert!(
        lines[1].contains(
            "head depth node=63 sample=2 pressure=101325 temperature=15.5 status=63 errors=1"
        ),
        "{out}"
    );
    std::fs::write(
        &path,
        "(1.0) can0 37F##1FDDATA\n".replace(
            "FDDATA",
            "070700CD8B019CFFFF7F00000000000000000000000000000000AA0700000000",
        ),
    )
    .unwrap();
    let (ok, out, err) = run(&["dump", "--fd", "--file", file]);
    assert!(ok, "{err}");
    assert!(
        out.contains("head sample node=63 sample=7 quaternion=[1.0, 0.0, 0.0, 0.0]"),
        "{out}"
    );
    let _ = std::fs::remove_file(&path);
}

#[test]
fn dump_file_reports_bad_lines_by_number_and_keeps_the_good_ones() {
    let path = std::env::temp_dir().join(format!("anguilla-bad-{}.log", std::process::id()));
    let long = "(1.000000) can0 123#".to_string() + &"0".repeat(5000);
    std::fs::write(
        &path,
        format!(
            "(1.000000) can0 123#00\n(1.1) can0 1234#00\n{long}\n(1.200000) can0 00123#80:00:11223344#AA\n(1.300000) can0 040#0100\n"
        ),
    )
    .unwrap();
    let (ok, out, err) = run(&["dump", "--file", path.to_str().unwrap()]);
    let _ = std::fs::remove_file(&path);
    assert!(!ok);
    assert_eq!(out.lines().count(), 2, "{out}");
    assert!(out.contains("sync counter=1"), "{out}");
    assert!(
        err.contains("candump log line 2: bad CAN id (expected"),
        "{err}"
    );
    assert!(
        err.contains("candump log line 3: line longer than 1024 bytes"),
        "{err}"
    );
    assert!(err.contains("candump log line 4: CAN XL frame"), "{err}");
    assert!(
        err.contains("3 bad lines skipped, 2 frames decoded"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");

    let (ok, _, err) = run(&["dump", "--file", "/nonexistent/x.log"]);
    assert!(!ok && err.contains("/nonexistent/x.log"), "{err}");
    let (ok, _, err) = run(&["dump"]);
    assert!(
        !ok && err.contains("--bus") && err.contains("--file"),
        "{err}"
    );
    let (ok, _, err) = run(&["dump", "--bus", "mem:x", "--file", "x.log"]);
    assert!(!ok && err.contains("cannot be used with"), "{err}");
}

/// can-utils' own converter (`asc2log`, Vector ASC to candump log) writes
/// error frames, remote frames with a DLC, FD frames and direction markers;
/// `dump --file` reads all of it.
#[test]
#[ignore = "needs asc2log (can-utils): CI installs it and runs this (.ci/run, --ignored)"]
fn dump_file_reads_what_can_utils_asc2log_writes() {
    anguilla_testkit::require(anguilla_testkit::on_path("asc2log"), || {
        "asc2log (can-utils) is not installed; apt-get install can-utils".to_owned()
    });
    let dir = std::env::temp_dir().join(format!("anguilla-asc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let asc = dir.join("in.asc");
    let log = dir.join("out.log");
    std::fs::write(&asc, ASC).unwrap();
    let st = Command::new("asc2log")
        .arg("-I")
        .arg(&asc)
        .arg("-O")
        .arg(&log)
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    let written = std::fs::read_to_string(&log).unwrap();
    let (ok, out, err) = run(&["dump", "--file", log.to_str().unwrap()]);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(ok, "{err}\n{written}");
    assert_eq!(out.lines().count(), 8, "{written}\n{out}");
    for want in ["#R8", "20000080#", "12345678#", "##"] {
        assert!(written.contains(want), "asc2log wrote no {want}: {written}");
    }
    assert!(out.contains("error frame: bus-error"), "{out}");
    assert!(out.contains("1FFFFFFF#R8"), "{out}");
}

const ASC: &str = "date Tue Nov 14 12:00:00.000 am 2023
base hex  timestamps absolute
no internal events logged
// version 9.0.0
Begin Triggerblock Tue Nov 14 12:00:00.000 am 2023
   0.000000 Start of measurement
   0.001000 1  123             Rx   d 4 DE AD BE EF
   0.002000 1  12345678x       Tx   d 0
   0.003000 1  7FF             Rx   r
   0.003500 1  1FFFFFFFx       Rx   r 8
   0.004000 1  ErrorFrame
   0.005000 2  0C1             Rx   d 8 00 11 22 33 44 55 66 77
   0.006000 CANFD   1 Rx        10                                   1 0 9 12 00 00 00 00 00 00 00 00 00 00 00 00        0    0      1000        0        0        0        0        0
   0.007000 CANFD   1 Tx  1abcdef0x                                   0 1 8  8 01 02 03 04 05 06 07 08        0    0      1000        0        0        0        0        0
End TriggerBlock
";

/// Only an operator drives: the Foxglove WebSocket protocol has no
/// authentication, so commands through it need the owner's explicit
/// `insecure-commands`; without it `anguilla foxglove` refuses to start and
/// says why (before, anyone who reached the port could drive).
#[test]
fn foxglove_commands_need_insecure_commands() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-fox-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("a.toml");
    std::fs::write(
        &cfg,
        "[ipc]\nprefix = \"anguilla-cli-fox\"\n[foxglove]\ncommands = true\n",
    )
    .unwrap();
    let cfg = cfg.to_str().unwrap();
    let args = [
        "foxglove",
        "--config",
        cfg,
        "--bind",
        "127.0.0.1:0",
        "--duration",
        "3",
    ];
    let (ok, _, err) = run(&args);
    assert!(!ok, "served commands without insecure-commands: {err}");
    assert!(
        err.contains("no authentication") && err.contains("insecure-commands = true"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The built-in robot out of the box: its head sensor on the first free
/// node id, its timeouts relaxed for a shared CPU (each named), and a
/// status line in the operator's convention (heading from the body's
/// centroid to the nose: 180° at the start, the robot lying along +x).
#[test]
fn the_builtin_robot_has_a_head_sensor_and_relaxed_timeouts() {
    let cfg =
        std::env::temp_dir().join(format!("anguilla-cli-builtin-{}.toml", std::process::id()));
    std::fs::write(
        &cfg,
        format!(
            "[ipc]\nprefix = \"anguilla-cli/builtin-{}\"\n",
            std::process::id()
        ),
    )
    .unwrap();
    let (ok, out, err) = run(&["run", "--duration", "2", "--config", cfg.to_str().unwrap()]);
    let _ = std::fs::remove_file(&cfg);
    assert!(ok, "{err}");
    assert!(
        err.contains("the simulated robot's head sensor is node 13"),
        "{err}"
    );
    for key in [
        "control.command-timeout = 2",
        "control.heartbeat-timeout = 2",
        "control.node-watchdog = 1",
        "control.feedback-timeout = ",
        "sensor.timeout = 2",
        "a real bus keeps the strict defaults",
    ] {
        assert!(err.contains(key), "{key}: {err}");
    }
    assert!(
        out.contains("simulated robot: speed +0.000 m/s, heading 180.0°, depth 1.00 m"),
        "{out}"
    );
    assert!(!out.contains("yaw"), "{out}");
}

/// Keys set in the file are the user's: the built-in robot keeps them.
#[test]
fn the_builtin_robot_keeps_timeouts_that_were_set() {
    let cfg = std::env::temp_dir().join(format!(
        "anguilla-cli-builtin-set-{}.toml",
        std::process::id()
    ));
    std::fs::write(
        &cfg,
        format!(
            "[ipc]\nprefix = \"anguilla-cli/builtin-set-{}\"\n[control]\ncommand-timeout = 0.4\n[sensor]\nnode = 30\n",
            std::process::id()
        ),
    )
    .unwrap();
    let (ok, _, err) = run(&["run", "--duration", "1", "--config", cfg.to_str().unwrap()]);
    let _ = std::fs::remove_file(&cfg);
    assert!(ok, "{err}");
    assert!(!err.contains("command-timeout"), "{err}");
    assert!(err.contains("control.heartbeat-timeout = 2"), "{err}");
    assert!(!err.contains("head sensor is node"), "{err}");
}

/// The completion scripts come from the command line's definition: every
/// shell's names the subcommands and their flags (down to `ctl swim
/// --heading`), and an unknown shell is a usage error listing the known.
#[test]
fn completions_name_the_subcommands_and_their_flags() {
    let (ok, bash, err) = run(&["completions", "bash"]);
    assert!(ok, "{err}");
    assert!(bash.contains("_anguilla()"), "a bash function: {bash}");
    assert!(bash.contains("complete -F _anguilla"), "registered: {bash}");
    for word in ["ctl", "--heading", "--depth", "swim", "estop", "man"] {
        assert!(bash.contains(word), "bash completion lacks {word}");
    }
    for shell in ["zsh", "fish", "elvish", "powershell"] {
        let (ok, script, err) = run(&["completions", shell]);
        assert!(ok, "{shell}: {err}");
        assert!(
            script.contains("heading") && script.contains("ctl"),
            "{shell} completion lacks ctl swim --heading: {script}"
        );
    }
    let (ok, _, err) = run(&["completions", "tcsh"]);
    assert!(!ok);
    assert!(err.contains("tcsh") && err.contains("bash"), "{err}");
}

/// `anguilla man DIR` writes one roff page per subcommand, named as man(1)
/// looks them up, each listed on stdout.
#[test]
fn man_writes_a_page_per_subcommand() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-man-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (ok, out, err) = run(&["man", dir.join("man1").to_str().unwrap()]);
    assert!(ok, "{err}");
    let dir = dir.join("man1");
    let listed: Vec<&str> = out.lines().collect();
    let mut pages: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    pages.sort();
    assert_eq!(listed.len(), pages.len(), "{out}");
    for page in [
        "anguilla.1",
        "anguilla-run.1",
        "anguilla-config-check.1",
        "anguilla-ctl-swim.1",
        "anguilla-teleop.1",
        "anguilla-completions.1",
        "anguilla-man.1",
    ] {
        assert!(pages.iter().any(|p| p == page), "{page} missing: {pages:?}");
    }
    #[cfg(feature = "remote")]
    assert!(
        pages.iter().any(|p| p == "anguilla-link-certs.1"),
        "{pages:?}"
    );
    #[cfg(feature = "foxglove")]
    assert!(
        pages.iter().any(|p| p == "anguilla-foxglove.1"),
        "{pages:?}"
    );
    // No page for clap's `help` subcommand.
    assert!(!pages.iter().any(|p| p.contains("help")), "{pages:?}");
    let run_page = std::fs::read_to_string(dir.join("anguilla-run.1")).unwrap();
    let version = env!("CARGO_PKG_VERSION");
    assert!(
        run_page.contains(&format!(".TH anguilla-run 1  \"anguilla {version}\"")),
        "{run_page}"
    );
    // roff writes a flag's hyphens as \-.
    assert!(run_page.contains("\\-\\-bus"), "{run_page}");
    let swim_page = std::fs::read_to_string(dir.join("anguilla-ctl-swim.1")).unwrap();
    assert!(swim_page.contains("\\-\\-heading"), "{swim_page}");
    let top = std::fs::read_to_string(dir.join("anguilla.1")).unwrap();
    assert!(
        top.contains(".SH SUBCOMMANDS") && top.contains("anguilla\\-ctl(1)"),
        "{top}"
    );
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}

/// `run --scenario`: a line the built-in robot cannot play is refused
/// before the daemon starts, naming the file, the line and what was
/// expected.
#[test]
fn a_scenario_the_built_in_robot_cannot_play_is_named() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-scenario-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("faults.txt");
    let cfg = dir.join("anguilla.toml");
    std::fs::write(
        &cfg,
        format!(
            "[ipc]\nprefix = \"anguilla-cli/scenario-{}\"\n",
            std::process::id()
        ),
    )
    .unwrap();
    for (text, want) in [
        (
            "1.0 joint 4 yaw snag 0.5\n2.0 joint 13 yaw snag 0.5\n",
            "scenario line 2: joint 13",
        ),
        (
            "1.0 joint 4 yaw snag 500\n",
            "scenario line 1: snag 500 out of range -100..=100 N·m",
        ),
    ] {
        std::fs::write(&file, text).unwrap();
        let (ok, _, err) = run_watched(&[
            "run",
            "--quiet",
            "--duration",
            "1",
            "--config",
            cfg.to_str().unwrap(),
            "--scenario",
            file.to_str().unwrap(),
        ]);
        assert!(!ok, "{text:?} accepted");
        assert!(
            err.contains(&format!("--scenario {}: ", file.display())) && err.contains(want),
            "{text:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: ts is a valid out-pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// `anguilla sim --truth FILE` records the ground truth as a session's
/// `/sim/truth` (issue 46, finding 7: `anguilla sim` recorded none): an
/// MCAP file whose one channel is `/sim/truth`, schema anguilla.SimTruth,
/// messages with the session's fields, the simulation's time increasing,
/// stamped with CLOCK_MONOTONIC (the daemon's clock) within the command's
/// run. A file that is there is refused and left as it was.
#[test]
fn sim_records_its_ground_truth() {
    let dir = std::env::temp_dir().join(format!("anguilla-cli-truth-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("truth.mcap");
    let before = monotonic_ns();
    let (ok, out, err) = run_watched(&[
        "sim",
        "--slcan-pty",
        "--duration",
        "1.5",
        "--truth",
        file.to_str().unwrap(),
    ]);
    let after = monotonic_ns();
    assert!(ok, "{out} {err}");
    assert!(
        out.contains("ground truth: ") && out.contains("samples of /sim/truth"),
        "{out}"
    );
    let bytes = std::fs::read(&file).unwrap();
    let mut last_sim_time = -1.0;
    let mut n = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        assert_eq!(m.channel.topic, "/sim/truth");
        let schema = m.channel.schema.as_ref().unwrap();
        assert_eq!(schema.name, "anguilla.SimTruth");
        assert!(
            (before..=after).contains(&m.log_time),
            "log time {} outside the run {before}..={after}",
            m.log_time
        );
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        for key in [
            "sim_time",
            "position",
            "orientation",
            "velocity",
            "speed",
            "heading_deg",
            "depth",
        ] {
            assert!(v.get(key).is_some(), "{key} missing: {v}");
        }
        // At rest in the water, 1 m deep, heading 180°.
        assert!((v["depth"].as_f64().unwrap() - 1.0).abs() < 0.05, "{v}");
        let t = v["sim_time"].as_f64().unwrap();
        assert!(t > last_sim_time, "{t} after {last_sim_time}");
        last_sim_time = t;
        n += 1;
    }
    assert!(n >= 2, "{n} messages");
    assert!(out.contains(&format!("ground truth: {n} samples")), "{out}");
    // Never replaced.
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--truth", file.to_str().unwrap()]);
    assert!(!ok);
    assert!(err.contains("already exists"), "{err}");
    assert_eq!(std::fs::read(&file).unwrap(), bytes);
    let (ok, _, err) = run(&["sim", "--slcan-pty", "--joints", "0", "--truth", "x.mcap"]);
    assert!(!ok);
    assert!(err.contains("--truth: needs a robot"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
