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
//! deleted (never the current one, [`prune`]); a session does not start
//! with less free space than `min-free`, and one that reaches it ends
//! cleanly, its files finished and synced, the cause logged.
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
    // The old sessions go first: what they free counts for min-free.
    let retained = || match prune(&root, &dir, rc, std::time::SystemTime::now()) {
        Ok(gone) => {
            for (d, why) in gone {
                tracing::warn!("recording: deleted {} ({why})", d.display());
            }
        }
        Err(e) => tracing::warn!("recording: retention in {}: {e}", root.display()),
    };
    retained();
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
    std::fs::create_dir_all(&dir)?;
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
                    tracing::error!(
                        "recording ended: {} MB free on {}, below [recording] min-free ({} MB); \
                         {} is finished and synced",
                        free / 1_000_000,
                        root.display(),
                        rc.min_free,
                        dir.display()
                    );
                    break;
                }
                if last_retention.elapsed() >= RETENTION_INTERVAL {
                    last_retention = std::time::Instant::now();
                    retained();
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
    Ok(())
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

/// Applies `[recording]` `keep-days` and `max-total` to the sessions in
/// `root` (directories named `session-<Unix s>`; nothing else is
/// touched): deletes those older than `keep-days`, then the oldest until
/// all take at most `max-total`; never `current`. Returns what it deleted
/// and why.
pub fn prune(
    root: &Path,
    current: &Path,
    rc: &crate::config::RecordingConfig,
    now: std::time::SystemTime,
) -> std::io::Result<Vec<(PathBuf, String)>> {
    let now_s = now
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut sessions: Vec<(u64, PathBuf, u64)> = Vec::new();
    for e in std::fs::read_dir(root)? {
        let e = e?;
        let path = e.path();
        let Some(t) = e
            .file_name()
            .to_str()
            .and_then(|n| n.strip_prefix("session-"))
            .and_then(|t| t.parse::<u64>().ok())
        else {
            continue;
        };
        if e.file_type()?.is_dir() && path != current {
            sessions.push((t, path.clone(), dir_bytes(&path)));
        }
    }
    sessions.sort();
    let mut gone = Vec::new();
    let mut total: u64 = sessions.iter().map(|s| s.2).sum::<u64>() + dir_bytes(current);
    let max_total = (rc.max_total * 1e6) as u64;
    for (t, path, bytes) in sessions {
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
        std::fs::remove_dir_all(&path)?;
        total = total.saturating_sub(bytes);
        gone.push((path, why));
    }
    Ok(gone)
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
        let gone = prune(&root, &current, &rc, at).unwrap();
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
        let gone = prune(&root, &current, &rc, at).unwrap();
        assert_eq!(gone.len(), 2);
        assert!(current.exists() && !b.exists() && !c.exists());
        // no limits: nothing goes
        session(&root, 1, 1);
        assert!(
            prune(&root, &current, &RecordingConfig::default(), at)
                .unwrap()
                .is_empty()
        );
        assert!(free_bytes(&root).unwrap() > 0);
        assert!(free_bytes(&root.join("missing")).is_err());
        std::fs::remove_dir_all(&root).unwrap();
    }
}
