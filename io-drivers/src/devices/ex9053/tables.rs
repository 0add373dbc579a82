//! The manual's configuration tables (§1.10) and the module's fixed identity, shared by both
//! protocols, the driver and the simulator.

/// Input channels DI0..DI15 (§1, "16 non-isolated digital input channels").
pub(crate) const CHANNELS: usize = 16;

/// TT, the module's only type code: "40 for DIO module" (§2.1, §2.4).
pub const TYPE_DIO: u8 = 0x40;

/// §1.10 "Baud Rate Setting (CC)": code → bits per second.
pub const BAUD_CODES: [(u8, u32); 8] = [
    (0x03, 1200),
    (0x04, 2400),
    (0x05, 4800),
    (0x06, 9600),
    (0x07, 19200),
    (0x08, 38400),
    (0x09, 57600),
    (0x0A, 115_200),
];

/// The baud rate of a CC code (§1.10), `None` outside 03..0A.
pub fn baud_of_code(code: u8) -> Option<u32> {
    BAUD_CODES.iter().find(|(c, _)| *c == code).map(|(_, b)| *b)
}

/// The CC code of a baud rate (§1.10), `None` for a rate the module does not have.
pub fn code_of_baud(baud: u32) -> Option<u8> {
    BAUD_CODES.iter().find(|(_, b)| *b == baud).map(|(c, _)| *c)
}

/// The character format of a DCON line: 8 data bits, no parity, 1 stop bit. §1.10 sets only
/// the baud (CC) and FF's checksum and counter bits; no parity or stop bits are settable.
pub const LINE_FORMAT: crate::line::settings::SerialFormat = crate::line::settings::SerialFormat {
    data_bits: 8,
    parity: crate::line::settings::Parity::None,
    stop_bits: 1,
};

/// FF bit 7, "Counter Update Direction": 1 = rising edge, 0 = falling edge (§1.10).
pub(crate) const FF_RISING_EDGE: u8 = 0x80;

/// FF bit 6, "Checksum Bit": 1 = enabled (§1.10).
pub const FF_CHECKSUM: u8 = 0x40;

/// Factory address, "Module Address: 01" (§1.3).
pub(crate) const DEFAULT_ADDRESS: u8 = 0x01;

/// Factory baud code, 9600 Bd (§1.3).
pub(crate) const DEFAULT_BAUD_CODE: u8 = 0x06;

/// Factory data format: the manual gives none; `00` (falling edge, no checksum) is what its
/// `$012` example reads (§2.4, `!01400600`).
pub(crate) const DEFAULT_FORMAT: u8 = 0x00;

/// INIT* mode address (§1.4: "Address=00, Baudrate=9600bps, no Checksum").
pub const INIT_ADDRESS: u8 = 0x00;

/// INIT* mode baud code, 9600 Bd (§1.4).
pub const INIT_BAUD_CODE: u8 = 0x06;

/// What `$AAF` answers (§2.8 example `!01D04.03`).
pub(crate) const FIRMWARE: &str = "D04.03";

/// The module name at the factory (§2.9 example `!019053`).
pub(crate) const DEFAULT_NAME: &str = "9053";

/// Longest name `~AAO(Data)` takes: "max 6 characters" (§2.14).
pub(crate) const MAX_NAME_LEN: usize = 6;

/// `~AA0` status bit: host watchdog enabled (§2.18, SS = 80).
pub(crate) const STATUS_WDT_ENABLED: u8 = 0x80;

/// `~AA0` status bit: host watchdog timeout status set (§1.5 "will be 04", §2.18 SS = 84).
pub(crate) const STATUS_WDT_TIMEOUT: u8 = 0x04;

/// DCON counters run 00000..99999 (§2.3) and then wrap.
pub(crate) const DCON_COUNTER_MODULUS: u32 = 100_000;

/// Modbus counters run 0..65535 (FC 03/04: "a maximum count value up to 65535") and wrap.
pub(crate) const MODBUS_COUNTER_MODULUS: u32 = 65_536;

/// The delay between the end of a request and the first byte of the answer. The manual gives
/// none; 1 ms is the order of such modules' firmware turnaround. The simulator answers after
/// it and the driver budgets it.
pub(crate) const REPLY_DELAY: std::time::Duration = std::time::Duration::from_millis(1);

/// One host watchdog count: 0.1 s (§2.20 "each count is 0.1 second").
pub(crate) const WDT_TICK_MS: u64 = 100;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn baud_codes_round_trip() {
        for (code, baud) in BAUD_CODES {
            assert_eq!(baud_of_code(code), Some(baud));
            assert_eq!(code_of_baud(baud), Some(code));
        }
        assert_eq!(baud_of_code(0x02), None);
        assert_eq!(baud_of_code(0x0B), None);
        assert_eq!(code_of_baud(14400), None);
    }
}
