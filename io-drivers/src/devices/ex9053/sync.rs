//! Synchronized sampling across the DCON modules of one line (§2.2 `#**`, §2.5 `$AA4`).
//!
//! `#**` is a broadcast: every module on the line takes a sample of its inputs at the same
//! instant; `$AA4` then reads each module's sample, with S = 1 on its first read. Drivers are
//! per module and the bus owner runs them in project order, so the line-level step is given to
//! one of them by the project file:
//!
//! - `sync: lead` — this module's driver sends `#**` at the start of its read plan, then reads
//!   its own sample with `$AA4`. Exactly one module of a synchronized line should lead, and it
//!   should be the first of them in the project file: the bus owner polls modules in that order
//!   and the broadcast must precede the followers' reads.
//! - `sync: follow` — the driver reads the sample with `$AA4` only.
//! - `sync: off` (the default) — the driver reads the live inputs with `@AA`.
//!
//! No change to the bus owner is needed beyond sending a frame that gets no reply
//! ([`crate::driver::Outgoing::NoReply`]). A follower checks S: S = 0 means no new sample was
//! taken since its last read (the broadcast was lost, or no module leads); the read then fails
//! (the points keep their last values and their quality drops) rather than pass an old sample
//! off as this cycle's. A follower polled before the lead still gets S = 1, one cycle late.
//!
//! Synchronized sampling is DCON only: the EX-9053D-M's Modbus map has no such function, so a
//! module running Modbus ignores the setting (logged).

/// A module's part in synchronized sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SyncRole {
    /// Reads the live inputs (`@AA`).
    #[default]
    Off,
    /// Sends `#**` for the line, then reads its sample (`$AA4`).
    Lead,
    /// Reads its sample (`$AA4`).
    Follow,
}

impl SyncRole {
    /// Parses the project-file value: `off`, `lead`, `follow` (`false` = `off`).
    pub fn parse(text: &str) -> Option<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "off" | "false" | "none" => Some(SyncRole::Off),
            "lead" | "leader" => Some(SyncRole::Lead),
            "follow" | "follower" => Some(SyncRole::Follow),
            _ => None,
        }
    }

    /// Whether this module sends the line's `#**`.
    pub fn sends_broadcast(self) -> bool {
        self == SyncRole::Lead
    }

    /// Whether this module reads its inputs with `$AA4`.
    pub fn reads_sample(self) -> bool {
        self != SyncRole::Off
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles() {
        assert_eq!(SyncRole::parse("lead"), Some(SyncRole::Lead));
        assert_eq!(SyncRole::parse(" Follow "), Some(SyncRole::Follow));
        assert_eq!(SyncRole::parse("off"), Some(SyncRole::Off));
        assert_eq!(
            SyncRole::parse("true"),
            None,
            "a bare true does not say who leads"
        );
        assert!(SyncRole::Lead.sends_broadcast() && SyncRole::Lead.reads_sample());
        assert!(!SyncRole::Follow.sends_broadcast() && SyncRole::Follow.reads_sample());
        assert!(!SyncRole::Off.reads_sample());
    }
}
