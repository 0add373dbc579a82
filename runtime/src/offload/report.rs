//! The push-down part of `softplc check`: where every rung runs, the tables the modules get,
//! and each output's expected reaction time.
//!
//! Reaction times are bounds from the timing model (DESIGN.md): a central output reacts to an
//! input within one scan period (the input may change just after its read), plus the input
//! phase (the slowest line's read floor: the logic waits for every line), plus the write of
//! its line (its write floor). A module reacts within its tick: 1 ms for a MiniMod, 10 ms for a
//! RESI-16DI8RO. Input conditioning (XLATUP/XLATDN) delays the input for both alike.

use std::fmt::Write as _;
use std::time::Duration;

use softplc_io::line::{line_budget_on, LineBudget, SysfsRoot};

use softplc_io::devices::{DeviceConfig, PushDown};

use super::planner::{Command, Feature, ModulePlacement, Placement, Plan, RungPlan};
use crate::project::{Binding, ModuleConfig, OnStop, Project};
use crate::scan::fmt_duration;

/// The central reaction bound of the outputs of bus `bus`: period + slowest read + the bus's
/// write floor.
fn central(project: &Project, budgets: &[LineBudget], bus: usize) -> (Duration, String) {
    let read = budgets
        .iter()
        .map(|b| b.read_floor)
        .max()
        .unwrap_or_default();
    let write = budgets.get(bus).map(|b| b.write_floor).unwrap_or_default();
    let period = project.scan.period;
    (
        period + read + write,
        format!(
            "period {} + inputs {} + write {}",
            fmt_duration(period),
            fmt_duration(read),
            fmt_duration(write)
        ),
    )
}

/// The central reaction bound of an output on bus `bus` under `plan`: the scan period plus
/// the slowest line's read floor plus the bus's write floor. A module reacts within its tick;
/// the equivalence tests allow exactly this difference between the two.
pub fn central_bound(project: &Project, plan: &Plan, bus: usize) -> Duration {
    central(project, &budgets(project, plan), bus).0
}

/// The line budgets with the plan's settings (read-back included).
fn budgets(project: &Project, plan: &Plan) -> Vec<LineBudget> {
    let devices = plan.device_configs(project);
    project
        .buses
        .iter()
        .enumerate()
        .map(|(b, bus)| {
            let mut drivers: Vec<_> = project
                .modules
                .iter()
                .zip(&devices)
                .filter(|(m, _)| m.bus == b)
                .map(|(m, d)| {
                    (
                        m.name.clone(),
                        (m.model.driver)(d),
                        m.model.points.iter().map(|p| p.access).collect::<Vec<_>>(),
                    )
                })
                .collect();
            let (_, adapter) = bus.adapter(&SysfsRoot::default());
            line_budget_on(bus.settings, adapter, &mut drivers)
        })
        .collect()
}

/// The report.
pub fn report(project: &Project, plan: &Plan) -> String {
    report_of(project, plan, None)
}

/// [`report`] of one task of a project of several tasks: `project` is the task's view, `task`
/// its name, which the heading says (the rungs are the task's, the modules on its buses).
pub fn task_report(project: &Project, plan: &Plan, task: &str) -> String {
    report_of(project, plan, Some(task))
}

