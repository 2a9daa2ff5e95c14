//! The daemon's guard over the files iceoryx2 shares with other users.
//!
//! iceoryx2 0.10 makes its services' files for their creator only, but two
//! things are open to every local user:
//!
//! - its directory (`[global] root-path`, `/tmp/iceoryx2/` by default),
//!   which it reuses whoever made it: another user who makes it first
//!   keeps the daemon from creating its services;
//! - its node-id segment, `/dev/shm/<iceoryx2 prefix><type hash>_node.0_10_0.global_mgmt`
//!   (16 bytes: iceoryx2's version, then a node counter), which every new
//!   node opens or creates: a user who writes 16 bytes into it makes every
//!   new iceoryx2 node fail, and one who truncates it makes new nodes hang.
//!
//! How iceoryx2 0.10 makes that segment (`iceoryx2-cal`,
//! `dynamic_storage/posix_shared_memory.rs`, built with
//! `enable_global_access(true)` by `iceoryx2/src/node/global_management_segment.rs`):
//! `shm_open(O_CREAT | O_EXCL)` with mode 0200 (its "not initialised yet"
//! mark), the version written, then `fchmod` to 0666. The last mode is set
//! explicitly, so no umask narrows it, and no configuration value chooses
//! it; between that `fchmod` and any chmod of ours, another user's inotify
//! watcher opened it read-write (and kept the descriptor) in 3 of 3 tries.
//!
//! So [`prepare`] makes the segment itself, before every iceoryx2 node
//! this crate makes (the daemon's and every tool's, [`crate`]'s one
//! `new_node`): `O_CREAT | O_EXCL | O_NOFOLLOW`, mode 0600 from its first
//! instant, holding what iceoryx2 writes (its version, a zero counter).
//! iceoryx2 then finds it made, sees it readable by its owner and
//! initialised, and opens it as it is: it never creates it, so it never
//! widens it. The alternatives were weaker: a directory only the service's
//! user and group can enter does not exist for POSIX shared memory (the
//! segment's directory is `/dev/shm`, every user's; iceoryx2's `root-path`
//! does not move it), a umask does not reach an explicit `fchmod`, and a
//! patched iceoryx2 is a fork to carry. The price: the segment's layout and
//! name are iceoryx2 0.10's ([`ICEORYX2_VERSION`]); another version opens
//! the segment only if they match, else refuses it as a version mismatch
//! (an error, never a wider file), and `the_node_id_segment_cannot_be_raced_at_its_creation`
//! (tests/tests/users.rs) fails on a layout that no longer fits.
//!
//! [`check`] runs before the daemon's first node: a directory or segment
//! that another user owns is refused, naming its path, owner and mode, and
//! the fix. [`restrict`] runs after it: a segment of the daemon's user that
//! something else made wide (an older anguilla, another iceoryx2 program)
//! becomes 0600 (its user's processes only: the daemon, the link, the tools
//! run as its user); such a segment was open before, so remove it (as
//! root, no anguilla program running) to be sure no descriptor of another
//! user's is left on it.

use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
use std::path::{Path, PathBuf};

use iceoryx2::prelude::*;

use crate::error::IpcError;

/// Where POSIX shared memory lives on Linux.
pub const SHM_DIR: &str = "/dev/shm";

/// The end of the node-id segment's name (iceoryx2 0.10).
const GLOBAL_MGMT: &str = ".global_mgmt";

/// The iceoryx2 version whose node-id segment [`prepare`] makes (its name
/// and layout: [`node_id_segment`]): its name carries it (`node.0_10_0`) and its first 8 bytes hold it
/// (`major << 32 | minor << 16 | patch`, native order), as iceoryx2's
/// `PackageVersion::to_u64` writes and checks it.
pub const ICEORYX2_VERSION: (u16, u16, u16) = (0, 10, 0);

