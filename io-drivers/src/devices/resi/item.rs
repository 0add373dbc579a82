//! What a register, a coil or an ASCII command reaches inside a RESI module, for every model of
//! the catalogue. The register map ([`super::map`]) and the ASCII command table
//! ([`super::ascii`]) both point at [`Item`]s; the module state ([`super::state`]) gives each
//! its meaning. Indexes are 0-based (`DI1` is index 0, `RO8` index 7).

/// A kind of value inside a module; with an index it is an [`Item`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    // --- digital inputs (2RI ch. 5, 16DI8RO ch. 10, 32DI ch. 11, 14RI ch. 12) ---
    /// DIn as sampled every 10 ms (L16833): 1 = input high.
    Di,
    /// Every DI as one number, bit n = DI(n+1) (ASCII `GDIS`; 32 bits on the 32DI).
    Dis,
    /// Sixteen DIs as one register: index 0 = DI1..16, 1 = DI17..32 (4x00101/4x00102).
    DisWord,
    /// Negated DIn (2RI `NDI1`, L2455).
    NegDi,
    /// Negated DIs as one number (2RI `NDIS`).
    NegDis,
    /// DI1 OR DI2 (2RI `ORDIS`).
    OrDis,
    /// DI1 XOR DI2 (2RI `XORDIS`).
    XorDis,
    /// DI1 AND DI2 (2RI `ANDDIS`).
    AndDis,
    /// Rising edges of DIn since power-on (`RISE DIn`, L20311).
    Rise,
    /// Falling edges of DIn since power-on (`FALL DIn`).
    Fall,
    /// RESET COUNTER: a write clears every edge counter; reads 0 (L20285).
    ResetCounter,
    /// A register the manual lists as unused, always 0 (14RI `FREE`).
    Free,
    // --- relays (16DI8RO ch. 10, 8CO ch. 13) ---
    /// ROn: the relay's state; a write switches it.
    Ro,
    /// Every relay as one number, bit n = RO(n+1) (`ROS`); a write sets all of them.
    Ros,
    /// Switching cycles of ROn, kept in FRAM, not resettable (`COUNTER ROn`, L20788).
    RoCounter,
    /// 8CO `PULSE ROn`: a write switches ROn on for value × 100 ms (L31538).
    RelayPulse,
    /// 8CO `PULSETIME_ROn`: remaining pulse time in ms (L31635).
    RelayPulseLeft,
    // --- 16DI8RO internal logic (10.1.1, L16432) ---
    /// A logic mask of ROn: bit n = DI(n+1) (4x20001..4x20040).
    Mask(Func),
    /// PULSE TIME of ROn in 1/10 s (4x20065, L21469).
    PulseTime,
    /// Remaining PULSE TIMER of ROn in 1/10 s, 0 when no pulse runs (4x20097, L21663).
    PulseTimer,
    /// ENABLE LOGIC FUNCTIONS (4x21001, L22516).
    EnableLogic,
    /// CLEAR ALL LOGIC FUNCTIONS (4x21002, L22530): a write clears; reads 0.
    ClearLogic,
    // --- 1RO (ch. 6) ---
    /// DO1: the commanded output (L4190).
    Do,
    /// NDO1.
    NegDo,
    /// TDO1: the true relay state, off-delay included.
    TrueDo,
    /// NTDO1.
    NegTrueDo,
    /// The output image `GDOS`: bit 0 DO1, bit 1 the true relay state (L3960).
    Dos,
    /// `GNDOS`: bit 0 NOT DO1, bit 1 the true relay state as printed (erratum 14).
    NegDos,
    /// OFFDLY coil: the off-delay timer runs.
    OffDelayOn,
    /// OFFDLY register: remaining off-delay in ms; a write starts it (L4291).
    OffDelay,
    // --- system ---
    /// DIPn switch.
    Dip,
    /// Every DIP switch as one number, bit n = DIP(n+1) (`GDIP`, 4x00103).
    DipWord,
    /// RESET SYSTEM (4x06001): a write reboots the module.
    ResetSystem,
    /// MODBUS UNIT ADDRESS (4x65222): the FLASH unit address, active after a reboot
    /// (L2728–L2731).
    UnitAddress,
    /// The unit / bus address in use (first value of `GMBADR`, L19919).
    BusAddress,
    /// ASCII `SMBADR`: writes the FLASH unit address, in use at once on slim modules
    /// (L2383) and on compact ones whose ADR switches are 0 (L19908); reads the FLASH value.
    SmbAdr,
    // --- 2RTD (ch. 7) ---
    /// A temperature of channel n in the channel's unit.
    Temp(Temp),
    /// STATUS of channel n: bit 0 valid, bit 1 ADC out of range, ... (L6921).
    Status,
    /// AVG_SUM of channel n (DOUBLE64).
    AvgSum,
    /// AVG_COUNT of channel n (UINT32).
    AvgCount,
    /// SENSOR_TYPE bitfields of channel n (4x06021, L8714).
    SensorType,
    /// ZERO_OFFSET of channel n, °C (4x06022).
    ZeroOffset,
    /// AVG_INTERVAL of channel n, seconds (4x06024).
    AvgInterval,
    // --- 1LED (ch. 8), 4LED (ch. 9) ---
    /// LOn set point, 0..4095.
    Lo,
    /// MODE of group n: 0 OFF, 1 ON, 2 FLASH, 3 FADE, 4 RANDOM, 5 SEQUENCE (L11692).
    Mode,
    /// FADESPEED of group n: steps per 1/100 s (L11731).
    FadeSpeed,
    /// MINTIME of group n.
    MinTime,
    /// MAXTIME of group n.
    MaxTime,
    /// CLOn: the output's current value.
    Clo,
    /// RLOn: the last random value.
    Rlo,
    /// ISFADING of group n.
    IsFading,
}

