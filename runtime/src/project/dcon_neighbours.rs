//! A module whose text commands a neighbour on the same bus takes for its own.
//!
//! Every MiniMod gets text commands at start-up, whatever its protocol: its watchdog is armed
//! by name (`@18>WDTTIME=148`, `@18?WDTTIME`; see the MiniMod driver's `watchdog`), and a
//! text-protocol MiniMod gets one every cycle (`@18?XWORD`). An EX-9053 in DCON mode without
//! its checksum reads the `@` and the next two characters as its own command and address and
//! answers as well (see `softplc_io::devices::ex9053`'s family): both replies are garbled,
//! and the MiniMod never starts.
//!
//! Which module hears which is decided by the families, the listener's own parser run on the
//! sender's own command line, so the check says exactly what the modules would do: MiniMods
//! 1..=9 are heard by none (`@5>` is no address), 10..=99 by the DCON address with the same
//! digits (MiniMod 18: DCON `18`, project address 24), 100..=247 by their first two digits
//! (MiniMod 123: DCON `12`, project address 18).

use super::model::ModuleConfig;

/// Every `(sender, listener)` pair of module indexes on one bus where the listener takes the
/// sender's start-up text commands for its own (each family says what it sends,
/// [`softplc_io::devices::Family::startup_text`], and what it takes,
/// [`softplc_io::devices::Family::takes_for_own`]).
pub(super) fn clashes<'a>(
    modules: impl Iterator<Item = Option<&'a ModuleConfig>> + Clone,
) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (i, sender) in modules.clone().enumerate() {
        let Some(sender) = sender else {
            continue;
        };
        let Some(line) = sender.model.family.startup_text(sender.device.address) else {
            continue;
        };
        for (j, listener) in modules.clone().enumerate() {
            if listener.is_some_and(|l| {
                j != i && l.bus == sender.bus && l.model.family.takes_for_own(&l.device, &line)
            }) {
                out.push((i, j));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use softplc_io::devices::ex9053::address_hearing;
    use softplc_io::devices::minimod::{write_command, TextId, WriteValue};

    /// The DCON address that takes the text commands of the MiniMod at `address` for its own.
    fn dcon_address_hearing(address: u8) -> Option<u8> {
        address_hearing(&write_command(address, TextId::WdtTime, WriteValue::Number(0)).ok()?)
    }

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
