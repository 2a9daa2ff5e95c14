//! Least privilege across Unix users: the daemon runs as its own user; a
//! member of its group can E-stop; a user outside the group can neither
//! read the state, nor command, nor E-stop. Needs root (to create the
//! users): ignored under plain `cargo test`, with that reason; CI runs them
//! as root (`.ci/run`: `--ignored`), where a missing requirement fails.
//!
//! iceoryx2 0.10 makes its files owner-only (0600/0400, whatever the
//! umask; see docs/ipc.md "Users and permissions"), so the tools that read
//! state and command over iceoryx2 run as the daemon's user; group members
//! reach the daemon through the E-stop socket (0660) and, for everything,
//! through `anguilla link`'s local socket (a 0770 directory of the daemon's
//! user and group; a tool goes there by itself when iceoryx2 is closed to
//! it, or with `--connect local`), without sudo.

use std::path::{Path, PathBuf};
use std::process::{Command as Proc, Output, Stdio};
use std::time::Duration;

use anguilla_system_tests::Watchdog;
use anguilla_system_tests::process::{
    Killed, anguilla_bin, iceoryx2_sandbox, node_id_segment, poll_until,
};

/// Users and a group made for the test, removed when dropped.
struct Users {
    group: String,
    users: Vec<String>,
}

impl Users {
    fn create(tag: u32) -> Option<Self> {
        let group = format!("angt{tag}");
        let run = |args: &[&str]| {
            Proc::new(args[0])
                .args(&args[1..])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success())
        };
        if !run(&["groupadd", &group]) {
            return None;
        }
        let mut me = Self {
            group: group.clone(),
            users: Vec::new(),
        };
        for (name, groups) in [
            (format!("angd{tag}"), vec!["-g", &group]),
            (format!("ango{tag}"), vec!["-G", &group]),
            (format!("angx{tag}"), vec![]),
        ] {
            let mut args = vec!["useradd", "-M", "-s", "/usr/sbin/nologin"];
            args.extend(groups);
            args.push(&name);
            if !run(&args) {
                return None;
            }
            me.users.push(name);
        }
        Some(me)
    }
}

impl Drop for Users {
    fn drop(&mut self) {
        for u in &self.users {
            let _ = Proc::new("userdel").arg(u).status();
        }
        let _ = Proc::new("groupdel").arg(&self.group).status();
    }
}

/// The start every test here shares: root, setpriv and the test's Unix
/// users. The tests are ignored under plain `cargo test` (they need root);
/// run (`--ignored`, as CI does), they fail naming what is missing.
fn users_for(test: &str, tag: u32) -> Users {
    anguilla_testkit::require(anguilla_testkit::is_root(), || {
        format!("{test}: creating Unix users needs root (run the tests as root, as CI does)")
    });
    anguilla_testkit::require(anguilla_testkit::on_path("setpriv"), || {
        format!("{test}: setpriv (util-linux) is not installed")
    });
    let users = Users::create(tag);
    anguilla_testkit::require(users.is_some(), || {
        format!("{test}: useradd/groupadd failed (not permitted in this environment)")
    });
    users.unwrap()
}

/// A directory of the test's own, `/tmp/anguilla-<name>-<tag>` (mode 1777),
/// with an iceoryx2 configuration that keeps its files apart from the other
/// tests' (iceoryx2 reads ./config/iceoryx2.toml first: root-path
/// `<dir>/iox2/`, prefix `iox_prefix`), `anguilla.toml` naming the daemon's
/// prefix, and the binary where every user can run it. Returns the
/// directory, the binary and the daemon's prefix.
fn sandbox(name: &str, tag: u32, iox_prefix: &str) -> (PathBuf, PathBuf, String) {
    use std::os::unix::fs::PermissionsExt as _;
    let dir = PathBuf::from(format!("/tmp/anguilla-{name}-{tag}"));
    iceoryx2_sandbox(&dir, iox_prefix);
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let prefix = format!("anguilla-{name}-{tag}");
    std::fs::write(
        dir.join("anguilla.toml"),
        format!("[ipc]\nprefix = \"{prefix}\"\n"),
    )
    .unwrap();
    let bin = dir.join("anguilla");
    std::fs::copy(anguilla_bin(), &bin).unwrap();
    std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o755)).unwrap();
    (dir, bin, prefix)
}

