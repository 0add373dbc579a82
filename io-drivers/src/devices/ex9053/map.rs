//! The Modbus RTU map of the EX-9053D-M (manual, "9053-M Modbus mapping" and the function
//! tables before it). Constants are 0-based protocol addresses; the doc gives the manual's
//! 1-based reference.
//!
//! | space            | address         | reference     | what                     | access |
//! |------------------|-----------------|---------------|--------------------------|--------|
//! | coil             | 0x0020..0x002F  | 00033..00048  | DI channel               | R      |
//! | coil             | 0x0040..0x004F  | 00065..00080  | DI latch high            | R      |
//! | coil             | 0x0060..0x006F  | 00097..00112  | DI latch low             | R      |
//! | coil             | 0x0100          | 00257         | protocol (1 = Modbus)    | R/W    |
//! | coil             | 0x0104          | 00261         | WDT enable               | R/W    |
//! | coil             | 0x0107          | 00264         | clear the latches        | W      |
//! | coil             | 0x010D          | 00270         | WDT timeout status       | R/W    |
//! | coil             | 0x0200..0x020F  | 00513..00528  | clear DI counter         | W      |
//! | coil             | 0x08CA          | 02251         | count edge (1 = rising)  | R/W    |
//! | discrete input   | 0x0000..0x000F  | 10001..10016  | DI channel               | R      |
//! | input register   | 0x0000..0x000F  | 30001..30016  | DI counter               | R      |
//! | holding register | 0x0000..0x000F  | (FC 03 table) | DI counter               | R      |
//! | holding register | 0x01E2..0x01E3  | 40483..40484  | module name 0x0090 0x5300| R      |
//! | holding register | 0x01E4          | 40485         | module address           | R/W    |
//! | holding register | 0x01E5          | 40486         | baud code (03..0A)       | R/W    |
//! | holding register | 0x01E8          | 40489         | WDT value, 0.1 s         | R/W    |
//! | FC 3 / FC 4      | 0x3038, qty 0   | 312345/412345 | host OK, no response     | —      |
//! | FC 0x46          | sub 00 / sub 04 | —             | read name / set address  | R / W  |
//!
//! Choices where the manual is silent: write-only coils read 0 (so FC 15 over 00513..00528,
//! which the manual lists, passes the server's read-before-write check); writing OFF to a
//! "write 0xFF00" coil does nothing; read-only addresses refuse writes with exception 02, out
//! of range values get 03; unlisted addresses 02. The name registers stay 0x0090 0x5300
//! whatever `~AAO` stored (they are the model code, not the DCON name). Reads of 40485/40486
//! return the value stored for the next reboot.

use crate::modbus::crc::append_crc;
use crate::modbus::server::RegisterBank;
use crate::modbus::ExceptionCode;

use super::state::{Ex9053State, WireProtocol};
use super::tables::{CHANNELS, MODBUS_COUNTER_MODULUS};

/// Coils 00033..00048: DI channel.
pub(crate) const COIL_DI: u16 = 0x0020;
/// Coils 00065..00080: DI latch high.
pub(crate) const COIL_LATCH_HIGH: u16 = 0x0040;
/// Coils 00097..00112: DI latch low.
pub(crate) const COIL_LATCH_LOW: u16 = 0x0060;
/// Coil 00257: protocol at the next reboot, ON = Modbus RTU.
pub(crate) const COIL_PROTOCOL: u16 = 0x0100;
/// Coil 00261: host watchdog enable.
pub(crate) const COIL_WDT_ENABLE: u16 = 0x0104;
/// Coil 00264: write ON to clear the latches.
pub(crate) const COIL_CLEAR_LATCHES: u16 = 0x0107;
/// Coil 00270: host watchdog timeout status; write ON to clear it.
pub(crate) const COIL_WDT_STATUS: u16 = 0x010D;
/// Coils 00513..00528: write ON to clear a channel's counter.
pub(crate) const COIL_CLEAR_COUNTER: u16 = 0x0200;
/// Coil 02251: count edge, ON = rising.
pub(crate) const COIL_COUNT_EDGE: u16 = 0x08CA;
/// Discrete inputs 10001..10016: DI channel.
pub(crate) const DI_INPUTS: u16 = 0x0000;
/// Input registers 30001..30016 (and holding registers 0..15, FC 03 table): counters.
pub(crate) const REG_COUNTERS: u16 = 0x0000;
/// Holding registers 40483..40484: module name.
pub(crate) const HR_NAME: u16 = 0x01E2;
/// Holding register 40485: module address, 1..=247, after reboot.
pub(crate) const HR_ADDRESS: u16 = 0x01E4;
/// Holding register 40486: baud code 03..0A, after reboot.
pub(crate) const HR_BAUD: u16 = 0x01E5;
/// Holding register 40489: host watchdog value, 0..=255 × 0.1 s.
pub(crate) const HR_WDT_VALUE: u16 = 0x01E8;
/// Registers 312345 / 412345 with quantity 0: host OK, no response.
pub(crate) const REG_HOST_OK: u16 = 0x3038;
/// The name registers' content ("0x0090 0x5300").
pub(crate) const NAME_WORDS: [u16; 2] = [0x0090, 0x5300];
/// The module-name function (0x46; MiniMod uses the same code for Collect).
pub(crate) const FC_MODULE: u8 = 0x46;
/// FC 0x46 sub-function 00: read the module name.
pub(crate) const SUB_READ_NAME: u8 = 0x00;
/// FC 0x46 sub-function 04: set the module address (after reboot).
pub(crate) const SUB_SET_ADDRESS: u8 = 0x04;

