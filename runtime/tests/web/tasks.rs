//! The page of a PLC of several tasks in headless Chromium (the two-tasks example on the
//! real clock, its lines simulated, the page on loopback port 0): the Program view draws both
//! tasks' ladders under each task's name and period, each lit by its own task (the panel
//! task's rung energised by the panel's own input once forced, its blinker's output from the
//! panel's blocks); the Trace view's task picker follows the signals typed as the router
//! would, and a trace armed from it names its task in the table and the plot.

use std::time::Duration;

use super::{chromium_available, screenshots, sign_in_with, Browser};
use crate::common::host::{log_value, Running};
use crate::common::scratch::Scratch;

const ENGINEER: &str = "tasks-page-engineer";

/// The example with the page (writes with [`ENGINEER`]) on loopback port 0, running; the
/// page's address as the log says it.
fn run_example() -> (Scratch, Running, String) {
    let s = crate::task_services::example_with_services(
        "web-page",
        &format!("  web: {{ bind: 127.0.0.1:0, writes: true, token: {ENGINEER} }}\n"),
    );
    let run = crate::task_services::start(&s);
    let web = log_value(&s.dir.join("log"), "web page: http://");
    (s, run, web)
}

/// What the elements of rung `rung` of the ladder `ladder` (an element id) pass or hold:
/// `1`/`0` per contact and coil, in drawing order.
fn lit(ladder: &str, rung: u32) -> String {
    format!(
        "(() => {{ const s = document.querySelector('#{ladder} svg[data-rung=\"{rung}\"]'); \
         return s ? [...s.querySelectorAll('.lad-el')].map(e => e.dataset.passes ?? e.dataset.energised).join('') : 'none'; }})()"
    )
}

#[test]
fn the_page_draws_every_tasks_ladders_lit_by_their_own_task_and_traces_name_the_task() {
    chromium_available();
    let (s, _run, web) = run_example();
    let mut b = Browser::start(&s.dir.join("chromium"));
    b.open(&format!("http://{web}/#program"));
    b.wait_for(
        "document.querySelector('#p2-ladder .lad-block') !== null",
        Duration::from_secs(30),
    )
    .expect("the panel task's ladder drawn");
    assert_eq!(
        b.eval("[...document.querySelectorAll('#program .program-task')].map(e => e.textContent)"),
        serde_json::json!(["Task press · every 30.0 ms", "Task panel · every 500 ms"])
    );
    assert_eq!(
        b.eval("[...document.querySelectorAll('#program .program-part')].map(e => e.dataset.task + ':' + e.dataset.program)"),
        serde_json::json!(["press:press.ladder.yaml", "panel:panel.ladder.yaml"])
    );
    assert_eq!(
        b.eval("document.getElementById('program-title').textContent"),
        "press: press.ladder.yaml + panel: panel.ladder.yaml"
    );
    // The panel's guard-open rung runs its own BLINK: the guard is open (guard_closed is the
    // press's input, off), and the box shows the panel's blinker turning on and off.
    let blink = "document.querySelector('#p2-ladder svg[data-rung=\"3\"] .lad-block').textContent";
    for q in ["Q 1", "Q 0"] {
        let shown = b.wait_for(
            &format!("{blink}.startsWith('guard_blinkBLINK') && {blink}.includes('{q}')"),
            Duration::from_secs(15),
        );
        assert!(
            shown.is_some(),
            "the panel's blinker {q}: {}",
            b.eval(blink)
        );
    }
    // The panel's enable rung is dark until the panel's own input (its key switch, forced
    // from the page) energises it; the press's two-hand rung then sees `enabled` pass.
    let settled = |b: &mut Browser, ladder: &str, rung: u32, want: &str| {
        let expr = lit(ladder, rung);
        if b.wait_for(&format!("{expr} === '{want}'"), Duration::from_secs(20))
            .is_none()
        {
            panic!(
                "{ladder} rung {rung} lit {} instead of {want}",
                b.eval(&expr)
            );
        }
    };
    settled(&mut b, "p2-ladder", 1, "00");
    settled(&mut b, "ladder", 1, "00000");
    sign_in_with(&mut b, ENGINEER);
    // The panel's slow line takes seconds to start: until its task scans, nothing answers.
    let force = format!(
        "fetch('/api/force', {{ method: 'POST', headers: {{ 'Content-Type': 'application/json', \
         'Authorization': 'Bearer {ENGINEER}' }}, body: JSON.stringify({{ tag: 'key_on', value: '1' }}) }}).then(r => r.status)"
    );
    let mut status = serde_json::Value::Null;
    for _ in 0..30 {
        status = b.eval(&force);
        if status == 200 {
            break;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    assert_eq!(status, 200, "the force of key_on");
    settled(&mut b, "p2-ladder", 1, "11");
    settled(&mut b, "ladder", 1, "00010");
    b.screenshot(&screenshots().join("tasks-program.png"));

    // The Trace view: the picker lists the tasks and follows the signals typed.
    b.eval("location.hash = '#trace'; true");
    assert_eq!(
        b.eval("[...document.querySelectorAll('#trace-task option')].map(o => o.textContent)"),
        serde_json::json!(["press (30.0 ms)", "panel (500 ms)"])
    );
    let typed = |b: &mut Browser, tags: &str, trigger: &str| {
        b.eval(&format!(
            "document.getElementById('trace-tags').value = '{tags}'; \
             document.getElementById('trace-tags').dispatchEvent(new Event('input')); \
             document.getElementById('trace-trigger').value = '{trigger}'; \
             document.getElementById('trace-trigger').dispatchEvent(new Event('input')); \
             document.getElementById('trace-task').value"
        ))
    };
    assert_eq!(
        typed(&mut b, "enabled, strokes", ""),
        "panel",
        "enabled's writer"
    );
    assert_eq!(
        typed(&mut b, "enabled, strokes", "press_down rising"),
        "press"
    );
    assert_eq!(typed(&mut b, "key_on, guard_lamp", ""), "panel");
    assert_eq!(
        typed(&mut b, "phase.cycle", ""),
        "press",
        "no owner: the first task"
    );
    typed(&mut b, "key_on, guard_lamp", "");
    b.eval(
        "document.getElementById('trace-name').value = 'panel_trace'; \
         document.getElementById('trace-pre').value = '0'; \
         document.getElementById('trace-post').value = '4'; \
         document.getElementById('trace-form').requestSubmit(); true",
    );
    let row =
        "(document.querySelector('#trace-table tr[data-trace=panel_trace] td') || {}).textContent";
    b.wait_for(
        &format!("{row} === 'panel_trace (task panel)'"),
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("the trace's row: {}", b.eval(row)));
    let title = "document.getElementById('trace-plot-title').textContent";
    b.wait_for(
        &format!("{title}.startsWith('Trace panel_trace · task panel · ')"),
        Duration::from_secs(15),
    )
    .unwrap_or_else(|| panic!("the plot's title: {}", b.eval(title)));
    b.screenshot(&screenshots().join("tasks-trace.png"));
}
