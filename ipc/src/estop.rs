//! The reserved E-stop path: a Unix datagram socket beside the iceoryx2
//! services, which nothing can fill or lock.
//!
//! iceoryx2 services have fixed capacities (nodes, ports, requests), and a
//! local program can take them all. An E-stop must still go through, so the
//! daemon also listens on `/tmp/anguilla/<prefix>/estop`: **any** datagram
//! sent there is an E-stop, whoever sent it and whatever it says (send the
//! text `ESTOP` by convention). A datagram socket holds no connection and no
//! slot per sender; a flood of datagrams is a flood of E-stops, which only
//! keeps the robot stopped. The socket is mode 0660: only the daemon's user
//! and group may send. `/tmp/anguilla` is shared like `/tmp` (mode 1777);
//! a prefix's directories belong to its daemon's user, writable by it
//! alone. A directory another user created first (or a symlink) keeps the
//! daemon from starting, naming it, never from being stopped.
//!
//! ```no_run
//! // What `anguilla ctl estop` does first.
//! anguilla_ipc::estop::send("anguilla").expect("daemon reachable");
//! ```

use std::io;
use std::os::unix::fs::PermissionsExt as _;
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::service::{IpcError, valid_prefix};

/// Where the E-stop sockets live unless [`SYSTEM_ROOT`] exists.
pub const ROOT: &str = "/tmp/anguilla";

/// The runtime root an installation makes at boot: defined with the
/// packaged layout's other facts ([`crate::service_user`]).
pub use crate::service_user::SYSTEM_ROOT;

/// The runtime root: [`SYSTEM_ROOT`] if it is a directory, else [`ROOT`]
/// (shared like /tmp, where another user could take a prefix's directory
/// first: the daemon then refuses to start, naming it).
pub fn root() -> &'static Path {
    static R: std::sync::OnceLock<&'static Path> = std::sync::OnceLock::new();
    R.get_or_init(|| {
        if std::fs::symlink_metadata(SYSTEM_ROOT).is_ok_and(|m| m.is_dir()) {
            Path::new(SYSTEM_ROOT)
        } else {
            Path::new(ROOT)
        }
    })
}

/// The E-stop socket of the daemon serving `prefix`.
pub fn socket_path(prefix: &str) -> Result<PathBuf, IpcError> {
    if !valid_prefix(prefix) || prefix.split('/').any(|p| p.is_empty() || p == "..") {
        return Err(IpcError::BadPrefix(prefix.to_string()));
    }
    // sun_path holds 108 bytes with its terminating NUL: a prefix of at
    // most 80 characters always fits.
    if prefix.len() > 80 {
        return Err(IpcError::BadPrefix(prefix.to_string()));
    }
    let p = root().join(prefix).join("estop");
    Ok(p)
}