/// The host OK frame to `unit`: `uu 04 30 38 00 00` + CRC (the -M never answers it).
pub(crate) fn host_ok_frame(unit: u8) -> Vec<u8> {
    let mut f = vec![unit, 0x04, 0x30, 0x38, 0x00, 0x00];
    append_crc(&mut f);
    f
}

fn channel_in(addr: u16, base: u16) -> Option<usize> {
    addr.checked_sub(base)
        .map(usize::from)
        .filter(|ch| *ch < CHANNELS)
}

fn bit(word: u16, ch: usize) -> bool {
    word & (1 << ch) != 0
}

fn counter_word(state: &Ex9053State, ch: usize) -> u16 {
    u16::try_from(state.counter(ch) % MODBUS_COUNTER_MODULUS).unwrap_or(u16::MAX)
}

/// The Modbus view of the module, by 0-based address.
impl RegisterBank for Ex9053State {
    fn read_coil(&self, addr: u16) -> Result<bool, ExceptionCode> {
        if let Some(ch) = channel_in(addr, COIL_DI) {
            return Ok(bit(self.inputs(), ch));
        }
        if let Some(ch) = channel_in(addr, COIL_LATCH_HIGH) {
            return Ok(bit(self.latch_high(), ch));
        }
        if let Some(ch) = channel_in(addr, COIL_LATCH_LOW) {
            return Ok(bit(self.latch_low(), ch));
        }
        if channel_in(addr, COIL_CLEAR_COUNTER).is_some() {
            return Ok(false);
        }
        match addr {
            COIL_PROTOCOL => Ok(self.eeprom().protocol == WireProtocol::Modbus),
            COIL_WDT_ENABLE => Ok(self.watchdog().0),
            COIL_CLEAR_LATCHES => Ok(false),
            COIL_WDT_STATUS => Ok(self.watchdog_timeout()),
            COIL_COUNT_EDGE => Ok(self.counter_rising()),
            _ => Err(ExceptionCode::IllegalDataAddress),
        }
    }

    fn read_discrete_input(&self, addr: u16) -> Result<bool, ExceptionCode> {
        channel_in(addr, DI_INPUTS)
            .map(|ch| bit(self.inputs(), ch))
            .ok_or(ExceptionCode::IllegalDataAddress)
    }

