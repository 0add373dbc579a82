//! The operator's page on a panel PC (800 × 480) in headless Chromium: signed in with the
//! operator's token, the operator writes a set point once and acknowledges an alarm; the page
//! never scrolls sideways and its controls are finger-sized; the audit file names the
//! operator for both.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use super::{chromium_available, http, run_plc, screenshots, sign_in_with, Browser, BIN, TOKEN};
use crate::common::host::{free_port, scratch_dir};

const OPERATOR: &str = "operator-token-0123456789";

fn project(dir: &Path, port: u16) {
    std::fs::write(dir.join("engineer.token"), format!("{TOKEN}\n")).unwrap();
    std::fs::write(dir.join("operator.token"), format!("{OPERATOR}\n")).unwrap();
    std::fs::write(dir.join("p.expr"), "lamp = jam\n").unwrap();
    std::fs::write(
        dir.join("project.yaml"),
        format!(
            "project: panel\n\
             scan: {{ period: 20ms }}\n\
             buses:\n  - {{ name: line1, port: sim, response_timeout: 50ms }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
             tags:\n\
             \x20 - {{ name: button, point: mm1.X1, operator: true, description: Start button }}\n\
             \x20 - {{ name: jam, type: bool, alarm: {{ text: Door jammed, priority: high }} }}\n\
             \x20 - {{ name: setpoint, type: u16, operator: true, description: Conveyor speed in mm/s }}\n\
             \x20 - {{ name: lamp, point: mm1.Y1, safe: false }}\n\
             program: {{ file: p.expr, kind: expr }}\n\
             service:\n  web: {{ bind: \"127.0.0.1:{port}\", writes: true, token_file: engineer.token, operator_token_file: operator.token }}\n"
        ),
    )
    .unwrap();
}

/// The page wider than the panel, and the visible controls less than 44 px tall (by name).
const FITS: &str = "(() => { const wide = document.documentElement.scrollWidth > 800 || document.body.scrollWidth > 800; \
     const small = [...document.querySelectorAll('button, input')].filter(c => c.offsetParent !== null && c.getBoundingClientRect().height < 44).map(c => c.outerHTML.slice(0, 60)); \
     return { wide, small }; })()";

#[test]
fn the_operator_writes_once_and_acknowledges_an_alarm_on_a_panel_pc() {
    chromium_available();
    let dir = scratch_dir("web", "operator");
    let port = free_port();
    project(&dir, port);
    let socket = dir.join("ctl.sock");
    let plc = run_plc(&dir.join("project.yaml"), &socket, port);

    let mut b = Browser::start(&dir.join("chromium"));
    b.page(
        "Emulation.setDeviceMetricsOverride",
        serde_json::json!({ "width": 800, "height": 480, "deviceScaleFactor": 1, "mobile": false }),
    );
    b.open(&format!("http://127.0.0.1:{port}/operator"));
    b.wait_for(
        "document.querySelector('.value[data-value=setpoint]') !== null && \
         document.querySelector('.value[data-value=setpoint]').textContent === '0'",
        Duration::from_secs(30),
    )
    .expect("the operator's tags with their live values");
    assert_eq!(b.eval("window.innerWidth"), 800);
    // The input is shown, not writable; the set point is writable once signed in.
    assert_eq!(
        b.eval("document.querySelector('.tag[data-tag=button] form') === null"),
        true,
        "an input offers no write"
    );
    assert_eq!(
        b.eval("document.querySelector('.tag[data-tag=setpoint] .desc').textContent"),
        "Conveyor speed in mm/s"
    );

    // The alarm comes (a write from the CLI, as a machine's condition would set it).
    let out = Command::new(BIN)
        .args(["write", "--socket"])
        .arg(&socket)
        .args(["jam", "1"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    b.wait_for(
        "document.querySelector('li.alarm.active.waiting[data-alarm=jam]') !== null",
        Duration::from_secs(10),
    )
    .expect("the alarm on the operator's page, waiting");
    assert_eq!(
        b.eval("document.querySelector('li.alarm[data-alarm=jam] .text').textContent"),
        "Door jammed"
    );

    sign_in_with(&mut b, OPERATOR);
    let fits = b.eval(FITS);
    assert_eq!(
        fits,
        serde_json::json!({ "wide": false, "small": [] }),
        "at 800 × 480"
    );
    b.screenshot(&screenshots().join("operator-800x480.png"));

    // Write once: 42 reaches the tag (the program does not write it, so it stays).
    b.wait_for(
        "!document.querySelector('form[data-write=setpoint] input').disabled",
        Duration::from_secs(10),
    )
    .expect("signed in, the set point is writable");
    b.eval(
        "document.querySelector('form[data-write=setpoint] input').value = '42'; \
         document.querySelector('form[data-write=setpoint]').requestSubmit(); true",
    );
    b.wait_for(
        "document.querySelector('.value[data-value=setpoint]').textContent === '42'",
        Duration::from_secs(10),
    )
    .expect("the written value comes back live");

    // Acknowledge: still active (jam is still 1), no longer waiting.
    b.eval("document.querySelector('button[data-ack=jam]').click(); true");
    b.wait_for(
        "(() => { const li = document.querySelector('li.alarm[data-alarm=jam]'); \
           return li !== null && li.classList.contains('active') && !li.classList.contains('waiting'); })()",
        Duration::from_secs(10),
    )
    .expect("acknowledged on the page");
    let fits = b.eval(FITS);
    assert_eq!(
        fits,
        serde_json::json!({ "wide": false, "small": [] }),
        "after the actions"
    );
    b.screenshot(&screenshots().join("operator-800x480-acknowledged.png"));

    let (code, text) = http(
        port,
        &format!("GET /api/alarms HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"),
    );
    assert_eq!(code, 200, "{text}");
    let alarms: serde_json::Value = serde_json::from_str(&text).unwrap();
    let jam = &alarms["current"][0];
    assert_eq!(
        (jam["name"].as_str(), jam["active"].as_bool()),
        (Some("jam"), Some(true))
    );
    assert_eq!(jam["acknowledged"], true);
    assert!(
        jam["acked_by"]
            .as_str()
            .is_some_and(|s| s.starts_with("web 127.0.0.1:") && s.ends_with(" operator")),
        "{jam}"
    );

    // The audit names the operator for the write and the acknowledgement.
    let end = Instant::now() + Duration::from_secs(10);
    let entries = loop {
        let (_, text) = http(
            port,
            &format!("GET /api/audit HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"),
        );
        let audit: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        let entries = audit["entries"].as_array().cloned().unwrap_or_default();
        if entries.len() >= 3 || Instant::now() > end {
            break entries;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let seen: Vec<(String, String, String)> = entries
        .iter()
        .map(|e| {
            let source = e["source"].as_str().unwrap_or_default();
            let who = if source == "cli" {
                "cli"
            } else {
                source.rsplit(' ').next().unwrap_or_default()
            };
            (
                e["action"].as_str().unwrap_or_default().to_owned(),
                e["what"].as_str().unwrap_or_default().to_owned(),
                who.to_owned(),
            )
        })
        .collect();
    let t = |a: &str, w: &str, r: &str| (a.to_owned(), w.to_owned(), r.to_owned());
    assert_eq!(
        seen,
        [
            t("acknowledge", "jam", "operator"),
            t("write", "setpoint=42", "operator"),
            t("write", "jam=1", "cli"),
        ],
        "newest first"
    );
    drop(b);
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
