//! What `check` says of a line's kinds of cycle and the overruns a run will show
//! (`softplc_io::line::CycleMix`): the same rules the scan and the bus owner run, played
//! forward with the timing model's costs, so `run --virtual` and the real clock show what
//! `check` predicted (`runtime/tests/cycle_mix.rs` holds them to it).

use softplc_io::line::{CycleMix, Prediction};

use crate::scan::fmt_duration;

/// The lines `check` prints for a line's mix and its prediction at the scan period.
pub(super) fn lines(mix: &CycleMix, p: &Prediction) -> Vec<String> {
    let mut kinds = vec![format!(
        "ordinary {} (each module's reads{})",
        fmt_duration(mix.ordinary),
        if mix.per_event.is_some() {
            " and an idle Collect round"
        } else {
            ""
        }
    )];
    if let Some(w) = mix.modules.iter().filter_map(|m| m.rewrite).max() {
        kinds.push(format!(
            "with an output rewrite +{} (each module every {}, from 3/4 of it on, one a cycle)",
            fmt_duration(w),
            fmt_duration(mix.output_refresh)
        ));
    }
    if let Some(f) = mix
        .modules
        .iter()
        .filter_map(|m| m.full_read)
        .max_by_key(|f| f.cost)
    {
        kinds.push(format!(
            "with a member's full read +{} (when nothing addressed to it answered for {}, and \
             every {} in any case)",
            fmt_duration(f.cost),
            fmt_duration(f.answer_within),
            fmt_duration(f.resync)
        ));
    }
    if let Some(e) = mix.per_event {
        let with_one = mix.ordinary + e;
        kinds.push(format!(
            "with an input change +{} each (one: {}, {})",
            fmt_duration(e),
            fmt_duration(with_one),
            if with_one > p.period {
                "over the period"
            } else {
                "within the period"
            }
        ));
    }
    vec![
        format!("cycle mix: {}", kinds.join("; ")),
        format!(
            "{}; each input change and each output the program changes adds its cost to its \
             cycle",
            predicted(p)
        ),
    ]
}

/// The prediction at the period: `predicted at 20.00ms with idle inputs and unchanged
/// outputs: 321 overrun(s) a minute (10.7% of cycles), the longest cycle …; the first cycle …`.
fn predicted(p: &Prediction) -> String {
    format!(
        "predicted at {} with idle inputs and unchanged outputs: {:.0} overrun(s) a minute \
         ({:.1}% of cycles), the longest cycle {}; the first cycle {} (every module read and \
         written in full)",
        fmt_duration(p.period),
        p.per_minute,
        p.share * 100.0,
        fmt_duration(p.longest),
        fmt_duration(p.first)
    )
}

/// What `check` says of a scan's lines played together (`CycleMix::predict_together`):
/// `task` names the task (`None`: the project's one scan), `lines` its serial lines.
pub(super) fn scan_line(task: Option<&str>, lines: &[&str], p: &Prediction) -> String {
    let whose = whose(task);
    let on = match lines {
        [one] => format!("on line {one}"),
        _ => format!(
            "on lines {} together (a cycle waits for the slowest read and overruns when any \
             line's work runs past its period)",
            lines.join(", ")
        ),
    };
    format!("{whose} {on}: {}", predicted(p))
}

/// `task NAME`, or `the scan` of a project without tasks.
fn whose(task: Option<&str>) -> String {
    match task {
        Some(name) => format!("task {name}"),
        None => "the scan".to_owned(),
    }
}

/// The warning for a scan of several lines that will overrun as a whole (each line's own
/// warning says what it does alone).
pub(super) fn scan_warning(task: Option<&str>, p: &Prediction) -> Option<String> {
    let whose = whose(task);
    (p.per_minute > 0.0).then(|| {
        format!(
            "warning: {whose}: {:.1}% of its cycles will overrun at the period {} ({:.0} a \
             minute with idle inputs, its lines together)",
            p.share * 100.0,
            fmt_duration(p.period),
            p.per_minute
        )
    })
}

/// The warning for a line whose cycles will overrun at the scan period, if they will.
pub(super) fn warning(bus: &str, p: &Prediction) -> Option<String> {
    if !p.inputs_in_time {
        return Some(format!(
            "warning: bus {bus}: an ordinary cycle's reads take longer than the {} the scan \
             waits for inputs (9/10 of the period {}): the line's inputs come every other cycle \
             at best, and {:.0}% of cycles will overrun",
            fmt_duration(p.period * 9 / 10),
            fmt_duration(p.period),
            p.share * 100.0
        ));
    }
    (p.per_minute > 0.0).then(|| {
        format!(
            "warning: bus {bus}: {:.1}% of cycles will overrun at the period {} ({:.0} a \
             minute with idle inputs: the cycles that carry a refresh, up to {}); a longer \
             period, fewer modules on the line or a faster line avoid it",
            p.share * 100.0,
            fmt_duration(p.period),
            p.per_minute,
            fmt_duration(p.longest)
        )
    })
}