/// The five logic functions of the 16DI8RO, in the order of their register blocks (erratum
/// 10: the text orders them differently).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Func {
    /// SWITCH: the relay follows the mapped input's level (10.1.1.3, L16508).
    Switch,
    /// TOGGLE: a rising edge inverts the relay (10.1.1.6, L16682).
    Toggle,
    /// SWITCH ON: a rising edge switches the relay on (10.1.1.4, L16564).
    SwitchOn,
    /// SWITCH OFF: a rising edge switches the relay off (10.1.1.5, L16621).
    SwitchOff,
    /// PULSE: a rising edge starts a retriggerable off-delay of PULSE TIME (10.1.1.7, L16707).
    Pulse,
}

impl Func {
    /// All five, in register order.
    pub const ALL: [Func; 5] = [
        Func::Switch,
        Func::Toggle,
        Func::SwitchOn,
        Func::SwitchOff,
        Func::Pulse,
    ];

    /// Position in [`Func::ALL`].
    pub const fn slot(self) -> usize {
        match self {
            Func::Switch => 0,
            Func::Toggle => 1,
            Func::SwitchOn => 2,
            Func::SwitchOff => 3,
            Func::Pulse => 4,
        }
    }
}

/// Which temperature of a 2RTD channel (7.16.2.1, L6775).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Temp {
    /// VALID_TEMP: the last valid measurement.
    Valid,
    /// REAL_TEMP: the last measurement, valid or not.
    Real,
    /// AVG_TEMP: the last average.
    Avg,
}

/// A kind and its 0-based index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Item {
    /// What it is.
    pub kind: Kind,
    /// Which one, 0-based.
    pub index: u8,
}

impl Kind {
    /// Whether its values are real numbers (2RTD temperatures and offsets); the others are
    /// integers.
    pub const fn is_real(self) -> bool {
        matches!(self, Kind::Temp(_) | Kind::AvgSum | Kind::ZeroOffset)
    }
}

impl Item {
    /// An item.
    pub const fn new(kind: Kind, index: u8) -> Self {
        Self { kind, index }
    }

    /// The item this one is a part of, with the part's first bit and width: `DI3` is bit 2 of
    /// `Dis`, `DIS17_32` bits 16..31 of it. Lets a driver read many points with one command
    /// (`GDIS`).
    pub const fn part_of(self) -> Option<(Item, u8, u8)> {
        let (whole, shift, width) = match self.kind {
            Kind::Di => (Kind::Dis, self.index, 1),
            Kind::DisWord => (Kind::Dis, self.index.saturating_mul(16), 16),
            Kind::Ro => (Kind::Ros, self.index, 1),
            Kind::Dip => (Kind::DipWord, self.index, 1),
            _ => return None,
        };
        Some((Item::new(whole, 0), shift, width))
    }
}