fn report_of(project: &Project, plan: &Plan, task: Option<&str>) -> String {
    let mut out = String::new();
    let on_stop = match project.offload.on_stop {
        OnStop::Clear => "cleared at stop",
        OnStop::Keep => "kept running at stop",
    };
    let of_task = task.map_or_else(String::new, |t| format!(" of task {t}"));
    let _ = writeln!(
        out,
        "\npush-down{of_task} (offload: {}; module tables {on_stop}):",
        project.offload.mode
    );
    if let Some(engine) = plan.silent_engine {
        let _ = writeln!(
            out,
            "  engine {engine} does not describe its rungs: every output stays central"
        );
    }
    let budgets = budgets(project, plan);
    let devices = plan.device_configs(project);
    let names: Vec<String> = project.tags.iter().map(|t| t.name.clone()).collect();
    let (mut pushed, mut kept) = (0usize, 0usize);
    for r in &plan.rungs {
        match &r.placement {
            Placement::Module(p) => {
                pushed += 1;
                module_rung(&mut out, project, &budgets, &devices, r, p, &names);
            }
            Placement::Central(reason) => {
                kept += 1;
                let _ = writeln!(
                    out,
                    "  {} {} ({}): central: {reason}",
                    site(r),
                    r.coil,
                    r.rung.shape.name()
                );
                if let Some(bus) = output_bus(project, r) {
                    let (bound, parts) = central(project, &budgets, bus);
                    let latency = input_latency(project, &devices, r);
                    let (bound, parts) = with_latency(&latency, bound, &parts);
                    let _ = writeln!(out, "      reaction ≤ {} ({parts})", fmt_duration(bound));
                }
            }
        }
    }
    if !plan.rungs.is_empty() {
        // The planner works per coil (every bool tag the program drives, however many rungs
        // drive it), so the count is of coils: a count of "rungs" here read as if rungs of
        // the program had gone missing.
        let _ = writeln!(
            out,
            "  {} coil(s) planned: {pushed} in modules, {kept} central (rungs that drive no bool tag, such as arithmetic, always run central)",
            pushed + kept
        );
    }
    for c in &plan.conditioning {
        let regs: Vec<String> = c
            .registers
            .iter()
            .map(|(r, v)| format!("{r} = {v} ms"))
            .collect();
        let _ = writeln!(
            out,
            "  input conditioning of {} in module {}: {}",
            c.tag,
            project.modules[c.module].name,
            regs.join(", ")
        );
    }
    for (m, push) in plan.push_down.iter().enumerate() {
        let list = push_down_settings(project, m, push);
        if list.is_empty() {
            continue;
        }
        let _ = writeln!(
            out,
            "  module {} settings added by the plan (registers written and verified at start-up): {}",
            project.modules[m].name,
            list.join(", ")
        );
    }
    out
}

/// Where a rung is, and its title when the program gives it one: `conveyor.yaml:4:5 "Belt
/// latch"` (a file position alone says little to the person who reads the report).
fn site(r: &RungPlan) -> String {
    match &r.rung.title {
        Some(title) => format!("{} \"{title}\"", r.rung.pos),
        None => r.rung.pos.to_string(),
    }
}

/// The start-up settings a module's driver adds for the plan, as `NAME: value` (what the
/// driver writes: the tables, the start values, and what they need besides).
pub(crate) fn push_down_settings(project: &Project, m: usize, push: &PushDown) -> Vec<String> {
    let Some(module) = project.modules.get(m) else {
        return Vec::new();
    };
    module
        .model
        .family
        .push_down_settings(module.model, &module.device.settings, push)
}

/// What the module's start-up does to its logic, in one line (`softplc check` prints it under
/// the module): the logic registers it clears and reads back before the first scan, whatever
/// the plan, then the pushed-down outputs' start values, then the tables of its settings.
/// `None` for a model without logic tables. `module` carries the plan's settings.
pub(crate) fn startup_logic(module: &ModuleConfig) -> Option<String> {
    let family = module.model.family;
    let cleared = family.logic_cleared_at_startup(module.model)?;
    let starts = family.startup_values(&module.device.settings);
    let starts = if starts.is_empty() {
        String::new()
    } else {
        format!(", then {}", starts.join(", "))
    };
    Some(format!(
        "start-up, before the first scan: clears {cleared} (read back: tables a crashed run left would drive the outputs){starts}, then its settings' tables"
    ))
}

/// The bus of the output a rung writes, if it is a module output.
/// The longest input latency of the module inputs rung `r` reads (a MiniMod's XLATUP/XLATDN
/// of X1..X3, 20 ms at power-on), and what it is: every reaction to those inputs, the
/// module's or the scan's, begins only once the module has taken the change.
fn input_latency(
    project: &Project,
    devices: &[DeviceConfig],
    r: &RungPlan,
) -> Option<(Duration, String)> {
    r.rung
        .shape
        .module_inputs()
        .into_iter()
        .filter_map(|tag| {
            let Binding::Point { module, point } = project.tags.get(tag.index())?.binding else {
                return None;
            };
            let m = project.modules.get(module)?;
            let name = m.model.points.get(point)?.name;
            let latency = devices.get(module)?.input_latency(name)?;
            Some((latency, format!("{name} of {}", m.name)))
        })
        .max_by_key(|(latency, _)| *latency)
}

