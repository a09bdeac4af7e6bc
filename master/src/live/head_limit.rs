//! The live view's limit on a request's head, exact: a head of more than
//! [`MAX_REQUEST_HEAD`] bytes gets 431, one of it or less is served. hyper's own bound (its
//! read buffer, [`RESPONSE_BUFFER`]) is loose — it is checked only after a read that did not
//! complete the head, so heads of up to about twice the buffer can still get through — and
//! stays behind this one as a backstop: every head this limit lets through fits hyper's
//! buffer whole, and every head hyper lets through is measured here.
//!
//! A head is measured as sent in its usual form: the request line (`METHOD target
//! HTTP/1.1`), each header line as `name: value`, each line ended by CRLF, and the blank line
//! that ends the head. Spaces a client adds around a header's value are not counted.

use super::limits::RESPONSE_BUFFER;
use axum::extract::Request;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};

/// The longest request head served, in bytes (measured as the module's doc says): half of
/// [`RESPONSE_BUFFER`], so that hyper always reads such a head whole, and far more than any
/// page, `curl` or browser sends (their heads are well under 8 KiB).
pub const MAX_REQUEST_HEAD: usize = RESPONSE_BUFFER / 2;

/// The length of `req`'s head in its usual form (see the module's doc).
pub fn head_len(req: &Request) -> usize {
    const CRLF: usize = 2;
    let target = req
        .uri()
        .path_and_query()
        .map_or(req.uri().path().len(), |p| p.as_str().len());
    let line = req.method().as_str().len() + 1 + target + 1 + "HTTP/1.1".len() + CRLF;
    let headers: usize = req
        .headers()
        .iter()
        .map(|(name, value)| name.as_str().len() + ": ".len() + value.len() + CRLF)
        .sum();
    line + headers + CRLF
}

/// 431 when `req`'s head is longer than [`MAX_REQUEST_HEAD`], else `None`.
pub fn too_large(req: &Request) -> Option<Response> {
    let len = head_len(req);
    (len > MAX_REQUEST_HEAD).then(|| {
        (
            StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
            format!(
                "431 request header fields too large: this request's head is {len} bytes, \
                 at most {MAX_REQUEST_HEAD} are served\n"
            ),
        )
            .into_response()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::{LiveState, LiveView};
    use std::io::{Read, Write};
    use std::net::TcpStream;
    use std::sync::Arc;

    /// A `GET /status` head of exactly `len` bytes for `host` (padded by one header), sent on
    /// a connection of its own; the response's status line.
    fn status_line_for_head_of(host: &str, len: usize) -> String {
        let bare = format!("GET /status HTTP/1.1\r\nhost: {host}\r\nconnection: close\r\n");
        let pad_line = "x-pad: \r\n".len();
        let fill = len - bare.len() - pad_line - 2;
        let head = format!("{bare}x-pad: {}\r\n\r\n", "a".repeat(fill));
        assert_eq!(head.len(), len);
        let mut s = TcpStream::connect(host).expect("connects");
        s.write_all(head.as_bytes()).expect("sends the head");
        let mut got = Vec::new();
        // The server answers and closes (`connection: close`); a reset after the answer is
        // fine, the answer having been read.
        let _ = s.read_to_end(&mut got);
        let text = String::from_utf8_lossy(&got);
        text.lines().next().unwrap_or("(nothing)").to_string()
    }

    /// The stated limit is the real one: a head of exactly [`MAX_REQUEST_HEAD`] bytes is
    /// served, one byte more gets 431.
    #[test]
    fn a_head_at_the_stated_limit_is_served_and_one_byte_more_gets_431() {
        let view = LiveView::start("127.0.0.1:0", Arc::new(LiveState::empty()), None, 1e6)
            .expect("serves on loopback");
        let host = view.local_addr().to_string();
        assert_eq!(status_line_for_head_of(&host, 200), "HTTP/1.1 200 OK");
        assert_eq!(
            status_line_for_head_of(&host, MAX_REQUEST_HEAD),
            "HTTP/1.1 200 OK"
        );
        assert_eq!(
            status_line_for_head_of(&host, MAX_REQUEST_HEAD + 1),
            "HTTP/1.1 431 Request Header Fields Too Large"
        );
        view.stop();
    }
}
