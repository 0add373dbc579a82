//! The server's own certificate and private key, checked before the server starts.
//!
//! async-opcua makes a pair at first start when there is none, but a pair a power cut damaged
//! at that first start (a key torn to a few hundred bytes, an empty certificate) is loaded as
//! it is: the endpoint then advertises a certificate no client can use, while the log says the
//! server runs. So the pair is read here first: a pair that does not read, or whose key is not
//! the certificate's, is moved aside (kept, with the time in its name, for whoever wants to
//! know what happened), a new pair is made, and the log says that clients must trust the new
//! certificate.

use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use opcua::crypto::{CertificateStore, PrivateKey};

/// The certificate, relative to the PKI folder (async-opcua's default).
pub(crate) const OWN_CERT: &str = "own/cert.der";
/// The private key, relative to the PKI folder (async-opcua's default).
pub(crate) const OWN_KEY: &str = "private/private.pem";

/// What the check found.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum OwnPair {
    /// Neither file: the server makes a pair.
    Absent,
    /// Both read, and the key is the certificate's.
    Sound,
    /// A damaged pair, moved aside: why, and where the files went.
    MovedAside {
        /// What was wrong.
        reason: String,
        /// The files as kept.
        kept: Vec<PathBuf>,
    },
}

/// Why a pair is not usable; `None` when it is.
fn damage(pki: &Path) -> Option<String> {
    let cert = match CertificateStore::read_cert(&pki.join(OWN_CERT)) {
        Ok(c) => c,
        Err(e) => return Some(format!("the certificate does not read ({e})")),
    };
    let key = match PrivateKey::read_pem_file(&pki.join(OWN_KEY)) {
        Ok(k) => k,
        Err(_) => return Some("the private key does not read".to_owned()),
    };
    // The certificate holds its public key's bits verbatim; the key's must be among them.
    let public = key
        .public_key_to_info()
        .map(|i| i.subject_public_key.raw_bytes().to_vec());
    let der = cert.to_der().unwrap_or_default();
    match public {
        Ok(bits) if !bits.is_empty() && der.windows(bits.len()).any(|w| w == bits) => None,
        _ => Some("the private key is not the certificate's".to_owned()),
    }
}

/// Checks the server's own pair in `pki`, moving a damaged one aside.
pub(crate) fn check_own_pair(pki: &Path) -> std::io::Result<OwnPair> {
    let files = [pki.join(OWN_CERT), pki.join(OWN_KEY)];
    if files.iter().all(|f| !f.exists()) {
        return Ok(OwnPair::Absent);
    }
    let Some(reason) = damage(pki) else {
        return Ok(OwnPair::Sound);
    };
    let stamp = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut kept = Vec::new();
    for f in files.iter().filter(|f| f.exists()) {
        let mut name = f.file_name().unwrap_or_default().to_os_string();
        name.push(format!(".damaged-{stamp}"));
        let to = f.with_file_name(name);
        std::fs::rename(f, &to)?;
        kept.push(to);
    }
    Ok(OwnPair::MovedAside { reason, kept })
}

/// The thumbprint (SHA-1, hex) of the certificate in `pki`, as clients show it; `None` when it
/// does not read.
pub(crate) fn thumbprint(pki: &Path) -> Option<String> {
    CertificateStore::read_cert(&pki.join(OWN_CERT))
        .ok()
        .map(|c| c.thumbprint().as_hex_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("softplc-pki-{name}-{}", std::process::id()));
        // Best effort: the test's scratch folder (it may not exist).
        drop(std::fs::remove_dir_all(&dir));
        std::fs::create_dir_all(dir.join("own")).unwrap();
        std::fs::create_dir_all(dir.join("private")).unwrap();
        dir
    }

    fn make_pair(pki: &Path) {
        let data = opcua::crypto::X509Data {
            key_size: 2048,
            common_name: "softplc test".into(),
            organization: "softplc".into(),
            organizational_unit: "test".into(),
            country: "FR".into(),
            state: "test".into(),
            alt_host_names: vec!["urn:softplc:test".into(), "localhost".into()].into(),
            certificate_duration_days: 30,
        };
        CertificateStore::create_certificate_and_key(
            &data,
            true,
            &pki.join(OWN_CERT),
            &pki.join(OWN_KEY),
        )
        .unwrap();
    }

    #[test]
    fn a_sound_pair_stays_and_a_torn_key_is_moved_aside() {
        let pki = folder("torn");
        assert_eq!(check_own_pair(&pki).unwrap(), OwnPair::Absent);
        make_pair(&pki);
        assert_eq!(check_own_pair(&pki).unwrap(), OwnPair::Sound);
        assert!(thumbprint(&pki).is_some_and(|t| t.len() == 40));

        // What a power cut at first start leaves: the key cut to 300 bytes.
        let key = std::fs::read(pki.join(OWN_KEY)).unwrap();
        std::fs::write(pki.join(OWN_KEY), &key[..300]).unwrap();
        let OwnPair::MovedAside { reason, kept } = check_own_pair(&pki).unwrap() else {
            panic!("a torn key is damage")
        };
        assert_eq!(reason, "the private key does not read");
        assert_eq!(kept.len(), 2);
        assert!(!pki.join(OWN_KEY).exists() && !pki.join(OWN_CERT).exists());
        assert_eq!(std::fs::read(&kept[1]).unwrap(), key[..300]);
    }

    #[test]
    fn a_key_of_another_pair_is_damage_too() {
        let pki = folder("mismatch");
        make_pair(&pki);
        let other = folder("mismatch-other");
        make_pair(&other);
        std::fs::copy(other.join(OWN_KEY), pki.join(OWN_KEY)).unwrap();
        let OwnPair::MovedAside { reason, .. } = check_own_pair(&pki).unwrap() else {
            panic!("a key of another pair is damage")
        };
        assert_eq!(reason, "the private key is not the certificate's");
    }
}
