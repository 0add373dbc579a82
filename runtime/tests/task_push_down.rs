//! Push-down in a project of several tasks: a rung of a task's program whose inputs and
//! output are points of one module on that task's own bus goes into the module, for each
//! task, and `check`'s report names the task; a rung reading another task's input stays in
//! the scan with that reason. On virtual clocks, each task's module runs its pushed rung by
//! itself: once the tasks have stopped (tables kept), the output still follows the input.

use std::path::Path;
use std::time::Duration;

use softplc::offload::Placement;
use softplc::plc::Plc;
use softplc::project::load;
use softplc::scan::TaskSet;
use softplc::service::web::{TaskPart, WebInfo};
use softplc_io::point::Value;
use softplc_io::sim::SharedWorld;
use softplc_io::time::LineInstant;

use crate::common::scratch::{Scratch, TWO_LINES};

/// The fast task's ladder: `valve` from its own module's inputs (pushed), `horn` also from
/// the slow task's `key` (central). The slow task's two programs: `lamp` from its own
/// module's input (pushed), `beacon` also from the fast task's `start` (central).
const PROJECT: &str = "\
project: po
offload: { mode: auto, on_stop: keep }
tasks:
  - name: fast
    period: 20ms
    buses: [fast_line]
    program: { file: fast.ladder.yaml, kind: ladder }
  - name: slow
    period: 200ms
    buses: [slow_line]
    programs:
      - { file: slow.ladder.yaml, kind: ladder }
      - { file: slow.rhai, kind: rhai }
{lines}tags:
  - { name: start,  point: f1.X1 }
  - { name: stop,   point: f1.X2 }
  - { name: valve,  point: f1.Y1, safe: false }
  - { name: horn,   point: f1.Y2, safe: false }
  - { name: key,    point: s1.X1 }
  - { name: lamp,   point: s1.Y1, safe: false }
  - { name: beacon, point: s1.Y2, safe: false }
";

fn folder(case: &str) -> Scratch {
    let s = Scratch::new("task-push-down", case);
    s.write("project.yaml", &PROJECT.replace("{lines}", TWO_LINES));
    s.write(
        "fast.ladder.yaml",
        "rungs:\n  - start /stop -> valve\n  - start key -> horn\n",
    );
    s.write("slow.ladder.yaml", "rungs:\n  - key -> lamp\n");
    s.write("slow.rhai", "beacon = key && !start;\n");
    s
}

#[test]
fn check_reports_each_tasks_push_down_and_why_a_rung_reading_another_task_stays() {
    let s = folder("check");
    let (ok, text, _) = crate::common::host::check_in(&s.dir, Path::new("project.yaml"));
    assert!(ok, "{text}");
    let at = |needle: &str| {
        text.find(needle)
            .unwrap_or_else(|| panic!("no `{needle}` in:\n{text}"))
    };
    let fast = at("push-down of task fast (offload: auto; module tables kept running at stop):");
    let slow = at("push-down of task slow (offload: auto; module tables kept running at stop):");
    let valve = at("fast.ladder.yaml:2:5 valve (combinational): module f1 Y1");
    let horn = at(
        "fast.ladder.yaml:3:5 horn (combinational): central: an input of another \
                   task: key is on bus slow_line, which task slow owns; this task copies its \
                   value at its cycle's start, and no module of this task's buses sees it",
    );
    let lamp = at("slow.ladder.yaml:2:5 lamp (combinational): module s1 Y1");
    let beacon = at(
        "slow.rhai:1:1 beacon (combinational): central: an input of another task: \
                     start is on bus fast_line, which task fast owns",
    );
    // Each task's rungs under its own heading.
    assert!(fast < valve && valve < slow && horn < slow, "{text}");
    assert!(slow < lamp && slow < beacon, "{text}");
}

fn world_of(worlds: &[SharedWorld], module: &str) -> (SharedWorld, usize) {
    for w in worlds {
        if let Some(d) = w.lock().expect("the world").find(module) {
            return (w.clone(), d);
        }
    }
    panic!("no simulator {module}");
}

