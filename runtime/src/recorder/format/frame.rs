//! Blocks framed with their length and CRC-32C, and the segment preamble.

use super::{BlockKind, FRAME, MAGIC, MAX_BLOCK, VERSION};

/// CRC-32C (Castagnoli), the checksum of every block.
pub(super) const CASTAGNOLI: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// A framed block: length, CRC-32C, kind, payload.
pub fn frame(kind: BlockKind, payload: &[u8]) -> Vec<u8> {
    let mut body = Vec::with_capacity(payload.len() + 1);
    body.push(kind as u8);
    body.extend_from_slice(payload);
    let mut out = Vec::with_capacity(body.len() + FRAME);
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&CASTAGNOLI.checksum(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// The preamble of a segment.
pub fn preamble() -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&VERSION.to_le_bytes());
    out
}

/// What [`next_block`] found at an offset.
#[derive(Debug, PartialEq, Eq)]
pub enum Framed<'a> {
    /// A whole block with a good CRC, and the offset after it.
    Block(BlockKind, &'a [u8], usize),
    /// The end of the bytes, exactly at a block boundary.
    Eof,
    /// A block cut short or damaged: the torn tail.
    Torn,
}

/// The block at `at` in `bytes`.
pub fn next_block(bytes: &[u8], at: usize) -> Framed<'_> {
    if at == bytes.len() {
        return Framed::Eof;
    }
    let Some(head) = bytes.get(at..at + FRAME) else {
        return Framed::Torn;
    };
    let len = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if len == 0 || len > MAX_BLOCK {
        return Framed::Torn;
    }
    let Some(body) = bytes.get(at + FRAME..at + FRAME + len) else {
        return Framed::Torn;
    };
    if CASTAGNOLI.checksum(body) != crc {
        return Framed::Torn;
    }
    match BlockKind::from_u8(body[0]) {
        Some(kind) => Framed::Block(kind, &body[1..], at + FRAME + len),
        None => Framed::Torn,
    }
}