/// Why an E-stop could not be sent.
#[derive(Debug, thiserror::Error)]
pub enum EStopError {
    /// The prefix does not make a socket path.
    #[error(transparent)]
    Path(#[from] IpcError),
    /// Nobody listens on the socket (no daemon, or it died).
    #[error("no daemon listens on {path}: {source}")]
    NoDaemon {
        /// The socket path.
        path: String,
        /// The OS error.
        source: io::Error,
    },
    /// The socket exists but this user may not send to it.
    #[error("not allowed to send to {path} ({source}): run as the daemon's user or group")]
    Denied {
        /// The socket path.
        path: String,
        /// The OS error.
        source: io::Error,
    },
}

/// Sends one E-stop datagram to the daemon serving `prefix`. Returns once
/// the kernel has queued it (the daemon acts within one control period).
pub fn send(prefix: &str) -> Result<(), EStopError> {
    let path = socket_path(prefix)?;
    let shown = path.display().to_string();
    let sock = UnixDatagram::unbound().map_err(|source| EStopError::NoDaemon {
        path: shown.clone(),
        source,
    })?;
    // A full receive queue means a flood of E-stops is already being
    // handled; wait a little for room rather than give up at once.
    sock.set_write_timeout(Some(Duration::from_millis(200)))
        .map_err(|source| EStopError::NoDaemon {
            path: shown.clone(),
            source,
        })?;
    match sock.send_to(b"ESTOP", &path) {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::PermissionDenied => Err(EStopError::Denied {
            path: shown,
            source: e,
        }),
        Err(e) if e.kind() == io::ErrorKind::WouldBlock => Ok(()),
        Err(source) => Err(EStopError::NoDaemon {
            path: shown,
            source,
        }),
    }
}

/// The daemon's end: bound to the prefix's socket.
#[derive(Debug)]
pub struct EStopListener {
    sock: UnixDatagram,
    path: PathBuf,
    /// The socket file's (device, inode): only ours is removed on drop.
    file: (u64, u64),
}

/// Why a directory on the way to the socket cannot be trusted, if so: the
/// root must be root's or ours, sticky when others may write it; every
/// directory below it ours and writable by us alone; none a symlink.
/// Otherwise another user could replace the socket with one of their own.
fn untrusted(dir: &Path, uid: u32) -> Option<String> {
    use std::os::unix::fs::MetadataExt as _;
    let m = match std::fs::symlink_metadata(dir) {
        Ok(m) => m,
        Err(e) => return Some(format!("{}: {e}", dir.display())),
    };
    let mode = m.mode();
    if !m.file_type().is_dir() {
        return Some(format!("{} is not a directory (a symlink?)", dir.display()));
    }
    // The package's runtime directory (and what its service made below
    // it) belong to the service's user: only that user runs a daemon there.
    if let Some(svc) = crate::service_user::service_account()
        && dir.starts_with(SYSTEM_ROOT)
        && m.uid() == svc.uid
        && m.uid() != uid
    {
        return Some(crate::service_user::package_layout(dir, &svc.name, uid));
    }
    if dir == root() {
        if m.uid() != 0 && m.uid() != uid {
            return Some(format!(
                "{} belongs to uid {} (expected root or this daemon's uid {uid}): remove it",
                dir.display(),
                m.uid()
            ));
        }
        if mode & 0o022 != 0 && mode & 0o1000 == 0 {
            return Some(format!(
                "{} is writable by others without the sticky bit",
                dir.display()
            ));
        }
    } else if m.uid() != uid || mode & 0o022 != 0 {
        return Some(format!(
            "{} belongs to uid {} with mode {:o} (expected this daemon's uid {uid}, writable by it \
             alone): another user may have created it; remove it",
            dir.display(),
            m.uid(),
            mode & 0o7777
        ));
    }
    None
}

/// The prefix's runtime directory, `/tmp/anguilla/<prefix>`, made if
/// missing and checked: the root is shared by the daemons of every user,
/// like /tmp (sticky, world-writable); a prefix's directories belong to its
/// daemon's user, searchable by all (each socket's mode, or a directory of
/// its own, decides who uses it). A directory another user made, one
/// others may write, or a symlink is refused, naming it.
pub fn runtime_dir(prefix: &str) -> Result<PathBuf, IpcError> {
    let path = socket_path(prefix)?;
    let dir = path.parent().unwrap_or(root()).to_path_buf();
    let io_err = |what: &str, d: &Path, e: io::Error| {
        IpcError::EStopSocket(format!("{what} {}: {e}", d.display()))
    };
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    let mut dirs: Vec<&Path> = dir
        .ancestors()
        .take_while(|d| d.starts_with(root()))
        .collect();
    dirs.reverse();
    for d in dirs {
        // The shared /tmp root is sticky and open like /tmp; an installed
        // one exists already (deploy/anguilla.tmpfiles).
        let mode = if d == root() { 0o1777 } else { 0o755 };
        match std::fs::create_dir(d) {
            Ok(()) => std::fs::set_permissions(d, std::fs::Permissions::from_mode(mode))
                .map_err(|e| io_err("setting the mode of", d, e))?,
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
            Err(e)
                if e.kind() == io::ErrorKind::PermissionDenied
                    && d.parent() == Some(root())
                    && root() == Path::new(ROOT) =>
            {
                use std::os::unix::fs::MetadataExt as _;
                let (owner, mode) = std::fs::metadata(root())
                    .map(|m| (m.uid(), m.mode() & 0o7777))
                    .unwrap_or((0, 0));
                return Err(IpcError::EStopSocket(format!(
                    "creating {}: {e}: {ROOT} (uid {owner}, mode {mode:o}) is shared by every \
                     user's daemons like /tmp and must be mode 1777; its owner can fix it: \
                     `chmod 1777 {ROOT}`",
                    d.display()
                )));
            }
            Err(e) => return Err(io_err("creating", d, e)),
        }
        if let Some(why) = untrusted(d, uid) {
            return Err(IpcError::EStopSocket(why));
        }
    }
    Ok(dir)
}

impl EStopListener {
    /// Binds the E-stop socket of `prefix`. A socket file left by a dead
    /// daemon (nobody receives on it) is replaced; one a live process
    /// receives on is not, and the daemon refuses to start
    /// ([`IpcError::EStopSocketInUse`]). Directories another user could
    /// tamper with are refused too.
    pub fn bind(prefix: &str) -> Result<Self, IpcError> {
        use std::os::unix::fs::MetadataExt as _;
        let path = socket_path(prefix)?;
        let shown = path.display().to_string();
        let io_err =
            |what: &str, e: io::Error| IpcError::EStopSocket(format!("{what} {shown}: {e}"));
        runtime_dir(prefix)?;
        let sock = match UnixDatagram::bind(&path) {
            Ok(s) => s,
            Err(e) if e.kind() == io::ErrorKind::AddrInUse => {
                // Connecting sends nothing: it only tells a live receiver
                // from a stale file.
                let probe = UnixDatagram::unbound().map_err(|e| io_err("probing", e))?;
                if probe.connect(&path).is_ok() {
                    return Err(IpcError::EStopSocketInUse(shown));
                }
                std::fs::remove_file(&path).map_err(|e| io_err("removing the stale", e))?;
                UnixDatagram::bind(&path).map_err(|e| io_err("binding", e))?
            }
            Err(e) => return Err(io_err("binding", e)),
        };
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o660))
            .map_err(|e| io_err("setting the mode of", e))?;
        let m = std::fs::symlink_metadata(&path).map_err(|e| io_err("reading", e))?;
        sock.set_nonblocking(true)
            .map_err(|e| io_err("configuring", e))?;
        Ok(Self {
            sock,
            path,
            file: (m.dev(), m.ino()),
        })
    }

    /// The socket's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Waits up to `timeout` for datagrams; returns how many arrived (each
    /// one an E-stop), having drained them (at most `max` per call, so a
    /// flood costs bounded work per wake-up). A wait a signal interrupts
    /// returns what it has.
    pub fn wait(&self, timeout: Duration, max: usize) -> io::Result<usize> {
        use std::os::fd::AsRawFd as _;
        let mut pfd = libc::pollfd {
            fd: self.sock.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        let ms = timeout.as_millis().min(i32::MAX as u128) as i32;
        // SAFETY: one valid pollfd for the duration of the call.
        let r = unsafe { libc::poll(&mut pfd, 1, ms) };
        if r < 0 {
            let e = io::Error::last_os_error();
            return if e.kind() == io::ErrorKind::Interrupted {
                Ok(0)
            } else {
                Err(e)
            };
        }
        let mut buf = [0u8; 64];
        let mut n = 0;
        // The socket is non-blocking: drain what is there.
        while n < max {
            match self.sock.recv(&mut buf) {
                Ok(_) => n += 1,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(_) => break,
            }
        }
        Ok(n)
    }
}

