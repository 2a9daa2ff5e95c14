//! Why a tool could not reach a link over TLS, in words.
//!
//! When Zenoh's TLS transport fails, it says only that no endpoint could be
//! reached (with a source path of its own). The tool then makes one TLS
//! handshake itself, with the same CA, certificate and key (rustls, the
//! library Zenoh's TLS uses), and names the likely cause: nothing listening,
//! the link's certificate for another host name, from another CA, expired
//! or not valid yet, or this tool's certificate refused or missing.

use std::io::{Read as _, Write as _};
use std::net::{TcpStream, ToSocketAddrs as _};
use std::sync::Arc;
use std::time::Duration;

use rustls::pki_types::{CertificateDer, PrivateKeyDer, ServerName};
use rustls::{AlertDescription, CertificateError, Error as TlsError};

use crate::{Endpoint, Tls};

/// How long the probe waits for the connection and each handshake step.
const PROBE_TIMEOUT: Duration = Duration::from_secs(3);

/// The likely cause of a failed TLS connection to `endpoint` with `tls`,
/// for a message: one sentence, no source paths.
pub fn tls_failure(endpoint: &Endpoint, tls: &Tls) -> String {
    match probe(endpoint, tls) {
        Ok(()) => "the TLS handshake itself succeeds (with this tool's files), so the link \
                   refused the session after it: check that its prefix and mode are this \
                   tool's"
            .into(),
        Err(why) => why,
    }
}

fn certs(path: &std::path::Path, what: &str) -> Result<Vec<CertificateDer<'static>>, String> {
    let file = std::fs::File::open(path)
        .map_err(|e| format!("cannot read {what} {}: {e}", path.display()))?;
    let certs: Vec<_> = rustls_pemfile::certs(&mut std::io::BufReader::new(file))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{what} {} is not PEM: {e}", path.display()))?;
    if certs.is_empty() {
        return Err(format!("{what} {} holds no certificate", path.display()));
    }
    Ok(certs)
}

fn key(path: &std::path::Path) -> Result<PrivateKeyDer<'static>, String> {
    let file = std::fs::File::open(path)
        .map_err(|e| format!("cannot read the key {}: {e}", path.display()))?;
    rustls_pemfile::private_key(&mut std::io::BufReader::new(file))
        .map_err(|e| format!("the key {} is not PEM: {e}", path.display()))?
        .ok_or_else(|| format!("the key {} holds no private key", path.display()))
}

/// `host:port` of a `tls/HOST:PORT` endpoint, and the host.
fn address(endpoint: &Endpoint) -> Result<(String, String), String> {
    let hp = endpoint
        .text
        .strip_prefix("tls/")
        .ok_or_else(|| format!("{} is not a TLS endpoint", endpoint.text))?;
    let hp = hp.split('#').next().unwrap_or(hp);
    let (host, _port) = hp
        .rsplit_once(':')
        .ok_or_else(|| format!("{} has no port", endpoint.text))?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    Ok((hp.to_string(), host.to_string()))
}

fn probe(endpoint: &Endpoint, tls: &Tls) -> Result<(), String> {
    let (hp, host) = address(endpoint)?;
    let mut roots = rustls::RootCertStore::empty();
    for c in certs(&tls.ca, "the CA file")? {
        roots
            .add(c)
            .map_err(|e| format!("the CA file {} is unusable: {e}", tls.ca.display()))?;
    }
    let chain = certs(&tls.cert, "this tool's certificate")?;
    let key = key(&tls.key)?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| format!("TLS: {e}"))?
        .with_root_certificates(roots)
        .with_client_auth_cert(chain, key)
        .map_err(|e| {
            format!(
                "this tool's certificate {} and key {} do not go together: {e}",
                tls.cert.display(),
                tls.key.display()
            )
        })?;
    let name = ServerName::try_from(host.clone())
        .map_err(|_| format!("'{host}' is not a host name or an address"))?;
    let addr = hp
        .to_socket_addrs()
        .map_err(|e| format!("cannot resolve {hp}: {e}"))?
        .next()
        .ok_or_else(|| format!("{hp} resolves to no address"))?;
    let mut tcp = TcpStream::connect_timeout(&addr, PROBE_TIMEOUT).map_err(|e| {
        format!(
            "nothing accepts connections at {hp} ({e}): is `anguilla link --listen {}` \
             running there?",
            endpoint.text
        )
    })?;
    let _ = tcp.set_read_timeout(Some(PROBE_TIMEOUT));
    let _ = tcp.set_write_timeout(Some(PROBE_TIMEOUT));
    let mut conn =
        rustls::ClientConnection::new(Arc::new(config), name).map_err(|e| format!("TLS: {e}"))?;
    let mut stream = rustls::Stream::new(&mut conn, &mut tcp);
    // The handshake, then a read: a server that refuses the client's
    // certificate says so after the client's Finished (TLS 1.3).
    let outcome = stream.flush().and_then(|()| {
        let mut b = [0u8; 1];
        match stream.read(&mut b) {
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                Ok(())
            }
            other => other.map(|_| ()),
        }
    });
    match outcome {
        Ok(()) => Ok(()),
        Err(e) => Err(
            match e.get_ref().and_then(|i| i.downcast_ref::<TlsError>()) {
                Some(t) => words(t, &host, tls),
                None if e.kind() == std::io::ErrorKind::UnexpectedEof
                    || e.kind() == std::io::ErrorKind::ConnectionReset =>
                {
                    format!(
                        "the link at {hp} closed the connection during the TLS handshake: it \
                     refused this tool's certificate {} (not signed by the robot's CA?), or \
                     it does not speak TLS",
                        tls.cert.display()
                    )
                }
                None => format!("TLS handshake with {hp}: {e}"),
            },
        ),
    }
}

