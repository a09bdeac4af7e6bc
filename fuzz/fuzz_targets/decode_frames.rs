//! Fuzz target: the wire decoder on arbitrary bytes — frames cut anywhere, lengths of any size —
//! must yield messages or a clean error, never panic or allocate past its frame limit, and every
//! message it decodes must encode and decode back to the same bytes.
#![no_main]

use bytes::BytesMut;
use libfuzzer_sys::fuzz_target;
use parrt_protocol::codec::{decode_payload, encode_payload};
use parrt_protocol::MessageCodec;
use tokio_util::codec::Decoder;

fuzz_target!(|data: &[u8]| {
    // The first byte picks where the stream is split, like bytes arriving in two reads.
    let Some((&cut, rest)) = data.split_first() else {
        return;
    };
    let cut = (cut as usize).min(rest.len());
    let mut codec = MessageCodec::new(64 * 1024);
    let mut buf = BytesMut::from(&rest[..cut]);
    let mut feed = Some(&rest[cut..]);
    loop {
        match codec.decode(&mut buf) {
            Ok(Some(msg)) => {
                // Compared as bytes: a decoded message may hold NaNs, which `==` never equates.
                let bytes = encode_payload(&msg).expect("a decoded message encodes");
                let again = decode_payload(&bytes).expect("its encoding decodes");
                assert_eq!(encode_payload(&again).expect("and encodes again"), bytes);
            }
            Ok(None) => match feed.take() {
                Some(more) => buf.extend_from_slice(more),
                None => break,
            },
            Err(_) => break,
        }
    }
    // The payload decoder alone, on the raw bytes.
    let _ = decode_payload(data);
});
