//! Why a reply was refused.

/// An echo field of a write reply (FC 5, 6, 15, 16, 22).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EchoField {
    /// The (0-based) address.
    Address,
    /// The value written (FC 5: 0xFF00 / 0x0000; FC 6: the register value).
    Value,
    /// The quantity written (FC 15, 16).
    Quantity,
    /// The AND mask (FC 22).
    AndMask,
    /// The OR mask (FC 22).
    OrMask,
}

impl std::fmt::Display for EchoField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Address => "address",
            Self::Value => "value",
            Self::Quantity => "quantity",
            Self::AndMask => "AND mask",
            Self::OrMask => "OR mask",
        })
    }
}

/// Why a reply was refused. All of these mean "the bus failed", not "the device said no": an
/// exception reply is a successful decode ([`crate::modbus::Response::Exception`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ReplyError {
    /// The frame's CRC does not match its content (line noise). Counted apart by the bus owner.
    #[error("CRC error: computed {expected:#06x}, frame carries {found:#06x}")]
    Crc {
        /// The CRC computed over the received bytes.
        expected: u16,
        /// The CRC the frame carries.
        found: u16,
    },
    /// The reply comes from another unit than the one asked.
    #[error("reply from unit {found}, expected unit {expected}")]
    WrongUnit {
        /// The unit the request was sent to.
        expected: u8,
        /// The address byte received.
        found: u8,
    },
    /// A Collect reply from a unit outside the window `first..=last`.
    #[error("Collect reply from unit {found}, outside window {first}..={last}")]
    OutsideWindow {
        /// FIRST of the request.
        first: u8,
        /// LAST of the request.
        last: u8,
        /// The address byte received.
        found: u8,
    },
    /// The reply carries another function code (neither the request's nor its exception).
    #[error("reply function {found}, expected {expected}")]
    WrongFunction {
        /// The request's function code.
        expected: u8,
        /// The function byte received.
        found: u8,
    },
    /// A read reply's byte count does not match the quantity asked.
    #[error("reply byte count {found}, expected {expected}")]
    WrongByteCount {
        /// The byte count the request implies (FC 1/2: ceil(count / 8); FC 3/4: 2 × count).
        expected: usize,
        /// The byte count received.
        found: u8,
    },
    /// A write reply's echo differs from the request.
    #[error("reply echoes {field} {found:#06x}, request had {expected:#06x}")]
    EchoMismatch {
        /// Which field differs.
        field: EchoField,
        /// The request's value.
        expected: u16,
        /// The echoed value.
        found: u16,
    },
    /// A Modbus TCP reply whose MBAP header is not the request's (another transaction id or
    /// unit id): a late answer to an earlier request, or a server that mixes them up.
    #[error("reply header (transaction or unit id) is not the request's")]
    HeaderMismatch,
    /// A byte the protocol fixes has another value (the trailing 0 of a Collect reply).
    #[error("malformed reply: unexpected byte at offset {offset}")]
    Malformed {
        /// Offset of the byte in the ADU (0 = address).
        offset: usize,
    },
}