/// The type hash in the node-id segment's name: iceoryx2 0.10 names each
/// dynamic storage `<prefix><SHA-1 of its type's name>_<name><suffix>`,
/// here the SHA-1 of `iceoryx2::node::global_management_segment::State`.
const SEGMENT_TYPE_HASH: &str = "9204dd183d1c4d8e1ff592a30766ffa6765aa8b5";

/// The node-id segment's size: iceoryx2's `Data<State>`, `#[repr(C)]`
/// `{ version: AtomicU64, data: { node_counter: AtomicU32 } }`.
const SEGMENT_SIZE: usize = 16;

/// The node-id segment of this process's iceoryx2 configuration.
pub fn node_id_segment() -> PathBuf {
    let (major, minor, patch) = ICEORYX2_VERSION;
    Path::new(SHM_DIR).join(format!(
        "{}{SEGMENT_TYPE_HASH}_node.{major}_{minor}_{patch}{}",
        prefix(),
        config().global.node.global_mgmt_suffix
    ))
}

/// Makes the node-id segment, mode 0600 from its creation and initialised
/// as iceoryx2 would, unless it exists: iceoryx2 then opens it instead of
/// making it 0666 (module doc). Returns the segment when it made it.
pub fn prepare() -> Result<Option<PathBuf>, IpcError> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let path = node_id_segment();
    let made = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create_new(true)
        .mode(0o600)
        .custom_flags(libc::O_NOFOLLOW)
        .open(&path);
    let fail = |e: std::io::Error| {
        IpcError::Foreign(format!(
            "making iceoryx2's node-id segment {} (mode 0600, before iceoryx2 would make it \
             0666): {e}",
            path.display()
        ))
    };
    let mut f = match made {
        Ok(f) => f,
        // Made already: check() and restrict() judge it.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => return Ok(None),
        Err(e) => return Err(fail(e)),
    };
    // The mode, whatever the umask took (it can only have narrowed it).
    f.set_permissions(std::fs::Permissions::from_mode(0o600))
        .map_err(fail)?;
    let (major, minor, patch) = ICEORYX2_VERSION;
    let version = (u64::from(major) << 32) | (u64::from(minor) << 16) | u64::from(patch);
    let mut bytes = [0u8; SEGMENT_SIZE];
    bytes[..8].copy_from_slice(&version.to_ne_bytes());
    // One write: an iceoryx2 node opening it meanwhile sees it empty or
    // its version 0, and waits for it (its own "not yet initialised").
    f.write_all(&bytes).map_err(fail)?;
    Ok(Some(path))
}

/// iceoryx2's configuration, read without its chatter: the first read
/// logs "No config file was loaded" to stdout, which is data for a tool
/// such as `ctl status --json` (`IOX2_LOG_LEVEL` still overrides).
pub(crate) fn config() -> &'static Config {
    set_log_level_from_env_or(LogLevel::Error);
    Config::global_config()
}

fn prefix() -> String {
    config().global.prefix.to_string()
}

fn root_path() -> PathBuf {
    PathBuf::from(config().global.root_path().to_string())
}

/// The node-id segments of the configured iceoryx2 prefix.
fn segments() -> Vec<PathBuf> {
    let prefix = prefix();
    let Ok(dir) = std::fs::read_dir(SHM_DIR) else {
        return Vec::new();
    };
    dir.filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&prefix) && n.ends_with(GLOBAL_MGMT))
        .map(|n| Path::new(SHM_DIR).join(n))
        .collect()
}

