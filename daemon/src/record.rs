//! Recording a session: the recorder thread.
//!
//! While recording (`recording.dir`), the controller hands every input and
//! output of every period to the recorder thread through a bounded channel
//! that never blocks (a full channel drops the record and counts it). The
//! recorder writes five files into a fresh directory, flushed and synced to
//! the disk every [`SYNC_INTERVAL`] and at the end (a recording that ends
//! early, the disk full or the daemon killed, replays as truncated):
//!
//! - `bus.log`: every frame in and out, in can-utils' `candump -l` format
//!   (interface `anguilla0`), so `canplayer`, python-can, SavvyCAN and
//!   cantools open it;
//! - `session.log`: the replay script, one line per event
//!   ([`crate::session`] has the format);
//! - `config.toml`: the configuration the daemon ran with;
//! - `state.bin`: every tenth [`StateSnapshot`], as its raw `#[repr(C)]`
//!   bytes (layout in `docs/ipc.md`);
//! - `session.mcap`: the same snapshots for Foxglove, Lichtblick and
//!   PlotJuggler ([`crate::mcap_log`] has the channels), finished with its
//!   summary at the end, and readable up to its last chunk (one a second)
//!   after a kill; with the built-in simulated robot, its ground truth
//!   too ([`crate::truth`]).
//!
//! `session.mcap`'s chunks are compressed (`[recording] compression`,
//! zstd by default). The disk is guarded (`[recording]` `max-total`,
//! `keep-days`, `min-free`): at the start and every
//! [`RETENTION_INTERVAL`] the oldest sessions beyond the limits are
//! deleted ([`prune`]); a session does not start with less free space
//! than `min-free`, and one that reaches it ends cleanly, its files
//! finished and synced, the cause logged and written at the end of
//! `session.log` (a `stopped` line: replay tells it from a kill).
//!
//! No recording is destroyed by another ([`create_session`]): a session's
//! directory is made with `mkdir`, never reused (a name already there,
//! from another daemon started in the same second or a clock set back,
//! gets a suffix: `session-<Unix s>-2`, `-3`…), and it is locked
//! (`flock` on the directory) for as long as its recorder runs. Retention
//! deletes only a session it can lock itself, holding the lock while it
//! deletes: a live one (another daemon's on the same directory) is left,
//! and one it cannot delete is logged by name and passed over.
//!
//! [`crate::replay`] replays a recording.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anguilla_protocol::candump::{self, Interface, LogEntry, Timestamp};
use crossbeam_channel::Receiver;

use crate::config::Config;
use crate::mcap_log::McapLog;
use crate::session::{self, Record};
use crate::truth::GroundTruth;
use anguilla_ipc::vocabulary::Nanos;
use anguilla_ipc::{Raw as _, StateSnapshot};