/// Sets `point` of `module` and lets its world run `after` without any scan; `out` then.
fn module_reacts(worlds: &[SharedWorld], module: &str, point: &str, on: bool, out: &str) -> Value {
    let (world, d) = world_of(worlds, module);
    let mut w = world.lock().expect("the world");
    w.set(d, point, Value::Bool(on)).expect("an input");
    let later: LineInstant = w.now() + Duration::from_millis(50);
    w.advance_to(later);
    w.get(d, out).expect("an output")
}

#[test]
fn each_tasks_module_runs_its_pushed_rung_on_virtual_clocks() {
    let s = folder("run");
    let project = load(&s.dir.join("project.yaml")).expect("valid");
    let plcs = Plc::build_tasks(&project, None, None).expect("builds");
    // Each task's plan: its own module's rung pushed, the rung reading the other task's
    // input central, with that reason.
    for (task, pushed, central, other) in [
        (
            "fast",
            "valve",
            "horn",
            "key is on bus slow_line, which task slow owns",
        ),
        (
            "slow",
            "lamp",
            "beacon",
            "start is on bus fast_line, which task fast owns",
        ),
    ] {
        let plc = &plcs.iter().find(|t| t.name == task).expect("a task").plc;
        let id = |name: &str| plc.image().id(name).expect("a tag");
        assert!(plc.plan().is_pushed(id(pushed)), "{task}: {pushed}");
        let rung = plc
            .plan()
            .rungs
            .iter()
            .find(|r| r.rung.coil == id(central))
            .expect("the central rung");
        match &rung.placement {
            Placement::Central(reason) => {
                assert!(reason.to_string().contains(other), "{task}: {reason}")
            }
            Placement::Module(_) => panic!("{task}: {central} pushed"),
        }
    }
    let worlds: Vec<SharedWorld> = plcs.iter().filter_map(|t| t.plc.world().cloned()).collect();
    assert_eq!(worlds.len(), 2, "a world per task on virtual clocks");
    {
        let (world, f1) = world_of(&worlds, "f1");
        let mut w = world.lock().expect("the world");
        w.set(f1, "X1", Value::Bool(true)).expect("start");
    }
    {
        let (world, s1) = world_of(&worlds, "s1");
        let mut w = world.lock().expect("the world");
        w.set(s1, "X1", Value::Bool(true)).expect("key");
    }
    let outcomes = TaskSet::new(plcs)
        .configure(|_, engine| engine.run_for(Duration::from_secs(3)))
        .run_virtual();
    assert_eq!(outcomes.len(), 2);
    for o in &outcomes {
        assert!(o.outcome.stats.cycles > 5, "{}: {:?}", o.name, o.outcome);
    }
    // The tasks have stopped; each module still runs the rung it was given.
    for (module, table) in [("f1", "Y1AON1"), ("s1", "Y1AON1")] {
        let (world, d) = world_of(&worlds, module);
        let w = world.lock().expect("the world");
        assert_eq!(
            w.get(d, table).expect("a register"),
            Value::U16(1),
            "{module}"
        );
        assert_eq!(w.get(d, "Y1").expect("Y1"), Value::Bool(true), "{module}");
    }
    assert_eq!(
        module_reacts(&worlds, "f1", "X1", false, "Y1"),
        Value::Bool(false),
        "valve follows start in module f1 without the fast task"
    );
    assert_eq!(
        module_reacts(&worlds, "f1", "X1", true, "Y1"),
        Value::Bool(true)
    );
    assert_eq!(
        module_reacts(&worlds, "f1", "X2", true, "Y1"),
        Value::Bool(false),
        "stop drops the valve in the module"
    );
    assert_eq!(
        module_reacts(&worlds, "s1", "X1", false, "Y1"),
        Value::Bool(false),
        "lamp follows key in module s1 without the slow task"
    );
    assert_eq!(
        module_reacts(&worlds, "s1", "X1", true, "Y1"),
        Value::Bool(true)
    );
}

