//! Root on the packaged layout acts as the package's service user.
//!
//! The Debian package makes [`SYSTEM_ROOT`] (`/run/anguilla`) at boot,
//! owned by the service's user (`anguilla`, deploy/anguilla.tmpfiles.conf),
//! with iceoryx2's directory below it. iceoryx2 makes every file of a node
//! for its creator only, so a daemon and its tools must share a user: a
//! root daemon's files would be closed to the service's tools, and a root
//! tool's (`sudo anguilla ctl status`) to the daemon, which then never
//! connects to it ("no state within 2 s" although it runs). So a process
//! that runs as root where the installed runtime root belongs to another
//! user becomes that user ([`adopt`]) before it makes any iceoryx2 node:
//! its groups (initgroups), group and user; a daemon keeps `CAP_SYS_NICE`
//! and `CAP_IPC_LOCK` (SCHED_FIFO and mlockall, as the unit gives them)
//! and nothing else. Called at the start of every command that talks to
//! a daemon, before any thread starts.

use std::ffi::{CStr, CString};
use std::os::unix::fs::MetadataExt as _;

/// The runtime root an installation makes at boot (deploy/anguilla.tmpfiles:
/// owned by the daemon's user and group, in `/run`, where no other user can
/// make anything first). Used when it exists, by the daemon and the tools
/// alike.
pub const SYSTEM_ROOT: &str = "/run/anguilla";

/// A user account: its name, uid and primary gid.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Account {
    /// The login name.
    pub name: String,
    /// The user id.
    pub uid: u32,
    /// The primary group id.
    pub gid: u32,
}

/// The account of `uid` from the password database, if it has one.
pub fn account(uid: u32) -> Option<Account> {
    let mut buf = vec![0u8; 16 << 10];
    // SAFETY: an all-zero passwd is a valid value to be filled in.
    let mut pw: libc::passwd = unsafe { std::mem::zeroed() };
    let mut found: *mut libc::passwd = std::ptr::null_mut();
    // SAFETY: every pointer is to a live buffer of the size given; the
    // result points into `pw` and `buf`, read before they go.
    let r =
        unsafe { libc::getpwuid_r(uid, &mut pw, buf.as_mut_ptr().cast(), buf.len(), &mut found) };
    if r != 0 || found.is_null() || pw.pw_name.is_null() {
        return None;
    }
    // SAFETY: getpwuid_r succeeded: pw_name is a NUL-terminated string in buf.
    let name = unsafe { CStr::from_ptr(pw.pw_name) }
        .to_string_lossy()
        .into_owned();
    Some(Account {
        name,
        uid: pw.pw_uid,
        gid: pw.pw_gid,
    })
}

/// The service's account: the owner of [`SYSTEM_ROOT`] when it is a
/// directory that a user other than root owns (the packaged layout).
pub fn service_account() -> Option<Account> {
    let m = std::fs::symlink_metadata(SYSTEM_ROOT).ok()?;
    if !m.file_type().is_dir() || m.uid() == 0 {
        return None;
    }
    Some(account(m.uid()).unwrap_or(Account {
        name: m.uid().to_string(),
        uid: m.uid(),
        gid: m.gid(),
    }))
}

/// What the process should keep of root's privileges when it becomes the
/// service's user.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Keep {
    /// Nothing (a tool).
    Nothing,
    /// `CAP_SYS_NICE` and `CAP_IPC_LOCK` (the daemon: its `[realtime]`).
    Realtime,
}

/// Why root could not become the service's user.
#[derive(Debug, thiserror::Error)]
#[error(
    "running as root on the packaged layout: becoming {user} (the owner of {SYSTEM_ROOT}), {step} failed: {source}"
)]
pub struct AdoptError {
    /// The service's user.
    pub user: String,
    /// The call that failed.
    pub step: &'static str,
    /// The OS error.
    pub source: std::io::Error,
}