impl Drop for EStopListener {
    fn drop(&mut self) {
        use std::os::unix::fs::MetadataExt as _;
        // Only our own socket file: another daemon may have replaced a
        // stale one at this path since.
        if std::fs::symlink_metadata(&self.path).is_ok_and(|m| (m.dev(), m.ino()) == self.file) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estop_datagram_reaches_the_listener_and_a_stale_socket_is_replaced() {
        let prefix = format!("anguilla-test/estop-{}", std::process::id());
        let l = EStopListener::bind(&prefix).unwrap();
        // A second daemon on the same prefix is refused while the first lives.
        let e = EStopListener::bind(&prefix).unwrap_err();
        assert!(matches!(e, IpcError::EStopSocketInUse(_)), "{e}");
        send(&prefix).unwrap();
        send(&prefix).unwrap();
        assert_eq!(l.wait(Duration::from_secs(2), 16).unwrap(), 2);
        assert_eq!(l.wait(Duration::from_millis(10), 16).unwrap(), 0);
        // A dead daemon's socket file: nobody receives, so it is replaced.
        let p2 = format!("{prefix}-stale");
        let path2 = socket_path(&p2).unwrap();
        // Its directories as a daemon makes them (a plain create_dir_all
        // made /tmp/anguilla 0755 on a clean machine, closing it to every
        // other user's daemon).
        runtime_dir(&p2).unwrap();
        drop(UnixDatagram::bind(&path2).unwrap()); // the file stays behind
        assert!(path2.exists());
        let l2 = EStopListener::bind(&p2).unwrap();
        send(&p2).unwrap();
        assert_eq!(l2.wait(Duration::from_secs(2), 16).unwrap(), 1);
    }

    #[test]
    fn a_directory_others_could_write_or_a_symlink_is_refused() {
        // Someone made the prefix's directory first, writable by all: they
        // could swap the socket for their own.
        let prefix = format!("anguilla-test/estop-open-{}", std::process::id());
        let dir = socket_path(&prefix)
            .unwrap()
            .parent()
            .unwrap()
            .to_path_buf();
        let _ = std::fs::remove_dir_all(&dir);
        // Its parents as a daemon makes them (/tmp/anguilla shared, 1777).
        runtime_dir(&format!(
            "anguilla-test/estop-parent-{}",
            std::process::id()
        ))
        .unwrap();
        std::fs::create_dir(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
        let e = EStopListener::bind(&prefix).unwrap_err().to_string();
        assert!(
            e.contains("writable by it alone") && e.contains("remove it"),
            "{e}"
        );
        // A symlink in its place.
        std::fs::remove_dir(&dir).unwrap();
        std::os::unix::fs::symlink("/tmp", &dir).unwrap();
        let e = EStopListener::bind(&prefix).unwrap_err().to_string();
        assert!(e.contains("is not a directory"), "{e}");
        std::fs::remove_file(&dir).unwrap();
        // Cleaned up, the daemon binds, and dropping it removes its socket.
        let l = EStopListener::bind(&prefix).unwrap();
        let path = l.path().to_path_buf();
        drop(l);
        assert!(!path.exists());
    }

    #[test]
    fn no_daemon_and_bad_prefixes_are_named() {
        let e = send("anguilla-test/nobody-here").unwrap_err();
        assert!(e.to_string().contains("no daemon listens"), "{e}");
        assert!(socket_path("../etc").is_err());
        assert!(socket_path("a//b").is_err());
        assert!(socket_path(&"x".repeat(150)).is_err());
    }
}
