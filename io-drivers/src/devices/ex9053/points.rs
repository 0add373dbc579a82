//! The points of both models, by the manual's names: the inputs DI0..DI15 as the manual numbers
//! its channels (§1.10 data format, Modbus map "DI channel"), and for each channel its latches
//! and counter; then the host watchdog timeout status and the synchronized-sampling flag.
//!
//! | index   | name                 | type | what                                             |
//! |---------|----------------------|------|--------------------------------------------------|
//! | 0..16   | `DIn`                | bool | input level (`@AA`/`$AA4`; 10001..10016)         |
//! | 16..32  | `DIn_LATCH_HIGH`     | bool | high since the previous poll (`$AAL1`; 00065..)  |
//! | 32..48  | `DIn_LATCH_LOW`      | bool | low since the previous poll (`$AAL0`; 00097..)   |
//! | 48..64  | `DIn_COUNTER`        | i32  | edge counter (`#AAN`; 30001..30016)              |
//! | 64      | `WDT_TIMEOUT`        | bool | host watchdog timeout status (`~AA0`; 00270)     |
//! | 65      | `SYNC_FIRST`         | bool | S of `$AA4`: first read of the sample            |
//!
//! Counters are `i32` because DCON counts to 99999 (§2.3), more than a `u16`.

use crate::point::{Access, PointSpec, ValueType};

use super::tables::CHANNELS;

macro_rules! points {
    ($($n:literal)*) => {
        &[
            $(PointSpec {
                name: concat!("DI", $n),
                ty: ValueType::Bool,
                access: Access::Input,
                doc: concat!("input DI", $n, " level (DCON @AA or $AA4; Modbus 10001..10016)"),
            },)*
            $(PointSpec {
                name: concat!("DI", $n, "_LATCH_HIGH"),
                ty: ValueType::Bool,
                access: Access::Input,
                doc: concat!(
                    "DI", $n, " was high since the previous poll (DCON $AAL1, §2.12; \
                     Modbus 00065..00080), cleared after each read"
                ),
            },)*
            $(PointSpec {
                name: concat!("DI", $n, "_LATCH_LOW"),
                ty: ValueType::Bool,
                access: Access::Input,
                doc: concat!(
                    "DI", $n, " was low since the previous poll (DCON $AAL0, §2.12; \
                     Modbus 00097..00112), cleared after each read"
                ),
            },)*
            $(PointSpec {
                name: concat!("DI", $n, "_COUNTER"),
                ty: ValueType::I32,
                access: Access::Input,
                doc: concat!(
                    "DI", $n, " edge counter (DCON #AAN 0..99999, §2.3; \
                     Modbus 30001..30016 0..65535)"
                ),
            },)*
            PointSpec {
                name: "WDT_TIMEOUT",
                ty: ValueType::Bool,
                access: Access::Input,
                doc: "host watchdog timeout status (DCON ~AA0, §2.18; Modbus 00270)",
            },
            PointSpec {
                name: "SYNC_FIRST",
                ty: ValueType::Bool,
                access: Access::Input,
                doc: "S of $AA4: the synchronized sample is read for the first time (§2.5)",
            },
        ]
    };
}

/// Every point of the EX-9053D and EX-9053D-M, in index order (see the module table).
pub(crate) static POINTS: &[PointSpec] = points!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);

/// A point, decoded from its name or index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Point {
    /// `DIn`.
    Input(usize),
    /// `DIn_LATCH_HIGH`.
    LatchHigh(usize),
    /// `DIn_LATCH_LOW`.
    LatchLow(usize),
    /// `DIn_COUNTER`.
    Counter(usize),
    /// `WDT_TIMEOUT`.
    WdtTimeout,
    /// `SYNC_FIRST`.
    SyncFirst,
}

/// Index of `WDT_TIMEOUT`.
pub(crate) const IDX_WDT_TIMEOUT: usize = 4 * CHANNELS;

/// Index of `SYNC_FIRST`.
pub(crate) const IDX_SYNC_FIRST: usize = 4 * CHANNELS + 1;

impl Point {
    /// Its index in [`POINTS`].
    pub(crate) fn index(self) -> usize {
        match self {
            Point::Input(ch) => ch,
            Point::LatchHigh(ch) => CHANNELS + ch,
            Point::LatchLow(ch) => 2 * CHANNELS + ch,
            Point::Counter(ch) => 3 * CHANNELS + ch,
            Point::WdtTimeout => IDX_WDT_TIMEOUT,
            Point::SyncFirst => IDX_SYNC_FIRST,
        }
    }

    /// The point at `index`.
    pub(crate) fn from_index(index: usize) -> Option<Self> {
        Some(match (index / CHANNELS, index % CHANNELS) {
            (0, ch) => Point::Input(ch),
            (1, ch) => Point::LatchHigh(ch),
            (2, ch) => Point::LatchLow(ch),
            (3, ch) => Point::Counter(ch),
            _ if index == IDX_WDT_TIMEOUT => Point::WdtTimeout,
            _ if index == IDX_SYNC_FIRST => Point::SyncFirst,
            _ => return None,
        })
    }

    /// The point called `name` (the manual's spelling, case-sensitive).
    pub(crate) fn from_name(name: &str) -> Option<Self> {
        POINTS
            .iter()
            .position(|p| p.name == name)
            .and_then(Self::from_index)
    }
}

/// The channel of `DIn` (`DI0`..`DI15`), as the project file's settings name channels.
pub(crate) fn channel_of(name: &str) -> Option<usize> {
    match Point::from_name(name) {
        Some(Point::Input(ch)) => Some(ch),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_indexes_agree() {
        assert_eq!(POINTS.len(), 4 * CHANNELS + 2);
        for (i, p) in POINTS.iter().enumerate() {
            let point = Point::from_name(p.name).unwrap();
            assert_eq!(point.index(), i, "{}", p.name);
        }
        assert_eq!(Point::from_name("DI15_COUNTER"), Some(Point::Counter(15)));
        assert_eq!(Point::from_name("DI16"), None);
        assert_eq!(Point::from_index(66), None);
        assert_eq!(channel_of("DI7"), Some(7));
        assert_eq!(channel_of("DI7_COUNTER"), None);
    }
}