    fn read_input_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        channel_in(addr, REG_COUNTERS)
            .map(|ch| counter_word(self, ch))
            .ok_or(ExceptionCode::IllegalDataAddress)
    }

    fn read_holding_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        if let Some(ch) = channel_in(addr, REG_COUNTERS) {
            return Ok(counter_word(self, ch));
        }
        match addr {
            HR_NAME => Ok(NAME_WORDS[0]),
            a if a == HR_NAME + 1 => Ok(NAME_WORDS[1]),
            HR_ADDRESS => Ok(u16::from(self.eeprom().address)),
            HR_BAUD => Ok(u16::from(self.eeprom().baud_code)),
            HR_WDT_VALUE => Ok(u16::from(self.watchdog().1)),
            _ => Err(ExceptionCode::IllegalDataAddress),
        }
    }

    fn write_coil(&mut self, addr: u16, value: bool) -> Result<(), ExceptionCode> {
        if let Some(ch) = channel_in(addr, COIL_CLEAR_COUNTER) {
            if value {
                self.clear_counter(ch);
            }
            return Ok(());
        }
        match addr {
            COIL_PROTOCOL => {
                let p = if value {
                    WireProtocol::Modbus
                } else {
                    WireProtocol::Dcon
                };
                self.set_stored_protocol(p, false)
                    .map_err(|_| ExceptionCode::IllegalDataValue)
            }
            COIL_WDT_ENABLE => {
                self.set_watchdog_enabled(value);
                Ok(())
            }
            COIL_CLEAR_LATCHES => {
                if value {
                    self.clear_latches();
                }
                Ok(())
            }
            COIL_WDT_STATUS => {
                if value {
                    self.reset_module_status();
                }
                Ok(())
            }
            COIL_COUNT_EDGE => {
                self.set_counter_rising(value);
                Ok(())
            }
            _ => Err(ExceptionCode::IllegalDataAddress),
        }
    }

    fn write_holding_register(&mut self, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        let bad = |_| ExceptionCode::IllegalDataValue;
        match addr {
            HR_ADDRESS => self.set_stored_address(value).map_err(bad),
            HR_BAUD => self.set_stored_baud_code(value).map_err(bad),
            HR_WDT_VALUE => {
                let v = u8::try_from(value).map_err(|_| ExceptionCode::IllegalDataValue)?;
                self.set_watchdog_value(v);
                Ok(())
            }
            _ => Err(ExceptionCode::IllegalDataAddress),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::ex9053::state::Variant;

    #[test]
    fn manual_references_are_one_more_than_the_protocol_address() {
        assert_eq!(COIL_DI + 1, 33);
        assert_eq!(COIL_LATCH_HIGH + 1, 65);
        assert_eq!(COIL_LATCH_LOW + 1, 97);
        assert_eq!(COIL_PROTOCOL + 1, 257);
        assert_eq!(COIL_WDT_ENABLE + 1, 261);
        assert_eq!(COIL_CLEAR_LATCHES + 1, 264);
        assert_eq!(COIL_WDT_STATUS + 1, 270);
        assert_eq!(COIL_CLEAR_COUNTER + 1, 513);
        assert_eq!(COIL_COUNT_EDGE + 1, 2251);
        assert_eq!(HR_NAME + 40001, 40483);
        assert_eq!(HR_ADDRESS + 40001, 40485);
        assert_eq!(HR_BAUD + 40001, 40486);
        assert_eq!(HR_WDT_VALUE + 40001, 40489);
        assert_eq!(REG_HOST_OK + 1, 12345);
    }

    #[test]
    fn bank_reads_and_writes() {
        let mut m = Ex9053State::factory(Variant::M);
        m.set_inputs(0x8001);
        assert_eq!(m.read_coil(COIL_DI), Ok(true));
        assert_eq!(m.read_coil(COIL_DI + 15), Ok(true));
        assert_eq!(m.read_discrete_input(1), Ok(false));
        assert_eq!(
            m.read_discrete_input(16),
            Err(ExceptionCode::IllegalDataAddress)
        );
        assert_eq!(m.read_coil(0x0050), Err(ExceptionCode::IllegalDataAddress));
        assert_eq!(m.read_holding_register(HR_NAME + 1), Ok(0x5300));
        assert_eq!(
            m.write_holding_register(HR_ADDRESS, 0),
            Err(ExceptionCode::IllegalDataValue)
        );
        assert_eq!(
            m.write_holding_register(HR_WDT_VALUE, 256),
            Err(ExceptionCode::IllegalDataValue)
        );
        assert_eq!(
            m.write_holding_register(REG_COUNTERS, 1),
            Err(ExceptionCode::IllegalDataAddress)
        );
        assert_eq!(m.write_coil(COIL_CLEAR_COUNTER + 3, true), Ok(()));
        assert_eq!(m.read_coil(COIL_CLEAR_COUNTER + 3), Ok(false));
        assert_eq!(host_ok_frame(1).len(), 8);
    }
}
