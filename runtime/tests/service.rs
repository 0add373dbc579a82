//! The service as systemd runs it: the unit file's checks, the sd_notify protocol, and the
//! control interface (status, force, write, unforce, reload) against a running instance on the
//! simulated default.

use crate::common::host::repo;
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

fn scratch(name: &str) -> PathBuf {
    crate::common::host::scratch_dir("service", name)
}

/// The unit as installed, with ExecStart pointing at the binary under test.
fn installed_unit(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("deploy/softplc@.service")).unwrap();
    let path = dir.join("softplc@quickstart.service");
    std::fs::write(&path, text.replace("/usr/bin/softplc", BIN)).unwrap();
    path
}

fn systemd_analyze(args: &[&str]) -> (bool, String) {
    let out = Command::new("systemd-analyze")
        .args(args)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "systemd-analyze is needed for the unit file checks (Debian package systemd): {e}"
            )
        });
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &*String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

#[test]
fn the_unit_file_verifies_clean_and_rates_ok() {
    let dir = scratch("unit");
    let unit = installed_unit(&dir);
    let (ok, text) = systemd_analyze(&["verify", unit.to_str().unwrap()]);
    assert!(
        ok && text.trim().is_empty(),
        "systemd-analyze verify printed:\n{text}"
    );
    // A second line of defence: a leak is contained by systemd, sized for the PLC (verify
    // above has checked the keys and values are valid for this systemd).
    let unit_text = std::fs::read_to_string(&unit).unwrap();
    for (key, value) in [
        ("MemoryHigh", "192M"),
        ("MemoryMax", "256M"),
        ("MemorySwapMax", "0"),
        ("TasksMax", "512"),
        ("LimitNOFILE", "4096"),
    ] {
        assert!(
            unit_text.lines().any(|l| l == format!("{key}={value}")),
            "{key}={value} missing"
        );
    }
    let (_, text) = systemd_analyze(&["security", "--offline=true", unit.to_str().unwrap()]);
    let overall = text
        .lines()
        .find(|l| l.contains("Overall exposure level"))
        .unwrap_or("");
    assert!(
        ["OK", "SAFE", "PERFECT"]
            .iter()
            .any(|w| overall.contains(w)),
        "rating must be OK or better: {overall}"
    );
}

/// Reads datagrams until `want` is seen or the deadline passes; returns all received.
fn wait_for(sock: &UnixDatagram, want: &str, within: Duration, seen: &mut Vec<String>) -> bool {
    let end = Instant::now() + within;
    let mut buf = [0u8; 512];
    while Instant::now() < end {
        if let Ok(n) = sock.recv(&mut buf) {
            let msg = String::from_utf8_lossy(&buf[..n]).to_string();
            seen.push(msg.clone());
            if msg.starts_with(want) {
                return true;
            }
        }
    }
    false
}

