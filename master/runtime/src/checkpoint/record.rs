//! A checkpoint's records: one per accepted tile, each sealed and bound to its file's header,
//! encoded for appending and scanned back on resume (a bad record skipped, a torn tail cut).

use super::seal::Seal;
use super::{CHECK_LEN, HEADER_LEN, RECORD_FIXED};
use crate::scheduler::AcceptedTile;
use parrt_protocol::{Packing, PixelFormat, TilePixels};
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use std::io::Read;

/// Appends the record of `t`, sealed plain, for the checkpoint whose header is `header`, to
/// `out`.
pub fn encode_record(t: &AcceptedTile, header: &[u8], out: &mut Vec<u8>) {
    encode_sealed_record(t, &Seal::Plain, header, out);
}

/// Appends the record of `t`, sealed with `seal` and bound to the checkpoint whose header is
/// `header` (its job), to `out`.
pub fn encode_sealed_record(t: &AcceptedTile, seal: &Seal, header: &[u8], out: &mut Vec<u8>) {
    let len = (RECORD_FIXED + t.pixels.bytes.len()) as u32;
    let start = out.len();
    out.extend_from_slice(&len.to_le_bytes());
    encode_payload(t, out);
    let check = seal.tag(&[header, &out[start..]]);
    out.extend_from_slice(&check);
}

/// Appends the payload of `t`'s record to `out`: tile id, render seconds, the ray counters,
/// the pixels.
pub(super) fn encode_payload(t: &AcceptedTile, out: &mut Vec<u8>) {
    out.extend_from_slice(&t.tile_id.to_le_bytes());
    out.extend_from_slice(&t.seconds.to_bits().to_le_bytes());
    for v in RayStats::to_array(&t.stats) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&t.pixels.bytes);
}

/// Decodes a payload whose checksum held; `None` unless it names a tile of `tiles` with that
/// tile's pixel count in `format`.
pub(super) fn decode_payload(
    p: &[u8],
    tiles: &[Tile],
    format: PixelFormat,
) -> Option<AcceptedTile> {
    let fixed = p.get(..RECORD_FIXED)?;
    let tile_id = u32::from_le_bytes(fixed[..4].try_into().ok()?);
    let seconds = f64::from_bits(u64::from_le_bytes(fixed[4..12].try_into().ok()?));
    let mut v = [0u64; 11];
    for (i, c) in fixed[12..].chunks_exact(8).enumerate() {
        v[i] = u64::from_le_bytes(c.try_into().ok()?);
    }
    let tile = tiles.get(tile_id as usize)?;
    let bytes = &p[RECORD_FIXED..];
    if bytes.len() != tile.pixel_count().checked_mul(format.bytes_per_pixel())? {
        return None;
    }
    Some(AcceptedTile {
        frame: 0,
        tile_id,
        pixels: TilePixels {
            format,
            packing: Packing::Raw,
            bytes: bytes.to_vec(),
        },
        stats: RayStats::from_array(v),
        seconds,
    })
}

/// What reading a checkpoint's records found.
#[derive(Debug, Default)]
pub struct Scan {
    /// The good records, the first one of each tile, in file order.
    pub tiles: Vec<AcceptedTile>,
    /// Records skipped: a checksum that did not hold, or a tile that is not this job's.
    pub bad_records: usize,
    /// Bytes after the last good record that were cut off (a torn or unreadable tail, and
    /// any bad records at the end).
    pub cut_bytes: u64,
    /// Where the last good record ends: the file's new length.
    pub good_len: u64,
}

/// Reads the plainly sealed records after `header` from `r` (positioned just past it), for
/// a job of `tiles` whose pixels travel as `format`: [`scan_sealed_records`] with
/// [`Seal::Plain`].
pub fn scan_records(
    r: &mut impl Read,
    file_len: u64,
    tiles: &[Tile],
    format: PixelFormat,
    header: &[u8],
) -> std::io::Result<Scan> {
    scan_sealed_records(r, file_len, tiles, format, &Seal::Plain, header)
}

