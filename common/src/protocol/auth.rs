//! Authentication: HMAC-SHA256 of the master's nonce keyed with the shared token. The token is
//! never sent; a MAC is checked in constant time. This proves a worker knows the token; it does
//! not encrypt anything (see docs/distributed.md).

use hmac::{Hmac, Mac};
use sha2::Sha256;
use std::fmt;
use thiserror::Error;

type HmacSha256 = Hmac<Sha256>;

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

    fn mac(&self) -> HmacSha256 {
        // HMAC accepts keys of any length; this cannot fail.
        <HmacSha256 as Mac>::new_from_slice(&self.0).expect("HMAC takes any key length")
    }

    /// The MAC a worker sends for `nonce`.
    pub fn sign(&self, nonce: &[u8]) -> Vec<u8> {
        let mut m = self.mac();
        m.update(nonce);
        m.finalize().into_bytes().to_vec()
    }

    /// Whether `mac` is the right MAC of `nonce` (constant-time comparison).
    pub fn verify(&self, nonce: &[u8], mac: &[u8]) -> bool {
        let mut m = self.mac();
        m.update(nonce);
        m.verify_slice(mac).is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_verifies_and_wrong_token_or_nonce_fails() {
        let t = Token::new("secret\n").unwrap();
        let nonce = [7u8; 32];
        let mac = t.sign(&nonce);
        assert_eq!(mac.len(), 32);
        assert!(t.verify(&nonce, &mac));
        assert!(!Token::new("Secret").unwrap().verify(&nonce, &mac));
        assert!(!t.verify(&[8u8; 32], &mac));
        assert!(!t.verify(&nonce, &mac[..31]));
        assert!(!t.verify(&nonce, &[]));
    }

    #[test]
    fn empty_token_is_an_error_and_debug_hides_it() {
        assert_eq!(Token::new(" \n"), Err(AuthError::Empty));
        let t = Token::new("hunter2").unwrap();
        assert!(!format!("{t:?}").contains("hunter2"));
    }
}