/// Writes a recording; runs on its own thread until the records and the
/// states close (the ground truth, `(daemon time ns, truth)` from a
/// simulated robot, goes to the MCAP file only, and may close any time).
/// `dir` is the session's name: made new, with a suffix where that name
/// is taken ([`create_session`]).
pub fn recorder(
    dir: PathBuf,
    cfg: Config,
    records: Receiver<Record>,
    mut states: Receiver<StateSnapshot>,
    mut truth: Receiver<(u64, GroundTruth)>,
) -> std::io::Result<()> {
    let root = dir.parent().map(PathBuf::from).unwrap_or_default();
    std::fs::create_dir_all(&root)?;
    let rc = &cfg.recording;
    // A directory retention cannot delete is named once, not every round.
    let mut named = std::collections::HashSet::new();
    // The old sessions go first: what they free counts for min-free.
    let mut retained =
        |current: Option<&Path>| match prune(&root, current, rc, std::time::SystemTime::now()) {
            Ok(p) => {
                for (d, why) in p.deleted {
                    tracing::warn!("recording: deleted {} ({why})", d.display());
                }
                for (d, e) in p.failed {
                    if named.insert(d.clone()) {
                        tracing::warn!(
                            "recording: retention could not delete {}: {e} (passed over; the \
                         others were still pruned)",
                            d.display()
                        );
                    }
                }
            }
            Err(e) => tracing::warn!("recording: retention in {}: {e}", root.display()),
        };
    retained(None);
    let min_free = (rc.min_free * 1e6) as u64;
    let free = free_bytes(&root)?;
    if free < min_free {
        return Err(std::io::Error::other(format!(
            "{} MB free on {}, below [recording] min-free ({} MB): the session is not recorded",
            free / 1_000_000,
            root.display(),
            rc.min_free
        )));
    }
    // Held until the recorder returns: retention (ours and other
    // daemons') leaves the session alone while it is written.
    let session_dir = create_session(&dir)?;
    let dir = session_dir.path().to_path_buf();
    tracing::info!("recording to {}", dir.display());
    let cfg_text = cfg.to_toml();
    std::fs::write(dir.join("config.toml"), &cfg_text)?;
    let mut session = BufWriter::new(std::fs::File::create(dir.join("session.log"))?);
    let mut bus = candump::Writer::new(BufWriter::new(std::fs::File::create(dir.join("bus.log"))?));
    let mut state = BufWriter::new(std::fs::File::create(dir.join("state.bin"))?);
    let mut mcap = McapLog::create(&dir.join("session.mcap"), &cfg)?;
    // The format, and which config.toml this session ran with (replay
    // checks it).
    session::write_header(&mut session, &cfg_text)?;
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0);
    let iface = Interface::new("anguilla0").map_err(|_| std::io::ErrorKind::InvalidInput)?;
    let mut start = None;
    let stamp = |now: Nanos, start: Option<Nanos>| {
        let t = epoch + now.saturating_sub(start.unwrap_or(now)).as_nanos();
        Timestamp {
            secs: t / 1_000_000_000,
            micros: ((t % 1_000_000_000) / 1000) as u32,
        }
    };
    // What is written reaches the disk at most SYNC_INTERVAL late: a power
    // cut or a kill loses at most that much (replay then says where the
    // recording ends).
    let ticks = crossbeam_channel::tick(SYNC_INTERVAL);
    let mut last_retention = std::time::Instant::now();
    let sync = |session: &mut BufWriter<std::fs::File>,
                bus: &mut candump::Writer<BufWriter<std::fs::File>>,
                state: &mut BufWriter<std::fs::File>| {
        for w in [&mut *session, bus.get_mut(), &mut *state] {
            w.flush()?;
            w.get_ref().sync_data()?;
        }
        std::io::Result::Ok(())
    };
    loop {
        crossbeam_channel::select! {
            recv(ticks) -> _ => {
                mcap.flush()?;
                sync(&mut session, &mut bus, &mut state)?;
                let free = free_bytes(&root)?;
                if free < min_free {
                    let why = format!(
                        "{} MB free on {}, below [recording] min-free ({} MB)",
                        free / 1_000_000,
                        root.display(),
                        rc.min_free,
                    );
                    tracing::error!(
                        "recording ended: {why}; {} is finished and synced",
                        dir.display()
                    );
                    // The end record: replay reads a stop, not a kill.
                    session::write_stopped(&mut session, &format!("min-free: {why}"))?;
                    break;
                }
                if last_retention.elapsed() >= RETENTION_INTERVAL {
                    last_retention = std::time::Instant::now();
                    retained(Some(&dir));
                }
            }
            recv(records) -> r => {
                let Ok(r) = r else { break };
                session::write_line(&mut session, &r)?;
                match r {
                    Record::Start(t) => start = Some(t),
                    Record::Rx(now, f) | Record::Tx(now, f) => {
                        bus.write(&LogEntry::new(stamp(now, start), iface, f))?;
                    }
                    _ => {}
                }
            }
            recv(states) -> s => {
                match s {
                    Ok(s) => {
                        state.write_all(s.as_bytes())?;
                        mcap.write(&s)?;
                    }
                    // Closed: wait on the records alone from now on.
                    Err(_) => states = crossbeam_channel::never(),
                }
            }
            recv(truth) -> t => {
                match t {
                    Ok((ns, t)) => mcap.write_truth(ns, &t)?,
                    Err(_) => truth = crossbeam_channel::never(),
                }
            }
        }
    }
    for (ns, t) in truth.try_iter() {
        mcap.write_truth(ns, &t)?;
    }
    // Records are closed; take what is left of the states.
    for s in states.try_iter() {
        state.write_all(s.as_bytes())?;
        mcap.write(&s)?;
    }
    mcap.finish()?;
    sync(&mut session, &mut bus, &mut state)?;
    tracing::info!(
        "recording: {} ended, {:.1} MB, the recorder's thread used {:.2} s of CPU",
        dir.display(),
        dir_bytes(&dir) as f64 / 1e6,
        thread_cpu_seconds()
    );
    drop(session_dir);
    Ok(())
}

