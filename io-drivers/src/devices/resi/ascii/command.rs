//! The ASCII command table: each command's short and long names, its channel index `x`, and
//! what it does to the module's items. A model lists its own commands; [`COMMON`] holds the
//! ones every chapter has (resi-spec §2.5: VER, TYP, OWN, CRE, COPY, GDIP, SMBADR, GMBADR,
//! RST).
//!
//! Names: "For each command, we define two different writings. A long version and a short
//! version" (L2045). The long names contain spaces (0x20), printed in the extraction as the
//! symbol-font glyph U+F06F (`GET⎵DIP`, L2193; `#SET SWITCH ON1:0x000F`, L16570); the table
//! writes them with plain spaces.

use super::super::item::Kind;

/// A value a command reads or writes: item `kind` at index `step × (x − 1) + add`, where `x`
/// is the command's channel number (1 for commands without one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// The kind of item.
    pub kind: Kind,
    /// Index step per channel number.
    pub step: u8,
    /// Index offset.
    pub add: u8,
}

impl Field {
    /// The item of channel `x` (`GDI3` → DI index 2).
    pub const fn x(kind: Kind) -> Self {
        Self {
            kind,
            step: 1,
            add: 0,
        }
    }

    /// A fixed item, whatever `x` is.
    pub const fn at(kind: Kind, index: u8) -> Self {
        Self {
            kind,
            step: 0,
            add: index,
        }
    }

    /// The fixed items `0..N` of `kind`, in order: a command that lists every channel's value
    /// (4LED `GLOS`: LO 1..12).
    pub const fn run<const N: usize>(kind: Kind) -> [Self; N] {
        let mut out = [Self::at(kind, 0); N];
        let mut i = 0;
        while i < N {
            // N is a channel count, well below 256.
            out[i] = Self::at(kind, i as u8);
            i += 1;
        }
        out
    }

    /// An item of a group of `step` (4LED `SALLx`: LO channel `3(x − 1) + add`).
    pub const fn group(kind: Kind, step: u8, add: u8) -> Self {
        Self { kind, step, add }
    }

    /// The index for channel number `x` (1-based).
    pub fn index(self, x: u8) -> u8 {
        self.step
            .wrapping_mul(x.saturating_sub(1))
            .wrapping_add(self.add)
    }
}

/// How a get command writes its numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fmt {
    /// Each value as `dec,hex` (`GDIS:<DISDec>,<DISHex>`, L18745; `GSS:<S1Dec>,<S1Hex>,
    /// <S2Dec>,<S2Hex>`, L6539).
    Pairs,
    /// Every decimal, then every hexadecimal (`GMBADR:<UnitDec>,<FlashDec>,<UnitHex>,
    /// <FlashHex>`, L19919; `GLOS`, L11137).
    DecsThenHexes,
    /// Real numbers with a `.` (2RTD `GTS:<SENSOR1Dbl>,<SENSOR2Dbl>`, L5425).
    Reals,
    /// A 2RTD SENSOR_TYPE word by its names, `<Type>,<Current>,<Linearisation>,<Unit>`, and
    /// for both channels `S1,...,S2,...` (`GSCS`, L6416; see
    /// `super::sensor_config`). Not numbers: the driver never plans a read through it.
    SensorConfig,
}

/// The fixed texts of the identity commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Text {
    /// `VERSION:<Hi>.<Med>.<Lo>`.
    Version,
    /// `TYPE:RESI-<model>-ASCII`.
    Type,
    /// `OWNER:RESI`.
    Owner,
    /// `CREATOR:DI HC SIGL,MSC`.
    Creator,
    /// `COPYRIGHT:...`.
    Copyright,
}

impl Text {
    /// The answer's keyword: these answer with their long name (resi-spec §2.4).
    pub const fn keyword(self) -> &'static str {
        match self {
            Text::Version => "VERSION",
            Text::Type => "TYPE",
            Text::Owner => "OWNER",
            Text::Creator => "CREATOR",
            Text::Copyright => "COPYRIGHT",
        }
    }
}

/// An action without values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `RC`: clear every edge counter (L18908).
    ResetCounters,
    /// `RSTSPCMODE`: switch the logic off and clear its tables (L18946).
    ClearLogic,
    /// `RST`: reboot; no answer (L19933).
    Reset,
}

/// What a command does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Answers a fixed text.
    Text(Text),
    /// Answers values.
    Get {
        /// The values, in answer order.
        fields: &'static [Field],
        /// How they are written.
        fmt: Fmt,
        /// The answer's keyword when it is not the short name with `x`.
        reply: Option<&'static str>,
    },
    /// Takes one parameter per field and answers `OK`.
    Set {
        /// The values, in parameter order.
        fields: &'static [Field],
    },
    /// Takes SENSOR_TYPE words by their names, as [`Fmt::SensorConfig`] writes them, and
    /// answers `OK` (2RTD `SSCS`, `SSC1`, `SSC2`, L6491–L6530).
    SetSensorConfig {
        /// The SENSOR_TYPE words, in parameter order.
        fields: &'static [Field],
    },
    /// Acts and answers `OK` (nothing for [`Op::Reset`]).
    Do(Op),
}