/// `bound` and `parts` with the input latency in front, when the rung has one.
fn with_latency(
    latency: &Option<(Duration, String)>,
    bound: Duration,
    parts: &str,
) -> (Duration, String) {
    match latency {
        Some((l, of)) => (
            *l + bound,
            format!("input latency {} ({of}) + {parts}", fmt_duration(*l)),
        ),
        None => (bound, parts.to_string()),
    }
}

fn output_bus(project: &Project, r: &RungPlan) -> Option<usize> {
    match project.tags.get(r.rung.coil.index())?.binding {
        Binding::Point { module, .. } => Some(project.modules[module].bus),
        Binding::Memory => None,
    }
}

fn module_rung(
    out: &mut String,
    project: &Project,
    budgets: &[LineBudget],
    devices: &[DeviceConfig],
    r: &RungPlan,
    p: &ModulePlacement,
    names: &[String],
) {
    let module = &project.modules[p.module];
    let point = module.model.points.get(p.point).map_or("?", |s| s.name);
    let _ = writeln!(
        out,
        "  {} {} ({}): module {} {point}, {}",
        site(r),
        r.coil,
        r.rung.shape.name(),
        module.name,
        p.feature.name()
    );
    for t in &p.tables {
        let value = if t.mask {
            format!("{:#06x}", t.value)
        } else {
            t.value.to_string()
        };
        let _ = writeln!(out, "      {:<14} = {value:<6} {}", t.register, t.meaning);
    }
    if let Some(on) = p.initial {
        let _ = writeln!(
            out,
            "      start: {point} = {} after the module's old tables are cleared, before these are armed (the central rung's start)",
            u8::from(on)
        );
    }
    let (bound, parts) = central(project, budgets, module.bus);
    // The module's own reaction and the scan's both wait for the input latency first.
    let latency = input_latency(project, devices, r);
    let (module_bound, module_parts) = with_latency(
        &latency,
        p.tick,
        &format!("its tick {}", fmt_duration(p.tick)),
    );
    let (bound, parts) = with_latency(&latency, bound, &parts);
    match (&p.command, p.feature) {
        (
            Some(Command::Pulse {
                trigger,
                width,
                width_ms,
                point,
            }),
            _,
        ) => {
            let reg = module.model.points.get(*point).map_or("?", |s| s.name);
            let trig: Vec<String> = trigger
                .iter()
                .map(|e| e.display(names).to_string())
                .collect();
            let period = project.scan.period;
            let scans = width.as_nanos().div_ceil(period.as_nanos().max(1));
            let central_width = period.saturating_mul(u32::try_from(scans).unwrap_or(u32::MAX));
            let _ = writeln!(
                out,
                "      on a rising edge of {} the scan writes {reg} = {width_ms}",
                trig.join(" or ")
            );
            let _ = writeln!(
                out,
                "      width: module {} exactly vs central {} (whole scans); start ≤ {} ({parts}), the same for both",
                fmt_duration(*width),
                fmt_duration(central_width),
                fmt_duration(bound)
            );
        }
        (
            Some(Command::Lamp {
                point,
                enable,
                mask,
            }),
            _,
        ) => {
            let reg = module.model.points.get(*point).map_or("?", |s| s.name);
            let _ = writeln!(
                out,
                "      the scan writes {reg} = {mask:#06x} when {} rises and 0 when it falls: one bus write per change of the enable, none per toggle; the tag shows the enable (the module's status does not show a blinking output)",
                enable.display(names)
            );
            let first = softplc_io::devices::minimod::first_on_within(*mask)
                .map_or_else(|| "never (mask 0)".into(), fmt_duration);
            let _ = writeln!(
                out,
                "      phase: the module's 100ms steps run freely from its power-on, so the pattern starts where they are, not at its first bit: the first on-step ≤ {first} after the write, which comes ≤ {} after the enable ({parts}); edges on the module's steps vs central on scan boundaries",
                fmt_duration(bound)
            );
        }
        (None, Feature::Pulse) => {
            let _ = writeln!(
                out,
                "      reaction: module ≤ {} ({module_parts}) vs central ≤ {} ({parts}); the pulse's end is timed by the module to its tick",
                fmt_duration(module_bound),
                fmt_duration(bound)
            );
        }
        (None, _) => {
            let _ = writeln!(
                out,
                "      reaction: module ≤ {} ({module_parts}) vs central ≤ {} ({parts})",
                fmt_duration(module_bound),
                fmt_duration(bound)
            );
        }
    }
}