/// A session directory this recorder made and holds locked (`flock` on
/// the directory, released when this is dropped or the process ends):
/// [`prune`] leaves it alone.
#[derive(Debug)]
pub struct SessionDir {
    path: PathBuf,
    _lock: std::fs::File,
}

impl SessionDir {
    /// Where it is (the name asked for, or that name with a suffix).
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// How many names [`create_session`] tries (`NAME`, `NAME-2`, …).
pub const MAX_SUFFIX: u32 = 1000;

/// Makes the session directory `wanted` new (`mkdir`: an existing one is
/// never reused or truncated); where the name is taken, `wanted-2`,
/// `wanted-3`… up to [`MAX_SUFFIX`]. The directory is locked before it
/// is returned; one that another daemon's retention took between the
/// `mkdir` and the lock (it locks what it deletes) is given up for the
/// next name.
pub fn create_session(wanted: &Path) -> std::io::Result<SessionDir> {
    let (Some(parent), Some(base)) = (wanted.parent(), wanted.file_name()) else {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "{}: expected a session directory's path (<dir>/session-<Unix s>)",
                wanted.display()
            ),
        ));
    };
    for n in 1..=MAX_SUFFIX {
        let path = if n == 1 {
            wanted.to_path_buf()
        } else {
            let mut name = base.to_os_string();
            name.push(format!("-{n}"));
            parent.join(name)
        };
        match std::fs::create_dir(&path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
        match lock_dir(&path) {
            Ok(Some(lock)) if same_file(&lock, &path) => {
                return Ok(SessionDir { path, _lock: lock });
            }
            // Taken by a retention that is deleting it, or gone.
            Ok(_) => continue,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::new(
        std::io::ErrorKind::AlreadyExists,
        format!(
            "{} and its {} suffixed names (-2 to -{MAX_SUFFIX}) are all taken: no session \
             directory made",
            wanted.display(),
            MAX_SUFFIX - 1
        ),
    ))
}

/// The start (Unix s) and the suffix (1 without one) of a session
/// directory's name: `session-<Unix s>` or `session-<Unix s>-<n>`, as
/// [`create_session`] names them; `None` for any other name.
pub fn session_name(name: &str) -> Option<(u64, u32)> {
    let rest = name.strip_prefix("session-")?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    match rest.split_once('-') {
        None if digits(rest) => Some((rest.parse().ok()?, 1)),
        Some((t, n)) if digits(t) && digits(n) => {
            let n: u32 = n.parse().ok()?;
            (n >= 2).then_some((t.parse().ok()?, n))
        }
        _ => None,
    }
}

/// Opens the directory at `path` (not following a symbolic link) and
/// locks it exclusively without waiting: `None` when another holds it.
fn lock_dir(path: &Path) -> std::io::Result<Option<std::fs::File>> {
    use std::os::fd::AsRawFd as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_DIRECTORY | libc::O_NOFOLLOW)
        .open(path)?;
    // SAFETY: flock on a descriptor this function owns.
    if unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
        let e = std::io::Error::last_os_error();
        return if e.raw_os_error() == Some(libc::EWOULDBLOCK) {
            Ok(None)
        } else {
            Err(e)
        };
    }
    Ok(Some(f))
}

/// Whether `path` (not followed) is still the file `f` has open.
fn same_file(f: &std::fs::File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    match (f.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// How often the recorder applies the retention limits.
pub const RETENTION_INTERVAL: std::time::Duration = std::time::Duration::from_secs(10);

/// Free bytes (for an unprivileged user) on the file system of `path`;
/// `u64::MAX` on one that reports no size (ramfs: nothing to guard).
pub fn free_bytes(path: &Path) -> std::io::Result<u64> {
    use std::os::unix::ffi::OsStrExt as _;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes())
        .map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))?;
    // SAFETY: statvfs writes the struct it is given; `c` is a valid
    // NUL-terminated path for the call's duration.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(c.as_ptr(), &mut st) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    if st.f_blocks == 0 {
        return Ok(u64::MAX);
    }
    Ok(st.f_bavail.saturating_mul(st.f_frsize))
}

/// The bytes of the files directly in `dir`.
fn dir_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .map(|it| {
            it.filter_map(Result::ok)
                .filter_map(|e| e.metadata().ok())
                .filter(|m| m.is_file())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0)
}

