//! The plant services of a PLC of several tasks (the two-tasks example with the metrics and
//! the web page on loopback port 0, real clock): they show every task's tags, and a force
//! from the page reaches the task owning the tag, whose result every service then shows.
//! With a slow first task and a fast task counting every cycle, an OPC UA client and a
//! Sparkplug host see every step of the count and every toggle of the slow task, both tasks'
//! modules (OPC UA `Modules`, a DBIRTH each, the metrics, the page) and the fast task's force
//! (`status`, an OPC UA write refused with BadLocked, Sparkplug's values, the metrics, the
//! page).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host::{log_value, repo, Running};
use crate::common::scratch::Scratch;

const TOKEN: &str = "two-tasks-engineer";

/// The example (ladder) copied with a `service:` section, in a scratch folder.
pub(crate) fn example_with_services(case: &str, service: &str) -> Scratch {
    let s = Scratch::new("task_services", case);
    for f in ["press.ladder.yaml", "panel.ladder.yaml"] {
        std::fs::copy(repo().join("examples/two-tasks").join(f), s.dir.join(f))
            .expect("copy the example");
    }
    let yaml = std::fs::read_to_string(repo().join("examples/two-tasks/project.yaml"))
        .expect("the example");
    s.write("project.yaml", &format!("{yaml}\nservice:\n{service}"));
    s
}

/// The `service:` lines of the metrics and the web page (writes with [`TOKEN`]) on
/// loopback port 0.
fn web_and_metrics() -> String {
    format!(
        "  metrics: 127.0.0.1:0\n  web: {{ bind: 127.0.0.1:0, writes: true, token: {TOKEN} }}\n"
    )
}

/// [`start`], then the addresses of the page and the metrics as the log says them.
fn start_serving(s: &Scratch) -> (Running, String, String) {
    let run = start(s);
    let log = s.dir.join("log");
    let web = log_value(&log, "web page: http://");
    let metrics = log_value(&log, "metrics at http://");
    (run, web, metrics)
}

/// `softplc run` of `s`'s project with its control socket `s.sock`.
pub(crate) fn start(s: &Scratch) -> Running {
    let log = std::fs::File::create(s.dir.join("log")).expect("a log file");
    Running(
        Command::new(env!("CARGO_BIN_EXE_softplc"))
            .arg("run")
            .arg(s.dir.join("project.yaml"))
            .args(["--for", "60s", "--quiet", "--socket"])
            .arg(s.dir.join("s.sock"))
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("softplc runs"),
    )
}

/// A broker for `s`'s project, whose `service:` gets an MQTT edge node `node` of group
/// `plant1` on it; the broker (stopped when dropped), its port and the Sparkplug payload
/// module's folder.
pub(crate) fn with_broker(s: &Scratch, node: &str) -> (crate::common::broker::Broker, u16, String) {
    let port = crate::common::host::free_port();
    let broker = crate::common::broker::Broker::start(&s.dir, port);
    let python = repo().join("target/py-venv/bin/python");
    let pb2 = crate::common::broker::sparkplug_pb2(&python, &s.dir);
    s.write(
        "project.yaml",
        &format!(
            "{}  mqtt: {{ host: 127.0.0.1, port: {port}, group: plant1, node: {node} }}\n",
            std::fs::read_to_string(s.dir.join("project.yaml")).expect("the project")
        ),
    );
    (broker, port, pb2.to_str().expect("UTF-8").to_owned())
}

/// One HTTP request: (status, body).
fn http(addr: &str, request: &str) -> (u16, String) {
    let Ok(mut c) = TcpStream::connect(addr) else {
        return (0, String::new());
    };
    drop(c.set_read_timeout(Some(Duration::from_secs(10))));
    drop(c.write_all(request.as_bytes()));
    let mut out = String::new();
    // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
    drop(c.read_to_string(&mut out));
    let status = out
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let body = out.split("\r\n\r\n").nth(1).unwrap_or("").to_owned();
    (status, body)
}