/// Why `path` (if it exists) cannot be trusted by a daemon of user `uid`:
/// another user owns it.
fn foreign(path: &Path, uid: u32, what: &str, fix: &str) -> Result<(), IpcError> {
    match std::fs::symlink_metadata(path) {
        // The package's iceoryx2 directory is its service user's: never
        // removed, only used as that user.
        Ok(m)
            if m.uid() != uid
                && path.starts_with(crate::service_user::SYSTEM_ROOT)
                && crate::service_user::service_account().is_some_and(|a| a.uid == m.uid()) =>
        {
            let user = crate::service_user::service_account().map_or_else(String::new, |a| a.name);
            Err(IpcError::Foreign(format!(
                "{what}: {}",
                crate::service_user::package_layout(path, &user, uid)
            )))
        }
        Ok(m) if m.uid() != uid && m.uid() != 0 => Err(IpcError::Foreign(format!(
            "{what} {} belongs to uid {} with mode {:o}, not to this daemon's user (uid {uid}): \
             another user made it first. {fix}",
            path.display(),
            m.uid(),
            m.mode() & 0o7777
        ))),
        Ok(m) if m.file_type().is_symlink() => Err(IpcError::Foreign(format!(
            "{what} {} is a symlink. {fix}",
            path.display()
        ))),
        _ => Ok(()),
    }
}

/// Before the daemon's first iceoryx2 node: refuses iceoryx2's directory
/// and node-id segment when another user owns them (root's are trusted).
pub fn check() -> Result<(), IpcError> {
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    let root = root_path();
    foreign(
        root.as_path(),
        uid,
        "iceoryx2's directory",
        "Remove it (as root), or give the daemon a directory of its own: [global] root-path \
         in /etc/iceoryx2/iceoryx2.toml (deploy/iceoryx2.toml: /run/anguilla/iceoryx2/, made at \
         boot by deploy/anguilla.tmpfiles)",
    )?;
    for s in segments() {
        foreign(
            &s,
            uid,
            "iceoryx2's node-id segment",
            "Remove it (as root), or give the daemon an iceoryx2 prefix of its own: [global] \
             prefix in /etc/iceoryx2/iceoryx2.toml (deploy/iceoryx2.toml)",
        )?;
    }
    Ok(())
}

/// After the daemon's first iceoryx2 node: its node-id segments (the
/// configured prefix's, owned by this user) become mode 0600. Returns the
/// segments changed.
pub fn restrict() -> Result<Vec<PathBuf>, IpcError> {
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    let mut changed = Vec::new();
    for s in segments() {
        let Ok(m) = std::fs::symlink_metadata(&s) else {
            continue;
        };
        if m.uid() == uid && m.file_type().is_file() && m.mode() & 0o077 != 0 {
            std::fs::set_permissions(&s, std::fs::Permissions::from_mode(0o600)).map_err(|e| {
                IpcError::Foreign(format!("restricting {} to its owner: {e}", s.display()))
            })?;
            changed.push(s);
        }
    }
    Ok(changed)
}

/// Why this process cannot make an iceoryx2 node, when the likely cause is
/// that the daemon's node-id segment is another user's (0600 after
/// [`restrict`]): it names the segment, its owner and mode, and the two
/// ways in.
pub fn closed_to_this_user() -> Option<String> {
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    segments().into_iter().find_map(|s| {
        let m = std::fs::symlink_metadata(&s).ok()?;
        (m.uid() != uid && uid != 0 && m.mode() & 0o006 != 0o006).then(|| {
            format!(
                "the daemon's iceoryx2 files are its user's: {} belongs to uid {} with mode {:o}. \
                 Run the tool as that user, or join its group and run `anguilla link` beside \
                 the daemon (the tools then go through its local socket by themselves)",
                s.display(),
                m.uid(),
                m.mode() & 0o7777
            )
        })
    })
}

/// How long one call into iceoryx2 that makes a node or opens the
/// daemon's services may take before the process gives up
/// ([`bounded`]). iceoryx2 retries a segment it cannot read (another
/// user's, truncated, half made) until its own timeouts, and waits for ever
/// on some; a tool must not.
pub const OPEN_LIMIT: std::time::Duration = std::time::Duration::from_secs(10);

