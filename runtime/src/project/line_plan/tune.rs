//! `tune: reply_delay` on a bus: every MiniMod on it answers as soon as the line's direction
//! control allows ([`super::direction`]), for this run only.
//!
//! The MiniMod waits its reply delay before every reply but a Collect's: RDELAYT hundredths
//! of a second, "Minimod waits 1/100 of a second" from the factory ("Setting the reply
//! delay"); 0 to 200 are accepted. Tuning adds `RDELAYT = 0` to the settings of each MiniMod
//! of the bus that does not set its own, so the driver sends `>RDELAYT=0` at the end of every
//! start-up sequence and never `>WCONF=1`: the module keeps its saved delay in flash, and
//! comes back from a power cycle with it ("AFTER HAVING MODIFIED THE SETTINGS, remember to
//! store them in memory"; a power cycle restores "the settings from internal stored
//! preferences"). The bus owner runs the start-up again for a module that comes back after
//! it was lost (DESIGN.md, the rules of a line), which applies the tuning again.
//!
//! Validation refuses it, at the bus's `tune`, on a line that does not turn round within a
//! character; other models on the bus keep their delays (a RESI's and an EX-9053's are not
//! the master's to set at run time).

use std::time::Duration;

use softplc_io::devices::{ModuleSettings, ReplyDelayTuning};

use super::super::model::Project;
use super::direction::{turnaround, FastTurn};

/// The one tuning there is.
pub(crate) const REPLY_DELAY: &str = "reply_delay";

/// What tuning did on one bus.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tuned {
    /// Why the line allows it.
    pub why: FastTurn,
    /// The modules set to RDELAYT = 0 (indexes into [`Project::modules`]).
    pub modules: Vec<usize>,
    /// MiniMods left at their own RDELAYT.
    pub own: Vec<usize>,
    /// The line's input floor as planned (a Collect round has no reply delay, but the
    /// polls and the refreshes do).
    pub floor: Duration,
    /// The same without the tuning.
    pub floor_untuned: Duration,
    /// A write of one changed output of a tuned module, with the tuning.
    pub write: Duration,
    /// The same without.
    pub write_untuned: Duration,
}

/// Adds the tuning to bus `b`'s MiniMods, when the bus asks for it; what it did.
pub(super) fn apply(project: &mut Project, b: usize) -> Option<Tuned> {
    let bus = project.buses.get(b)?;
    if !bus.tune_reply_delay {
        return None;
    }
    // Validation refused it already where it does not hold.
    let why = turnaround(bus).ok()?;
    let (mut modules, mut own) = (Vec::new(), Vec::new());
    for m in super::on_bus(project, b) {
        let module = &mut project.modules[m];
        match module
            .model
            .family
            .tune_reply_delay(&mut module.device.settings)
        {
            ReplyDelayTuning::NotTunable => {}
            ReplyDelayTuning::Own => own.push(m),
            ReplyDelayTuning::Tuned => modules.push(m),
        }
    }
    Some(Tuned {
        why,
        floor: Duration::ZERO,
        floor_untuned: Duration::ZERO,
        write: Duration::ZERO,
        write_untuned: Duration::ZERO,
        modules,
        own,
    })
}

/// Fills in the floors of `tuned` once the line's input mode is chosen: as planned, and with
/// the tuned modules at their factory delay.
pub(super) fn floors(project: &Project, b: usize, tuned: &mut Tuned) {
    let modules = tuned.modules.clone();
    let untuned = move |m: usize, settings: &mut ModuleSettings| {
        if modules.contains(&m) {
            project.modules[m]
                .model
                .family
                .factory_reply_delay(settings);
        }
    };
    tuned.floor = super::floor_with(project, b, &|_, _| {});
    tuned.floor_untuned = super::floor_with(project, b, &untuned);
    if let Some(&m) = tuned.modules.first() {
        tuned.write = super::change_write_with(project, m, &|_, _| {});
        tuned.write_untuned = super::change_write_with(project, m, &untuned);
    }
}