/// CPU seconds (user and system) the calling thread has used.
fn thread_cpu_seconds() -> f64 {
    // SAFETY: getrusage writes the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_THREAD, &mut u) } != 0 {
        return 0.0;
    }
    let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
    t(u.ru_utime) + t(u.ru_stime)
}

/// What [`prune`] did.
#[derive(Debug, Default)]
pub struct Pruned {
    /// The sessions deleted, and why.
    pub deleted: Vec<(PathBuf, String)>,
    /// Those the limits would delete that could not be (partly deleted,
    /// perhaps), and the error: passed over, the next ones were pruned.
    pub failed: Vec<(PathBuf, std::io::Error)>,
    /// Those the limits would delete that are live (another recorder
    /// holds their lock): left alone.
    pub live: Vec<PathBuf>,
}

/// Applies `[recording]` `keep-days` and `max-total` to the sessions in
/// `root` (directories named `session-<Unix s>` or `session-<Unix s>-<n>`,
/// [`session_name`]; nothing else is touched): deletes those older than
/// `keep-days`, then the oldest until all take at most `max-total`
/// (`current`, this recorder's session, counted); never `current`, nor a session another recorder holds (it is live: every
/// session is deleted under its lock), and one that cannot be deleted is
/// passed over and named in [`Pruned::failed`]. An error only when `root`
/// cannot be read.
pub fn prune(
    root: &Path,
    current: Option<&Path>,
    rc: &crate::config::RecordingConfig,
    now: std::time::SystemTime,
) -> std::io::Result<Pruned> {
    prune_with(root, current, rc, now, &mut |p| std::fs::remove_dir_all(p))
}