/// One command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    /// The short name (`SSON`).
    pub short: &'static str,
    /// The long names, with their spaces (`SET SWITCH ON`); misprints the manual gives as the
    /// only long form are listed too (8CO `GET PPULSE TIMER`, erratum 11).
    pub long: &'static [&'static str],
    /// The channel numbers `x` the name takes (`SSON1`..`SSON8`), if any.
    pub x: Option<(u8, u8)>,
    /// What it does.
    pub action: Action,
}

impl Command {
    /// A get command without a channel.
    pub const fn get(
        short: &'static str,
        long: &'static [&'static str],
        fields: &'static [Field],
        fmt: Fmt,
    ) -> Self {
        Self::new(
            short,
            long,
            Action::Get {
                fields,
                fmt,
                reply: None,
            },
        )
    }

    /// A set command without a channel.
    pub const fn set(
        short: &'static str,
        long: &'static [&'static str],
        fields: &'static [Field],
    ) -> Self {
        Self::new(short, long, Action::Set { fields })
    }

    /// A set command taking sensor configurations by name.
    pub const fn set_sensor_config(
        short: &'static str,
        long: &'static [&'static str],
        fields: &'static [Field],
    ) -> Self {
        Self::new(short, long, Action::SetSensorConfig { fields })
    }

    /// An action.
    pub const fn op(short: &'static str, long: &'static [&'static str], op: Op) -> Self {
        Self::new(short, long, Action::Do(op))
    }

    /// A command without a channel: what the constructors above share.
    const fn new(short: &'static str, long: &'static [&'static str], action: Action) -> Self {
        Self {
            short,
            long,
            x: None,
            action,
        }
    }

    /// The same taking channel numbers `first..=last`.
    pub const fn xs(mut self, first: u8, last: u8) -> Self {
        self.x = Some((first, last));
        self
    }

    /// The same answering with another keyword (no channel number appended).
    pub const fn reply(mut self, keyword: &'static str) -> Self {
        if let Action::Get { fields, fmt, .. } = self.action {
            self.action = Action::Get {
                fields,
                fmt,
                reply: Some(keyword),
            };
        }
        self
    }

    /// Whether `keyword` names this command; the channel number if so (1 for commands
    /// without one). `lenient` ignores case and spaces (a simulator option; the manual
    /// shows only upper case and single spaces).
    pub fn matches(&self, keyword: &str, lenient: bool) -> Option<u8> {
        std::iter::once(self.short)
            .chain(self.long.iter().copied())
            .find_map(|name| self.rest(keyword, name, lenient))
    }

    fn rest(&self, keyword: &str, name: &str, lenient: bool) -> Option<u8> {
        let rest = if lenient {
            let squeeze = |s: &str| -> String {
                s.chars()
                    .filter(|c| *c != ' ')
                    .map(|c| c.to_ascii_uppercase())
                    .collect()
            };
            squeeze(keyword).strip_prefix(&squeeze(name))?.to_string()
        } else {
            keyword.strip_prefix(name)?.to_string()
        };
        match self.x {
            None => rest.is_empty().then_some(1),
            Some((first, last)) => {
                if rest.is_empty() || !rest.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                rest.parse::<u8>()
                    .ok()
                    .filter(|x| (first..=last).contains(x))
            }
        }
    }

    /// The keyword of the answer for channel `x`.
    pub fn reply_keyword(&self, x: u8) -> String {
        match self.action {
            Action::Text(t) => t.keyword().to_string(),
            Action::Get {
                reply: Some(keyword),
                ..
            } => keyword.to_string(),
            _ if self.x.is_some() => format!("{}{x}", self.short),
            _ => self.short.to_string(),
        }
    }
}

const fn text(short: &'static str, long: &'static [&'static str], t: Text) -> Command {
    Command {
        short,
        long,
        x: None,
        action: Action::Text(t),
    }
}

/// The commands of every chapter (resi-spec §2.5; 16DI8RO table L18660–L19939).
pub static COMMON: &[Command] = &[
    text("VER", &["VERSION"], Text::Version),
    text("TYP", &["TYPE"], Text::Type),
    text("OWN", &["OWNER"], Text::Owner),
    text("CRE", &["CREATOR"], Text::Creator),
    text("COPY", &["COPYRIGHT"], Text::Copyright),
    Command::get(
        "GDIP",
        &["GET DIP"],
        &[Field::at(Kind::DipWord, 0)],
        Fmt::Pairs,
    ),
    Command::set(
        "SMBADR",
        &["SET MODBUS ADDRESS"],
        &[Field::at(Kind::SmbAdr, 0)],
    ),
    Command::get(
        "GMBADR",
        &["GET MODBUS ADDRESS"],
        &[Field::at(Kind::BusAddress, 0), Field::at(Kind::SmbAdr, 0)],
        Fmt::DecsThenHexes,
    ),
    Command::op("RST", &["RESET"], Op::Reset),
];

/// The command `keyword` names among `own` then [`COMMON`], with its channel number.
pub fn find(
    own: &'static [Command],
    keyword: &str,
    lenient: bool,
) -> Option<(&'static Command, u8)> {
    own.iter()
        .chain(COMMON.iter())
        .find_map(|c| c.matches(keyword, lenient).map(|x| (c, x)))
}

#[cfg(test)]
mod tests {
    use super::*;

    static OWN: &[Command] = &[
        Command::get("GDIS", &["GET DIS"], &[Field::at(Kind::Dis, 0)], Fmt::Pairs),
        Command::get("GDI", &["GET DI"], &[Field::x(Kind::Di)], Fmt::Pairs).xs(1, 16),
        Command::set("SSWITCH", &["SET SWITCH"], &[Field::x(Kind::Ro)]).xs(1, 8),
        Command::set("SSON", &["SET SWITCH ON"], &[Field::x(Kind::Ro)]).xs(1, 8),
        Command::get(
            "GPTIME",
            &["GET PULSE TIME"],
            &[Field::x(Kind::PulseTime)],
            Fmt::Pairs,
        )
        .xs(1, 8),
        Command::get(
            "GPTIMER",
            &["GET PULSE TIMER"],
            &[Field::x(Kind::PulseTimer)],
            Fmt::Pairs,
        )
        .xs(1, 8),
    ];

    fn name(keyword: &str) -> Option<(&'static str, u8)> {
        find(OWN, keyword, false).map(|(c, x)| (c.short, x))
    }

    #[test]
    fn short_and_long_names_with_channels() {
        assert_eq!(name("GDIS"), Some(("GDIS", 1)));
        assert_eq!(name("GET DIS"), Some(("GDIS", 1)));
        assert_eq!(name("GDI12"), Some(("GDI", 12)));
        assert_eq!(name("GET DI16"), Some(("GDI", 16)));
        assert_eq!(name("GDI17"), None, "DI17 does not exist");
        assert_eq!(name("GDI0"), None);
        assert_eq!(name("SET SWITCH ON1"), Some(("SSON", 1)));
        assert_eq!(name("SET SWITCH1"), Some(("SSWITCH", 1)));
        assert_eq!(name("SSON8"), Some(("SSON", 8)));
        assert_eq!(name("GPTIME3"), Some(("GPTIME", 3)));
        assert_eq!(name("GPTIMER3"), Some(("GPTIMER", 3)));
        assert_eq!(name("GET PULSE TIMER3"), Some(("GPTIMER", 3)));
        assert_eq!(name("GET DIP"), Some(("GDIP", 1)));
        assert_eq!(name("RESET"), Some(("RST", 1)));
        assert_eq!(name("VERSION"), Some(("VER", 1)));
        assert_eq!(name("get dis"), None, "upper case only unless lenient");
        assert_eq!(
            find(OWN, "set switchon1", true).map(|(c, x)| (c.short, x)),
            Some(("SSON", 1))
        );
        assert_eq!(name("SETSWITCHON1"), None);
        assert_eq!(name("GDI+1"), None);
        assert_eq!(name(""), None);
    }

    #[test]
    fn reply_keywords() {
        let (c, x) = find(OWN, "GET DI3", false).unwrap();
        assert_eq!(c.reply_keyword(x), "GDI3");
        let (c, x) = find(OWN, "VER", false).unwrap();
        assert_eq!(c.reply_keyword(x), "VERSION");
        let (c, x) = find(OWN, "GET DIP", false).unwrap();
        assert_eq!(c.reply_keyword(x), "GDIP");
        assert_eq!(Field::group(Kind::Lo, 3, 2).index(2), 5);
        assert_eq!(Field::at(Kind::Lo, 2).index(4), 2);
    }

    /// A listing command's fields are the channels' items in channel order, whatever `x` is.
    #[test]
    fn a_run_is_every_channel_in_order() {
        let run: [Field; 3] = Field::run(Kind::Clo);
        assert_eq!(
            run,
            [
                Field::at(Kind::Clo, 0),
                Field::at(Kind::Clo, 1),
                Field::at(Kind::Clo, 2)
            ]
        );
        assert_eq!(run.map(|f| f.index(5)), [0, 1, 2]);
    }
}
