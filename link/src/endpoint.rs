//! The link's endpoints and TLS files, checked before Zenoh sees them, the
//! prefix's local socket and who may reach it, the errors, and the Zenoh
//! configuration built from them.

use std::net::IpAddr;
use std::path::{Path, PathBuf};

/// What went wrong setting up or using the link; the text names the
/// endpoint or the key and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// An endpoint is not one the link accepts.
    #[error("endpoint '{endpoint}': {why}")]
    Endpoint {
        /// The endpoint given.
        endpoint: String,
        /// What is wrong and what was expected.
        why: String,
    },
    /// A TLS file is missing or unreadable.
    #[error("TLS {what} '{path}': {why}")]
    Tls {
        /// Which file (CA, certificate, key).
        what: &'static str,
        /// Its path.
        path: String,
        /// The error.
        why: String,
    },
    /// Zenoh refused; the text names the step.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The daemon's interface failed.
    #[error(transparent)]
    Ipc(#[from] anguilla_ipc::IpcError),
    /// Making certificates failed.
    #[error("certificates: {0}")]
    Certs(String),
    /// A socket of the link's own failed; the text names it.
    #[error("{0}")]
    Socket(String),
}

#[cfg(feature = "zenoh")]
pub(crate) fn zenoh_err<E: std::fmt::Display>(what: &'static str) -> impl Fn(E) -> LinkError {
    move |e| LinkError::Zenoh(format!("{what}: {e}"))
}

/// TLS files: the CA that signs both ends, and this end's certificate and key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tls {
    /// The robot's CA certificate (PEM).
    pub ca: PathBuf,
    /// This end's certificate (PEM), signed by the CA.
    pub cert: PathBuf,
    /// This end's private key (PEM).
    pub key: PathBuf,
}

impl Tls {
    fn check(&self) -> Result<(), LinkError> {
        for (what, p) in [
            ("CA certificate", &self.ca),
            ("certificate", &self.cert),
            ("key", &self.key),
        ] {
            std::fs::metadata(p).map_err(|e| LinkError::Tls {
                what,
                path: p.display().to_string(),
                why: e.to_string(),
            })?;
        }
        Ok(())
    }
}

/// The word for the prefix's local link socket in `--listen`, `--connect`
/// and `[link] listen`.
pub const LOCAL: &str = "local";

/// The prefix's local link socket: `/tmp/anguilla/<prefix>/link/sock`.
pub fn local_socket(prefix: &str) -> Result<PathBuf, LinkError> {
    let estop = anguilla_ipc::estop::socket_path(prefix)?;
    Ok(estop.with_file_name("link").join("sock"))
}

/// A checked endpoint: its protocol, and whether its address is loopback.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// As given (`tcp/127.0.0.1:7447`), or the local socket's
    /// (`unixsock-stream//tmp/anguilla/<prefix>/link/sock`).
    pub text: String,
    /// TLS (`tls/`) rather than plain TCP.
    pub tls: bool,
    /// A Unix socket (`unixsock-stream/PATH`): its directory's mode decides
    /// who connects.
    pub unix: bool,
}

impl Endpoint {
    /// The local link of `prefix` ([`local_socket`]).
    pub fn local(prefix: &str) -> Result<Self, LinkError> {
        let p = local_socket(prefix)?;
        Ok(Self {
            text: format!("unixsock-stream/{}", p.display()),
            tls: false,
            unix: true,
        })
    }

    /// `text`, or the local link of `prefix` for [`LOCAL`].
    pub fn parse_at(text: &str, prefix: &str, tls: Option<&Tls>) -> Result<Self, LinkError> {
        if text == LOCAL {
            Self::local(prefix)
        } else {
            Self::parse(text, tls)
        }
    }

    /// Plain TCP: on loopback, but open to every local user (no
    /// authentication). The link listens there only with
    /// `insecure-loopback`.
    pub fn insecure(&self) -> bool {
        !self.tls && !self.unix
    }

    /// Whether the link may listen here: anywhere but plain TCP, and there
    /// only with `insecure_loopback`; the refusal says why and what to do.
    pub fn listenable(&self, insecure_loopback: bool) -> Result<(), LinkError> {
        if self.insecure() && !insecure_loopback {
            return Err(LinkError::Endpoint {
                endpoint: self.text.clone(),
                why: "plain TCP has no authentication, and every local user can connect to a \
                      loopback port and drive the robot. Listen on 'local' (the default: a Unix \
                      socket only the link's user and group reach; tools use --connect local) \
                      or tls/, or accept the risk with --insecure-loopback ([link] \
                      insecure-loopback = true)"
                    .into(),
            });
        }
        Ok(())
    }

