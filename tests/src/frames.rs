//! RTU frames built by hand, with a CRC computed here rather than by the codec under test.

/// CRC-16/MODBUS (polynomial 0xA001 reflected, initial 0xFFFF), bit by bit as the Modbus
/// over Serial Line specification (6.2.2) describes it.
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
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

/// `body` followed by its CRC, low byte first.
pub fn rtu(body: &[u8]) -> Vec<u8> {
    let crc = crc16(body);
    let mut f = body.to_vec();
    f.extend_from_slice(&crc.to_le_bytes());
    f
}

/// The MiniMod's reply to its per-cycle FC 2 read of discrete inputs 0..=9 (10001..10010):
/// `unit 02 02 b0 b1` + CRC, where `b0` holds X1..X3 in bits 0..2 and `b1` holds X9/X10
/// (FB1/FB2) in bits 0..1.
pub fn minimod_inputs_reply(unit: u8, x: [bool; 3], fb: [bool; 2]) -> Vec<u8> {
    let b0 = x
        .iter()
        .enumerate()
        .fold(0u8, |acc, (i, &on)| acc | (u8::from(on) << i));
    let b1 = u8::from(fb[0]) | (u8::from(fb[1]) << 1);
    rtu(&[unit, 0x02, 0x02, b0, b1])
}

/// An exception reply: `unit, function | 0x80, code` + CRC.
pub fn exception(unit: u8, function: u8, code: u8) -> Vec<u8> {
    rtu(&[unit, function | 0x80, code])
}

/// Hex bytes as `05 02 00 ...`, for messages.
pub fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_of_the_manual_fc2_read() {
        // FC 2 read of discrete inputs 0..=9 of unit 5: `05 02 00 00 00 0A F9 89`.
        assert_eq!(
            rtu(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]),
            [0x05, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89]
        );
        // The specification's example: `02 07` has CRC 0x1241 (sent `41 12`).
        assert_eq!(crc16(&[0x02, 0x07]), 0x1241);
    }
}