/// Reads the records after `header` from `r` (positioned just past it), for a job of `tiles`
/// whose pixels travel as `format`. Never trusts a record whose seal fails (damaged, written
/// without the key, or bound to another header: another job, frame or file); stops at a
/// length that cannot be (the framing is lost) or at a torn end.
pub fn scan_sealed_records(
    r: &mut impl Read,
    file_len: u64,
    tiles: &[Tile],
    format: PixelFormat,
    seal: &Seal,
    header: &[u8],
) -> std::io::Result<Scan> {
    let max_pixels = tiles.iter().map(|t| t.pixel_count()).max().unwrap_or(0);
    let max_payload = RECORD_FIXED + max_pixels * format.bytes_per_pixel();
    let mut seen = vec![false; tiles.len()];
    let mut scan = Scan::default();
    let mut pos = HEADER_LEN as u64;
    scan.good_len = pos;
    let mut buf = Vec::new();
    let len_ok = |n: usize| (RECORD_FIXED..=max_payload).contains(&n);
    loop {
        let n = match read_sealed(r, &mut buf, len_ok, seal, header)? {
            Sealed::End => break,
            Sealed::Torn(n) => {
                if crate::mutation::is(crate::mutation::Mutation::TrustTornRecord) {
                    if let Some(t) = decode_payload(&buf[..n], tiles, format) {
                        if !std::mem::replace(&mut seen[t.tile_id as usize], true) {
                            scan.tiles.push(t);
                        }
                    }
                }
                break;
            }
            Sealed::Forged(n) => {
                pos += (4 + n + CHECK_LEN) as u64;
                scan.bad_records += 1;
                continue;
            }
            Sealed::Good(n) => n,
        };
        pos += (4 + n + CHECK_LEN) as u64;
        match decode_payload(&buf[..n], tiles, format) {
            None => scan.bad_records += 1,
            Some(t) => {
                let first = !std::mem::replace(&mut seen[t.tile_id as usize], true);
                if first {
                    scan.tiles.push(t);
                }
                scan.good_len = pos;
            }
        }
    }
    scan.cut_bytes = file_len.saturating_sub(scan.good_len);
    Ok(scan)
}

/// The next record of a checkpoint as [`read_sealed`] read it (`n`: its payload's length).
pub(super) enum Sealed {
    /// The end of the file, a torn length, or a length no record of the file can have (the
    /// framing is lost): nothing after it can be trusted.
    End,
    /// A length, then fewer bytes than it says: the payload as far as it was read.
    Torn(usize),
    /// A whole record whose seal fails.
    Forged(usize),
    /// A whole record whose seal holds: its payload is the buffer's first `n` bytes.
    Good(usize),
}

/// Reads the next record (its length, payload and check) from `r` into `buf`, and checks its
/// seal against `seal` and the file's `header`; a length `len_ok` refuses ends the reading.
pub(super) fn read_sealed(
    r: &mut impl Read,
    buf: &mut Vec<u8>,
    len_ok: impl Fn(usize) -> bool,
    seal: &Seal,
    header: &[u8],
) -> std::io::Result<Sealed> {
    let mut len = [0u8; 4];
    if !read_full(r, &mut len)? {
        return Ok(Sealed::End);
    }
    let n = u32::from_le_bytes(len) as usize;
    if !len_ok(n) {
        return Ok(Sealed::End);
    }
    buf.resize(n + CHECK_LEN, 0);
    if !read_full(r, buf)? {
        return Ok(Sealed::Torn(n));
    }
    let (payload, check) = buf.split_at(n);
    if seal.tag(&[header, &len, payload])[..] != check[..] {
        return Ok(Sealed::Forged(n));
    }
    Ok(Sealed::Good(n))
}

/// Fills `buf` from `r`: `false` if the input ended first (having read any part of it).
pub(super) fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => return Ok(false),
            Ok(k) => got += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}