/// A rustls error as its likely cause and fix.
fn words(e: &TlsError, host: &str, tls: &Tls) -> String {
    match e {
        TlsError::InvalidCertificate(
            CertificateError::NotValidForName | CertificateError::NotValidForNameContext { .. },
        ) => format!(
            "the link's certificate is not for the name '{host}': connect by a name it has, \
             or make it one (`anguilla link certs DIR --robot-name {host}`)"
        ),
        // Another CA of the same name (every `anguilla link certs` CA has
        // one) fails the signature, an unknown one the issuer.
        TlsError::InvalidCertificate(
            CertificateError::UnknownIssuer | CertificateError::BadSignature,
        ) => format!(
            "the link's certificate is not signed by the CA this tool trusts ({}): give the \
             robot's ca.pem",
            tls.ca.display()
        ),
        TlsError::InvalidCertificate(
            CertificateError::Expired | CertificateError::ExpiredContext { .. },
        ) => "the link's certificate has expired: make new ones (`anguilla link certs`)".into(),
        TlsError::InvalidCertificate(
            CertificateError::NotValidYet | CertificateError::NotValidYetContext { .. },
        ) => "the link's certificate is not valid yet: check both machines' clocks".into(),
        TlsError::AlertReceived(AlertDescription::CertificateRequired) => {
            "the link requires a client certificate: give this tool --cert and --key".into()
        }
        TlsError::AlertReceived(AlertDescription::CertificateExpired) => format!(
            "the link says this tool's certificate {} has expired: ask for a new one \
             (`anguilla link certs DIR --operator NAME` on the robot)",
            tls.cert.display()
        ),
        TlsError::AlertReceived(
            AlertDescription::BadCertificate
            | AlertDescription::UnknownCA
            | AlertDescription::CertificateUnknown
            | AlertDescription::AccessDenied
            | AlertDescription::DecryptError,
        ) => format!(
            "the link refused this tool's certificate {}: it is not signed by the robot's \
             CA (`anguilla link certs DIR --operator NAME` on the robot makes one)",
            tls.cert.display()
        ),
        other => format!("TLS: {other}"),
    }
}

