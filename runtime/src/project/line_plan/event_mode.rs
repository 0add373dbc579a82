//! The default input mode of a line of MiniMods: event mode (FC 70 Collect) where its floor is
//! lower than polling's. Which modules can join a Collect round, and which leave their mode
//! open, their families say ([`softplc_io::devices::InputModes`]).
//!
//! MiniMod manual, "Modbus function “Collect” (event management)": the function "lowers the
//! required time down to 5% of the original time when no variations have happened". Whether it
//! does on a given line depends on the line: an idle round costs one request, 3 ms for every
//! address of the window and 1 ms ("The Modbus function Collect"), where polling costs each
//! module a request, its reply delay (10 ms from the factory) and its reply. So the choice is
//! made per line from the two floors, with the timing model `check` uses
//! (`softplc_io::line::input_floor`: every reply delay, the adapter's latency per
//! transaction and per Collect):
//! - the candidates are the modules whose mode is open: MiniMods (Modbus protocol) whose
//!   settings do not say `events:`;
//!   a module that says `events: true` or `events: false` keeps it (that is how a project pins
//!   the mode);
//! - they get `events: true` when the line's input floor with them in the round is lower than
//!   with them polled, for a round that carries one event: a plan that wins only while nothing
//!   changes loses at the first change, the cycle the program needs soonest. The floors of
//!   both plans are kept for `check`.
//!
//! Where event mode is not offered by default: a line with a module of another model (every
//! slave hears a Collect broadcast, and only the MiniMod's manual says what it does with
//! FC 70), a Modbus TCP bus (a gateway answers a broadcast with nothing), and text-protocol
//! MiniMods (the project chose to talk to them in text). A round with events costs more than
//! an idle one ([`softplc_io::line::CollectFloor::per_event`]); `check` says
//! up to how many events a round Collect stays the cheaper.

use std::time::Duration;

use softplc_io::devices::ModuleSettings;
use softplc_io::line::CollectFloor;

use super::super::model::Project;

/// How a bus's MiniMods read their inputs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum InputPlan {
    /// No MiniMod whose mode is left open: every mode is the project's.
    #[default]
    AsWritten,
    /// Polled, event mode not offered here: why.
    NotOffered(&'static str),
    /// Chosen from the two floors.
    Chosen(Choice),
}

/// A choice between the two plans.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Choice {
    /// Whether the candidates run Collect.
    pub collect: bool,
    /// The modules chosen for (indexes into [`Project::modules`]).
    pub modules: Vec<usize>,
    /// The line's input floor with them polled.
    pub polling: Duration,
    /// The line's input floor with them in event mode: an idle round.
    pub event_mode: Duration,
    /// What each event adds to a round (not from the window's last address).
    pub per_event: Duration,
    /// The Collect window of the event-mode plan.
    pub window: (u8, u8),
}

impl Choice {
    /// How many events a round may carry with Collect still no slower than polling.
    pub fn break_even(&self) -> u32 {
        let margin = self.polling.saturating_sub(self.event_mode);
        if self.per_event.is_zero() {
            return 0;
        }
        (margin.as_nanos() / self.per_event.as_nanos()) as u32
    }
}

/// Why bus `b`'s modules cannot have event mode by default, if they cannot.
fn not_offered(project: &Project, b: usize, modules: &[usize]) -> Option<&'static str> {
    if project
        .buses
        .get(b)
        .is_some_and(|bus| bus.port.is_modbus_tcp())
    {
        return Some("a Modbus TCP bus: a gateway answers no broadcast, and Collect is one");
    }
    if modules
        .iter()
        .any(|&m| !super::input_modes(&project.modules[m]).collect)
    {
        return Some(
            "a model other than the MiniMod is on the line, and every slave hears a Collect \
             broadcast (FC 70 is the MiniMod's own)",
        );
    }
    None
}

/// Chooses for bus `b`'s open MiniMods, adding `events: true` where Collect is cheaper.
pub(super) fn apply(project: &mut Project, b: usize) -> InputPlan {
    let modules = super::on_bus(project, b);
    let candidates: Vec<usize> = modules
        .iter()
        .copied()
        .filter(|&m| super::input_modes(&project.modules[m]).open)
        .collect();
    if candidates.is_empty() {
        return InputPlan::AsWritten;
    }
    if let Some(why) = not_offered(project, b, &modules) {
        return InputPlan::NotOffered(why);
    }
    let polling = super::floor_with(project, b, &|_, _| {});
    let with_events = |m: usize, settings: &mut ModuleSettings| {
        if candidates.contains(&m) {
            project.modules[m].model.family.choose_events(settings);
        }
    };
    let event_mode = super::floor_with(project, b, &with_events);
    let member_modules: Vec<usize> = modules
        .iter()
        .copied()
        .filter(|&m| candidates.contains(&m) || super::input_modes(&project.modules[m]).events)
        .collect();
    let members: Vec<u8> = member_modules
        .iter()
        .map(|&m| {
            project.modules[m]
                .device
                .address
                .unit()
                .map_or(0, |u| u.get())
        })
        .collect();
    // A member's RDELAYM starts every slot later ("Setting the Modbus communication timeout").
    let frame_timeout = member_modules
        .iter()
        .map(|&m| super::input_modes(&project.modules[m]).frame_timeout)
        .max()
        .unwrap_or_default();
    let floor = project.buses.get(b).and_then(|bus| {
        CollectFloor::over(bus.settings, super::adapter(project, b), &members)
            .map(|f| f.with_frame_timeout(frame_timeout))
    });
    let per_event = floor.map_or(Duration::ZERO, |f| f.per_event());
    let collect = event_mode + per_event < polling;
    if collect {
        for &m in &candidates {
            let module = &mut project.modules[m];
            module
                .model
                .family
                .choose_events(&mut module.device.settings);
        }
    }
    InputPlan::Chosen(Choice {
        collect,
        modules: candidates,
        polling,
        event_mode,
        per_event,
        window: floor.map_or((0, 0), |f| f.window()),
    })
}
