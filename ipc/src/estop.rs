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
//! a program that creates a prefix's directory or socket first keeps the
//! daemon from starting (it says so), never from being stopped.
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

/// Where the E-stop sockets live.
pub const ROOT: &str = "/tmp/anguilla";

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
    let p = Path::new(ROOT).join(prefix).join("estop");
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
}

impl EStopListener {
    /// Binds the E-stop socket of `prefix`. A socket file left by a dead
    /// daemon (nobody receives on it) is replaced; one a live process
    /// receives on is not, and the daemon refuses to start
    /// ([`IpcError::Squatted`]).
    pub fn bind(prefix: &str) -> Result<Self, IpcError> {
        let path = socket_path(prefix)?;
        let shown = path.display().to_string();
        let io_err =
            |what: &str, e: io::Error| IpcError::EStopSocket(format!("{what} {shown}: {e}"));
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| io_err("creating the directory of", e))?;
            // The root is shared by the daemons of every user, like /tmp
            // (sticky, world-writable); a prefix's directories are its
            // daemon's, searchable by all (the socket's mode decides who
            // sends). Best effort: another user's directory stays as it is.
            for d in dir.ancestors().take_while(|d| d.starts_with(ROOT)) {
                let mode = if d == Path::new(ROOT) { 0o1777 } else { 0o755 };
                let _ = std::fs::set_permissions(d, std::fs::Permissions::from_mode(mode));
            }
        }
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
        Ok(Self { sock, path })
    }

    /// The socket's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Waits up to `timeout` for datagrams; returns how many arrived (each
    /// one an E-stop), having drained them all (at most `max` per call, so
    /// a flood costs bounded work per wake-up).
    pub fn wait(&self, timeout: Duration, max: usize) -> io::Result<usize> {
        let mut buf = [0u8; 64];
        self.sock
            .set_read_timeout(Some(timeout.max(Duration::from_micros(1))))?;
        let mut n = 0;
        match self.sock.recv(&mut buf) {
            Ok(_) => n += 1,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(0);
            }
            Err(e) => return Err(e),
        }
        self.sock.set_nonblocking(true)?;
        while n < max {
            match self.sock.recv(&mut buf) {
                Ok(_) => n += 1,
                Err(_) => break,
            }
        }
        self.sock.set_nonblocking(false)?;
        Ok(n)
    }
}

impl Drop for EStopListener {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
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
        std::fs::create_dir_all(path2.parent().unwrap()).unwrap();
        drop(UnixDatagram::bind(&path2).unwrap()); // the file stays behind
        assert!(path2.exists());
        let l2 = EStopListener::bind(&p2).unwrap();
        send(&p2).unwrap();
        assert_eq!(l2.wait(Duration::from_secs(2), 16).unwrap(), 1);
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