/// A Zenoh error's text without the source location Zenoh appends
/// (` at /root/.cargo/registry/…/file.rs:123.`).
pub fn without_source_paths(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find(" at /") {
        out.push_str(&rest[..i]);
        let tail = &rest[i + 4..];
        // The path runs to ".rs:LINE" (and an optional '.').
        match tail.find(".rs:") {
            Some(j) => {
                let after = &tail[j + 4..];
                let digits = after.chars().take_while(char::is_ascii_digit).count();
                let after = &after[digits..];
                rest = after.strip_prefix('.').unwrap_or(after);
            }
            None => {
                out.push_str(&rest[i..]);
                rest = "";
            }
        }
    }
    out.push_str(rest);
    out.trim_end().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn source_paths_are_cut() {
        let z = "Unable to connect to any of [tls/127.0.0.1:9]! at \
                 /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-1.5.1/src/net/runtime/orchestrator.rs:412.";
        assert_eq!(
            without_source_paths(z),
            "Unable to connect to any of [tls/127.0.0.1:9]!"
        );
        assert_eq!(without_source_paths("nothing here"), "nothing here");
        assert_eq!(without_source_paths("a at /x.rs:1. b at /y.rs:22"), "a b");
    }

    /// A TLS server with the robot's certificate of `dir` that asks for
    /// client certificates of its CA, accepting one connection; its port.
    fn server(dir: &std::path::Path) -> u16 {
        let ca = certs(&dir.join("ca.pem"), "ca").unwrap();
        let mut roots = rustls::RootCertStore::empty();
        roots.add(ca[0].clone()).unwrap();
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let verifier = rustls::server::WebPkiClientVerifier::builder_with_provider(
            roots.into(),
            provider.clone(),
        )
        .build()
        .unwrap();
        let config = rustls::ServerConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()
            .unwrap()
            .with_client_cert_verifier(verifier)
            .with_single_cert(
                certs(&dir.join("robot.pem"), "robot").unwrap(),
                key(&dir.join("robot.key")).unwrap(),
            )
            .unwrap();
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        std::thread::spawn(move || {
            if let Ok((mut tcp, _)) = listener.accept() {
                // As a link does: the connection stays open until the
                // client leaves (or a long time), whatever the machine's
                // load makes of the client's pace.
                let _ = tcp.set_read_timeout(Some(Duration::from_secs(30)));
                let mut conn = rustls::ServerConnection::new(Arc::new(config)).unwrap();
                let mut s = rustls::Stream::new(&mut conn, &mut tcp);
                let mut b = [0u8; 1];
                while let Ok(1..) = s.read(&mut b) {}
            }
        });
        port
    }

    fn files(dir: &std::path::Path, who: &str) -> Tls {
        Tls {
            ca: dir.join("ca.pem"),
            cert: dir.join(format!("{who}.pem")),
            key: dir.join(format!("{who}.key")),
        }
    }

    /// Each cause as an operator reads it: the link's certificate for
    /// another name, from another CA, and this tool's certificate refused.
    #[test]
    fn each_tls_cause_is_named() {
        let base =
            std::env::temp_dir().join(format!("anguilla-diagnose-tls-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let (robot, other) = (base.join("robot"), base.join("other"));
        // The robot's certificate names only "localhost".
        crate::certs::make(&robot, &["localhost".into()], &["alice".into()]).unwrap();
        crate::certs::make(&other, &["localhost".into()], &["mallory".into()]).unwrap();
        let at = |host: &str, port: u16, tls: &Tls| {
            let ep = Endpoint::parse(&format!("tls/{host}:{port}"), Some(tls)).unwrap();
            tls_failure(&ep, tls)
        };
        let alice = files(&robot, "alice");
        let said = at("127.0.0.1", server(&robot), &alice);
        assert!(
            said.contains("the link's certificate is not for the name '127.0.0.1'"),
            "{said}"
        );
        let said = at("localhost", server(&robot), &alice);
        assert!(said.contains("the TLS handshake itself succeeds"), "{said}");
        // Alice trusting another CA than the robot's.
        let wrong_ca = Tls {
            ca: other.join("ca.pem"),
            ..alice.clone()
        };
        let said = at("localhost", server(&robot), &wrong_ca);
        assert!(
            said.contains("not signed by the CA this tool trusts"),
            "{said}"
        );
        // Mallory trusts the robot's CA; her certificate is another CA's.
        let mallory = Tls {
            ca: robot.join("ca.pem"),
            ..files(&other, "mallory")
        };
        let said = at("localhost", server(&robot), &mallory);
        assert!(said.contains("refused this tool's certificate"), "{said}");
        let _ = std::fs::remove_dir_all(&base);
    }

    #[test]
    fn nothing_listening_is_named() {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let dir = std::env::temp_dir().join(format!("anguilla-diagnose-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        crate::certs::make(&dir, &["localhost".into()], &["op".into()]).unwrap();
        let tls = Tls {
            ca: dir.join("ca.pem"),
            cert: dir.join("op.pem"),
            key: dir.join("op.key"),
        };
        let ep = Endpoint::parse(&format!("tls/127.0.0.1:{port}"), Some(&tls)).unwrap();
        let said = tls_failure(&ep, &tls);
        assert!(said.contains("nothing accepts connections"), "{said}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
