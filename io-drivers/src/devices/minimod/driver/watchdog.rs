//! Arming the module's watchdog in a way that does not depend on where its registers are.
//!
//! The manual gives WDTTIME and WDTYMASK two ways. Its table "Modbus register map (read and
//! write registers)" lists "40129 WDTTIME UINT16 (word) Watch-dog timeout, in 1/100 of
//! seconds" and "40145 WDTYMASK Bitmap4 Bitmask for the outputs Y1..Y4 when the watch-dog is
//! firing" (holding registers 128 and 144). Every other bit/word pair of the same table
//! follows "coil *n* = bit *n* % 16 of holding register *n* / 16" (Y1..Y4 00001..00004 and
//! YWORD 40001; EVX1..3 00081.. and XEVMASK 40006; EVY1..4 00097.. and YEVMASK 40007), and
//! by that rule WDTY1..4 (00145..00148) are the bits of holding register 9 and WDTTIME is
//! holding register 8: the table's 40129 / 40145 read like the coil numbers 00129 / 00145.
//! On a module that follows the other reading, writing the table's registers leaves the
//! watchdog, the outputs' safety net for a dead host, unarmed while the write succeeds (or
//! is refused with an exception the start-up cannot explain).
//!
//! So both are set and read back **by name**, through the text protocol, whatever protocol
//! the module is driven with:
//!
//! - `@5>WDTTIME=n` + CR, answered `OK`; `@5?WDTTIME`, answered `WDTTIME=nnnnn` (text tables
//!   "WDTtime": "Sets the time, in 1/100 of a second, for firing the watch-dog on serial
//!   communication with the master" / "Shows the timeout ... which fires the watch-dog");
//! - `@5>WDTMASK=m`, `@5?WDTMASK` ("WDTmask": "Sets the mask for the output configuration
//!   when the watch-dog fires" / "Returns the bit mask of the output configuration to be used
//!   when the watch-dog fires").
//!
//! A name is the same under both readings, and the read-back comes from the module by the
//! same name, so an armed watchdog is proven armed whichever register the firmware has. The
//! text protocol is always there beside Modbus: "On the serial line it is possible to use,
//! even concurrently, the Modbus RTU protocol and the simple text protocol" ("RS-485 serial
//! interface"); "Two communication protocols are available, even at the same time, on the
//! same bus or device" ("Process control and data acquisition by a PC/PLC"). The commands are
//! always addressed (`@5`), so no other MiniMod acts on them.
//!
//! One neighbour can hear them: an EX-9053 in DCON mode reads the two characters after `@` as
//! its hexadecimal address (`@AA`, "Read Digital Input Status"), and answers a command it does
//! not know with `?AA` ("Invalid Command"). A MiniMod at 1..=9 is safe (`@5>` is no DCON
//! address); one at 10..=99 is heard by the EX-9053 whose DCON address has the same digits
//! (MiniMod 18 and DCON `18`, project address 24), one at 100..=247 by the one named by its
//! first two digits (MiniMod 123 and DCON `12`). Their two answers then collide and the
//! MiniMod's start-up fails loudly (a garbled answer stops the start naming the module, or
//! none comes and the module is lost and retried), never silently unarmed. Give such a pair
//! other addresses; a text-protocol MiniMod has the same constraint on every command.
//!
//! A read-back that differs stops the start ([`DecodeError::Mismatch`] with the register's
//! name), after an error log that names the module, the register and both readings. The text
//! protocol has no checksum, so a reply with a garbled digit reads as another value: the bus
//! owner asks again, and only the same answer twice is the module's (the log follows it, never
//! a single garbled reply; see `crate::driver::Integrity`); a module
//! that does not answer is lost, retried, and armed when it answers. The watchdog is never
//! left silently unarmed. The sequence is part of the start-up, so it runs again on every
//! restart (a module back after it was lost, a power cycle, a fired watchdog), in polled,
//! event (Collect) and text mode alike.
//!
//! Why not probe which register the module has: a read of the reading the module does not
//! follow may be refused (exception 02 for an address it does not implement), and an
//! exception at start-up stops the start; by name there is nothing to probe.
//!
//! A program that commands WDTTIME or WDTYMASK while it runs (a tag on the point) is written
//! by name too, `>WDTTIME=n` answered `OK` ([`command_by_name`]).
//!
//! The coils need no such care: the coil table (WDTY1..4 00145..00148, WDTFB1..2
//! 00113..00114, as the prose says: "The Single Coil at address 112 enables the watch-dog for
//! the first feedback bit"; WDTFIRED 00161) is the same under both readings.
//!
//! [`DecodeError::Mismatch`]: crate::driver::DecodeError::Mismatch