#[test]
fn an_output_two_programs_of_a_task_write_stays_central_naming_the_other_place() {
    let s = folder("shared");
    s.write("slow.rhai", "beacon = key && !start;\nlamp = !key;\n");
    let (ok, text, _) = crate::common::host::check_in(&s.dir, Path::new("project.yaml"));
    assert!(ok, "{text}");
    assert!(
        text.contains(
            "slow.ladder.yaml:2:5 lamp (combinational): central: an output also written \
             elsewhere: another rung of the program at slow.rhai:2:1"
        ),
        "{text}"
    );
    assert!(
        text.contains(
            "slow.rhai:2:1: warning: tag `lamp` is also written by an earlier program of task \
             `slow` at slow.ladder.yaml:2:5"
        ),
        "{text}"
    );
}

#[test]
fn the_pages_program_view_marks_each_tasks_pushed_rungs_from_its_own_plan() {
    let s = folder("page");
    let project = load(&s.dir.join("project.yaml")).expect("loads");
    let builder = softplc::plc::TaskBuilder::new(&project, None, None).expect("compiles");
    let parts: Vec<TaskPart> = (0..project.tasks.len())
        .map(|i| {
            // Planned before any line starts, as the task's PLC then runs it.
            let planned = builder.planned(i).expect("compiles");
            let built = builder.build(i).expect("builds");
            assert_eq!(&planned.plan, built.plc.plan());
            assert_eq!(planned.instance_counts, built.plc.instance_counts());
            let task = &project.tasks[i];
            TaskPart::of(&planned, &task.name, task.scan.period)
        })
        .collect();
    let web = softplc::project::WebConfig {
        bind: "127.0.0.1:0".parse().expect("an address"),
        writes: false,
        token: None,
        operator_token: None,
        trend: Vec::new(),
    };
    let owner = |t: usize| builder.ownership().owner(softplc::image::TagId(t as u32));
    let info = serde_json::to_value(WebInfo::of_tasks(&project, &web, owner, parts)).expect("JSON");
    assert_eq!(
        info["tasks"],
        serde_json::json!([
            {"name": "fast", "period_us": 20_000},
            {"name": "slow", "period_us": 200_000}
        ])
    );
    // Each program under its task, each rung's mark: the module of the task's own bus it is
    // pushed into, or why it stays in that task's scan.
    let marks: Vec<(u64, String, u64, String)> = (info["programs"].as_array().expect("programs"))
        .iter()
        .flat_map(|p| {
            let (task, file) = (
                p["task"].as_u64().unwrap_or(9),
                p["file"].as_str().unwrap_or("?"),
            );
            let lines = p["lines"].as_array().cloned().unwrap_or_default();
            lines.into_iter().enumerate().flat_map(move |(n, l)| {
                (l["rungs"].as_array().cloned().unwrap_or_default())
                    .into_iter()
                    .map(move |r| {
                        let at = match r["module"].as_str() {
                            Some(m) => format!("in {m}"),
                            None => r["central"]
                                .as_str()
                                .unwrap_or("?")
                                .chars()
                                .take(24)
                                .collect(),
                        };
                        (task, file.to_owned(), n as u64 + 1, at)
                    })
            })
        })
        .collect();
    let marks: Vec<(u64, &str, u64, &str)> = marks
        .iter()
        .map(|(t, f, n, at)| (*t, f.as_str(), *n, at.as_str()))
        .collect();
    assert_eq!(
        marks,
        [
            (0, "fast.ladder.yaml", 2, "in f1"),
            (0, "fast.ladder.yaml", 3, "an input of another task"),
            (1, "slow.ladder.yaml", 2, "in s1"),
            (1, "slow.rhai", 1, "an input of another task"),
        ],
        "{info}"
    );
    // The pushed outputs are marked on the I/O table whichever task pushed them.
    let pushed: Vec<&str> = (info["tags"].as_array().expect("tags").iter())
        .filter(|t| t["pushed"] == true)
        .filter_map(|t| t["name"].as_str())
        .collect();
    assert_eq!(pushed, ["valve", "lamp"]);
    assert_eq!(
        info["tags"][0]["task"], 0,
        "start: read by the fast task's line"
    );
    assert_eq!(
        info["tags"][4]["task"], 1,
        "key: read by the slow task's line"
    );
    assert_eq!(info["tags"][5]["task"], 1, "lamp: the slow task's");
}
