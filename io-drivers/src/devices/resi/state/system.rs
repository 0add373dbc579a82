//! DIP switches and the unit / bus address (resi-spec §1.3, §1.4).
//!
//! - Compact series (L17705–L17761): ADR0..3 = DIP1..4 give the address 1..15; 0 means "the
//!   internal MODBUS/RTU unit number … from the FLASH memory in the range of 0 to 255".
//!   BR0..2 = DIP5..7 select 4800..256000 Bd, DIP8 parity NONE/EVEN.
//! - Slim series (L1765–L1849): DIP1+2 select 9600..57600 Bd, DIP3 RS232/RS485, DIP4 "FD"
//!   forces unit 255; otherwise the FLASH unit address is used.
//! - `SMBADR` writes the FLASH address; slim modules use it at once (L2383), compact ones
//!   only when their ADR switches are 0 (L19908). A write of 4x65222 is "activated after a
//!   power off/power on cycle or a software reboot" (L2728).
//! - A change of the DIP switches restarts the module (L17759, L1845).
//!
//! The manual gives no factory setting. The simulator starts with the baud and parity of
//! `softplc sim`'s default line (19200 Bd, even parity) and ADR 0, so the module answers at
//! its FLASH address, the one given as `MODEL@ADDR`.

use crate::line::Parity;

use super::super::model::Series;

/// Baud rates of the compact series by BR2..BR0 (L17742–L17750).
const COMPACT_BAUD: [u32; 8] = [4800, 9600, 19200, 38400, 57600, 115_200, 230_400, 256_000];

/// Baud rates of the slim series by DIP2, DIP1 (L1771–L1774; the column order is inferred).
const SLIM_BAUD: [u32; 4] = [9600, 19200, 38400, 57600];

/// DIP switches and addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct System {
    series: Series,
    dip: u8,
    flash: u8,
    address: u8,
    /// 4x65222 parity option of slim modules: set "by the PC software" (L1775).
    slim_parity: Parity,
}

impl System {
    /// A module whose FLASH address is `flash`, with the default switches.
    pub(crate) fn new(series: Series, flash: u8) -> Self {
        let dip = match series {
            Series::Compact => 0b1010_0000, // BR = 010 (19200 Bd), PARITY = EVEN, ADR = 0
            Series::Slim => 0b0101,         // BR = 19200 Bd, RS485
        };
        let mut s = Self {
            series,
            dip,
            flash,
            address: flash,
            slim_parity: Parity::Even,
        };
        s.boot();
        s
    }

    /// The switches, bit n = DIP(n+1).
    pub(crate) fn dip(&self) -> u8 {
        self.dip
    }

    /// Sets the switches (bits beyond the series' count are dropped). The caller restarts
    /// the module.
    pub(crate) fn set_dip(&mut self, dip: u8) {
        self.dip = match self.series {
            Series::Compact => dip,
            Series::Slim => dip & 0x0F,
        };
    }

    /// The address in use.
    pub(crate) fn address(&self) -> u8 {
        self.address
    }

    /// The FLASH address.
    pub(crate) fn flash(&self) -> u8 {
        self.flash
    }

    fn dip_address(&self) -> Option<u8> {
        match self.series {
            Series::Compact => Some(self.dip & 0x0F).filter(|a| *a != 0),
            Series::Slim => (self.dip & 0x08 != 0).then_some(255),
        }
    }

    /// `SMBADR`: stores the FLASH address and uses it at once where the manual says so.
    pub(crate) fn smbadr(&mut self, address: u8) {
        self.flash = address;
        // "affect the MODBUS/RTU communication immediately" (slim, L2383) unless DIP4 forces
        // 255; compact modules only when their ADR switches are 0 (L19908).
        if self.dip_address().is_none() {
            self.address = address;
        }
    }

    /// MODBUS UNIT ADDRESS (4x65222) written: stored, used after the next boot; "All values
    /// above unit ID 255 define also the unit ID 255" (L2726).
    pub(crate) fn set_unit_address(&mut self, value: u16) {
        self.flash = u8::try_from(value).unwrap_or(u8::MAX);
    }