    /// Checks `text`: `tcp/HOST:PORT` with a loopback host (`127.0.0.0/8`,
    /// `::1`, `localhost`), `tls/HOST:PORT` with any host when `tls` is
    /// given, or `unixsock-stream/PATH` with an absolute path. Every other
    /// form is refused, naming what is expected.
    pub fn parse(text: &str, tls: Option<&Tls>) -> Result<Self, LinkError> {
        let e = Self::parse_form(text, tls.is_some())?;
        if let Some(t) = tls.filter(|_| e.tls) {
            t.check()?;
        }
        Ok(e)
    }

    /// [`Endpoint::parse`] without reading the TLS files: `tls` says
    /// whether they are configured (`anguilla config check` on another
    /// computer than the robot).
    pub fn parse_form(text: &str, tls: bool) -> Result<Self, LinkError> {
        let bad = |why: String| LinkError::Endpoint {
            endpoint: text.to_string(),
            why,
        };
        let (proto, addr) = text.split_once('/').ok_or_else(|| {
            bad(
                "expected tcp/HOST:PORT (loopback) or tls/HOST:PORT, e.g. tcp/127.0.0.1:7447"
                    .into(),
            )
        })?;
        if proto == "unixsock-stream" {
            // sun_path: 108 bytes with the NUL.
            if !addr.starts_with('/') || addr.len() > 107 || addr.contains(['#', '?']) {
                return Err(bad(format!(
                    "expected unixsock-stream/ and an absolute path of at most 107 bytes \
                     (unixsock-stream//tmp/anguilla/PREFIX/link/sock), or '{LOCAL}'"
                )));
            }
            return Ok(Self {
                text: text.to_string(),
                tls: false,
                unix: true,
            });
        }
        if addr.contains('#') || addr.contains('?') {
            return Err(bad(
                "endpoint options (#, ?) are not accepted: TLS is set with --ca/--cert/--key or [link]"
                    .into(),
            ));
        }
        let (host, port) = addr
            .rsplit_once(':')
            .ok_or_else(|| bad("expected HOST:PORT after the protocol".into()))?;
        port.parse::<u16>()
            .map_err(|_| bad(format!("port '{port}' is not a number 0..=65535")))?;
        let host = host.trim_start_matches('[').trim_end_matches(']');
        if host.is_empty() {
            return Err(bad("the host is empty".into()));
        }
        // A name counts as loopback only if every address it resolves to is
        // (a hosts file could point `localhost` elsewhere).
        let loopback = match host.parse::<IpAddr>() {
            Ok(a) => a.is_loopback(),
            Err(_) => {
                use std::net::ToSocketAddrs as _;
                let addrs: Vec<_> = (host, 0u16)
                    .to_socket_addrs()
                    .map(|a| a.collect())
                    .unwrap_or_default();
                !addrs.is_empty() && addrs.iter().all(|a| a.ip().is_loopback())
            }
        };
        match proto {
            "tcp" if loopback => Ok(Self {
                text: text.to_string(),
                tls: false,
                unix: false,
            }),
            // An IPv6 address keeps its brackets in the suggestion
            // (`tls/[::]:7447`, not `tls/:::7447`).
            "tcp" => Err(bad(format!(
                "plain TCP is allowed on loopback only (127.0.0.1, ::1, localhost), and '{host}' \
                 is not loopback: use tls/{}:{port} with the robot's CA, certificate and key \
                 (anguilla link certs makes them)",
                if host.contains(':') {
                    format!("[{host}]")
                } else {
                    host.to_string()
                }
            ))),
            "tls" => match tls {
                true => Ok(Self {
                    text: text.to_string(),
                    tls: true,
                    unix: false,
                }),
                false => Err(bad(
                    "tls/ needs the robot's CA and this end's certificate and key \
                     (--ca, --cert, --key; [link] ca, cert, key for the link)"
                        .into(),
                )),
            },
            other => Err(bad(format!(
                "protocol '{other}' is not supported (expected '{LOCAL}', unixsock-stream, tcp on \
                 loopback, or tls)"
            ))),
        }
    }
}

