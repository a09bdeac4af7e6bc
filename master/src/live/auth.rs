//! Who may see the live view: on a loopback address, anyone who can reach it (only this
//! machine's users) through a `Host` that names it (so a web page whose name was rebound to
//! 127.0.0.1 cannot read it); on any other, only a request carrying the view key, as
//! `Authorization: Bearer KEY` or the `key` URL parameter. The view key is not the workers'
//! token but derived from it one way ([`view_key`]): whoever holds the key can watch, not
//! join or feed the render. Everything else gets 401 (421 for a wrong `Host`) and nothing else.
//!
//! The query is parsed as a form (`form_urlencoded`), the page's address encodes the key with
//! `percent-encoding`, and keys are compared in constant time (`subtle`).

use hmac::{Hmac, Mac};
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

/// What the HMAC that derives the view key says it is for.
const VIEW_KEY_CONTEXT: &[u8] = b"parrt live view";

/// The live view's key for one run (`run`: random bytes drawn when the view starts) of a
/// render whose workers' token is `token`: HMAC-SHA256 keyed by the token over
/// "parrt live view" and `run`, in lower-case hex (64 characters). One way: the key does not
/// give the token back, so a page's address (in a browser's history, a proxy's log) cannot
/// let a worker in; and bound to the run, so an address left behind (a key file a killed
/// master could not remove) opens no later view, even of the same token.
pub fn view_key(token: &[u8], run: &[u8]) -> String {
    // HMAC takes a key of any length: `new_from_slice` cannot fail for it.
    let Ok(mut mac) = Hmac::<sha2::Sha256>::new_from_slice(token) else {
        unreachable!("HMAC accepts keys of every length")
    };
    mac.update(VIEW_KEY_CONTEXT);
    mac.update(run);
    mac.finalize()
        .into_bytes()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Whether a request with this `Authorization` header value and URL query may be served,
/// given the view key (`None`: none is needed).
pub fn allowed(key: Option<&[u8]>, authorization: Option<&[u8]>, query: Option<&str>) -> bool {
    let Some(key) = key else {
        return true;
    };
    let bearer = authorization
        .and_then(|h| h.strip_prefix(b"Bearer "))
        .is_some_and(|t| same(t, key));
    bearer || query.is_some_and(|q| query_key(q).is_some_and(|t| same(&t, key)))
}

/// The decoded value of the first `key` parameter of a query string (form encoding: `%XX`
/// is a byte, `+` a space; a `%` without two hex digits stays as it is).
pub fn query_key(query: &str) -> Option<Vec<u8>> {
    form_urlencoded::parse(query.as_bytes())
        .find(|(k, _)| k == "key")
        .map(|(_, v)| v.into_owned().into_bytes())
}

/// `key` as the value of a URL's `key` parameter, which [`query_key`] decodes back.
pub fn encode_key(key: &[u8]) -> String {
    percent_encoding::percent_encode(key, NOT_UNRESERVED).to_string()
}

/// The `Host` values a view bound at `bound` answers to: for a loopback address, `localhost`
/// and the address itself, each with the bound port (`None` for any other address, which needs
/// the key: the name a browser elsewhere uses for this machine cannot be known here, and a
/// rebound page does not hold the key).
pub fn hosts(bound: &SocketAddr) -> Option<Vec<String>> {
    if needs_token(bound) {
        return None;
    }
    let port = bound.port();
    let ip = match bound.ip() {
        std::net::IpAddr::V6(ip) => format!("[{ip}]"),
        ip => ip.to_string(),
    };
    Some(vec![format!("localhost:{port}"), format!("{ip}:{port}")])
}

/// Whether a request's `Host` header is one of `hosts` (ASCII case ignored); with no list,
/// any.
pub fn host_allowed(hosts: Option<&[String]>, host: Option<&[u8]>) -> bool {
    let Some(hosts) = hosts else {
        return true;
    };
    host.is_some_and(|h| hosts.iter().any(|a| a.as_bytes().eq_ignore_ascii_case(h)))
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
        assert!(!allowed(t, Some(b"Bearer wrong"), Some("key=nope")));
        assert!(!allowed(t, Some(b"s3cret"), None));
        assert!(!allowed(t, Some(b"Bearer s3cre"), None));
        assert!(allowed(t, Some(b"Bearer s3cret"), None));
        assert!(allowed(t, None, Some("a=1&key=s3cret")));
        assert!(allowed(Some(b"a b/c"), None, Some("key=a%20b%2Fc")));
        assert!(!allowed(t, None, Some("key=%")));
        assert!(allowed(Some(b"a b"), None, Some("key=a+b")));
        assert!(allowed(Some(b"%4"), None, Some("x=%26&key=%4")));
    }

    #[test]
    fn the_view_key_is_derived_one_way_and_is_not_the_token() {
        let k = view_key(b"s3cret", b"run 1");
        assert_eq!(k.len(), 64);
        assert!(k
            .bytes()
            .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase()));
        assert_ne!(
            k,
            view_key(b"s3cres", b"run 1"),
            "another token, another key"
        );
        assert_ne!(k, view_key(b"s3cret", b"run 2"), "another run, another key");
        assert!(!k.contains("s3cret"));
        assert!(allowed(Some(k.as_bytes()), None, Some(&format!("key={k}"))));
        assert!(!allowed(
            Some(k.as_bytes()),
            Some(b"Bearer s3cret"),
            Some("key=s3cret")
        ));
    }

    #[test]
    fn a_loopback_view_answers_only_to_its_own_names() {
        let h = hosts(&"127.0.0.1:8080".parse().expect("addr"));
        let h = h.as_deref();
        for ok in ["localhost:8080", "127.0.0.1:8080", "LocalHost:8080"] {
            assert!(host_allowed(h, Some(ok.as_bytes())), "{ok}");
        }
        for bad in [
            "evil.example:8080",
            "localhost",
            "127.0.0.1",
            "localhost:8081",
            "localhost.:8080",
            "127.0.0.1:8080.evil.example",
            "",
        ] {
            assert!(!host_allowed(h, Some(bad.as_bytes())), "{bad}");
        }
        assert!(!host_allowed(h, None), "no Host");
        let v6 = hosts(&"[::1]:9".parse().expect("addr"));
        assert!(host_allowed(v6.as_deref(), Some(b"[::1]:9")));
        assert!(hosts(&"0.0.0.0:9".parse().expect("addr")).is_none());
        assert!(host_allowed(None, Some(b"anything")));
    }

    #[test]
    fn the_address_carries_a_token_the_query_gives_back() {
        assert_eq!(encode_key(b"0123abcXYZ-._~"), "0123abcXYZ-._~");
        assert_eq!(encode_key(b"a b/c&d=\xc3\xa9"), "a%20b%2Fc%26d%3D%C3%A9");
        for t in ["s3cret", "a b+c/d?e&f=g%h", "\u{e9}t\u{e9}"] {
            let q = format!("a=1&key={}", encode_key(t.as_bytes()));
            assert_eq!(query_key(&q).as_deref(), Some(t.as_bytes()), "{q}");
        }
    }
}
