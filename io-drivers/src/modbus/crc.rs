//! CRC-16/MODBUS: polynomial 0x8005 reflected (0xA001), initial value 0xFFFF, no final XOR.
//!
//! On the wire the CRC follows the frame low byte first (Modbus over Serial Line v1.02,
//! §2.5.1.2). Check value: `crc16(b"123456789") == 0x4B37`.

/// The reflected polynomial.
const POLY: u16 = 0xA001;

/// One entry per byte value: the CRC register after shifting that byte through 8 rounds.
const TABLE: [u16; 256] = build_table();

const fn build_table() -> [u16; 256] {
    let mut table = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = i as u16;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ POLY
            } else {
                crc >> 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

/// The CRC-16/MODBUS of `bytes` (as a number; the wire order is low byte first).
pub(crate) fn crc16(bytes: &[u8]) -> u16 {
    bytes.iter().fold(0xFFFF_u16, |crc, &b| {
        // `(crc ^ b) & 0xFF` is at most 255, so the index is always in the table.
        let idx = usize::from((crc ^ u16::from(b)) & 0x00FF);
        (crc >> 8) ^ TABLE[idx]
    })
}

/// Appends the CRC of `frame` to it, low byte first, as on the wire.
pub fn append_crc(frame: &mut Vec<u8>) {
    let crc = crc16(frame);
    frame.extend_from_slice(&crc.to_le_bytes());
}

/// The CRC carried in the last two bytes of `frame` (low byte first), and the CRC computed
/// over the bytes before them: `(computed, carried)`. `None` if `frame` is shorter than 2.
pub(crate) fn split_crc(frame: &[u8]) -> Option<(u16, u16)> {
    let split = frame.len().checked_sub(2)?;
    let (body, tail) = frame.split_at(split);
    match tail {
        [lo, hi] => Some((crc16(body), u16::from_le_bytes([*lo, *hi]))),
        _ => None,
    }
}

/// Whether `frame`, ending with its two CRC bytes, is intact. A frame shorter than 3 bytes
/// (no content) is never intact.
pub fn check_crc(frame: &[u8]) -> bool {
    frame.len() > 2 && matches!(split_crc(frame), Some((computed, carried)) if computed == carried)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bitwise reference, independent of the table.
    fn crc16_bitwise(bytes: &[u8]) -> u16 {
        let mut crc = 0xFFFF_u16;
        for &b in bytes {
            crc ^= u16::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xA001
                } else {
                    crc >> 1
                };
            }
        }
        crc
    }

    fn with_crc(body: &[u8]) -> Vec<u8> {
        let mut v = body.to_vec();
        append_crc(&mut v);
        v
    }

    #[test]
    fn check_value() {
        assert_eq!(crc16(b"123456789"), 0x4B37);
        assert_eq!(crc16(&[]), 0xFFFF);
    }

    #[test]
    fn known_vectors_wire_order() {
        let cases: [(&[u8], [u8; 2]); 6] = [
            (&[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03], [0x76, 0x87]),
            (&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A], [0xC5, 0xCD]),
            (&[0x01, 0x05, 0x00, 0xAC, 0xFF, 0x00], [0x4C, 0x1B]),
            (&[0x01, 0x01, 0x00, 0x00, 0x00, 0x01], [0xFD, 0xCA]),
            (&[0x00, 0x46, 0x01, 0x10, 0x00, 0x00], [0x89, 0xED]),
            (&[0x04, 0x46, 0x05, 0x02, 0x00, 0x05, 0x00], [0x9E, 0x8E]),
        ];
        for (body, crc) in cases {
            let frame = with_crc(body);
            assert_eq!(frame.get(body.len()..), Some(&crc[..]), "{body:02X?}");
            assert!(check_crc(&frame));
        }
    }

    #[test]
    fn table_matches_bitwise_reference() {
        for b in 0..=255u8 {
            assert_eq!(crc16(&[b]), crc16_bitwise(&[b]));
        }
        // A pseudo-random stream of lengths 0..300.
        let mut x = 0x1234_5678_u32;
        let mut data = Vec::new();
        for _ in 0..300 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            data.push(x.to_le_bytes()[0]);
            assert_eq!(crc16(&data), crc16_bitwise(&data));
        }
    }

    #[test]
    fn corruption_detected() {
        let frame = with_crc(&[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03]);
        for i in 0..frame.len() {
            for bit in 0..8 {
                let mut bad = frame.clone();
                if let Some(b) = bad.get_mut(i) {
                    *b ^= 1 << bit;
                }
                assert!(!check_crc(&bad), "flip byte {i} bit {bit}");
            }
        }
    }

    #[test]
    fn short_frames_never_pass() {
        assert!(!check_crc(&[]));
        assert!(!check_crc(&[0xFF]));
        // The CRC of nothing is 0xFFFF, but a frame with no content is not a frame.
        assert!(!check_crc(&[0xFF, 0xFF]));
        assert_eq!(split_crc(&[0x01]), None);
        assert_eq!(split_crc(&[0xFF, 0xFF]), Some((0xFFFF, 0xFFFF)));
    }
}