fn ctl(socket: &Path, args: &[&str]) -> (bool, String) {
    let out = Command::new(BIN)
        .args(args)
        .arg("--socket")
        .arg(socket)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &*String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

#[test]
fn a_running_instance_notifies_systemd_and_obeys_its_control_socket() {
    let dir = scratch("run");
    // A copy of the quick start whose program can be broken and mended for reload.
    let program = dir.join("conveyor.expr");
    std::fs::copy(repo().join("programs/conveyor.expr"), &program).unwrap();
    crate::common::host::copy_quickstart_plant(&dir);
    let project = std::fs::read_to_string(repo().join("examples/quickstart/project.yaml"))
        .unwrap()
        .replace("../../programs/conveyor.expr", "conveyor.expr");
    let project_path = dir.join("project.yaml");
    std::fs::write(&project_path, project).unwrap();

    let notify_path = dir.join("notify");
    let notify = UnixDatagram::bind(&notify_path).unwrap();
    notify
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let socket = dir.join("ctl.sock");
    let mut child = Command::new(BIN)
        .args(["run", "--quiet", "--for", "20s", "--socket"])
        .arg(&socket)
        .arg(&project_path)
        .env("NOTIFY_SOCKET", &notify_path)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();

    let mut seen = Vec::new();
    assert!(
        wait_for(&notify, "READY=1", Duration::from_secs(10), &mut seen),
        "READY: {seen:?}"
    );
    assert!(
        wait_for(&notify, "WATCHDOG=1", Duration::from_secs(5), &mut seen),
        "{seen:?}"
    );

    let (ok, text) = ctl(&socket, &["status"]);
    assert!(ok, "{text}");
    assert!(text.contains("module mm1 (line1): good"), "{text}");

    let (ok, text) = ctl(&socket, &["force", "stop", "1"]);
    assert!(ok && text.contains("stop forced to 1"), "{text}");
    let (_, text) = ctl(&socket, &["status"]);
    assert!(
        text.lines()
            .any(|l| l.contains("stop") && l.contains("FORCED 1")),
        "{text}"
    );
    let (ok, text) = ctl(&socket, &["force", "motor", "maybe"]);
    assert!(!ok && text.contains("motor is bool"), "{text}");
    let (ok, text) = ctl(&socket, &["force", "nosuchtag", "1"]);
    assert!(!ok && text.contains("no tag \"nosuchtag\""), "{text}");

    // A broken program is refused and the running one keeps scanning.
    std::fs::write(&program, "motor = start &\n").unwrap();
    let (ok, text) = ctl(&socket, &["reload"]);
    assert!(
        !ok && text.contains("reload refused") && text.contains("conveyor.expr:1:"),
        "{text}"
    );
    std::fs::copy(repo().join("programs/conveyor.expr"), &program).unwrap();
    let (ok, text) = ctl(&socket, &["reload"]);
    assert!(ok && text.contains("reloaded"), "{text}");

    let (ok, text) = ctl(&socket, &["unforce", "--all"]);
    assert!(ok && text.contains("1 force(s) removed"), "{text}");

    #[allow(unsafe_code)]
    // SIGTERM: STOPPING, then a clean exit after the safe state.
    // SAFETY: kill with a valid pid and signal.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM)
    };
    assert!(
        wait_for(&notify, "STOPPING=1", Duration::from_secs(5), &mut seen),
        "{seen:?}"
    );
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    assert!(!socket.exists(), "the control socket is removed on exit");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// Starts the quick start copy in `dir` with extra arguments; returns the child once its
/// control socket answers.
fn start(dir: &Path, socket: &Path, extra: &[&str]) -> std::process::Child {
    start_in(dir, socket, extra, None)
}

/// [`start`] with `$STATE_DIRECTORY` set, as systemd sets it for a unit with
/// `StateDirectory=`.
fn start_in(
    dir: &Path,
    socket: &Path,
    extra: &[&str],
    state: Option<&Path>,
) -> std::process::Child {
    let mut command = Command::new(BIN);
    if let Some(state) = state {
        command.env("STATE_DIRECTORY", state);
    }
    let child = command
        .args(["run", "--quiet", "--for", "20s", "--socket"])
        .arg(socket)
        .args(extra)
        .arg(dir.join("project.yaml"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let end = Instant::now() + Duration::from_secs(10);
    while Instant::now() < end && !ctl(socket, &["status"]).0 {
        std::thread::sleep(Duration::from_millis(50));
    }
    child
}

fn stop(mut child: std::process::Child) {
    #[allow(unsafe_code)]
    // SAFETY: kill with a valid pid and signal.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM)
    };
    // Only reaps the child: its exit status is not what this test checks.
    drop(child.wait());
}

#[test]
fn forces_are_lost_on_restart_unless_kept() {
    let dir = scratch("forces");
    std::fs::copy(
        repo().join("programs/conveyor.expr"),
        dir.join("conveyor.expr"),
    )
    .unwrap();
    crate::common::host::copy_quickstart_plant(&dir);
    let project = std::fs::read_to_string(repo().join("examples/quickstart/project.yaml"))
        .unwrap()
        .replace("../../programs/conveyor.expr", "conveyor.expr");
    // The page is not needed here, and its fixed port may be taken by a parallel test.
    let project = match project.find("\nservice:") {
        Some(i) => project[..i + 1].to_string(),
        None => project,
    };
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let socket = dir.join("ctl.sock");
    let forced = |socket: &Path| {
        ctl(socket, &["status"])
            .1
            .lines()
            .any(|l| l.contains("stop") && l.contains("FORCED 1"))
    };

    let plc = start(&dir, &socket, &["--keep-forces"]);
    assert!(ctl(&socket, &["force", "stop", "1"]).0);
    stop(plc);
    assert!(dir.join("project.yaml.forces.json").exists());

    let plc = start(&dir, &socket, &["--keep-forces"]);
    assert!(forced(&socket), "kept across the restart");
    stop(plc);

    let plc = start(&dir, &socket, &[]);
    assert!(!forced(&socket), "a plain restart clears forces");
    stop(plc);

    // Under systemd the unit's dynamic user cannot write beside the project: kept forces go
    // to its state directory, one folder per instance.
    let state = dir.join("var-lib-softplc");
    let plc = start_in(&dir, &socket, &["--keep-forces"], Some(&state));
    assert!(ctl(&socket, &["force", "stop", "1"]).0);
    stop(plc);
    let instance = dir.file_name().unwrap();
    assert!(state
        .join(instance)
        .join("project.yaml.forces.json")
        .exists());
    let plc = start_in(&dir, &socket, &["--keep-forces"], Some(&state));
    assert!(
        forced(&socket),
        "kept across the restart, from the state directory"
    );
    stop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// The drop-in the package ships for the plant network is inert as installed, and once
/// uncommented it is what systemd takes: its keys verify with the unit and allow the
/// addresses it names beside the unit's localhost.
#[test]
fn the_plant_network_drop_in_is_commented_and_valid_once_uncommented() {
    let dir = scratch("drop-in");
    let text = std::fs::read_to_string(repo().join("deploy/plant-network.conf")).unwrap();
    assert!(
        text.lines().all(|l| l.is_empty() || l.starts_with('#')),
        "{text}"
    );
    // Uncommented: the section and its IPAddressAllow= lines (their trailing comments go,
    // as systemd takes no comment after a value).
    let uncommented: Vec<String> = text
        .lines()
        .filter_map(|l| l.strip_prefix('#'))
        .filter(|l| l.starts_with('[') || l.starts_with("IPAddressAllow="))
        .map(|l| l.split(" #").next().unwrap_or(l).trim().to_string())
        .collect();
    assert_eq!(uncommented[0], "[Service]", "{uncommented:?}");
    assert!(uncommented.len() >= 2, "{uncommented:?}");
    let unit = installed_unit(&dir);
    // A section may come again in a unit file: the drop-in's [Service] after the unit's last.
    let mut merged = std::fs::read_to_string(&unit).unwrap();
    for line in &uncommented {
        merged.push_str(line);
        merged.push('\n');
    }
    std::fs::write(&unit, &merged).unwrap();
    let (ok, out) = systemd_analyze(&["verify", unit.to_str().unwrap()]);
    assert!(
        ok && out.trim().is_empty(),
        "systemd-analyze verify printed:\n{out}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// `check` names every listener and peer beyond this machine, with the drop-in that lets it
/// through the shipped unit; a project on loopback gets no such note.
#[test]
fn check_names_the_addresses_the_unit_must_allow() {
    let dir = scratch("unit-network");
    std::fs::write(dir.join("p.expr"), "y = x\n").unwrap();
    let head = "project: net\nscan: { period: 100ms }\nbuses:\n  - { name: line1, port: sim }\n\
                modules:\n  - { name: mm1, bus: line1, model: minimod, address: 1 }\ntags:\n  \
                - { name: x, point: mm1.X1 }\n  - { name: y, point: mm1.Y1, safe: false }\n\
                program: { file: p.expr, kind: expr }\n";
    let check = |name: &str, service: &str| {
        let project = dir.join(name);
        std::fs::write(&project, format!("{head}{service}")).unwrap();
        let out = Command::new(BIN)
            .arg("check")
            .arg(&project)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    let remote = check(
        "remote.yaml",
        "service:\n  mqtt: { host: 192.168.10.20, group: plant, node: net }\n  modbus_tcp: { \
         bind: \"0.0.0.0:5020\" }\n",
    );
    let drop_in = "/etc/systemd/system/softplc@.service.d/plant-network.conf";
    for want in [
        format!(
            "note: service.mqtt's broker is 192.168.10.20:1883, beyond this machine: the shipped \
             systemd unit allows loopback traffic only (IPAddressDeny=any); allow the broker's \
             address with IPAddressAllow= in {drop_in}"
        ),
        format!(
            "note: service.modbus_tcp listens on 0.0.0.0:5020, beyond this machine: the shipped \
             systemd unit allows loopback traffic only (IPAddressDeny=any); allow the clients' \
             addresses with IPAddressAllow= in {drop_in}"
        ),
    ] {
        assert!(remote.contains(&want), "no {want:?} in\n{remote}");
    }
    let local = check(
        "local.yaml",
        "service:\n  mqtt: { host: 127.0.0.1, group: plant, node: net }\n  opcua: { port: \
         4841 }\n",
    );
    assert!(!local.contains("IPAddressDeny"), "{local}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// A project on one simulated MiniMod whose program latches `seen` when `cmd` is set and then
/// clears `cmd` itself: a write of `cmd` shows as `seen` = 1 and `cmd` back at 0.
fn write_once_project(dir: &Path) {
    std::fs::write(dir.join("p.expr"), "seen = seen | cmd\ncmd = false\n").unwrap();
    std::fs::write(
        dir.join("project.yaml"),
        "project: writeonce\n\
         scan: { period: 20ms }\n\
         buses:\n  - { name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms }\n\
         modules:\n  - { name: mm1, bus: line1, model: minimod, address: 1 }\n\
         tags:\n  - { name: button, point: mm1.X1 }\n  - { name: cmd, type: bool }\n  - { name: seen, type: bool }\n\
         program: { file: p.expr, kind: expr }\n",
    )
    .unwrap();
}

/// A tag's value in `softplc status` (its line's second word).
fn value_of(socket: &Path, tag: &str) -> String {
    ctl(socket, &["status"])
        .1
        .lines()
        .find(|l| l.split_whitespace().next() == Some(tag))
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap_or_default()
        .to_string()
}

#[test]
fn an_operator_write_sets_a_tag_once_and_the_program_takes_it_back() {
    let dir = scratch("write");
    write_once_project(&dir);
    let socket = dir.join("ctl.sock");
    let plc = start(&dir, &socket, &[]);
    assert_eq!(value_of(&socket, "seen"), "0");

    let (ok, text) = ctl(&socket, &["write", "cmd", "1"]);
    assert!(ok && text.contains("cmd written: 1 (at cycle"), "{text}");
    // The program saw the write in its next scan and cleared cmd in the same scan.
    let end = Instant::now() + Duration::from_secs(5);
    while value_of(&socket, "seen") != "1" && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(value_of(&socket, "seen"), "1");
    assert_eq!(value_of(&socket, "cmd"), "0", "the program took cmd back");

    // Refused, with the reason: an input, a value of another type, an unknown tag, a force.
    let (ok, text) = ctl(&socket, &["write", "button", "1"]);
    assert!(!ok && text.contains("button is an input"), "{text}");
    let (ok, text) = ctl(&socket, &["write", "cmd", "maybe"]);
    assert!(!ok && text.contains("cmd is bool"), "{text}");
    let (ok, text) = ctl(&socket, &["write", "nosuchtag", "1"]);
    assert!(!ok && text.contains("no tag \"nosuchtag\""), "{text}");
    assert!(ctl(&socket, &["force", "seen", "0"]).0);
    let (ok, text) = ctl(&socket, &["write", "seen", "1"]);
    assert!(!ok && text.contains("seen is forced"), "{text}");
    stop(plc);

    // The audit file holds every one of them, with its source, after a restart too.
    let audit = || {
        let out = Command::new(BIN)
            .args(["audit", "--last", "100", "-p"])
            .arg(dir.join("project.yaml"))
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let plc = start(&dir, &socket, &[]);
    assert!(ctl(&socket, &["unforce", "seen"]).0);
    assert!(ctl(&socket, &["reload"]).0);
    stop(plc);
    let text = audit();
    let lines: Vec<&str> = text.lines().collect();
    let want = [
        ("write", "cmd=1", ""),
        ("write", "button=1", "REFUSED: button is an input"),
        ("write", "cmd=maybe", "REFUSED: cmd is bool"),
        ("write", "nosuchtag=1", "REFUSED: no tag"),
        ("force", "seen=0", "seen forced to 0"),
        ("write", "seen=1", "REFUSED: seen is forced"),
        // Forces are lost on restart: nothing left to remove.
        ("unforce", "seen", "0 force(s) removed"),
        ("reload", "", "reloaded"),
    ];
    assert_eq!(lines.len(), want.len(), "{text}");
    for (line, (action, what, result)) in lines.iter().zip(want) {
        let words: Vec<&str> = line.split_whitespace().collect();
        // UTC, "cycle", N, source, action, ...
        assert!(words[0].ends_with('Z') && words[1] == "cycle", "{line}");
        assert_eq!((words[3], words[4]), ("cli", action), "{line}");
        assert!(line.contains(what) && line.contains(result), "{line}");
    }
    // Best effort: the test's scratch folder.
    drop(std::fs::remove_dir_all(dir));
}

/// The value of `key=` in the unit's text, with a size's `M` suffix read as MiB.
fn unit_number(unit: &str, key: &str) -> u64 {
    let value = unit
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{key}=")))
        .unwrap_or_else(|| panic!("{key}= missing"));
    match value.strip_suffix('M') {
        Some(mib) => mib.parse::<u64>().unwrap() << 20,
        None => value.parse().unwrap(),
    }
}

/// A figure of `/proc/PID/status` (`VmHWM`: kB; `Threads`: a count).
fn proc_status(pid: u32, key: &str) -> u64 {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{key}:")))
        .unwrap();
    line.split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn the_units_limits_leave_room_for_a_plc_of_two_tasks_at_its_own_bounds() {
    let unit = std::fs::read_to_string(repo().join("deploy/softplc@.service")).unwrap();
    let memory_high = unit_number(&unit, "MemoryHigh");
    let tasks_max = unit_number(&unit, "TasksMax");
    let nofile = unit_number(&unit, "LimitNOFILE");
    // What the PLC holds at most by its own bounds fits under MemoryHigh with room for the
    // program, the image and the services: the default trace budget and the recorder's
    // largest hold on a full disk.
    let trace = softplc::project::TraceBudget::default().memory;
    let hold = softplc::recorder::Settings::new(PathBuf::new(), Duration::ZERO, u64::MAX).hold_bytes
        as u64;
    assert!(
        trace + hold + (64 << 20) <= memory_high,
        "MemoryHigh {memory_high} B leaves too little beside {trace} B of traces and a \
         {hold} B hold"
    );

    // The two-tasks example with its web page, metrics and a record, every byte of the trace
    // budget armed: what it takes stays well inside the unit's limits.
    let dir = scratch("limits");
    for f in ["project.yaml", "press.ladder.yaml", "panel.ladder.yaml"] {
        std::fs::copy(repo().join("examples/two-tasks").join(f), dir.join(f)).unwrap();
    }
    let mut yaml = std::fs::read_to_string(dir.join("project.yaml")).unwrap();
    yaml.push_str("service:\n  web: { bind: 127.0.0.1:0 }\n  metrics: 127.0.0.1:0\n");
    std::fs::write(dir.join("project.yaml"), yaml).unwrap();
    let socket = dir.join("ctl.sock");
    let run = crate::common::host::run_virtual_with(
        &dir.join("project.yaml"),
        &socket,
        &["--record", "10m"],
    );
    let pid = run.0.id();
    let s = socket.to_str().unwrap();
    let mut armed = 0;
    for i in 0..20 {
        let (task, tags) = match i % 2 {
            0 => (
                "press",
                "hand_left,hand_right,guard_closed,ram_top,press_down",
            ),
            _ => ("panel", "key_on,running_lamp,guard_lamp,strokes,enabled"),
        };
        let name = format!("t{i}");
        let out = Command::new(BIN)
            .args(["trace", "arm", &name, "--task", task, "--tags", tags])
            .args(["--pre", "49999", "--post", "50000", "--socket", s])
            .output()
            .unwrap();
        if out.status.success() {
            armed += 1;
        } else {
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(err.contains("of the 64 MiB trace budget is left"), "{err}");
        }
    }
    assert_eq!(armed, 10, "6.4 MB a trace: ten fit the default budget");
    let peak = proc_status(pid, "VmHWM") << 10;
    let threads = proc_status(pid, "Threads");
    let files = std::fs::read_dir(format!("/proc/{pid}/fd"))
        .unwrap()
        .count() as u64;
    eprintln!("at the trace budget: peak {peak} B resident, {threads} threads, {files} files");
    assert!(
        peak < memory_high,
        "peak {peak} B against MemoryHigh {memory_high} B"
    );
    // Clients take a thread and a file each, capped (web 16, metrics 16, control 32), at most
    // doubled while evicted ones finish: the limits leave room for all of them.
    assert!(threads + 2 * 64 < tasks_max, "{threads} threads");
    assert!(files + 2 * 64 < nofile, "{files} files");
    drop(run);
}
