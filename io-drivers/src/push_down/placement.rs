//! What a module's own logic runs in a rung's place, and why a rung stays in the scan: the
//! vocabulary between the runtime's planner and each device family's push-down target
//! ([`crate::devices::Family::push_down`]).

use std::fmt;
use std::time::Duration;

use crate::devices::minimod::{self as mm, PulseWidth};
use crate::devices::resi as r;
use crate::rung::BoolExpr;
use crate::time::fmt_duration;

/// One register the planner writes into a module at start-up (read back and verified by the
/// driver; cleared at stop unless the project keeps the tables).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TableEntry {
    /// The register's name in the model's map (`Y1AON1`, `SWITCH_RO3`).
    pub register: &'static str,
    /// Its value.
    pub value: u32,
    /// A bit mask (shown in hex) rather than a number.
    pub mask: bool,
    /// What it means, for the report (`X1-X2`).
    pub meaning: String,
}

/// A write the scan sends to a module at run time instead of the output itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Command {
    /// MiniMod pulser: on an edge of `trigger` (evaluated centrally, after the logic) while no
    /// pulse runs, write `width_ms` to the pulser register `point` (`YPULSEn`); the module
    /// holds the output on for exactly that many ms.
    Pulse {
        /// Index of the pulser register among the model's points.
        point: usize,
        /// Starts the pulse.
        trigger: Vec<BoolExpr>,
        /// Length.
        width: Duration,
        /// The register value.
        width_ms: PulseWidth,
    },
    /// MiniMod blinker: the scan writes `mask` to the blinker register `point` (`YLAMPn`)
    /// when `enable` (evaluated centrally, after the logic) rises and 0 when it falls; the
    /// module plays the mask on its own free-running 100 ms steps.
    Lamp {
        /// Index of the blinker register among the model's points.
        point: usize,
        /// Shows the mask while true.
        enable: BoolExpr,
        /// The register value: bit k is shown during step k of 16.
        mask: u16,
    },
}

/// Which module feature runs the rung.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// MiniMod YnAON1..3 / YnAOFF1..3.
    AutoOnOff,
    /// MiniMod YPULSEn, triggered by the scan.
    Pulser,
    /// MiniMod YLAMPn, enabled by the scan.
    Lamp,
    /// RESI-16DI8RO SWITCH.
    Switch,
    /// RESI-16DI8RO SWITCH ON + SWITCH OFF.
    SwitchOnOff,
    /// RESI-16DI8RO TOGGLE.
    Toggle,
    /// RESI-16DI8RO PULSE + PULSE TIME.
    Pulse,
}

impl Feature {
    /// The manual's name.
    pub fn name(self) -> &'static str {
        match self {
            Feature::AutoOnOff => "automatic outputs AON/AOFF (an OFF condition wins)",
            Feature::Pulser => "pulser YPULSE",
            Feature::Lamp => "blinker YLAMP",
            Feature::Switch => "SWITCH",
            Feature::SwitchOnOff => "SWITCH ON / SWITCH OFF",
            Feature::Toggle => "TOGGLE",
            Feature::Pulse => "PULSE",
        }
    }
}

/// A rung placed in a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModulePlacement {
    /// Index of the module among the project's modules.
    pub module: usize,
    /// The coil's output point, among the model's points.
    pub point: usize,
    /// The module feature.
    pub feature: Feature,
    /// Registers written at start-up, for the report and the clear at stop.
    pub tables: Vec<TableEntry>,
    /// The same tables as the driver takes them.
    pub pushed: Pushed,
    /// What the scan writes at run time, if anything.
    pub command: Option<Command>,
    /// The module's own reaction: its tick (input conditioning comes on top, for the module
    /// and for the scan alike).
    pub tick: Duration,
    /// The output's value written at start-up, after the module's old tables are cleared and
    /// before these are armed, when the rung keeps a state (a latch, a toggle, an edge set /
    /// reset, a pulse): the module never resets an output when its tables are written, so
    /// without it a pushed-down output would start from whatever the module held (a latch left
    /// on by a crashed run would stay on). It is the central rung's start: the tag's initial
    /// value, no pulse running. `None` for a combinational rung or a SWITCH: the module sets
    /// those from its inputs at once, as the first scan would.
    pub initial: Option<bool>,
}

/// A placement's tables as the module's driver takes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// No table (a pulser is driven by the scan).
    Nothing,
    /// A MiniMod output's AON/AOFF conditions.
    MiniMod(mm::AutoOutput),
    /// A RESI-16DI8RO relay's logic row.
    Resi(r::LogicRow),
}

