//! What `check` says of a line's plan: which input plan softplc chose for its MiniMods and why
//! (both floors and what they include), and what `tune: reply_delay` set
//! (`project/line_plan/`).

use softplc_io::line::AdapterTiming;

use crate::project::line_plan::event_mode::{Choice, InputPlan};
use crate::project::line_plan::tune::Tuned;
use crate::project::{BusConfig, Project};
use crate::scan::fmt_duration;

/// The lines `check` prints for `bus` (each to be indented by the caller).
pub(super) fn lines(project: &Project, bus: &BusConfig, adapter: AdapterTiming) -> Vec<String> {
    let mut out = Vec::new();
    let names = |modules: &[usize]| {
        modules
            .iter()
            .filter_map(|&m| project.modules.get(m).map(|m| m.name.as_str()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let held = if adapter.latency.is_zero() {
        String::new()
    } else {
        format!(
            ", up to {} of adapter latency per transaction and per Collect",
            fmt_duration(adapter.latency)
        )
    };
    match &bus.plan.inputs {
        InputPlan::AsWritten => {}
        InputPlan::NotOffered(why) => {
            out.push(format!(
                "input plan: polling (event mode is not offered by default: {why})"
            ));
        }
        InputPlan::Chosen(choice) => out.push(chosen(choice, &names(&choice.modules), &held)),
    }
    if let Some(tuned) = &bus.plan.tuned {
        out.push(tuning(tuned, &names(&tuned.modules), &names(&tuned.own)));
    }
    out
}

fn chosen(c: &Choice, modules: &str, held: &str) -> String {
    let (first, last) = c.window;
    let both = format!(
        "the line's input floor with them polled is {} (each module's reads: request, reply \
         delay, reply, t3.5{held}), in event mode {} (one idle Collect round over window \
         {first}–{last}: request, 3 ms a slot + 1 ms, t3.5, no reply delay; and what the \
         modules read besides their inputs)",
        fmt_duration(c.polling),
        fmt_duration(c.event_mode),
    );
    if c.collect {
        format!(
            "input plan: event mode (Collect) for {modules}, chosen: {both}; each event adds {}, \
             so a round stays cheaper than polling up to {} event(s); a module is read in full \
             when nothing addressed to it was answered for event_refresh (a write's echo \
             counts), which is also when a silent module is seen (an idle round is silence \
             either way), and at least every event_resync, one module a cycle; pin the mode \
             with events: false",
            fmt_duration(c.per_event),
            c.break_even()
        )
    } else {
        format!(
            "input plan: polling for {modules}, chosen: {both}; a round with one event takes {}; \
             pin the mode with events: true",
            fmt_duration(c.event_mode + c.per_event)
        )
    }
}

fn tuning(t: &Tuned, modules: &str, own: &str) -> String {
    let own = if own.is_empty() {
        String::new()
    } else {
        format!("; {own} keep their own RDELAYT")
    };
    format!(
        "tune: reply_delay sets RDELAYT=0 (reply at once; factory 10 ms) on {modules} at every \
         start-up, not saved (no WCONF): {}{own}; input floor {} with it, {} without; a \
         changed output written {} with it, {} without",
        t.why.describe(),
        fmt_duration(t.floor),
        fmt_duration(t.floor_untuned),
        fmt_duration(t.write),
        fmt_duration(t.write_untuned)
    )
}

#[cfg(test)]
mod tests;
