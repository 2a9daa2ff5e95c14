//! The robot's small certificate authority (`anguilla link certs`): a CA,
//! the robot's certificate (the names and addresses the operators connect
//! to) and one client certificate per operator, all signed by the CA, with
//! rcgen (ECDSA P-256, ring). The link trusts only this CA for clients
//! (mutual TLS), so an operator needs a certificate from it.
//!
//! Keep the CA's key off the robot and the laptops once the certificates
//! are made. The certificates are valid [`LEAF_YEARS`] (the CA
//! [`CA_YEARS`]); there is no revocation: to shut out a lost key sooner,
//! make a new CA and hand out new certificates.

use std::path::{Path, PathBuf};

use rcgen::{
    BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa,
    Issuer, KeyPair, KeyUsagePurpose,
};

use crate::LinkError;

/// Years the CA is valid.
pub const CA_YEARS: i32 = 10;
/// Years the robot's and the operators' certificates are valid: a lost
/// key stops working then (there is no revocation list; before, make a new
/// CA and hand out new certificates).
pub const LEAF_YEARS: i32 = 2;

/// What [`make`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Made {
    /// Every file written, in order.
    pub files: Vec<PathBuf>,
}

fn certs_err<E: std::fmt::Display>(what: &'static str) -> impl Fn(E) -> LinkError {
    move |e| LinkError::Certs(format!("{what}: {e}"))
}

/// A name usable as a certificate's common name and a file name.
fn check_name(kind: &str, name: &str) -> Result<(), LinkError> {
    if name.is_empty()
        || name.len() > 64
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
        || name.starts_with('.')
    {
        return Err(LinkError::Certs(format!(
            "{kind} name '{name}' is not valid (expected 1 to 64 letters, digits, '-', '_', '.', \
             not starting with '.')"
        )));
    }
    Ok(())
}

/// Today's date (UTC) as (year, month, day), from the system clock.
fn today() -> (i32, u8, u8) {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm).
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u8;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u8;
    let year = (yoe + era * 400 + i64::from(month <= 2)) as i32;
    (year, month, day.min(28))
}

/// Valid from yesterday (clocks differ) for `years` years.
fn validity(p: &mut CertificateParams, years: i32) {
    let (y, m, d) = today();
    p.not_before = rcgen::date_time_ymd(y, m, d) - std::time::Duration::from_secs(86_400);
    p.not_after = rcgen::date_time_ymd(y + years, m, d);
}

fn dn(cn: &str) -> DistinguishedName {
    let mut d = DistinguishedName::new();
    d.push(DnType::OrganizationName, "anguilla");
    d.push(DnType::CommonName, cn);
    d
}

fn write_new(path: &Path, text: &str, secret: bool) -> Result<(), LinkError> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(if secret { 0o600 } else { 0o644 })
        .open(path)
        .map_err(|e| {
            LinkError::Certs(format!(
                "{}: {e} (an existing file is never overwritten: choose an empty directory)",
                path.display()
            ))
        })?;
    f.write_all(text.as_bytes())
        .and_then(|()| f.sync_all())
        .map_err(|e| LinkError::Certs(format!("{}: {e}", path.display())))
}

/// Makes in `dir` (created if missing; existing files are never
/// overwritten): `ca.pem` and `ca.key`; `robot.pem` and `robot.key` for
/// the link, valid for `robot_names` (DNS names or IP addresses the
/// operators use in `tls/NAME:PORT`); and `NAME.pem`, `NAME.key` for each
/// operator (its certificate's common name is NAME). Keys are written
/// mode 0600.
pub fn make(dir: &Path, robot_names: &[String], operators: &[String]) -> Result<Made, LinkError> {
    if robot_names.is_empty() {
        return Err(LinkError::Certs(
            "the robot needs at least one name or address (--robot-name), e.g. localhost or \
             192.168.1.10"
                .into(),
        ));
    }
    for n in operators {
        check_name("operator", n)?;
        if matches!(n.as_str(), "ca" | "robot") {
            return Err(LinkError::Certs(format!(
                "operator name '{n}' is reserved (the CA's and the robot's files)"
            )));
        }
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| LinkError::Certs(format!("{}: {e}", dir.display())))?;
    let mut files = Vec::new();
    let mut put = |name: String, text: String, secret: bool| -> Result<(), LinkError> {
        let p = dir.join(name);
        write_new(&p, &text, secret)?;
        files.push(p);
        Ok(())
    };

    let mut ca = CertificateParams::new(Vec::<String>::new()).map_err(certs_err("CA"))?;
    ca.distinguished_name = dn("anguilla robot CA");
    ca.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    validity(&mut ca, CA_YEARS);
    ca.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    let ca_key = KeyPair::generate().map_err(certs_err("CA key"))?;
    let ca_cert = ca.self_signed(&ca_key).map_err(certs_err("CA"))?;
    put("ca.pem".into(), ca_cert.pem(), false)?;
    put("ca.key".into(), ca_key.serialize_pem(), true)?;
    let issuer = Issuer::new(ca, ca_key);

    let leaf = |cn: &str, sans: Vec<String>, usage: ExtendedKeyUsagePurpose| {
        let mut p = CertificateParams::new(sans).map_err(certs_err("certificate names"))?;
        p.distinguished_name = dn(cn);
        p.extended_key_usages = vec![usage];
        p.key_usages = vec![KeyUsagePurpose::DigitalSignature];
        p.use_authority_key_identifier_extension = true;
        validity(&mut p, LEAF_YEARS);
        let key = KeyPair::generate().map_err(certs_err("key"))?;
        let cert = p.signed_by(&key, &issuer).map_err(certs_err("signing"))?;
        Ok::<_, LinkError>((cert.pem(), key.serialize_pem()))
    };
    let (pem, key) = leaf(
        "robot",
        robot_names.to_vec(),
        ExtendedKeyUsagePurpose::ServerAuth,
    )?;
    put("robot.pem".into(), pem, false)?;
    put("robot.key".into(), key, true)?;
    for n in operators {
        let (pem, key) = leaf(n, Vec::new(), ExtendedKeyUsagePurpose::ClientAuth)?;
        put(format!("{n}.pem"), pem, false)?;
        put(format!("{n}.key"), key, true)?;
    }
    Ok(Made { files })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn makes_the_files_and_never_overwrites() {
        let dir = std::env::temp_dir().join(format!("anguilla-certs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let made = make(
            &dir,
            &["localhost".into(), "127.0.0.1".into()],
            &["alice".into()],
        )
        .unwrap();
        assert_eq!(made.files.len(), 6);
        let key = std::fs::read_to_string(dir.join("alice.key")).unwrap();
        assert!(key.starts_with("-----BEGIN PRIVATE KEY-----"));
        use std::os::unix::fs::PermissionsExt as _;
        let mode = std::fs::metadata(dir.join("ca.key"))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o600);
        let again = make(&dir, &["localhost".into()], &[])
            .unwrap_err()
            .to_string();
        assert!(again.contains("never overwritten"), "{again}");
        let bad = make(&dir, &["localhost".into()], &["../x".into()])
            .unwrap_err()
            .to_string();
        assert!(bad.contains("'../x' is not valid"), "{bad}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