/// Why a rung stays central.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reason {
    /// `offload: never`; `pushable` tells whether `auto` would push it down.
    Never {
        /// Set on the coil's tag (else the project's mode).
        by_tag: bool,
        /// What `auto` would do: the module placement it would get.
        would: Option<Box<ModulePlacement>>,
    },
    /// The engine says the rung is none of the module's forms.
    Opaque(String),
    /// The coil is not a module output.
    NotAnOutput {
        /// What it is (`a memory tag`).
        what: String,
    },
    /// The coil's module has no logic tables.
    NoTables {
        /// The module.
        module: String,
        /// Its model.
        model: &'static str,
    },
    /// A condition reads a memory tag.
    Memory {
        /// The tag.
        tag: String,
    },
    /// A condition reads a point of a bus another task owns: the task running the rung only
    /// copies its value in at its cycle's start.
    OtherTask {
        /// The tag.
        tag: String,
        /// The task owning its bus.
        task: String,
        /// The bus.
        bus: String,
    },
    /// A condition reads a point of another module.
    OtherModule {
        /// The tag.
        tag: String,
        /// Its module.
        module: String,
    },
    /// A condition reads a point of the module its logic cannot check.
    NotCheckable {
        /// The tag.
        tag: String,
        /// Its point.
        point: &'static str,
        /// What the module checks.
        checks: &'static str,
    },
    /// The sum of products does not fit.
    TooManyTerms {
        /// ON conditions needed.
        on: usize,
        /// OFF conditions needed.
        off: usize,
    },
    /// A time the module cannot represent.
    Time {
        /// The time.
        time: Duration,
        /// What the module takes.
        takes: &'static str,
    },
    /// The coil is written by more than this rung.
    WrittenElsewhere {
        /// By what.
        by: String,
    },
    /// The module has no such function.
    Unsupported {
        /// Why, in words.
        why: &'static str,
    },
    /// The module's tables cannot be read back to verify them on this protocol.
    NotVerifiable {
        /// Why.
        why: &'static str,
    },
    /// The pulse trigger reads a coil written later in the scan (or the rung's own coil).
    TriggerReadsLater {
        /// The tag.
        tag: String,
    },
    /// The module's settings already set a register the rung needs.
    SettingTaken {
        /// The register.
        register: String,
    },
    /// A BLINK the module could play, but whose phase the engineer has not freed: a BLINK
    /// starts on when its enable rises, the module's blinker steps run freely.
    BlinkPhase {
        /// The mask it would get.
        mask: u16,
    },
    /// A blinker whose timing the module's 16 steps of 100 ms cannot repeat.
    BlinkTiming {
        /// The blinker as written (`500ms on, 500ms off`).
        blink: String,
        /// What does not fit, in words.
        why: &'static str,
        /// On/off times near it that would go down.
        nearby: Vec<(Duration, Duration)>,
    },
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reason::Never { by_tag, would } => {
                let whose = if *by_tag {
                    "the tag's"
                } else {
                    "the project's"
                };
                write!(f, "offload: never ({whose} choice)")?;
                if let Some(p) = would {
                    write!(f, "; auto would push it into {}", p.feature.name())?;
                }
                Ok(())
            }
            Reason::Opaque(why) => f.write_str(why),
            Reason::NotAnOutput { what } => write!(f, "the coil is {what}, not a module output"),
            Reason::NoTables { module, model } => {
                write!(f, "module {module} ({model}) has no logic tables")
            }
            Reason::Memory { tag } => write!(
                f,
                "memory or a timer in the condition: {tag} is a memory tag, which the module \
                 cannot see"
            ),
            Reason::OtherTask { tag, task, bus } => write!(
                f,
                "an input of another task: {tag} is on bus {bus}, which task {task} owns; this \
                 task copies its value at its cycle's start, and no module of this task's \
                 buses sees it"
            ),
            Reason::OtherModule { tag, module } => {
                write!(f, "an input from another module: {tag} is on {module}")
            }
            Reason::NotCheckable { tag, point, checks } => write!(
                f,
                "{tag} ({point}) cannot be checked by the module's logic, which checks {checks}"
            ),
            Reason::TooManyTerms { on, off } => write!(
                f,
                "too many terms: the condition needs {on} ON and {off} OFF conditions, the \
                 module has 3 of each"
            ),
            Reason::Time { time, takes } => write!(
                f,
                "a time the module cannot represent: {} (it takes {takes})",
                fmt_duration(*time)
            ),
            Reason::WrittenElsewhere { by } => {
                write!(f, "an output also written elsewhere: {by}")
            }
            Reason::Unsupported { why } => f.write_str(why),
            Reason::NotVerifiable { why } => f.write_str(why),
            Reason::TriggerReadsLater { tag } => write!(
                f,
                "the trigger reads {tag}, which is written by this rung or a later one (the \
                 scan evaluates the trigger after the logic)"
            ),
            Reason::SettingTaken { register } => write!(
                f,
                "the module's settings already set {register}; remove it there to let the \
                 planner write it"
            ),
            Reason::BlinkPhase { mask } => write!(
                f,
                "a BLINK starts on when its enable rises, and the module's blinker steps run \
                 freely from its power-on; with `blink_phase: free` on the tag (or a LAMP \
                 block) it would go down as YLAMP = {mask:#06x}"
            ),
            Reason::BlinkTiming { blink, why, nearby } => {
                write!(f, "a blinker the module cannot play: {blink}: {why}")?;
                let near: Vec<String> = nearby
                    .iter()
                    .map(|(on, off)| format!("{}ms/{}ms", on.as_millis(), off.as_millis()))
                    .collect();
                match near.as_slice() {
                    [] => Ok(()),
                    [one] => write!(f, "; {one} would go down"),
                    [first @ .., last] => {
                        write!(f, "; {} or {last} would go down", first.join(", "))
                    }
                }
            }
        }
    }
}