pub(crate) fn get(addr: &str, path: &str) -> String {
    let (code, body) = http(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"),
    );
    assert_eq!(code, 200, "GET {path}: {body}");
    body
}

/// Polls `what` every 100 ms until it holds (at most `within`); the last text seen.
fn wait_until(within: Duration, mut what: impl FnMut() -> (bool, String)) -> String {
    let begin = Instant::now();
    loop {
        let (done, text) = what();
        if done {
            return text;
        }
        assert!(begin.elapsed() < within, "not within {within:?}:\n{text}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn the_services_show_every_tasks_tags_and_a_force_from_the_page_reaches_its_owner() {
    let s = example_with_services("web-metrics", &web_and_metrics());
    let (_run, web, metrics) = start_serving(&s);
    // Tags of both tasks, as the first task's image holds them (it copies the others').
    let text = wait_until(Duration::from_secs(20), || {
        let text = get(&metrics, "/metrics");
        (
            text.contains("softplc_tag_value{tag=\"strokes\"} 0")
                && text.contains("softplc_tag_value{tag=\"key_on\"} 0")
                && text.contains("softplc_tag_value{tag=\"enabled\"} 0"),
            text,
        )
    });
    assert!(
        text.contains("softplc_tag_quality{tag=\"key_on\"}"),
        "{text}"
    );
    // Each task's figures, labelled with its name; the panel's cycles grow on its own period.
    let scans = |text: &str, task: &str| -> Option<u64> {
        let key = format!("softplc_task_scans_total{{task=\"{task}\"}} ");
        text.lines()
            .find_map(|l| l.strip_prefix(key.as_str()))
            .and_then(|v| v.parse().ok())
    };
    let first = wait_until(Duration::from_secs(20), || {
        let text = get(&metrics, "/metrics");
        (scans(&text, "panel").is_some_and(|n| n >= 1), text)
    });
    assert!(
        first.contains("softplc_task_period_seconds{task=\"press\"} 0.03"),
        "{first}"
    );
    assert!(
        first.contains("softplc_task_period_seconds{task=\"panel\"} 0.5"),
        "{first}"
    );
    for family in [
        "softplc_task_overruns_total",
        "softplc_task_cycle_p99_seconds",
        "softplc_task_cycle_max_seconds",
        "softplc_task_lateness_p99_seconds",
    ] {
        assert!(
            first.contains(&format!("{family}{{task=\"panel\"}} ")),
            "{first}"
        );
    }
    let (press, panel) = (scans(&first, "press"), scans(&first, "panel"));
    wait_until(Duration::from_secs(20), || {
        let text = get(&metrics, "/metrics");
        (
            scans(&text, "press") > press && scans(&text, "panel") > panel,
            text,
        )
    });
    // The panel task owns key_on: the page's force goes to it, its program sets `enabled`,
    // the press task copies that in, and the services (on the press task's boundary) see it.
    // The panel's slow line takes seconds to start: until its task scans, nothing answers.
    let body = r#"{"tag":"key_on","value":"1"}"#;
    wait_until(Duration::from_secs(30), || {
        let (code, text) = http(
            &web,
            &format!(
                "POST /api/force HTTP/1.1\r\nHost: {web}\r\nConnection: close\r\n\
                 Content-Type: application/json\r\nAuthorization: Bearer {TOKEN}\r\n\
                 Content-Length: {}\r\n\r\n{body}",
                body.len()
            ),
        );
        assert!(code == 200 || code == 504, "{code} {text}");
        (code == 200, text)
    });
    wait_until(Duration::from_secs(20), || {
        let text = get(&metrics, "/metrics");
        (
            text.contains("softplc_tag_value{tag=\"key_on\"} 1")
                && text.contains("softplc_tag_value{tag=\"enabled\"} 1"),
            text,
        )
    });
    // The page: every tag of both tasks, with the values the panel task set.
    let info: serde_json::Value = serde_json::from_str(&get(&web, "/api/info")).expect("JSON");
    let names: Vec<&str> = info["tags"]
        .as_array()
        .expect("tags")
        .iter()
        .filter_map(|t| t["name"].as_str())
        .collect();
    let at = |tag: &str| names.iter().position(|n| *n == tag).expect(tag);
    let state: serde_json::Value = serde_json::from_str(&get(&web, "/api/state")).expect("JSON");
    let values = &state["state"]["v"];
    assert_eq!(values[at("key_on")], true, "{state}");
    assert_eq!(values[at("enabled")], true, "{state}");
    assert_eq!(values[at("strokes")], 0, "{state}");
    // Each task's figures for the overview's Tasks card.
    let tasks = state["stats"]["tasks"].as_array().expect("tasks");
    let named: Vec<&str> = tasks.iter().filter_map(|t| t["name"].as_str()).collect();
    assert_eq!(named, ["press", "panel"], "{state}");
    assert_eq!(tasks[1]["period_us"], 500_000, "{state}");
    assert!(tasks[1]["scans"].as_u64() > Some(0), "{state}");
    // The Program view is served every task's program, each with its own task's push-down
    // marks and diagram, and each task's block outputs.
    assert_eq!(
        info["tasks"],
        serde_json::json!([
            {"name": "press", "period_us": 30_000},
            {"name": "panel", "period_us": 500_000}
        ]),
        "{info}"
    );
    let programs = info["programs"].as_array().expect("programs");
    let served: Vec<(&str, u64)> = programs
        .iter()
        .map(|p| {
            (
                p["file"].as_str().unwrap_or("?"),
                p["task"].as_u64().unwrap_or(9),
            )
        })
        .collect();
    assert_eq!(
        served,
        [("press.ladder.yaml", 0), ("panel.ladder.yaml", 1)],
        "{info}"
    );
    let coils = |p: &serde_json::Value| -> Vec<String> {
        p["lines"]
            .as_array()
            .expect("lines")
            .iter()
            .flat_map(|l| l["rungs"].as_array().cloned().unwrap_or_default())
            .map(|r| names[r["coil"].as_u64().expect("coil") as usize].to_owned())
            .collect()
    };
    assert_eq!(coils(&programs[0]), ["press_down"], "{info}");
    assert_eq!(
        coils(&programs[1]),
        ["enabled", "running_lamp", "guard_lamp"],
        "the panel's rungs marked from the panel's own plan: {info}"
    );
    // The panel's plan says why its lamp rung stays in its scan: press_down is the press's.
    let lamp_rung = &programs[1]["lines"][7]["rungs"][0]["central"];
    assert!(
        lamp_rung
            .as_str()
            .is_some_and(|r| r.starts_with("an input of another task")),
        "{lamp_rung}"
    );
    assert_eq!(programs[1]["diagram"].as_array().map(Vec::len), Some(3));
    assert_eq!(info["tags"][at("key_on")]["task"], 1, "{info}");
    assert_eq!(info["tags"][at("strokes")]["task"], 0, "{info}");
    assert_eq!(info["buses"][1]["task"], 1, "{info}");
    // The panel's BLINK (its only block) in the panel's own block outputs: the guard is open.
    let blink = &state["state"]["tb"][1][0];
    assert!(blink["Q"].is_boolean(), "{state}");
}

/// Runs a third-party client (`runtime/tests/<script>` on the test venv's Python) with `args`
/// until it prints DONE or FAIL (at most 60 s); its PASS lines.
pub(crate) fn run_python(script: &str, args: &[&str]) -> Vec<String> {
    let python = repo().join("target/py-venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: make it with `python3 -m venv target/py-venv` and install \
         runtime/tests/opcua/requirements.txt and runtime/tests/mqtt/requirements.txt",
        python.display()
    );
    let mut child = Command::new(python)
        .arg(repo().join("runtime/tests").join(script))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("the client runs");
    let lines = crate::common::host::lines_of(child.stdout.take().expect("its output"));
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut passed = Vec::new();
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let line = lines.recv_timeout(left).unwrap_or_else(|_| {
            drop(child.kill());
            panic!("the client said nothing more after {passed:?}")
        });
        if line == "DONE" {
            break;
        }
        assert!(!line.starts_with("FAIL"), "{line} (after {passed:?})");
        if let Some(step) = line.strip_prefix("PASS ") {
            passed.push(step.to_owned());
        }
    }
    drop(child.wait());
    passed
}

#[test]
fn an_opcua_client_reads_each_tasks_figures_and_sees_them_grow() {
    let s = example_with_services("opcua", "  opcua: { port: 0 }\n");
    let _run = start(&s);
    let addr = log_value(&s.dir.join("log"), "OPC UA server at opc.tcp://");
    let passed = run_python(
        "opcua/tasks_client.py",
        &[
            &format!("opc.tcp://{addr}/"),
            "urn:softplc:two-tasks",
            "press",
            "panel",
        ],
    );
    assert_eq!(passed.len(), 3, "{passed:?}");
    assert_eq!(passed[1], "period press 30.0", "{passed:?}");
    assert!(passed[2].starts_with("grow press="), "{passed:?}");
}

#[test]
fn a_sparkplug_host_sees_each_tasks_metrics_in_nbirth_and_ndata() {
    let s = example_with_services("mqtt", "");
    let (_broker, port, pb2) = with_broker(&s, "press1");
    let _run = start(&s);
    let passed = run_python(
        "mqtt/tasks_consumer.py",
        &[
            &port.to_string(),
            "plant1",
            "press1",
            &pb2,
            "press",
            "panel",
        ],
    );
    assert_eq!(passed.len(), 2, "{passed:?}");
    assert!(passed[1].starts_with("data press="), "{passed:?}");
}

/// Two tasks on two lines, real clock: the first task `slow` (300 ms) toggles `slow_toggle`
/// every cycle and drives sm.Y1; the task `fast` (20 ms) counts `count` up every cycle and
/// drives fm.Y1. The fast task's module comes first in the project. `held` is the fast
/// task's (it writes it) and writable, for a force.
fn counting_tasks(case: &str, service: &str) -> Scratch {
    let s = Scratch::new("task_services", case);
    s.write(
        "fast.rhai",
        "count += 1;\ntoggle = !toggle;\nfast_lamp = toggle;\nheld = toggle;\n",
    );
    s.write(
        "slow.rhai",
        "slow_toggle = !slow_toggle;\nslow_lamp = slow_toggle;\n",
    );
    s.write(
        "project.yaml",
        &format!(
            "project: counting
tasks:
  - {{ name: slow, period: 300ms, program: {{ file: slow.rhai, kind: rhai }}, buses: [slow_line] }}
  - {{ name: fast, period: 20ms, program: {{ file: fast.rhai, kind: rhai }}, buses: [fast_line] }}
buses:
  - {{ name: slow_line, port: sim, baud: 57600, response_timeout: 20ms, tune: reply_delay }}
  - {{ name: fast_line, port: sim, baud: 57600, response_timeout: 20ms, tune: reply_delay }}
modules:
  - {{ name: fm, bus: fast_line, model: minimod, address: 1 }}
  - {{ name: sm, bus: slow_line, model: minimod, address: 1 }}
tags:
  - {{ name: count, type: u16 }}
  - {{ name: toggle, type: bool }}
  - {{ name: slow_toggle, type: bool }}
  - {{ name: fast_lamp, point: fm.Y1, safe: false }}
  - {{ name: slow_lamp, point: sm.Y1, safe: false }}
  - {{ name: held, type: bool, scada: write }}
service:
{service}"
        ),
    );
    s
}

/// Forces `held` through the control socket once the fast task answers (its line starts
/// first); the status text then.
fn force_held(s: &Scratch) -> String {
    let socket = s.dir.join("s.sock");
    let socket = socket.to_str().expect("UTF-8");
    wait_until(Duration::from_secs(30), || {
        let (ok, out) = crate::common::host::softplc(&["force", "held", "1", "--socket", socket]);
        (ok, out)
    });
    wait_until(Duration::from_secs(10), || {
        let (_, out) = crate::common::host::softplc(&["status", "--socket", socket]);
        (out.contains("FORCED"), out)
    })
}

/// The count in a client's `PASS changes count N slow_toggle M` line.
fn changes_counted(passed: &[String]) -> (u64, u64) {
    let line = passed
        .iter()
        .find_map(|p| p.strip_prefix("changes "))
        .unwrap_or_else(|| panic!("no changes counted: {passed:?}"));
    let n: Vec<u64> = line.split(' ').filter_map(|w| w.parse().ok()).collect();
    (n[0], n[1])
}

#[test]
fn an_opcua_client_sees_every_change_of_every_task_each_tasks_modules_and_forces() {
    let s = counting_tasks("opcua-changes", "  opcua: { port: 0, writes: true }\n");
    let _run = start(&s);
    let addr = log_value(&s.dir.join("log"), "OPC UA server at opc.tcp://");
    let status = force_held(&s);
    // The status marks the fast task's force and lists both tasks' modules.
    let held = status
        .lines()
        .find(|l| l.trim_start().starts_with("held "))
        .unwrap_or_else(|| panic!("{status}"));
    assert!(held.contains("FORCED 1"), "{status}");
    // In project order: the fast task's fm first, though the slow task is the first task;
    // each good once its own task has read it.
    let socket = s.dir.join("s.sock");
    let status = wait_until(Duration::from_secs(20), || {
        let (_, out) =
            crate::common::host::softplc(&["status", "--socket", socket.to_str().expect("UTF-8")]);
        (
            out.contains("module fm (fast_line): good")
                && out.contains("module sm (slow_line): good"),
            out,
        )
    });
    assert!(
        status.find("module fm") < status.find("module sm"),
        "{status}"
    );
    let passed = run_python(
        "opcua/task_changes_client.py",
        &[&format!("opc.tcp://{addr}/"), "urn:softplc:counting", "3"],
    );
    assert_eq!(passed.len(), 3, "{passed:?}");
    assert!(passed[0].starts_with("modules fm="), "{passed:?}");
    // Every step of the fast task's count, not one per slow cycle: 3 s at 20 ms is 150 steps,
    // a loaded machine scans fewer; the slow task's toggles came too (about 10).
    let (count, toggles) = changes_counted(&passed);
    assert!(count >= 40, "{passed:?}");
    assert!(toggles >= 3, "{passed:?}");
    assert_eq!(passed[2], "forced", "{passed:?}");
}

#[test]
fn a_sparkplug_host_sees_every_change_of_every_task_and_each_tasks_modules_as_devices() {
    let s = counting_tasks("mqtt-changes", "");
    let (_broker, port, pb2) = with_broker(&s, "counting1");
    let _run = start(&s);
    force_held(&s);
    let passed = run_python(
        "mqtt/task_changes_consumer.py",
        &[&port.to_string(), "plant1", "counting1", &pb2, "3"],
    );
    assert_eq!(passed.len(), 3, "{passed:?}");
    assert_eq!(passed[0], "births fm sm", "{passed:?}");
    assert_eq!(passed[2], "forced", "{passed:?}");
    let (count, toggles) = changes_counted(&passed);
    assert!(count >= 40, "{passed:?}");
    assert!(toggles >= 3, "{passed:?}");
}

#[test]
fn the_metrics_and_the_page_show_every_tasks_modules_and_forces() {
    let s = counting_tasks(
        "web-modules",
        &web_and_metrics().replace(
            &format!("token: {TOKEN} }}"),
            &format!("token: {TOKEN}, trend: [count] }}"),
        ),
    );
    let (_run, web, metrics) = start_serving(&s);
    force_held(&s);
    // Each task's module with its live figures, from its own task; the fast task's force.
    let requests = |text: &str, module: &str, bus: &str| -> Option<u64> {
        let key = format!("softplc_module_requests_total{{module=\"{module}\",bus=\"{bus}\"}} ");
        text.lines()
            .find_map(|l| l.strip_prefix(key.as_str()))
            .and_then(|v| v.parse().ok())
    };
    let first = wait_until(Duration::from_secs(20), || {
        let text = get(&metrics, "/metrics");
        (
            text.contains("softplc_module_quality{module=\"fm\",bus=\"fast_line\"} 0")
                && text.contains("softplc_module_quality{module=\"sm\",bus=\"slow_line\"} 0")
                && text.contains("softplc_tag_forced{tag=\"held\"} 1"),
            text,
        )
    });
    let before = (
        requests(&first, "fm", "fast_line"),
        requests(&first, "sm", "slow_line"),
    );
    assert!(before.0.is_some() && before.1.is_some(), "{first}");
    wait_until(Duration::from_secs(20), || {
        let text = get(&metrics, "/metrics");
        (
            requests(&text, "fm", "fast_line") > before.0
                && requests(&text, "sm", "slow_line") > before.1,
            text,
        )
    });
    // The page: both modules listed and good, the force marked.
    let info: serde_json::Value = serde_json::from_str(&get(&web, "/api/info")).expect("JSON");
    let modules: Vec<&str> = info["modules"]
        .as_array()
        .expect("modules")
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert_eq!(modules, ["fm", "sm"], "{info}");
    let lamp = info["tags"]
        .as_array()
        .expect("tags")
        .iter()
        .find(|t| t["name"] == "fast_lamp")
        .expect("fast_lamp");
    assert_eq!(lamp["module"], 0, "bound to fm on the page: {lamp}");
    assert_eq!(lamp["kind"], "output", "{lamp}");
    let state = wait_until(Duration::from_secs(10), || {
        let text = get(&web, "/api/state");
        let state: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        let good = state["stats"]["modules"]
            .as_array()
            .is_some_and(|m| m.len() == 2 && m.iter().all(|m| m["q"] == 0));
        (good, text)
    });
    let state: serde_json::Value = serde_json::from_str(&state).expect("JSON");
    assert_eq!(state["state"]["forced"], serde_json::json!([5]), "{state}");
    assert_eq!(state["state"]["v"][5], true, "{state}");
    // Each task's Rhai program listed under its task, its tags decorated.
    let served: Vec<(&str, &str, u64)> = info["programs"]
        .as_array()
        .expect("programs")
        .iter()
        .map(|p| {
            let file = p["file"].as_str().unwrap_or("?");
            (
                file,
                p["kind"].as_str().unwrap_or("?"),
                p["task"].as_u64().unwrap_or(9),
            )
        })
        .collect();
    assert_eq!(served, [("slow.rhai", "rhai", 0), ("fast.rhai", "rhai", 1)]);
    // The trend samples the fast task's count at the fast task's cycles, not at the slow
    // first task's (300 ms): several samples per slow cycle, each a higher count.
    let trend = wait_until(Duration::from_secs(20), || {
        let text = get(&web, "/api/trend");
        let trend: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        let t = trend["t"].as_array().cloned().unwrap_or_default();
        let span = match (t.first(), t.last()) {
            (Some(a), Some(b)) => b.as_f64().unwrap_or(0.0) - a.as_f64().unwrap_or(0.0),
            _ => 0.0,
        };
        (span >= 3000.0, text)
    });
    let trend: serde_json::Value = serde_json::from_str(&trend).expect("JSON");
    let t: Vec<f64> = (trend["t"].as_array().expect("t").iter())
        .filter_map(serde_json::Value::as_f64)
        .collect();
    let count: Vec<f64> = (trend["series"][0].as_array().expect("count").iter())
        .filter_map(serde_json::Value::as_f64)
        .collect();
    let span = t[t.len() - 1] - t[0];
    let slow_cycles = span / 300.0;
    assert!(
        t.len() as f64 >= 1.5 * slow_cycles,
        "{} samples in {span} ms: {trend}",
        t.len()
    );
    assert!(
        count.windows(2).all(|w| w[1] > w[0]),
        "each sample a later cycle of the fast task: {trend}"
    );
}
