//! Mutual authentication with the shared token: each side sends a fresh nonce, and each proves
//! it knows the token with an HMAC-SHA256 over both nonces, keyed with the token. The master
//! proves first ([`Token::master_proof`] = HMAC(token, "parrt master proof" ‖ worker nonce ‖
//! master nonce)); the worker answers only after checking it ([`Token::worker_proof`] =
//! HMAC(token, "parrt worker proof" ‖ master nonce ‖ worker nonce)). The labels separate the
//! two roles, so one MAC can never stand for the other, and both nonces bind each MAC to this
//! one conversation. The token is never sent; MACs are checked in constant time. Nothing is
//! encrypted (see docs/distributed.md for what this does not stop).

use super::message::NONCE_LEN;
use hmac::{Hmac, Mac};
use sha2::Sha256;
use std::fmt;
use thiserror::Error;

type HmacSha256 = Hmac<Sha256>;

/// Bytes of a MAC (HMAC-SHA256).
pub const MAC_LEN: usize = 32;

/// Domain-separation label of the master's proof.
const MASTER_LABEL: &[u8] = b"parrt master proof\0";
/// Domain-separation label of the worker's proof (same length as the master's).
const WORKER_LABEL: &[u8] = b"parrt worker proof\0";

/// Errors making a token.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum AuthError {
    /// The token is empty (after trimming a token file's trailing newline).
    #[error("the token is empty")]
    Empty,
}

/// The shared secret. Its `Debug` output never shows the secret.
#[derive(Clone, PartialEq, Eq)]
pub struct Token(Vec<u8>);

impl fmt::Debug for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Token(<{} bytes>)", self.0.len())
    }
}

impl Token {
    /// A token from its text; surrounding whitespace (a file's newline) is dropped.
    pub fn new(text: &str) -> Result<Self, AuthError> {
        let t = text.trim();
        if t.is_empty() {
            return Err(AuthError::Empty);
        }
        Ok(Token(t.as_bytes().to_vec()))
    }

    /// The token's text bytes (to hand to a child process through its environment).
    pub fn as_bytes(&self) -> &[u8] {
        &self.0
    }

    fn mac(&self, label: &[u8], first: &[u8], second: &[u8]) -> HmacSha256 {
        // HMAC accepts keys of any length; this cannot fail.
        let mut m =
            <HmacSha256 as Mac>::new_from_slice(&self.0).expect("HMAC takes any key length");
        m.update(label);
        m.update(first);
        m.update(second);
        m
    }

    /// The master's proof for a conversation: sent in the Challenge, checked by the worker.
    pub fn master_proof(
        &self,
        worker_nonce: &[u8; NONCE_LEN],
        master_nonce: &[u8; NONCE_LEN],
    ) -> [u8; MAC_LEN] {
        self.mac(MASTER_LABEL, worker_nonce, master_nonce)
            .finalize()
            .into_bytes()
            .into()
    }

    /// Whether `mac` is the master's proof for these nonces (constant-time comparison).
    pub fn verify_master_proof(
        &self,
        worker_nonce: &[u8; NONCE_LEN],
        master_nonce: &[u8; NONCE_LEN],
        mac: &[u8],
    ) -> bool {
        self.mac(MASTER_LABEL, worker_nonce, master_nonce)
            .verify_slice(mac)
            .is_ok()
    }

    /// The worker's proof for a conversation: sent in Auth, checked by the master.
    pub fn worker_proof(
        &self,
        master_nonce: &[u8; NONCE_LEN],
        worker_nonce: &[u8; NONCE_LEN],
    ) -> Vec<u8> {
        self.mac(WORKER_LABEL, master_nonce, worker_nonce)
            .finalize()
            .into_bytes()
            .to_vec()
    }

    /// Whether `mac` is the worker's proof for these nonces (constant-time comparison).
    pub fn verify_worker_proof(
        &self,
        master_nonce: &[u8; NONCE_LEN],
        worker_nonce: &[u8; NONCE_LEN],
        mac: &[u8],
    ) -> bool {
        self.mac(WORKER_LABEL, master_nonce, worker_nonce)
            .verify_slice(mac)
            .is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proofs_verify_and_wrong_token_nonce_or_role_fails() {
        let t = Token::new("secret\n").unwrap();
        let (w, m) = ([7u8; NONCE_LEN], [9u8; NONCE_LEN]);
        let mp = t.master_proof(&w, &m);
        let wp = t.worker_proof(&m, &w);
        assert_eq!(wp.len(), MAC_LEN);
        assert!(t.verify_master_proof(&w, &m, &mp));
        assert!(t.verify_worker_proof(&m, &w, &wp));
        // One role's MAC never stands for the other's, even with the nonces swapped.
        assert!(!t.verify_worker_proof(&m, &w, &mp));
        assert!(!t.verify_worker_proof(&w, &m, &mp));
        assert!(!t.verify_master_proof(&w, &m, &wp));
        assert!(!t.verify_master_proof(&m, &w, &wp));
        assert!(!Token::new("Secret")
            .unwrap()
            .verify_worker_proof(&m, &w, &wp));
        assert!(!t.verify_worker_proof(&[8u8; NONCE_LEN], &w, &wp));
        assert!(!t.verify_worker_proof(&m, &[8u8; NONCE_LEN], &wp));
        assert!(!t.verify_worker_proof(&m, &w, &wp[..31]));
        assert!(!t.verify_worker_proof(&m, &w, &[]));
    }

    #[test]
    fn empty_token_is_an_error_and_debug_hides_it() {
        assert_eq!(Token::new(" \n"), Err(AuthError::Empty));
        let t = Token::new("hunter2").unwrap();
        assert!(!format!("{t:?}").contains("hunter2"));
    }
}