/// Makes the local link's directory, `/tmp/anguilla/<prefix>/link`, mode
/// 0770: this process's user and group (the operators) may enter it,
/// nobody else; returns the socket's path. The prefix's directories are
/// checked as the daemon's E-stop socket's are; a `link` directory that
/// another user made, a symlink, or one open to others is refused, naming
/// its owner and mode. Call it before opening the link, with the umask at
/// 007 so that the socket Zenoh makes is the group's too.
pub fn prepare_local(prefix: &str) -> Result<PathBuf, LinkError> {
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
    let sock = local_socket(prefix)?;
    let dir = anguilla_ipc::estop::runtime_dir(prefix)?.join("link");
    let fail = |why: String| LinkError::Endpoint {
        endpoint: format!("unixsock-stream/{}", sock.display()),
        why,
    };
    match std::fs::create_dir(&dir) {
        Ok(()) => std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o770))
            .map_err(|e| fail(format!("setting the mode of {}: {e}", dir.display())))?,
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(fail(format!("creating {}: {e}", dir.display()))),
    }
    let m = std::fs::symlink_metadata(&dir)
        .map_err(|e| fail(format!("reading {}: {e}", dir.display())))?;
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    if !m.file_type().is_dir() || m.uid() != uid || m.mode() & 0o007 != 0 {
        return Err(fail(format!(
            "{} belongs to uid {} with mode {:o}{} (expected a directory of this user, uid \
             {uid}, closed to others, mode 0770): another user may have made it; remove it",
            dir.display(),
            m.uid(),
            m.mode() & 0o7777,
            if m.file_type().is_dir() {
                ""
            } else {
                ", not a directory"
            },
        )));
    }
    Ok(sock)
}

/// Why a tool cannot use the local link at `endpoint`, if the kernel says
/// so before Zenoh tries: the directory is not this user's to enter.
pub fn local_access(endpoint: &Endpoint) -> Option<String> {
    use std::os::unix::fs::MetadataExt as _;
    let path = Path::new(endpoint.text.strip_prefix("unixsock-stream/")?);
    let dir = path.parent()?;
    match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
            let group = std::fs::metadata(dir).map(|m| m.gid()).ok();
            Some(format!(
                "permission denied on {}: the local link admits its user and the members of its \
                 group only{}; ask to be added to that group (usermod -aG GROUP USER, then log in \
                 again)",
                dir.display(),
                group.map_or(String::new(), |g| format!(" (gid {g})")),
            ))
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Some(format!(
            "no link listens on {} (is `anguilla link` running for this prefix?)",
            path.display()
        )),
        _ => None,
    }
}

/// A JSON string literal (JSON5 values for Zenoh's configuration).
#[cfg(feature = "zenoh")]
fn json(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

#[cfg(feature = "zenoh")]
fn path_json(p: &Path) -> String {
    json(&p.display().to_string())
}

/// The Zenoh configuration both ends share: the mode, explicit endpoints
/// only (no multicast scouting, no gossip), and TLS with mutual
/// authentication when `tls` is given. `listen` says which side.
#[cfg(feature = "zenoh")]
pub(crate) fn zenoh_config(
    mode: &str,
    endpoints: &[Endpoint],
    listen: bool,
    tls: Option<&Tls>,
) -> Result<zenoh::Config, LinkError> {
    let mut c = zenoh::Config::default();
    let list = serde_json::Value::Array(
        endpoints
            .iter()
            .map(|e| serde_json::Value::String(e.text.clone()))
            .collect(),
    )
    .to_string();
    let mut set = |k: &str, v: String| {
        c.insert_json5(k, &v)
            .map_err(|e| LinkError::Zenoh(format!("configuration {k} = {v}: {e}")))
    };
    set("mode", json(mode))?;
    set("scouting/multicast/enabled", "false".into())?;
    set("scouting/gossip/enabled", "false".into())?;
    if listen {
        set("listen/endpoints", list)?;
        set("connect/endpoints", "[]".into())?;
    } else {
        set("listen/endpoints", "[]".into())?;
        set("connect/endpoints", list)?;
        // Wait for the link up to 2 s at open, then fail with a message.
        set("connect/timeout_ms", "2000".into())?;
        set("connect/exit_on_failure", "true".into())?;
    }
    if let Some(t) = tls {
        set("transport/link/tls/root_ca_certificate", path_json(&t.ca))?;
        set("transport/link/tls/enable_mtls", "true".into())?;
        let (cert, key) = if listen {
            ("listen_certificate", "listen_private_key")
        } else {
            ("connect_certificate", "connect_private_key")
        };
        set(&format!("transport/link/tls/{cert}"), path_json(&t.cert))?;
        set(&format!("transport/link/tls/{key}"), path_json(&t.key))?;
    }
    Ok(c)
}
