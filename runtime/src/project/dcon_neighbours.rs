//! A MiniMod whose text commands an EX-9053 on the same bus takes for its own.
//!
//! Every MiniMod gets text commands at start-up, whatever its protocol: its watchdog is armed
//! by name (`@18>WDTTIME=148`, `@18?WDTTIME`; see the MiniMod driver's `watchdog`), and a
//! text-protocol MiniMod gets one every cycle (`@18?XWORD`). An EX-9053 in DCON mode reads the
//! `@` and the next two characters as its own command and address (`@AA`, "Read Digital
//! Input Status", EX-9053 manual §2.13) and answers a command it does not know with `?AA`
//! ("Invalid Command"), on top of the MiniMod's `OK`: both replies are garbled, and the
//! MiniMod never starts. With its checksum on (data format bit 6, §1.10) the EX-9053 takes the
//! line's last two characters for one, and they do not add up.
//!
//! Which EX-9053 hears which MiniMod is decided by the EX-9053's own DCON parser run on the
//! MiniMod's own command line, so the check says exactly what the modules would do: MiniMods
//! 1..=9 are heard by none (`@5>` is no address), 10..=99 by the DCON address with the same
//! digits (MiniMod 18: DCON `18`, project address 24), 100..=247 by their first two digits
//! (MiniMod 123: DCON `12`, project address 18).

use softplc_io::devices::ex9053::{Command, ParseError};
use softplc_io::devices::minimod::{write_command, TextId, WriteValue};
use softplc_io::devices::{ModuleSettings, Protocol};

use super::model::ModuleConfig;

/// The DCON address (as the project writes an EX-9053's address: the number) that takes the
/// text commands of the MiniMod at `address` for its own; `None` when none does.
pub(crate) fn dcon_address_hearing(address: u8) -> Option<u8> {
    let line = write_command(address, TextId::WdtTime, WriteValue::Number(0)).ok()?;
    let body = line.strip_suffix(b"\r").unwrap_or(&line);
    match Command::parse(body) {
        Ok(command) => command.address(),
        Err(ParseError::Invalid { address }) => Some(address),
        Err(ParseError::NoAddress) => None,
    }
}

/// Every `(MiniMod, EX-9053)` pair of module indexes on one bus where the EX-9053, in DCON mode
/// without checksum, hears the MiniMod's text commands.
pub(super) fn clashes<'a>(
    modules: impl Iterator<Item = Option<&'a ModuleConfig>> + Clone,
) -> Vec<(usize, usize)> {
    let dcon_without_checksum = |m: &ModuleConfig| {
        m.device.protocol == Protocol::Text
            && matches!(&m.device.settings, ModuleSettings::Ex9053(s) if !s.checksum)
    };
    let mut out = Vec::new();
    for (i, mm) in modules.clone().enumerate() {
        let Some(mm) = mm.filter(|m| matches!(m.device.settings, ModuleSettings::MiniMod(_)))
        else {
            continue;
        };
        let Some(heard_by) = dcon_address_hearing(mm.device.address.get()) else {
            continue;
        };
        for (j, ex) in modules.clone().enumerate() {
            if ex.is_some_and(|ex| {
                ex.bus == mm.bus && dcon_without_checksum(ex) && ex.device.address.get() == heard_by
            }) {
                out.push((i, j));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn which_dcon_address_hears_which_minimod() {
        assert_eq!(dcon_address_hearing(5), None, "@5> is no DCON address");
        assert_eq!(dcon_address_hearing(9), None);
        assert_eq!(dcon_address_hearing(10), Some(0x10));
        assert_eq!(dcon_address_hearing(18), Some(0x18));
        assert_eq!(dcon_address_hearing(99), Some(0x99));
        assert_eq!(dcon_address_hearing(123), Some(0x12));
        assert_eq!(dcon_address_hearing(247), Some(0x24));
    }
}
