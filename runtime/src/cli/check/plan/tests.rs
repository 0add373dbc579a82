//! What `check` says of a line's input plan and tuning, on projects of the simulated line and
//! a serial port.

use std::path::PathBuf;

use crate::project::{parse_str, ProjectErrors};

/// A project whose buses and modules are `lines` (YAML list items), with a one-line program, in
/// a folder of its own.
fn project(tag: &str, lines: &str) -> Result<crate::project::Project, ProjectErrors> {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("softplc-check-plan-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("p.expr"), "t = t\n").unwrap();
    let text = format!(
        "project: plan\nscan: {{ period: 100ms }}\n{lines}tags:\n  - {{ name: t, type: bool }}\n\
         program: {{ file: p.expr, kind: expr }}\n"
    );
    let parsed = parse_str(&text, &dir.join("project.yaml"));
    // Best effort: the test's scratch folder.
    drop(std::fs::remove_dir_all(&dir));
    parsed
}

fn minimods(bus: &str, addresses: &[u8], settings: &str) -> String {
    let mut s = format!("buses:\n  - {bus}\nmodules:\n");
    for a in addresses {
        s.push_str(&format!(
            "  - {{ name: mm{a}, bus: line1, model: minimod, address: {a}{settings} }}\n"
        ));
    }
    s
}

/// The report's lines that start with `prefix`, trimmed.
fn lines_of(project: &crate::project::Project, prefix: &str) -> Vec<String> {
    super::super::report(project, None)
        .lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with(prefix))
        .map(str::to_string)
        .collect()
}

const SIM: &str = "{ name: line1, port: sim }";

#[test]
fn four_factory_minimods_run_collect_by_default_and_check_says_why() {
    let p = project("four", &minimods(SIM, &[1, 2, 3, 4], "")).unwrap();
    assert!(p.modules.iter().all(|m| match &m.device.settings {
        softplc_io::devices::ModuleSettings::MiniMod(s) => s.events(),
        _ => false,
    }));
    // Polling: 4 × (8 characters + 10 ms + 7 characters + t3.5) = 4 × 20.599 ms; Collect: 8
    // characters + 4 × 3 ms + 1 ms + t3.5 = 19.588 ms; an event 8.745 ms: 7 fit in between.
    assert_eq!(
        lines_of(&p, "input plan:"),
        [
            "input plan: event mode (Collect) for mm1, mm2, mm3, mm4, chosen: the line's input \
          floor with them polled is 82.40ms (each module's reads: request, reply delay, reply, \
          t3.5), in event mode 19.59ms (one idle Collect round over window 1–4: request, 3 ms a \
          slot + 1 ms, t3.5, no reply delay; and what the modules read besides their inputs); \
          each event adds 8.74ms, so a round stays cheaper than polling up to 7 event(s); a \
          module is read in full when nothing addressed to it was answered for event_refresh (a \
          write's echo counts), which is also when a silent module is seen (an idle round is \
          silence either way), and at least every event_resync, one module a cycle; pin the \
          mode with events: false"
        ]
    );
}

#[test]
fn polling_wins_for_one_fast_module_and_for_a_wide_window() {
    // 57600, RDELAYT 0: a poll is 15 characters + t3.5 (4.61 ms), a round 8 characters + 4 ms
    // + t3.5 (7.28 ms).
    let bus = "{ name: line1, port: sim, baud: 57600 }";
    let p = project("one", &minimods(bus, &[1], ", settings: { RDELAYT: 0 }")).unwrap();
    let plan = lines_of(&p, "input plan:");
    assert!(
        plan[0].starts_with("input plan: polling for mm1, chosen: the line's input floor with them polled is 4.61ms") && plan[0].contains("in event mode 7.28ms"),
        "{plan:?}"
    );
    // Modules 1 and 60 at the factory delay: two polls (41.20 ms) against a window of 60
    // slots (4.58 ms + 181 ms + t3.5 = 187.59 ms).
    let p = project("wide", &minimods(SIM, &[1, 60], "")).unwrap();
    let plan = lines_of(&p, "input plan:");
    assert!(
        plan[0].starts_with("input plan: polling for mm1, mm60"),
        "{plan:?}"
    );
    assert!(plan[0].contains("in event mode 187.59ms"), "{plan:?}");
    assert!(
        lines_of(&p, "collect floor").is_empty(),
        "no member, no round"
    );
}

