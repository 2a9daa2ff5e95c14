//! Remote operation of an anguilla daemon over [Zenoh](https://zenoh.io):
//! the bridge `anguilla link` runs on the tether computer ([`bridge`]; the
//! command's run, its options checked and the bridge opened, run and
//! counted, is [`run`]), and the session the operator tools open with
//! `--connect` ([`remote`]). The
//! real-time daemon never links Zenoh: the link is its own process, an
//! operator tool of the daemon like any other (iceoryx2, `docs/ipc.md`).
//!
//! **Why Zenoh itself.** iceoryx2 0.10's Zenoh tunnel is a prototype that
//! carries publish-subscribe and events but not request-response, and the
//! daemon's authority rests on request-response (each client port is one
//! identity). The `zenoh` crate gives queries with replies, TLS with mutual
//! authentication and an access-control list in the router, which is what a
//! remote control needs.
//!
//! **The wire** (documented for other Zenoh implementations in
//! `docs/remote.md`), under the daemon's prefix `P`:
//!
//! | key | what | payload |
//! |---|---|---|
//! | `P/state` | the link publishes | one `StateSnapshot` (docs/ipc.md layout) |
//! | `P/command/<token>` | a tool's query, the link's reply | `CommandRequest` → client id (16 bytes, LE) + `CommandReply`; an empty query (a hello, which opens the session) → client id, the link's epoch and clock |
//! | `P/estop` | a tool's query, the link's reply | anything → UTF-8 text (relayed to the E-stop socket) |
//!
//! A remote tool's identity is its **token**: 128 random bits it draws at
//! start and keeps secret (TLS on the wire, and the link's access-control
//! list lets no remote client declare a queryable, so no query reaches
//! anyone but the link). The link gives each token its own iceoryx2 client
//! port, so the daemon sees each remote tool as one client, with the same
//! authority, deadman and E-stop rules as a local one.
//!
//! **Security.** Only operators reach the link:
//! - **local** (the default): a Unix socket, `/tmp/anguilla/<prefix>/link/sock`,
//!   in a directory of mode 0770 that belongs to the link's user and group
//!   ([`prepare_local`]): the kernel lets only that user and the members of
//!   its group (the operators) connect;
//! - `tls/` anywhere, with the robot's CA ([`certs`]), mutual
//!   authentication on;
//! - plain `tcp/` on loopback only, and only with `insecure-loopback`
//!   ([`Endpoint::insecure`]): every local user can connect there.
//!
//! The router's access-control list allows remote clients exactly the
//! allowlist's keys (`[link] inbound`, `outbound`), and multicast and
//! gossip scouting stay off.
//!
//! **Features.** `zenoh` (default) is everything but [`wire`] (the link's
//! message layouts and the command key's token, which read bytes from
//! other hosts) and the endpoint checks; without it this crate builds no
//! Zenoh, which is how the fuzz targets (`fuzz/`) decode the link's messages.

#![warn(missing_docs)]

#[cfg(feature = "zenoh")]
pub mod bridge;
#[cfg(feature = "zenoh")]
pub mod certs;
pub mod config;
#[cfg(feature = "zenoh")]
pub mod diagnose;
mod endpoint;
#[cfg(feature = "zenoh")]
pub mod remote;
pub mod ros2;
#[cfg(feature = "zenoh")]
pub mod run;
pub mod wire;

#[cfg(feature = "zenoh")]
pub use bridge::{Bridge, BridgeStats, LinkSettings};
pub use endpoint::{Endpoint, LOCAL, LinkError, Tls, local_access, local_socket, prepare_local};
#[cfg(feature = "zenoh")]
pub(crate) use endpoint::{zenoh_config, zenoh_err};
#[cfg(feature = "zenoh")]
pub use remote::{RemoteClient, ask_prefix, remote_estop};

/// Where a link says which daemon prefix it serves (a query's reply: the
/// prefix, UTF-8), whatever that prefix: a tool given another prefix asks
/// here to say which one to give (docs/remote.md).
pub const INFO_KEY: &str = "_anguilla/link/prefix";