/// When this process runs as root and [`SYSTEM_ROOT`] belongs to another
/// user (the package's), becomes that user (module doc) and returns the
/// line to tell the operator; otherwise changes nothing and returns
/// `None`. Call it before any thread starts: capabilities are per thread.
pub fn adopt(keep: Keep) -> Result<Option<String>, AdoptError> {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        return Ok(None);
    }
    let Some(acct) = service_account() else {
        return Ok(None);
    };
    let fail = |step: &'static str| AdoptError {
        user: acct.name.clone(),
        step,
        source: std::io::Error::last_os_error(),
    };
    let check = |r: libc::c_int, step: &'static str| if r == 0 { Ok(()) } else { Err(fail(step)) };
    if keep == Keep::Realtime {
        // SAFETY: plain prctl; keeps the permitted set across setuid.
        check(
            unsafe { libc::prctl(libc::PR_SET_KEEPCAPS, 1, 0, 0, 0) },
            "prctl(PR_SET_KEEPCAPS)",
        )?;
    }
    let name = CString::new(acct.name.clone()).map_err(|_| AdoptError {
        user: acct.name.clone(),
        step: "its name",
        source: std::io::Error::from(std::io::ErrorKind::InvalidInput),
    })?;
    // SAFETY: name is NUL-terminated; the calls change this process's
    // credentials (glibc applies them to every thread).
    check(
        unsafe { libc::initgroups(name.as_ptr(), acct.gid) },
        "initgroups",
    )?;
    // SAFETY: as above.
    check(unsafe { libc::setgid(acct.gid) }, "setgid")?;
    // SAFETY: as above.
    check(unsafe { libc::setuid(acct.uid) }, "setuid")?;
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != acct.uid {
        return Err(fail("setuid (still root)"));
    }
    let kept = if keep == Keep::Realtime {
        keep_realtime().map_err(|source| AdoptError {
            user: acct.name.clone(),
            step: "capset(CAP_SYS_NICE, CAP_IPC_LOCK)",
            source,
        })?;
        ", keeping CAP_SYS_NICE and CAP_IPC_LOCK as the unit does"
    } else {
        ""
    };
    Ok(Some(format!(
        "running as user {} (uid {}), the owner of {SYSTEM_ROOT}, the package's runtime \
         directory: the daemon and its tools must share a user to reach each other's \
         iceoryx2 files{kept}",
        acct.name, acct.uid
    )))
}

/// Makes `CAP_SYS_NICE` and `CAP_IPC_LOCK` this thread's only permitted
/// and effective capabilities (kept across setuid by PR_SET_KEEPCAPS).
fn keep_realtime() -> std::io::Result<()> {
    #[repr(C)]
    struct Header {
        version: u32,
        pid: libc::c_int,
    }
    #[repr(C)]
    #[derive(Clone, Copy, Default)]
    struct Data {
        effective: u32,
        permitted: u32,
        inheritable: u32,
    }
    const VERSION_3: u32 = 0x2008_0522;
    const CAP_IPC_LOCK: u32 = 14;
    const CAP_SYS_NICE: u32 = 23;
    let set = (1u32 << CAP_IPC_LOCK) | (1u32 << CAP_SYS_NICE);
    let mut header = Header {
        version: VERSION_3,
        pid: 0,
    };
    let data = [
        Data {
            effective: set,
            permitted: set,
            inheritable: 0,
        },
        Data::default(),
    ];
    // SAFETY: capset with a version-3 header and its two data words.
    let r = unsafe { libc::syscall(libc::SYS_capset, &mut header, data.as_ptr()) };
    if r != 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: plain prctl.
    unsafe { libc::prctl(libc::PR_SET_KEEPCAPS, 0, 0, 0, 0) };
    Ok(())
}

/// Why a daemon of `uid` cannot use `dir`, part of the package's runtime
/// directory (the service user `user`'s), and what to do instead.
pub(crate) fn package_layout(dir: &std::path::Path, user: &str, uid: u32) -> String {
    format!(
        "{} belongs to user {user}, the installed service's (deploy/anguilla.tmpfiles.conf \
         makes {SYSTEM_ROOT} at boot), not to this daemon's uid {uid}: on the packaged layout \
         a daemon runs as that user, as the service does: `sudo -u {user} anguilla run ...` \
         (root becomes that user by itself; stop the service first if it serves the same \
         prefix: `sudo systemctl stop anguilla`)",
        dir.display()
    )
}
