//! The seal of a checkpoint's header and records: a plain SHA-256 that finds damage, or an
//! HMAC-SHA256 under a key derived from the job's lasting secret that also finds records
//! written without it (the module doc of [`super`], *Seals*).

use super::CHECK_LEN;
use hmac::{Hmac, Mac};
use sha2::{Digest, Sha256};

/// How the header and each record are checksummed: a plain SHA-256 (finds damage only), or an
/// HMAC-SHA256 under a key derived from the job's secret (also finds records written without
/// it).
#[derive(Clone, PartialEq, Eq)]
pub enum Seal {
    /// SHA-256: anyone who can write the file can seal a record.
    Plain,
    /// HMAC-SHA256 under this key.
    Keyed([u8; 32]),
}

impl std::fmt::Debug for Seal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Seal::Plain => write!(f, "Plain"),
            Seal::Keyed(_) => write!(f, "Keyed(<key>)"),
        }
    }
}

type HmacSha256 = Hmac<Sha256>;

impl Seal {
    /// The keyed seal of a job whose secret is `secret` (the master's token): the key is
    /// HMAC-SHA256(secret, a label), so the checkpoint's key is not the handshake's.
    pub fn from_secret(secret: &[u8]) -> Seal {
        let mut m =
            <HmacSha256 as Mac>::new_from_slice(secret).expect("HMAC takes a key of any length");
        m.update(b"parrt checkpoint records v1");
        Seal::Keyed(m.finalize().into_bytes().into())
    }

    pub(super) fn byte(&self) -> u8 {
        match self {
            Seal::Plain => 0,
            Seal::Keyed(_) => 1,
        }
    }

    /// The first [`CHECK_LEN`] bytes of the seal of `parts`, concatenated.
    pub(super) fn tag(&self, parts: &[&[u8]]) -> [u8; CHECK_LEN] {
        let mut out = [0u8; CHECK_LEN];
        match self {
            Seal::Plain => {
                let mut h = Sha256::new();
                for p in parts {
                    h.update(p);
                }
                out.copy_from_slice(&h.finalize()[..CHECK_LEN]);
            }
            Seal::Keyed(key) => {
                let mut m = <HmacSha256 as Mac>::new_from_slice(key)
                    .expect("HMAC takes a key of any length");
                for p in parts {
                    m.update(p);
                }
                out.copy_from_slice(&m.finalize().into_bytes()[..CHECK_LEN]);
            }
        }
        out
    }
}