/// `anguilla run` as `user` in the sandbox `dir`, once `ctl status --json`
/// answers that user; the daemon and that first status.
fn daemon_as(user: &str, bin: &Path, dir: &Path, prefix: &str) -> (Killed, Output) {
    let daemon = Killed(
        as_user(user, bin, dir)
            .args(["run", "--quiet", "--config", "anguilla.toml"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let status = poll_until(
        "the daemon answering its own user",
        Duration::from_secs(30),
        || {
            let o = ctl(user, bin, dir, prefix, &["status", "--json"]);
            o.status.success().then_some(o)
        },
    );
    (daemon, status)
}

/// `anguilla` run as `user` (its groups included) in `dir`.
fn as_user(user: &str, bin: &Path, dir: &Path) -> Proc {
    let gid = Proc::new("id").args(["-g", user]).output().unwrap();
    let gid = String::from_utf8_lossy(&gid.stdout).trim().to_string();
    let mut p = Proc::new("setpriv");
    p.args(["--reuid", user, "--regid", &gid, "--init-groups", "--"])
        .arg(bin)
        .current_dir(dir);
    p
}

fn ctl(user: &str, bin: &Path, dir: &Path, prefix: &str, args: &[&str]) -> Output {
    as_user(user, bin, dir)
        .args(["ctl", "--prefix", prefix])
        .args(args)
        .output()
        .unwrap()
}

fn mode_of(out: &Output) -> Option<u64> {
    let text = String::from_utf8_lossy(&out.stdout);
    let at = text.find("\"mode\":")? + 7;
    text[at..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

#[test]
#[ignore = "needs root (creates Unix users) and setpriv: CI runs it as root (.ci/run, --ignored)"]
fn only_the_daemons_user_and_group_reach_it() {
    let _dog = Watchdog::new("users", Duration::from_secs(180));
    let tag = std::process::id() % 100_000;
    let users = users_for("users", tag);
    let (daemon_user, operator, outsider) = (&users.users[0], &users.users[1], &users.users[2]);
    let (dir, bin, prefix) = sandbox("users", tag, &format!("iu{tag}_"));
    let (_daemon, status) = daemon_as(daemon_user, &bin, &dir, &prefix);
    assert_eq!(mode_of(&status), Some(0), "idle");

    // The outsider: no state, no command, no E-stop.
    let o = ctl(outsider, &bin, &dir, &prefix, &["status"]);
    assert_eq!(o.status.code(), Some(2), "outsider read the state");
    let o = ctl(outsider, &bin, &dir, &prefix, &["enable"]);
    assert_eq!(o.status.code(), Some(2), "outsider commanded");
    let o = ctl(outsider, &bin, &dir, &prefix, &["estop"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "outsider e-stopped: {err}");
    assert!(err.contains("not allowed to send"), "{err}");
    let o = ctl(daemon_user, &bin, &dir, &prefix, &["status", "--json"]);
    assert_eq!(mode_of(&o), Some(0), "still idle after the outsider");

    // iceoryx2's node-id segment, which iceoryx2 makes 0666: the daemon
    // closed it to other users, so the outsider can neither write nor
    // truncate it (either blocked every new tool).
    let seg = node_id_segment(&format!("iu{tag}_")).expect("the daemon's node-id segment");
    use std::os::unix::fs::MetadataExt as _;
    assert_eq!(std::fs::metadata(&seg).unwrap().mode() & 0o777, 0o600);
    for script in ["printf 0123456789abcdef > \"$0\"", ": > \"$0\""] {
        let o = Proc::new("setpriv")
            .args([
                "--reuid",
                outsider,
                "--regid",
                outsider,
                "--clear-groups",
                "--",
            ])
            .args(["sh", "-c", script])
            .arg(&seg)
            .output()
            .unwrap();
        assert!(
            !o.status.success(),
            "the outsider wrote {}: {script}",
            seg.display()
        );
    }
    let o = ctl(daemon_user, &bin, &dir, &prefix, &["status", "--json"]);
    assert_eq!(
        mode_of(&o),
        Some(0),
        "tools still start after the outsider's tries"
    );

    // The operator (group member): the E-stop goes through.
    let o = ctl(operator, &bin, &dir, &prefix, &["estop"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "operator e-stop: {} {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    poll_until(
        "the operator's e-stop latched",
        Duration::from_secs(10),
        || {
            let o = ctl(daemon_user, &bin, &dir, &prefix, &["status", "--json"]);
            (mode_of(&o) == Some(6)).then_some(())
        },
    );
    // The daemon's user drives it (as operators do through sudo -u).
    let o = ctl(daemon_user, &bin, &dir, &prefix, &["reset"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    drop(_daemon);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Only the operators reach the robot, without sudo: the link's default endpoint, run as the
/// daemon's user, admits the group's members (every tool, no sudo) and
/// nobody else; before, it listened on plain loopback TCP, where any local
/// user enabled the robot and made it swim.
#[test]
#[ignore = "needs root (creates Unix users) and setpriv: CI runs it as root (.ci/run, --ignored)"]
fn only_the_group_reaches_the_local_link() {
    let _dog = Watchdog::new("users-link", Duration::from_secs(180));
    let tag = (std::process::id() + 1) % 100_000;
    let users = users_for("users-link", tag);
    let (daemon_user, operator, outsider) = (&users.users[0], &users.users[1], &users.users[2]);
    let (dir, bin, prefix) = sandbox("users-link", tag, &format!("il{tag}_"));
    let (_daemon, _) = daemon_as(daemon_user, &bin, &dir, &prefix);
    // The link with its defaults: the local socket only.
    let _link = Killed(
        as_user(daemon_user, &bin, &dir)
            .args(["link", "--config", "anguilla.toml"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let remote = |user: &str, args: &[&str]| {
        as_user(user, &bin, &dir)
            .args(["ctl", "--prefix", &prefix, "--connect", "local"])
            .args(args)
            .output()
            .unwrap()
    };
    let status = poll_until(
        "the operator reading through the link",
        Duration::from_secs(30),
        || {
            let o = remote(operator, &["status", "--json"]);
            o.status.success().then_some(o)
        },
    );
    assert_eq!(mode_of(&status), Some(0), "idle");
    // Without --connect: iceoryx2 is closed to the operator, and the tool
    // goes through the local link by itself, saying so.
    let o = ctl(operator, &bin, &dir, &prefix, &["status", "--json"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(mode_of(&o), Some(0), "operator without --connect: {err}");
    assert!(err.contains("through the local link"), "{err}");
    // The outsider cannot even reach the socket: no state, no command.
    for args in [
        &["status"][..],
        &["enable"],
        &["swim", "--amplitude", "0.5", "--frequency", "1"],
    ] {
        let o = remote(outsider, args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_ne!(
            o.status.code(),
            Some(0),
            "outsider {args:?} through the link: {err}"
        );
        assert!(
            err.contains("permission denied") && err.contains("group"),
            "{err}"
        );
        // Nor without --connect: no way round to the link.
        let o = ctl(outsider, &bin, &dir, &prefix, args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "outsider {args:?}: {err}");
        assert!(!err.contains("through the local link"), "{err}");
        assert!(
            err.contains("iceoryx2 files are its user's") && err.contains("join its group"),
            "{err}"
        );
    }
    let o = ctl(daemon_user, &bin, &dir, &prefix, &["status", "--json"]);
    assert_eq!(mode_of(&o), Some(0), "still idle after the outsider");
    // The operator drives without sudo.
    let o = remote(operator, &["enable"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "operator enable: {} {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let o = ctl(daemon_user, &bin, &dir, &prefix, &["status", "--json"]);
    assert_eq!(mode_of(&o), Some(2), "ready after the operator's enable");
    drop(_link);
    drop(_daemon);
    let _ = std::fs::remove_dir_all(&dir);
}

/// No other user keeps the daemon down: a user who makes iceoryx2's directory first no longer
/// leaves the daemon failing in iceoryx2's words (or hanging): it refuses at
/// once, naming the directory, its owner and mode, and the fix.
#[test]
#[ignore = "needs root (creates Unix users) and setpriv: CI runs it as root (.ci/run, --ignored)"]
fn a_foreign_iceoryx2_directory_is_refused_by_name() {
    let _dog = Watchdog::new("users-squat", Duration::from_secs(120));
    let tag = (std::process::id() + 2) % 100_000;
    let users = users_for("users-squat", tag);
    let (daemon_user, outsider) = (&users.users[0], &users.users[2]);
    let (dir, bin, _) = sandbox("users-squat", tag, &format!("is{tag}_"));
    let iox = dir.join("iox2");
    // The outsider makes the directory first, open to all.
    let o = Proc::new("setpriv")
        .args([
            "--reuid",
            outsider,
            "--regid",
            outsider,
            "--clear-groups",
            "--",
        ])
        .args(["sh", "-c", "mkdir -m 0777 \"$0\""])
        .arg(&iox)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = as_user(daemon_user, &bin, &dir)
        .args([
            "run",
            "--quiet",
            "--config",
            "anguilla.toml",
            "--duration",
            "5",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_ne!(
        o.status.code(),
        Some(0),
        "the daemon ran on a foreign directory: {err}"
    );
    assert!(
        err.contains(&iox.display().to_string())
            && err.contains("belongs to uid")
            && err.contains("root-path"),
        "{err}"
    );
    drop(users);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The watcher of the race: as `user`, inotify on /dev/shm (through
/// ctypes: no package needed), and on every event about a segment named
/// `iox_prefix`…`.global_mgmt` it tries to open it read-write for 50 ms.
/// Prints `watching` once the watch is set, `OPENED <name>` on success
/// (and keeps the descriptor, as an attacker would), `never` when the
/// file `stop` appears in `dir`.
const WATCHER: &str = r#"
import ctypes, os, select, struct, sys, time
shm, prefix, stop = sys.argv[1], sys.argv[2], sys.argv[3]
libc = ctypes.CDLL(None, use_errno=True)
fd = libc.inotify_init1(os.O_NONBLOCK)
IN_CREATE, IN_ATTRIB, IN_MODIFY = 0x100, 0x4, 0x2
assert libc.inotify_add_watch(fd, shm.encode(), IN_CREATE | IN_ATTRIB | IN_MODIFY) >= 0
print("watching", flush=True)
kept = []
def attempt(name):
    end = time.monotonic() + 0.05
    while time.monotonic() < end:
        try:
            kept.append(os.open(os.path.join(shm, name), os.O_RDWR))
            print("OPENED", name, flush=True)
            return True
        except OSError:
            pass
    return False
while not os.path.exists(stop):
    r, _, _ = select.select([fd], [], [], 0.05)
    if not r:
        continue
    buf = os.read(fd, 65536)
    i = 0
    while i < len(buf):
        _, _, _, n = struct.unpack_from("iIII", buf, i)
        name = buf[i + 16:i + 16 + n].rstrip(b"\0").decode(errors="replace")
        i += 16 + n
        if name.startswith(prefix) and name.endswith(".global_mgmt") and attempt(name):
            sys.exit(0)
print("never", flush=True)
"#;

/// The node-id segment is never open to another user, not even for the
/// milliseconds between iceoryx2 making it (0666, whatever the umask) and
/// the daemon's chmod: an outsider's inotify watcher tries to open it
/// read-write at every event about it while the daemon starts, three
/// times over (a new iceoryx2 prefix each time: a new segment).
#[test]
#[ignore = "needs root (creates Unix users) and setpriv: CI runs it as root (.ci/run, --ignored)"]
fn the_node_id_segment_cannot_be_raced_at_its_creation() {
    let _dog = Watchdog::new("users-race", Duration::from_secs(240));
    let tag = (std::process::id() + 3) % 100_000;
    let users = users_for("users-race", tag);
    // The system's Python: one in root's home (pyenv) is not the outsider's.
    let python = "/usr/bin/python3";
    anguilla_testkit::require(Proc::new(python).arg("--version").output().is_ok(), || {
        format!("users-race: {python} (the watcher) is not installed")
    });
    let (daemon_user, outsider) = (&users.users[0], &users.users[2]);
    let iox_prefix = format!("ir{tag}_");
    let (dir, bin, prefix) = sandbox("users-race", tag, &iox_prefix);
    let stop = dir.join("stop");
    let mut watcher = Killed(
        Proc::new("setpriv")
            .args([
                "--reuid",
                outsider,
                "--regid",
                outsider,
                "--clear-groups",
                "--",
                python,
                "-c",
                WATCHER,
                anguilla_ipc::guard::SHM_DIR,
                &iox_prefix,
            ])
            .arg(&stop)
            .stdout(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let mut said = std::io::BufReader::new(watcher.0.stdout.take().unwrap());
    let mut line = String::new();
    std::io::BufRead::read_line(&mut said, &mut line).unwrap();
    assert_eq!(line.trim(), "watching", "the watcher did not start");
    for round in 0..3 {
        // A new iceoryx2 prefix and directory each round: a new segment.
        std::fs::write(
            dir.join("config/iceoryx2.toml"),
            format!(
                "[global]\nroot-path = \"{}/iox2-{round}/\"\nprefix = \"{iox_prefix}{round}_\"\n",
                dir.display()
            ),
        )
        .unwrap();
        let log = dir.join(format!("daemon-{round}.err"));
        let mut daemon = Killed(
            as_user(daemon_user, &bin, &dir)
                .args(["run", "--quiet", "--config", "anguilla.toml"])
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(&log).unwrap())
                .spawn()
                .unwrap(),
        );
        // A tool of the daemon's user beside it: it opens the segment too.
        poll_until(
            "the daemon answering its own user",
            Duration::from_secs(30),
            || {
                if let Ok(Some(s)) = daemon.0.try_wait() {
                    panic!(
                        "round {round}: the daemon ended ({s}): {}",
                        std::fs::read_to_string(&log).unwrap_or_default()
                    );
                }
                ctl(daemon_user, &bin, &dir, &prefix, &["status"])
                    .status
                    .success()
                    .then_some(())
            },
        );
        unsafe { libc::kill(daemon.0.id() as i32, libc::SIGINT) };
        let _ = daemon.0.wait();
    }
    std::fs::write(&stop, b"").unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut said, &mut rest).unwrap();
    assert_eq!(
        rest.trim(),
        "never",
        "another user opened the daemon's node-id segment read-write"
    );
    while let Some(seg) = node_id_segment(&iox_prefix) {
        std::fs::remove_file(seg).unwrap();
    }
    drop(users);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The packaged layout (issue 46, finding 9): `/run/anguilla` and its
/// iceoryx2 directory made for the service's user, as
/// deploy/anguilla.tmpfiles.conf makes them at boot, in a mount namespace
/// of the test's own (a tmpfs on /run that no other process sees), and the
/// service's daemon running as that user. Then:
/// - root's `anguilla ctl status` reads its state (before: "no state
///   within 2 s": root's iceoryx2 files were closed to the daemon) and
///   says it ran as the service's user;
/// - root's `anguilla run` runs (before: refused, "/run/anguilla belongs to
///   uid N ...: remove it"), as the service's user;
/// - another user's `anguilla run` is refused, naming the service's user
///   and how to run as it, never advising to remove the directory.
#[test]
#[ignore = "needs root (creates Unix users) and setpriv: CI runs it as root (.ci/run, --ignored)"]
fn on_the_packaged_layout_root_reaches_and_runs_the_daemon_as_the_services_user() {
    let _dog = Watchdog::new("users-package", Duration::from_secs(240));
    let tag = (std::process::id() + 4) % 100_000;
    let users = users_for("users-package", tag);
    let (svc, group, outsider) = (&users.users[0], &users.group, &users.users[2]);
    let (dir, bin, prefix) = sandbox("users-package", tag, &format!("ip{tag}_"));
    // iceoryx2 where the package puts it (deploy/iceoryx2.toml).
    std::fs::write(
        dir.join("config/iceoryx2.toml"),
        format!("[global]\nroot-path = \"/run/anguilla/iceoryx2/\"\nprefix = \"ip{tag}_\"\n"),
    )
    .unwrap();
    std::fs::write(
        dir.join("other.toml"),
        format!("[ipc]\nprefix = \"{prefix}-root\"\n"),
    )
    .unwrap();
    std::fs::write(
        dir.join("third.toml"),
        format!("[ipc]\nprefix = \"{prefix}-third\"\n"),
    )
    .unwrap();
    // Polls of 0.1 s, for at most 60 s times the patience.
    let polls = (600.0 * anguilla_system_tests::process::patience()) as u32;
    let script = format!(
        r#"set -u
mount -t tmpfs -o mode=0755 anguilla-test /run || exit 90
install -d -m 0750 -o {svc} -g {group} /run/anguilla /run/anguilla/iceoryx2 || exit 91
as_svc() {{ setpriv --reuid={svc} --regid={group} --init-groups -- "$@"; }}
setpriv --reuid={svc} --regid={group} --init-groups -- {bin} run --quiet --config anguilla.toml >daemon.out 2>daemon.err &
d=$!
i=0
until as_svc {bin} ctl --prefix {prefix} status >/dev/null 2>&1; do
    i=$((i + 1))
    if [ $i -gt {polls} ] || ! kill -0 $d 2>/dev/null; then
        echo "the service's daemon never answered its user"; cat daemon.err; kill $d; exit 92
    fi
    sleep 0.1
done
{bin} ctl --prefix {prefix} status >root-status.out 2>root-status.err
echo "root-status $?"
{bin} run --config other.toml --duration 1 >root-run.out 2>root-run.err
echo "root-run $?"
setpriv --reuid={outsider} --regid={outsider} --clear-groups -- {bin} run --config third.toml --duration 1 >third-run.out 2>third-run.err
echo "third-run $?"
kill $d
wait $d || true
"#,
        bin = bin.display(),
    );
    let o = Proc::new("unshare")
        .args(["--mount", "--propagation", "private", "sh", "-c", &script])
        .current_dir(&dir)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout).into_owned();
    let file = |n: &str| std::fs::read_to_string(dir.join(n)).unwrap_or_default();
    assert!(
        o.status.success() && said.contains("third-run"),
        "the namespace's script: {} {said} {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    let exit = |what: &str| {
        said.lines()
            .find_map(|l| l.strip_prefix(&format!("{what} ")))
            .unwrap_or_else(|| panic!("no {what} in {said}"))
            .to_owned()
    };
    assert_eq!(
        exit("root-status"),
        "0",
        "sudo anguilla ctl status: {} {}",
        file("root-status.out"),
        file("root-status.err")
    );
    assert!(
        file("root-status.out").contains("mode"),
        "{}",
        file("root-status.out")
    );
    assert!(
        file("root-status.err").contains(&format!("running as user {svc}")),
        "{}",
        file("root-status.err")
    );
    assert_eq!(
        exit("root-run"),
        "0",
        "sudo anguilla run: {}",
        file("root-run.err")
    );
    assert!(
        file("root-run.err").contains(&format!("running as user {svc}")),
        "{}",
        file("root-run.err")
    );
    assert_ne!(exit("third-run"), "0", "{}", file("third-run.err"));
    let third = file("third-run.err");
    assert!(
        third.contains(&format!("sudo -u {svc} anguilla run")) && !third.contains("remove it"),
        "another user's refusal: {third}"
    );
    eprintln!(
        "root's ctl: {}another user's run: {}",
        file("root-status.err"),
        third.lines().last().unwrap_or_default()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