/// The state's key under `prefix`.
pub fn state_key(prefix: &str) -> String {
    format!("{prefix}/state")
}

/// A remote session's command key under `prefix`.
pub fn command_key(prefix: &str, token: &str) -> String {
    format!("{prefix}/command/{token}")
}

/// The E-stop key under `prefix`.
pub fn estop_key(prefix: &str) -> String {
    format!("{prefix}/estop")
}

/// `N` bytes from the kernel's random source (tokens, epochs).
#[cfg(feature = "zenoh")]
pub(crate) fn urandom<const N: usize>() -> std::io::Result<[u8; N]> {
    use std::io::Read as _;
    let mut b = [0u8; N];
    std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut b))?;
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_tcp_is_loopback_only() {
        for ok in [
            "tcp/127.0.0.1:7447",
            "tcp/127.3.2.1:1",
            "tcp/[::1]:7447",
            "tcp/localhost:7447",
        ] {
            let e = Endpoint::parse(ok, None).unwrap();
            // Listened on only when the owner accepts every local user.
            let why = e.listenable(false).unwrap_err().to_string();
            assert!(
                why.contains("--insecure-loopback") && why.contains(ok),
                "{why}"
            );
            assert!(e.listenable(true).is_ok(), "{ok}");
        }
        let local = Endpoint::local("anguilla").unwrap();
        assert!(local.unix && local.listenable(false).is_ok());
        for (bad, says) in [
            ("tcp/0.0.0.0:7447", "loopback only"),
            ("tcp/192.168.1.5:7447", "loopback only"),
            ("tcp/[::]:7447", "use tls/[::]:7447 with"),
            ("tcp/[fe80::1]:7447", "use tls/[fe80::1]:7447 with"),
            ("tcp/192.168.1.5:7447", "use tls/192.168.1.5:7447 with"),
            ("tcp/robot.local:7447", "loopback only"),
            ("tls/0.0.0.0:7447", "needs the robot's CA"),
            ("udp/127.0.0.1:7447", "not supported"),
            ("127.0.0.1:7447", "expected tcp/HOST:PORT"),
            ("tcp/127.0.0.1", "HOST:PORT"),
            ("tcp/127.0.0.1:70000", "not a number"),
            ("tcp/127.0.0.1:7447#iface=lo", "options"),
        ] {
            let e = Endpoint::parse(bad, None).unwrap_err().to_string();
            assert!(e.contains(says) && e.contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn tls_needs_its_files() {
        let t = Tls {
            ca: "/nonexistent/ca.pem".into(),
            cert: "/nonexistent/robot.pem".into(),
            key: "/nonexistent/robot.key".into(),
        };
        let e = Endpoint::parse("tls/0.0.0.0:7447", Some(&t))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/ca.pem"), "{e}");
    }

    #[cfg(feature = "zenoh")]
    #[test]
    fn the_configuration_has_no_scouting_and_mutual_tls() {
        let dir = std::env::temp_dir().join(format!("anguilla-link-cfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let t = Tls {
            ca: dir.join("ca.pem"),
            cert: dir.join("r.pem"),
            key: dir.join("r.key"),
        };
        let e = Endpoint {
            text: "tls/0.0.0.0:7447".into(),
            tls: true,
            unix: false,
        };
        let c = zenoh_config("router", &[e], true, Some(&t)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&c.to_string()).unwrap();
        assert_eq!(v["scouting"]["multicast"]["enabled"], false);
        assert_eq!(v["scouting"]["gossip"]["enabled"], false);
        assert_eq!(v["transport"]["link"]["tls"]["enable_mtls"], true);
        assert_eq!(v["listen"]["endpoints"][0], "tls/0.0.0.0:7447");
        assert_eq!(
            v["transport"]["link"]["tls"]["root_ca_certificate"],
            t.ca.display().to_string()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