use super::super::map::{Item, WatchdogRegisters};
use super::super::text::{self, TextId, WriteValue};
use super::settings::SetupStep;
use super::Tag;
use crate::modbus::UnitId;

/// The registers armed by name: the register table's name and the text identifier.
const BY_NAME: [(&str, TextId); 2] = [("WDTTIME", TextId::WdtTime), ("WDTYMASK", TextId::WdtMask)];

/// Takes WDTTIME and WDTYMASK out of the start-up's `(addr, value, name)` registers and
/// returns their steps by name: written with `>ID=n`, read back with `?ID`. The last of
/// duplicates wins, as for every register.
pub(super) fn arm_by_name(registers: &mut Vec<(u16, u16, &'static str)>) -> Vec<SetupStep> {
    let mut steps = Vec::new();
    for (name, id) in BY_NAME {
        let Some(value) = registers.iter().rev().find(|r| r.2 == name).map(|r| r.1) else {
            continue;
        };
        registers.retain(|r| r.2 != name);
        steps.push(SetupStep::Text {
            id,
            name,
            value: WriteValue::Number(value),
            number: value,
            verify: true,
        });
    }
    steps
}

/// A program's command to WDTTIME or WDTYMASK (a tag on the point), by name as at start-up:
/// the line and its tag, or `None` for any other register.
pub(super) fn command_by_name(unit: UnitId, item: Item, value: u16) -> Option<(Vec<u8>, Tag)> {
    let (id, tag) = match item {
        Item::WdtTime => (TextId::WdtTime, Tag::WdtTimeByName(value)),
        Item::WdtYMask => (TextId::WdtMask, Tag::WdtMaskByName(value)),
        _ => return None,
    };
    let line = text::write_command(unit.get(), id, WriteValue::Number(value)).ok()?;
    Some((line, tag))
}

/// Says why a read-back by name differs, when `name` is one of the registers armed here: the
/// module, the register, what it holds, and where each reading of the manual puts it.
pub(super) fn explain_mismatch(address: u8, name: &str, expected: u32, found: u32) {
    let Some(&(_, id)) = BY_NAME.iter().find(|(n, _)| *n == name) else {
        return;
    };
    let [table, aliased] = WatchdogRegisters::ALL.map(WatchdogRegisters::describe);
    tracing::error!(
        address,
        register = name,
        "MiniMod at address {address}: its watch-dog is not armed as the project says: \
         {name} read back by name (?{id}) is {found}, not {expected}. The manual places the \
         watch-dog's registers two ways ({table}; {aliased}); the name depends on neither, so \
         the module refused or lost the value"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wdttime_and_wdtymask_leave_the_registers_for_steps_by_name() {
        let mut registers = vec![
            (19, 30, "XLATUP1"),
            (128, 40, "WDTTIME"),
            (144, 2, "WDTYMASK"),
            (128, 145, "WDTTIME"),
        ];
        let steps = arm_by_name(&mut registers);
        assert_eq!(registers, [(19, 30, "XLATUP1")]);
        assert_eq!(
            steps,
            [
                SetupStep::Text {
                    id: TextId::WdtTime,
                    name: "WDTTIME",
                    value: WriteValue::Number(145),
                    number: 145,
                    verify: true,
                },
                SetupStep::Text {
                    id: TextId::WdtMask,
                    name: "WDTYMASK",
                    value: WriteValue::Number(2),
                    number: 2,
                    verify: true,
                },
            ]
        );
        let mut none = vec![(19, 30, "XLATUP1")];
        assert!(arm_by_name(&mut none).is_empty());
    }
}
