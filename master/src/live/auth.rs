//! Who may see the live view: on a loopback address, anyone who can reach it (only this
//! machine's users); on any other, only a request carrying the token, as
//! `Authorization: Bearer TOKEN` or the `token` URL parameter. Everything else gets 401 and
//! nothing else.
//!
//! The query is parsed as a form (`form_urlencoded`), the page's address encodes the token with
//! `percent-encoding`, and tokens are compared in constant time (`subtle`).

use percent_encoding::{AsciiSet, NON_ALPHANUMERIC};
use std::net::SocketAddr;
use subtle::ConstantTimeEq;

/// What a token's bytes are percent-encoded as in the page's address: all but RFC 3986's
/// unreserved characters.
const NOT_UNRESERVED: &AsciiSet = &NON_ALPHANUMERIC
    .remove(b'-')
    .remove(b'.')
    .remove(b'_')
    .remove(b'~');

/// Whether serving on `addr` needs the token.
pub fn needs_token(addr: &SocketAddr) -> bool {
    !addr.ip().is_loopback()
}

/// Whether a request with this `Authorization` header value and URL query may be served,
/// given the token (`None`: none is needed).
pub fn allowed(token: Option<&[u8]>, authorization: Option<&[u8]>, query: Option<&str>) -> bool {
    let Some(token) = token else {
        return true;
    };
    let bearer = authorization
        .and_then(|h| h.strip_prefix(b"Bearer "))
        .is_some_and(|t| same(t, token));
    bearer || query.is_some_and(|q| query_token(q).is_some_and(|t| same(&t, token)))
}

/// The decoded value of the first `token` parameter of a query string (form encoding: `%XX`
/// is a byte, `+` a space; a `%` without two hex digits stays as it is).
pub fn query_token(query: &str) -> Option<Vec<u8>> {
    form_urlencoded::parse(query.as_bytes())
        .find(|(k, _)| k == "token")
        .map(|(_, v)| v.into_owned().into_bytes())
}

/// `token` as the value of a URL's `token` parameter, which [`query_token`] decodes back.
pub fn encode_token(token: &[u8]) -> String {
    percent_encoding::percent_encode(token, NOT_UNRESERVED).to_string()
}

/// Equality in time independent of where the bytes differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.ct_eq(b).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_is_open_and_other_addresses_need_the_token() {
        assert!(!needs_token(&"127.0.0.1:80".parse().expect("addr")));
        assert!(!needs_token(&"[::1]:80".parse().expect("addr")));
        assert!(needs_token(&"0.0.0.0:80".parse().expect("addr")));
        assert!(needs_token(&"192.168.1.2:80".parse().expect("addr")));
    }

    #[test]
    fn the_token_must_match_as_bearer_or_parameter() {
        let t = Some(&b"s3cret"[..]);
        assert!(allowed(None, None, None));
        assert!(!allowed(t, None, None));
        assert!(!allowed(t, Some(b"Bearer wrong"), Some("token=nope")));
        assert!(!allowed(t, Some(b"s3cret"), None));
        assert!(!allowed(t, Some(b"Bearer s3cre"), None));
        assert!(allowed(t, Some(b"Bearer s3cret"), None));
        assert!(allowed(t, None, Some("a=1&token=s3cret")));
        assert!(allowed(Some(b"a b/c"), None, Some("token=a%20b%2Fc")));
        assert!(!allowed(t, None, Some("token=%")));
        assert!(allowed(Some(b"a b"), None, Some("token=a+b")));
        assert!(allowed(Some(b"%4"), None, Some("x=%26&token=%4")));
    }

    #[test]
    fn the_address_carries_a_token_the_query_gives_back() {
        assert_eq!(encode_token(b"0123abcXYZ-._~"), "0123abcXYZ-._~");
        assert_eq!(encode_token(b"a b/c&d=\xc3\xa9"), "a%20b%2Fc%26d%3D%C3%A9");
        for t in ["s3cret", "a b+c/d?e&f=g%h", "\u{e9}t\u{e9}"] {
            let q = format!("a=1&token={}", encode_token(t.as_bytes()));
            assert_eq!(query_token(&q).as_deref(), Some(t.as_bytes()), "{q}");
        }
    }
}