#[test]
fn a_pinned_mode_is_kept_and_a_mixed_line_is_polled() {
    let p = project(
        "pinned",
        &minimods(SIM, &[1, 2], ", settings: { events: false }"),
    )
    .unwrap();
    assert!(lines_of(&p, "input plan:").is_empty());
    assert!(lines_of(&p, "collect floor").is_empty());
    let mixed = format!(
        "{}  - {{ name: r1, bus: line1, model: resi-16di8ro, address: 5 }}\n",
        minimods(SIM, &[1, 2], "")
    );
    let p = project("mixed", &mixed).unwrap();
    assert_eq!(
        lines_of(&p, "input plan:"),
        [
            "input plan: polling (event mode is not offered by default: a model other than the \
          MiniMod is on the line, and every slave hears a Collect broadcast (FC 70 is the \
          MiniMod's own))"
        ]
    );
}

#[test]
fn tune_reply_delay_says_what_it_sets_and_both_floors() {
    let bus = "{ name: line1, port: sim, baud: 57600, tune: reply_delay }";
    let p = project("tuned", &minimods(bus, &[1, 2, 3, 4], "")).unwrap();
    let tuned = lines_of(&p, "tune:");
    assert_eq!(tuned.len(), 1, "{tuned:?}");
    assert!(
        tuned[0].starts_with(
            "tune: reply_delay sets RDELAYT=0 (reply at once; factory 10 ms) on mm1, mm2, mm3, \
             mm4 at every start-up, not saved (no WCONF): the simulated line has no transceiver \
             to turn round; input floor "
        ),
        "{tuned:?}"
    );
    // Tuned polls (4 × 4.61 ms) still lose to a round of 8 characters + 13 ms + t3.5
    // (16.28 ms), which has no reply delay to tune; a changed output (FC 5: 8 + 8
    // characters + t3.5) is written in 4.81 ms instead of 14.81 ms.
    assert!(
        tuned[0].ends_with(
            "input floor 16.28ms with it, 16.28ms without; a changed output written 4.81ms \
             with it, 14.81ms without"
        ),
        "{tuned:?}"
    );
    assert_eq!(
        lines_of(
            &p,
            "input plan: event mode (Collect) for mm1, mm2, mm3, mm4"
        )
        .len(),
        1
    );
    // Two tuned modules: their polls (2 × 4.61 ms) beat the round (8 characters + 7 ms + t3.5
    // = 10.28 ms), whose 3 ms a slot are the manual's at any baud.
    let p = project("tuned2", &minimods(bus, &[1, 2], "")).unwrap();
    assert_eq!(lines_of(&p, "input plan: polling for mm1, mm2").len(), 1);
}

#[test]
fn tune_reply_delay_is_refused_where_the_host_turns_the_line_round() {
    let bus = "{ name: line1, port: /dev/ttyUSB9, tune: reply_delay }";
    let errors = project("refused", &minimods(bus, &[1], ""))
        .unwrap_err()
        .to_string();
    assert!(
        errors.contains(
            "project.yaml:4:46: error: tune: reply_delay needs a line that turns round within a \
             character (MiniMod RDELAYT=0 answers at once): the line's direction control is the \
             host's (direction: host, no rs485:)"
        ),
        "{errors}"
    );
    let slow =
        "{ name: line1, port: /dev/ttyUSB9, rs485: { delay_after_send: 2ms }, tune: reply_delay }";
    let errors = project("slow", &minimods(slow, &[1], ""))
        .unwrap_err()
        .to_string();
    assert!(
        errors.contains("rs485.delay_after_send 2.00ms keeps the transmitter on"),
        "{errors}"
    );
    for fast in [
        "{ name: line1, port: /dev/ttyUSB9, direction: auto, tune: reply_delay }",
        "{ name: line1, port: /dev/ttyUSB9, rs485: {}, tune: reply_delay }",
    ] {
        let p = project("fast", &minimods(fast, &[1], "")).unwrap();
        assert!(p.buses[0].plan.tuned.is_some(), "{fast}");
    }
    let bad = "{ name: line1, port: sim, tune: fast }";
    let errors = project("bad", &minimods(bad, &[1], ""))
        .unwrap_err()
        .to_string();
    assert!(errors.contains("tune must be reply_delay"), "{errors}");
}