    /// Boot: the address from the switches or FLASH.
    pub(crate) fn boot(&mut self) {
        self.address = self.dip_address().unwrap_or(self.flash);
    }

    /// The baud rate the switches select.
    pub(crate) fn baud(&self) -> u32 {
        match self.series {
            Series::Compact => COMPACT_BAUD[usize::from((self.dip >> 4) & 7)],
            Series::Slim => SLIM_BAUD[usize::from(self.dip & 3)],
        }
    }

    /// The parity: DIP8 on compact modules (L17754), the configured one on slim modules.
    pub(crate) fn parity(&self) -> Parity {
        match self.series {
            Series::Compact if self.dip & 0x80 != 0 => Parity::Even,
            Series::Compact => Parity::None,
            Series::Slim => self.slim_parity,
        }
    }

    /// The switch bits that select `baud`, if the series has it.
    pub(crate) fn baud_bits(&self, baud: u32) -> Option<u8> {
        match self.series {
            Series::Compact => COMPACT_BAUD
                .iter()
                .position(|b| *b == baud)
                .map(|i| (i as u8) << 4),
            Series::Slim => SLIM_BAUD.iter().position(|b| *b == baud).map(|i| i as u8),
        }
    }

    /// Mask of the switch bits that select the baud rate.
    pub(crate) fn baud_mask(&self) -> u8 {
        match self.series {
            Series::Compact => 0x70,
            Series::Slim => 0x03,
        }
    }

    /// Sets the parity: DIP8 on compact modules, the stored setting on slim ones (odd only
    /// there, L754).
    pub(crate) fn set_parity(&mut self, parity: Parity) -> bool {
        match (self.series, parity) {
            (Series::Compact, Parity::Odd) => false,
            (Series::Compact, p) => {
                self.dip = if p == Parity::Even {
                    self.dip | 0x80
                } else {
                    self.dip & 0x7F
                };
                true
            }
            (Series::Slim, p) => {
                self.slim_parity = p;
                true
            }
        }
    }

    /// Sets the address switches (compact: ADR0..3 = `address` 0..15; slim: FD for 255).
    pub(crate) fn set_address_switches(&mut self, address: u8) -> bool {
        match (self.series, address) {
            (Series::Compact, 0..=15) => {
                self.dip = (self.dip & 0xF0) | address;
                true
            }
            (Series::Slim, 0) => {
                self.dip &= !0x08;
                true
            }
            (Series::Slim, 255) => {
                self.dip |= 0x08;
                true
            }
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compact_address_rules() {
        let mut s = System::new(Series::Compact, 20);
        assert_eq!(
            (s.address(), s.baud(), s.parity()),
            (20, 19200, Parity::Even)
        );
        s.smbadr(30);
        assert_eq!(s.address(), 30, "ADR = 0: used at once");
        s.set_address_switches(5);
        s.boot();
        assert_eq!(s.address(), 5);
        s.smbadr(40);
        assert_eq!((s.address(), s.flash()), (5, 40), "ADR ≠ 0: stored only");
        s.set_dip(0b0111_0000);
        assert_eq!((s.baud(), s.parity()), (256_000, Parity::None));
        assert_eq!(s.baud_bits(4800), Some(0));
        assert!(!s.set_parity(Parity::Odd));
        s.set_unit_address(1000);
        assert_eq!(s.flash(), 255);
    }

    #[test]
    fn slim_address_rules() {
        let mut s = System::new(Series::Slim, 7);
        assert_eq!((s.address(), s.baud()), (7, 19200));
        s.set_address_switches(255);
        s.boot();
        assert_eq!(s.address(), 255, "FD forces 255");
        s.smbadr(9);
        assert_eq!(s.address(), 255, "FD still forces 255");
        s.set_address_switches(0);
        s.boot();
        s.smbadr(10);
        assert_eq!(s.address(), 10, "slim SMBADR is immediate (L2383)");
        s.set_dip(0xFF);
        assert_eq!(s.dip(), 0x0F);
        assert_eq!(s.baud(), 57600);
    }
}