/// [`prune`], deleting with `remove` (a test makes it fail: as root no
/// permission can).
pub fn prune_with(
    root: &Path,
    current: Option<&Path>,
    rc: &crate::config::RecordingConfig,
    now: std::time::SystemTime,
    remove: &mut dyn FnMut(&Path) -> std::io::Result<()>,
) -> std::io::Result<Pruned> {
    let now_s = now
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut sessions: Vec<((u64, u32), PathBuf, u64)> = Vec::new();
    // An entry that cannot be read is not a session this can judge.
    for e in std::fs::read_dir(root)?.filter_map(Result::ok) {
        let path = e.path();
        let Some(key) = e.file_name().to_str().and_then(session_name) else {
            continue;
        };
        if e.file_type().is_ok_and(|t| t.is_dir()) && Some(path.as_path()) != current {
            sessions.push((key, path.clone(), dir_bytes(&path)));
        }
    }
    sessions.sort();
    let mut done = Pruned::default();
    let mut total: u64 = sessions.iter().map(|s| s.2).sum::<u64>() + current.map_or(0, dir_bytes);
    let max_total = (rc.max_total * 1e6) as u64;
    for ((t, _), path, bytes) in sessions {
        let age_days = now_s.saturating_sub(t) as f64 / 86_400.0;
        let why = if rc.keep_days > 0.0 && age_days > rc.keep_days {
            format!(
                "{age_days:.1} days old, [recording] keep-days = {}",
                rc.keep_days
            )
        } else if max_total > 0 && total > max_total {
            format!(
                "all sessions took {:.1} MB, [recording] max-total = {} MB",
                total as f64 / 1e6,
                rc.max_total
            )
        } else {
            continue;
        };
        // Deleted under its lock: a recorder cannot take it meanwhile.
        let lock = match lock_dir(&path) {
            Ok(Some(lock)) if same_file(&lock, &path) => lock,
            // Replaced since it was listed: judged next round.
            Ok(Some(_)) => continue,
            Ok(None) => {
                done.live.push(path);
                continue;
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => {
                done.failed.push((path, e));
                continue;
            }
        };
        match remove(&path) {
            Ok(()) => {
                total = total.saturating_sub(bytes);
                done.deleted.push((path, why));
            }
            Err(e) => {
                // What went before the error is freed all the same.
                total = total.saturating_sub(bytes.saturating_sub(dir_bytes(&path)));
                done.failed.push((path, e));
            }
        }
        drop(lock);
    }
    Ok(done)
}

/// How often the recorder flushes its files and syncs them to the disk.
pub const SYNC_INTERVAL: std::time::Duration = std::time::Duration::from_secs(1);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RecordingConfig;

    fn session(root: &Path, t: u64, bytes: usize) -> PathBuf {
        let d = root.join(format!("session-{t}"));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("state.bin"), vec![0u8; bytes]).unwrap();
        d
    }

    /// The oldest sessions go first, to the age limit and then to the
    /// size limit; the current one and anything not a session stay.
    #[test]
    fn retention_deletes_the_oldest_sessions_never_the_current_one() {
        let root = std::env::temp_dir().join(format!("anguilla-prune-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let day = 86_400;
        let now = 100 * day;
        let old = session(&root, now - 40 * day, 1_000_000);
        let a = session(&root, now - 3 * day, 4_000_000);
        let b = session(&root, now - 2 * day, 4_000_000);
        let c = session(&root, now - day, 4_000_000);
        let current = session(&root, now, 5_000_000);
        std::fs::create_dir_all(root.join("notes")).unwrap();
        std::fs::write(root.join("session-x"), b"not a session").unwrap();
        let at = std::time::UNIX_EPOCH + std::time::Duration::from_secs(now);
        let rc = RecordingConfig {
            keep_days: 30.0,
            max_total: 14.0,
            ..RecordingConfig::default()
        };
        let gone = prune(&root, Some(&current), &rc, at).unwrap().deleted;
        let gone: Vec<&PathBuf> = gone.iter().map(|(p, _)| p).collect();
        // 40 days old; then 4 + 4 + 4 + 5 = 17 MB > 14: the oldest, a
        assert_eq!(gone, [&old, &a]);
        assert!(b.exists() && c.exists() && current.exists());
        assert!(root.join("notes").exists() && root.join("session-x").exists());
        // the current one alone beyond the limit: every other goes, it stays
        let rc = RecordingConfig {
            max_total: 10.0,
            ..RecordingConfig::default()
        };
        std::fs::write(current.join("state.bin"), vec![0u8; 11_000_000]).unwrap();
        let gone = prune(&root, Some(&current), &rc, at).unwrap().deleted;
        assert_eq!(gone.len(), 2);
        assert!(current.exists() && !b.exists() && !c.exists());
        // no limits: nothing goes
        session(&root, 1, 1);
        assert!(
            prune(&root, Some(&current), &RecordingConfig::default(), at)
                .unwrap()
                .deleted
                .is_empty()
        );
        assert!(free_bytes(&root).unwrap() > 0);
        assert!(free_bytes(&root.join("missing")).is_err());
        std::fs::remove_dir_all(&root).unwrap();
    }
    fn scratch(name: &str) -> PathBuf {
        let root = std::env::temp_dir().join(format!("anguilla-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        root
    }

    /// Polls `f` until it holds; the watchdog (a minute times the
    /// patience: far beyond the milliseconds it takes) only stops a hung
    /// test.
    fn wait_until(what: &str, f: impl FnMut() -> bool) {
        anguilla_testkit::wait_until(what, std::time::Duration::from_secs(60), f);
    }

    /// A clock set back, or two daemons started in the same second: the
    /// session already there is kept byte for byte, the new one gets the
    /// next free suffix (a plain file of that name is passed over too),
    /// and both names read as sessions in their order.
    #[test]
    fn a_start_second_taken_gets_a_suffix_and_the_older_session_is_kept() {
        let root = scratch("suffix");
        let old = session(&root, 1000, 3);
        std::fs::write(old.join("session.log"), b"recorded before\n").unwrap();
        std::fs::write(root.join("session-1000-3"), b"a file").unwrap();
        let a = create_session(&old).unwrap();
        assert_eq!(a.path(), root.join("session-1000-2"));
        let b = create_session(&old).unwrap();
        assert_eq!(b.path(), root.join("session-1000-4"));
        assert_eq!(
            std::fs::read(old.join("session.log")).unwrap(),
            b"recorded before\n"
        );
        assert_eq!(std::fs::read(old.join("state.bin")).unwrap(), [0; 3]);
        assert_eq!(std::fs::read_dir(a.path()).unwrap().count(), 0);
        assert_eq!(session_name("session-1000"), Some((1000, 1)));
        assert_eq!(session_name("session-1000-2"), Some((1000, 2)));
        for not in [
            "session-1000-1",
            "session-1000-",
            "session--2",
            "session-x",
            "session-1-2-3",
        ] {
            assert_eq!(session_name(not), None, "{not}");
        }
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// Retention passes over a live session (another recorder's: locked)
    /// and over one it cannot delete, names that one with its error, and
    /// prunes the rest; a live session it leaves is deleted once closed.
    #[test]
    fn retention_leaves_live_sessions_and_goes_on_past_one_it_cannot_delete() {
        let root = scratch("prune-locked");
        let at = std::time::UNIX_EPOCH + std::time::Duration::from_secs(5000);
        let stuck = session(&root, 1000, 1_000);
        let live = create_session(&root.join("session-2000")).unwrap();
        std::fs::write(live.path().join("state.bin"), [1; 1_000]).unwrap();
        let later = session(&root, 3000, 1_000);
        let kept = session(&root, 4000, 1_000);
        // 4 kB against 3 kB (max-total's floor is the configuration's
        // check, not this one's): one must go; the stuck and the live one
        // stay, so the next, and only it, goes.
        let rc = RecordingConfig {
            max_total: 0.003,
            ..RecordingConfig::default()
        };
        let mut remove = |p: &Path| {
            if p == stuck {
                Err(std::io::Error::from(std::io::ErrorKind::PermissionDenied))
            } else {
                std::fs::remove_dir_all(p)
            }
        };
        let done = prune_with(&root, None, &rc, at, &mut remove).unwrap();
        let deleted: Vec<_> = done.deleted.iter().map(|(p, _)| p).collect();
        assert_eq!(deleted, [&later], "{done:?}");
        assert_eq!(done.failed.len(), 1, "{done:?}");
        assert_eq!(done.failed[0].0, stuck);
        assert_eq!(
            done.failed[0].1.kind(),
            std::io::ErrorKind::PermissionDenied
        );
        assert_eq!(done.live, [live.path()]);
        assert!(stuck.exists() && live.path().exists() && kept.exists());
        assert_eq!(
            std::fs::read(live.path().join("state.bin")).unwrap(),
            [1; 1_000]
        );
        // Closed: now it may go.
        let path = live.path().to_path_buf();
        drop(live);
        let rc = RecordingConfig {
            max_total: 0.0015,
            ..RecordingConfig::default()
        };
        let done = prune(&root, None, &rc, at).unwrap();
        let deleted: Vec<_> = done.deleted.iter().map(|(p, _)| p).collect();
        assert_eq!(deleted, [&stuck, &path], "{done:?}");
        assert!(kept.exists());
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// Two recorders on one directory (two daemons): a second one started
    /// in the same second gets its own directory, and one whose retention
    /// would delete the first's live session for `max-total` leaves it;
    /// the first's files are whole when it ends.
    #[test]
    fn a_second_recorder_neither_truncates_nor_deletes_the_first_ones_live_session() {
        let root = scratch("two-recorders");
        let start = |name: &str, max_total: f64| {
            let (tx, rx) = crossbeam_channel::unbounded();
            let mut cfg = Config::default();
            cfg.recording.max_total = max_total;
            cfg.recording.min_free = 0.0;
            let dir = root.join(name);
            let h = std::thread::spawn(move || {
                recorder(
                    dir,
                    cfg,
                    rx,
                    crossbeam_channel::never(),
                    crossbeam_channel::never(),
                )
            });
            (tx, h)
        };
        let (first, first_h) = start("session-1000", 0.0);
        let first_dir = root.join("session-1000");
        wait_until("the first session is made", || {
            first_dir.join("config.toml").exists()
        });
        for k in 0..50 {
            first.send(Record::Start(Nanos::from_nanos(k))).unwrap();
        }
        // Same second; then a later one whose limit the first's files pass.
        let (second, second_h) = start("session-1000", 0.0);
        let (third, third_h) = start("session-1001", 1e-6);
        for (name, d) in [("second", "session-1000-2"), ("third", "session-1001")] {
            wait_until(name, || root.join(d).join("config.toml").exists());
        }
        drop((second, third));
        second_h.join().unwrap().unwrap();
        third_h.join().unwrap().unwrap();
        assert!(first_dir.exists(), "the live session was deleted");
        first.send(Record::End).unwrap();
        drop(first);
        first_h.join().unwrap().unwrap();
        let log = std::fs::read_to_string(first_dir.join("session.log")).unwrap();
        assert_eq!(
            log.lines().filter(|l| l.starts_with("start ")).count(),
            50,
            "{log}"
        );
        assert!(log.ends_with("E\n"), "{log}");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