static OPENING: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
/// The stop signal a handler saw while no call was under [`bounded`] (0:
/// none): a call that starts after it ends the process at once.
static STOPPED_BY: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);
/// Whether this process's own loop polls the stop flag ([`stop_is_polled`]).
static POLLED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Says that this process's loop polls the stop flag and must see every
/// stop signal itself: from now on a stop signal during a call under
/// [`bounded`] no longer ends the process ([`opening`] stays false); the
/// call finishes and the loop stops as it stops on its own. The daemon
/// calls it: it opens its own state reader while its control loop already
/// drives the robot, and a Ctrl-C that ended the process there (the CI
/// failure of stop 60: SIGINT while a loaded machine took seconds to open
/// it) left the actuators enabled and the recording unfinished. The
/// watchdog's limit ([`OPEN_LIMIT`]) still holds.
pub fn stop_is_polled() {
    POLLED.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Called by a stop signal's handler that found no call under [`bounded`]
/// ([`opening`] false): a call that starts later ends the process at once
/// (exit code 128 + `sig`), so a signal that came just before a blocking
/// call is not lost in it. Async-signal-safe (one atomic store).
pub fn stop_requested(sig: i32) {
    STOPPED_BY.store(sig, std::sync::atomic::Ordering::SeqCst);
}

/// Whether a call under [`bounded`] is running: a stop signal's handler
/// that sees it ends the process at once (`libc::_exit`; the call cannot
/// be interrupted). Async-signal-safe (one atomic load).
pub fn opening() -> bool {
    use std::sync::atomic::Ordering::SeqCst;
    OPENING.load(SeqCst) > 0 && !POLLED.load(SeqCst)
}

/// What to check when iceoryx2 does not answer: its directory and
/// node-id segments, as this process's configuration names them.
pub fn files_to_check() -> String {
    let root = root_path();
    if root.starts_with(crate::service_user::SYSTEM_ROOT) {
        // The package's directory is made at boot: it is not removed.
        return format!(
            "iceoryx2's directory {} (the package's: its service user's, mode 0750) and its \
             node-id segment {SHM_DIR}/{}…{GLOBAL_MGMT} (owner, mode, 16 bytes): another user's \
             or a damaged segment blocks every new iceoryx2 node; remove the segment as root \
             while no anguilla program runs, and run the tools as the service's user",
            root.display(),
            prefix()
        );
    }
    format!(
        "iceoryx2's directory {} and its node-id segment {SHM_DIR}/{}…{GLOBAL_MGMT} (owner, \
         mode, 16 bytes): another user's or a damaged one blocks every new iceoryx2 node; \
         remove them as root while no anguilla program runs",
        root_path().display(),
        prefix()
    )
}

/// Runs `f`, a call into iceoryx2 that may block (making a node, opening
/// the daemon's services), and ends the process if it has not returned
/// within [`OPEN_LIMIT`]: the message names `what` and
/// [`files_to_check`], the exit code is 2 (the tools' "no daemon"). While
/// it runs, [`opening`] is true, so a stop signal ends the process too.
pub fn bounded<T>(what: &str, f: impl FnOnce() -> T) -> T {
    use std::sync::atomic::Ordering::SeqCst;
    // Counted before the watchdog thread exists, so a signal that finds
    // the thread (as a test does) finds the call under way; and a signal
    // whose handler found none is seen here (one of the two sees the
    // other: both sequentially consistent).
    OPENING.fetch_add(1, SeqCst);
    let sig = STOPPED_BY.load(SeqCst);
    if sig != 0 && !POLLED.load(SeqCst) {
        // SAFETY: _exit ends the process at once, as the signal's handler
        // would have had the call been under way.
        unsafe { libc::_exit(128 + sig) };
    }
    let done = std::sync::Arc::new((std::sync::Mutex::new(false), std::sync::Condvar::new()));
    let (d, msg) = (
        done.clone(),
        format!(
            "{what}: iceoryx2 did not answer within {} s: {}",
            OPEN_LIMIT.as_secs(),
            files_to_check()
        ),
    );
    // A small stack: it only waits. glibc keeps the stacks of ended
    // threads for the next ones, and a locked daemon (`mlockall`) counts
    // each; Rust's default (2 MiB) made 8 MB of them.
    let dog = std::thread::Builder::new()
        .name("anguilla-open-limit".into())
        .stack_size(64 << 10)
        .spawn(move || {
            let (m, cv) = &*d;
            let Ok(g) = m.lock() else { return };
            let Ok((g, _)) = cv.wait_timeout_while(g, OPEN_LIMIT, |finished| !*finished) else {
                return;
            };
            if !*g {
                eprintln!("{msg}");
                // SAFETY: _exit ends the process without running anything
                // of this process's; nothing is left to clean up that a
                // hung iceoryx2 call would let us clean.
                unsafe { libc::_exit(2) };
            }
        });
    let r = f();
    OPENING.fetch_sub(1, SeqCst);
    let (m, cv) = &*done;
    if let Ok(mut g) = m.lock() {
        *g = true;
        cv.notify_all();
    }
    if let Ok(h) = dog {
        let _ = h.join();
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A node of ours leaves a node-id segment of this user's that others
    /// may write (iceoryx2's 0666); `restrict` closes it, and a node still
    /// opens afterwards.
    #[test]
    fn the_node_id_segment_is_closed_to_other_users() {
        check().unwrap();
        let _node = crate::service::new_node("guard-test").unwrap();
        let segs = segments();
        assert!(!segs.is_empty(), "no {GLOBAL_MGMT} under {SHM_DIR}");
        restrict().unwrap();
        // SAFETY: geteuid has no preconditions.
        let uid = unsafe { libc::geteuid() };
        for s in segments() {
            let m = std::fs::metadata(&s).unwrap();
            if m.uid() == uid {
                assert_eq!(m.mode() & 0o777, 0o600, "{}", s.display());
            }
        }
        let _again = crate::service::new_node("guard-test-2").unwrap();
    }

    /// A stop signal that came just before a blocking call is not lost in
    /// it (the CI failure of stop 55: SIGTERM between the watchdog's start
    /// and the call's count waited out the 10 s limit): the call ends the
    /// process at once, with the signal's exit code.
    #[test]
    fn a_stop_signal_before_a_blocking_call_ends_the_process_at_once() {
        // SAFETY: the child only stores and loads atomics and calls _exit
        // (no allocation, no lock: safe after fork in a threaded process).
        let pid = unsafe { libc::fork() };
        assert!(pid >= 0, "fork failed");
        if pid == 0 {
            stop_requested(libc::SIGTERM);
            bounded("a call that never returns", || {
                loop {
                    std::hint::spin_loop()
                }
            });
            // SAFETY: as above; not reached when bounded ends the process.
            unsafe { libc::_exit(0) };
        }
        let mut status = 0;
        // SAFETY: pid is our child.
        assert_eq!(unsafe { libc::waitpid(pid, &mut status, 0) }, pid);
        assert!(libc::WIFEXITED(status), "status {status:#x}");
        assert_eq!(libc::WEXITSTATUS(status), 128 + libc::SIGTERM);
    }

    /// A process whose loop polls the stop flag (the daemon, its robot
    /// driven meanwhile) is not ended by a stop signal that comes before or
    /// during a call under `bounded`: the call returns its value, and the
    /// handler's test (`opening`) says not to end it.
    #[test]
    fn a_process_that_polls_its_stop_flag_is_not_ended_by_a_signal_in_a_bounded_call() {
        // SAFETY: as above (atomics and _exit in the child).
        let pid = unsafe { libc::fork() };
        assert!(pid >= 0, "fork failed");
        if pid == 0 {
            stop_is_polled();
            stop_requested(libc::SIGINT);
            let (value, opening_inside) = bounded("a call that returns", || (7, opening()));
            // SAFETY: as above.
            unsafe { libc::_exit(if opening_inside { 1 } else { value }) };
        }
        let mut status = 0;
        // SAFETY: pid is our child.
        assert_eq!(unsafe { libc::waitpid(pid, &mut status, 0) }, pid);
        assert!(libc::WIFEXITED(status), "status {status:#x}");
        assert_eq!(
            libc::WEXITSTATUS(status),
            7,
            "1: opening() was true inside the call"
        );
    }
}
