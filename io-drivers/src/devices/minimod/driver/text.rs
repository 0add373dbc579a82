//! The text protocol's side of the driver ("Text commands protocol"): its transactions, and
//! each answer parsed once and handed to the part of the driver that asked.

use super::super::text::{self, TextId};
use super::{MiniModDriver, Tag};
use crate::driver::{DecodeError, Integrity, Outgoing, Transaction};
use crate::modbus::UnitId;

impl MiniModDriver {
    pub(super) fn text_tx(line: Vec<u8>, tag: Tag) -> Transaction {
        Transaction {
            frame: Outgoing::Text {
                line,
                terminator: text::TERMINATOR,
                // The text protocol has no checksum ("Text commands protocol").
                integrity: Integrity::Unchecked,
            },
            tag: tag.encode(),
        }
    }

    pub(super) fn read_tx(&self, unit: UnitId, id: TextId, tag: Tag) -> Transaction {
        Self::text_tx(text::read_command(unit.get(), id), tag)
    }

    pub(super) fn on_text(&mut self, tag: u32, bytes: &[u8]) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let reply = text::parse_reply(bytes).map_err(|_| unexpected)?;
        match Tag::decode(tag) {
            Some(t @ (Tag::SetupWrite(_) | Tag::SetupVerify(_))) => {
                self.on_setup_text(tag, t, reply)
            }
            Some(t @ (Tag::WriteRegister(_) | Tag::WdtTimeByName(_) | Tag::WdtMaskByName(_))) => {
                self.on_write_text(tag, t, reply)
            }
            Some(t) if t.is_write() => self.on_write_text(tag, t, reply),
            Some(t) => self.on_read_text(tag, t, reply),
            None => Err(unexpected),
        }
    }
}
