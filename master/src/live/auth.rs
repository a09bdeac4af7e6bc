//! Who may see the live view: on a loopback address, anyone who can reach it (only this
//! machine's users); on any other, only a request carrying the token, as
//! `Authorization: Bearer TOKEN` or the `token` URL parameter. Everything else gets 401 and
//! nothing else.

use std::net::SocketAddr;

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

/// The decoded value of the first `token=` parameter of a query string.
pub fn query_token(query: &str) -> Option<Vec<u8>> {
    query
        .split('&')
        .find_map(|kv| kv.strip_prefix("token="))
        .map(percent_decode)
}

fn percent_decode(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match b[i] {
            b'%' if i + 2 < b.len() => match (hex(b[i + 1]), hex(b[i + 2])) {
                (Some(h), Some(l)) => {
                    out.push((h * 16 + l) as u8);
                    i += 3;
                    continue;
                }
                _ => out.push(b'%'),
            },
            b'+' => out.push(b' '),
            c => out.push(c),
        }
        i += 1;
    }
    out
}

/// Equality in time independent of where the bytes differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
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
    }
}
