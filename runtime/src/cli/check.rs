//! `softplc check PROJECT`: validate, print the I/O map and each line's budget.

use std::path::PathBuf;
use std::process::ExitCode;

use softplc_io::line::{line_budget_on, members_floor, AdapterTiming, EchoMode, SysfsRoot};
use softplc_io::point::Access;

use crate::image::{ProcessImage, TagId};
use crate::logic::load;
use crate::project::{Binding, PortConfig, Project};
use crate::scan::fmt_duration;

/// Arguments of `softplc check`.
#[derive(Debug, clap::Args)]
pub(crate) struct CheckArgs {
    /// The project file.
    project: PathBuf,
}

pub(super) fn check(args: CheckArgs) -> anyhow::Result<ExitCode> {
    let project = match super::built_services::load(&args.project) {
        Ok(p) => p,
        Err(errors) => {
            super::out::errln(&errors);
            return Ok(ExitCode::FAILURE);
        }
    };
    let image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
    let (engines, ownership) = match load::load_tasks(&project, &image) {
        Ok(loaded) => loaded,
        Err(e) => {
            super::out::errln(&e.to_string());
            return Ok(ExitCode::FAILURE);
        }
    };
    // The I/O map and budgets as the drivers will run: with the push-down plan's settings
    // (tables, read-back). Each task's program is planned on its own view of the project
    // (its buses' modules, its period), as its thread runs it.
    let views: Vec<_> = (0..project.tasks.len())
        .map(|i| project.task_view(i, |t| ownership.owner(TagId(t as u32)) == Some(i)))
        .collect();
    let plans: Vec<_> = views
        .iter()
        .zip(&engines)
        .map(|(view, engine)| crate::offload::plan_program(view, engine.as_ref()))
        .collect();
    let mut planned = project.clone();
    for (i, (view, plan)) in views.iter().zip(&plans).enumerate() {
        let mine = planned
            .modules
            .iter_mut()
            .filter(|m| project.task_of_bus(m.bus) == i);
        for (module, device) in mine.zip(plan.device_configs(view)) {
            module.device = device;
        }
    }
    let execution = engines.first().and_then(|e| e.execution());
    super::out::out(&report(&planned, execution.as_deref()))?;
    if project.multitask() {
        super::out::out(&tasks::report(&project, &engines, &ownership))?;
    }
    super::out::out(&programs::shared_write_warnings(&project, &engines))?;
    let mut failed = false;
    for ((view, plan), task) in views.iter().zip(&plans).zip(&project.tasks) {
        let report = match project.multitask() {
            true => crate::offload::report::task_report(view, plan, &task.name),
            false => crate::offload::report::report(view, plan),
        };
        super::out::out(&report)?;
        let failures = plan.require_failures();
        if !failures.is_empty() {
            super::out::errln(&crate::offload::runtime::lines(&failures).to_string());
            failed = true;
        }
    }
    if failed {
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}

/// The text `check` prints for a valid project: I/O map, budgets, warnings; adapter
/// latencies are read from this machine's sysfs. `execution` is the engine's line on how the
/// program runs ([`crate::logic::LogicEngine::execution`]).
pub(crate) fn report(project: &Project, execution: Option<&str>) -> String {
    report_on(project, &SysfsRoot::default(), execution)
}

/// [`report`], with sysfs under `sysfs` (a fake tree in tests).
#[cfg(test)]
pub(crate) fn report_with(project: &Project, sysfs: &SysfsRoot) -> String {
    report_on(project, sysfs, None)
}

fn report_on(project: &Project, sysfs: &SysfsRoot, execution: Option<&str>) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let scan = &project.scan;
    if project.multitask() {
        let _ = writeln!(
            out,
            "project {}: {} tasks (each its own thread, period and watchdog)",
            project.name,
            project.tasks.len()
        );
    } else {
        let _ = writeln!(out, "project {}: scan {}", project.name, timing(scan));
        out.push_str(&programs::lines(&project.programs, ""));
        if let Some(line) = execution {
            let _ = writeln!(out, "  {line}");
        }
    }
    let mut worst = std::time::Duration::ZERO;
    let mut warnings = Vec::new();
    // Each serial line's cycle mix by the task driving it, played together below.
    let mut scans: Vec<Vec<(String, softplc_io::line::CycleMix)>> =
        vec![Vec::new(); project.tasks.len().max(1)];
    for (b, bus) in project.buses.iter().enumerate() {
        let port = match &bus.port {
            PortConfig::Sim => "sim (simulated modules)".to_string(),
            PortConfig::Serial(p) => p.display().to_string(),
            PortConfig::Tcp(e) => tcp::describe(e, project.modules.iter().filter(|m| m.bus == b)),
        };
        let line = if bus.port.is_modbus_tcp() {
            String::new()
        } else {
            format!(", {}", bus.settings)
        };
        // The bus's budget counts against the period of the task doing its I/O.
        let period = project.bus_period(b);
        let task = match project.multitask() {
            true => format!(", task {}", project.tasks[project.task_of_bus(b)].name),
            false => String::new(),
        };
        let _ = writeln!(
            out,
            "\nbus {}: {port}{line}, response timeout {}, retries {}{task}",
            bus.name,
            fmt_duration(bus.response_timeout),
            bus.retries
        );
        // What the adapter holds back counts in every transaction that waits for bytes back
        // (line/latency.rs); an echo comes while the request is sent and adds nothing.
        let (assumed, adapter) = bus.adapter(sysfs);
        if let PortConfig::Tcp(_) = bus.port {
            let _ = writeln!(out, "  {}", tcp::connection());
        } else {
            let _ = writeln!(out, "  adapter latency: {assumed}");
        }
        if bus.echo == EchoMode::Discard {
            let _ = writeln!(
                out,
                "  echo: discard (every request is read back and verified; it comes back while \
                 it is sent, so the budget counts nothing for it)"
            );
        }
        let mut drivers = Vec::new();
        for (m, module) in project
            .modules
            .iter()
            .enumerate()
            .filter(|(_, m)| m.bus == b)
        {
            let _ = writeln!(
                out,
                "  module {} = {} @{} ({}){}",
                module.name,
                module.model.name,
                module.device.address,
                module.device.protocol.name(),
                described(module.description.as_ref())
            );
            if let Some(line) = crate::offload::report::startup_logic(module) {
                let _ = writeln!(out, "    {line}");
            }
            let (watchdog, warning) = crate::project::watchdog::report(module);
            let _ = writeln!(out, "{watchdog}");
            warnings.extend(warning);
            if let Some(profile) = module.model.profile {
                let _ = write!(out, "{}", profile_map(profile, m, &project.tags));
            }
            for (i, tag) in project.tags.iter().enumerate() {
                if let Binding::Point { module: tm, point } = tag.binding {
                    if tm == m {
                        let p = &module.model.points[point];
                        let dir = match p.access {
                            Access::Input => "in ",
                            Access::Output => "out",
                            Access::ReadWrite => "r/w",
                        };
                        let safe = tag.safe.map(|v| format!(" safe={v}")).unwrap_or_default();
                        let _ = writeln!(
                            out,
                            "    {dir} {:<8} {:<4} → tag #{i} {}{safe}{}",
                            p.name,
                            p.ty.name(),
                            tag.name,
                            described(tag.description.as_ref())
                        );
                    }
                }
            }
            drivers.push((
                module.name.clone(),
                (module.model.driver)(&module.device),
                module
                    .model
                    .points
                    .iter()
                    .map(|p| p.access)
                    .collect::<Vec<_>>(),
            ));
        }
        let budget = line_budget_on(bus.settings, adapter, &mut drivers);
        if bus.port.is_modbus_tcp() {
            out.push_str(&tcp::budget(bus, &budget, period));
            continue;
        }
        warnings.extend(turnaround::warnings(
            bus,
            adapter,
            drivers
                .iter()
                .map(|(name, d, _)| (name.as_str(), d.as_ref())),
        ));
        let mix = project.cycle_mix(b, adapter);
        let held = latency_clause(adapter, "each with ");
        // A line in event mode: its longest input phase is a refresh after the round.
        let round = if budget.collect_round.is_zero() {
            String::new()
        } else {
            format!(
                " after an idle Collect round of {}, a refresh cycle",
                fmt_duration(budget.collect_round)
            )
        };
        let _ = writeln!(
            out,
            "  budget: inputs {} ({} transactions{held}{round}), full output write {}, cycle \
             floor {}",
            fmt_duration(budget.read_floor),
            budget
                .modules
                .iter()
                .map(|m| m.read_transactions)
                .sum::<usize>(),
            fmt_duration(budget.write_floor),
            fmt_duration(budget.cycle_floor())
        );
        if let Some(line) = collect_floor_line(bus.settings, adapter, &drivers) {
            let _ = writeln!(out, "  {line}");
        }
        for line in plan::lines(project, bus, adapter) {
            let _ = writeln!(out, "  {line}");
        }
        let floor = budget.cycle_floor().as_secs_f64();
        for m in &budget.modules {
            let share = if floor > 0.0 {
                format!(
                    " ({:.0}% of the line's cycle floor)",
                    (m.read_time + m.write_time).as_secs_f64() * 100.0 / floor
                )
            } else {
                String::new()
            };
            let _ = writeln!(
                out,
                "    {}: read {} in {} tx, write {} in {} tx{share}",
                m.name,
                fmt_duration(m.read_time),
                m.read_transactions,
                fmt_duration(m.write_time),
                m.write_transactions
            );
        }
        worst = worst.max(mix.ordinary);
        // What a module that stops answering costs (bus.rs: its first failed cycle with the
        // line's retries, then one attempt per cycle until lost, then one probe per backoff),
        // against how long the scan waits for a line's inputs.
        // With echo: discard the response timeout starts once the echo is back, which the
        // adapter holds back as it would a reply.
        let attempt = softplc_io::line::failed_attempt(bus.settings, bus.response_timeout)
            + match bus.echo {
                EchoMode::Discard => adapter.latency,
                EchoMode::None => std::time::Duration::ZERO,
            };
        let first = attempt * (u32::from(bus.retries) + 1);
        let n = budget.modules.len() as u32;
        let input_wait = period * 9 / 10;
        let _ = writeln!(
            out,
            "  on failure: a silent module costs the line {} in its first failed cycle, then {} \
             per cycle until lost (3 cycles), then one probe of {} per backoff (1 s to 30 s); \
             the scan waits {} for inputs, then goes on with the line's last values (stale)",
            fmt_duration(first),
            fmt_duration(attempt),
            fmt_duration(attempt),
            fmt_duration(input_wait)
        );
        // A note, not a warning: the scan no longer waits for a dead line, so this costs the
        // line's detection time, not the machine's cycle (a warning would fire on almost
        // every real project, the quick start included).
        if first * n > period {
            let _ = writeln!(
                out,
                "  note: bus {}: with every module silent (a dead line) the first failed cycle takes {} ({n} module(s) × {} attempt(s) × {} with response timeout {}), longer than the scan period {}: the scan goes on without it, the line's inputs stale, then bad once its modules are lost; a shorter response_timeout or fewer retries find the fault sooner",
                bus.name,
                fmt_duration(first * n),
                u32::from(bus.retries) + 1,
                fmt_duration(attempt),
                fmt_duration(bus.response_timeout),
                fmt_duration(period)
            );
        }
        let prediction = mix.predict(period);
        for line in cycle_mix::lines(&mix, &prediction) {
            let _ = writeln!(out, "  {line}");
        }
        warnings.extend(cycle_mix::warning(&bus.name, &prediction));
        if let Some(lines) = scans.get_mut(project.task_of_bus(b)) {
            lines.push((bus.name.clone(), mix));
        }
    }
    // A scan of several lines overruns when any of them does, and a slow line's read holds
    // the others' writes back: its own prediction, not the lines' apart.
    for (t, lines) in scans.iter().enumerate() {
        let task = project.multitask().then(|| project.tasks[t].name.as_str());
        // One line's own prediction above is its scan's.
        if lines.is_empty() || (task.is_none() && lines.len() == 1) {
            continue;
        }
        let period = project.tasks.get(t).map_or(scan.period, |t| t.scan.period);
        let p = softplc_io::line::CycleMix::predict_together(lines.iter().map(|(_, m)| m), period);
        let names: Vec<&str> = lines.iter().map(|(name, _)| name.as_str()).collect();
        let _ = writeln!(out, "\n{}", cycle_mix::scan_line(task, &names, &p));
        if lines.len() > 1 {
            warnings.extend(cycle_mix::scan_warning(task, &p));
        }
    }
    let memory: Vec<_> = project
        .tags
        .iter()
        .filter(|t| t.binding == Binding::Memory)
        .collect();
    if !memory.is_empty() {
        let _ = writeln!(out, "\nmemory tags:");
        for t in memory {
            let _ = writeln!(
                out,
                "  {} {} = {}{}",
                t.name,
                t.ty.name(),
                t.initial,
                described(t.description.as_ref())
            );
        }
    }
    let plant_lines = plant::lines(project);
    if !plant_lines.is_empty() {
        out.push('\n');
    }
    for line in plant_lines {
        let _ = writeln!(out, "{line}");
    }
    // With tasks, each line's cycle mix above is its own task's.
    if !project.multitask() {
        let _ = writeln!(
            out,
            "\nlines are polled in parallel: an ordinary cycle's input phase can be no shorter \
             than {} (the slowest line's; a refresh or an input change makes a cycle longer: \
             each line's cycle mix says by how much)",
            fmt_duration(worst)
        );
    }
    out.push_str(&crate::service::network::report(project));
    let notes = unit_network::notes(project);
    if !notes.is_empty() {
        out.push('\n');
    }
    for note in notes {
        let _ = writeln!(out, "{note}");
    }
    for w in warnings {
        let _ = writeln!(out, "{w}");
    }
    out
}

/// A task's timing as `check` says it: `period 20.00ms, watchdog 100.00ms × 3`.
fn timing(scan: &crate::project::ScanConfig) -> String {
    format!(
        "period {}, watchdog {} × {}",
        fmt_duration(scan.period),
        fmt_duration(scan.watchdog.time),
        scan.watchdog.sensitivity
    )
}

/// A description at the end of an I/O map's line: `  — Start button, green`, or nothing.
fn described(description: Option<&crate::project::DocText>) -> String {
    description.map_or(String::new(), |d| format!("  — {d}"))
}

/// A profile module's I/O map: where the profile came from, its timing and poll groups, then
/// every point (table, address, type, scaling, access, group, the manual's name) with the tag
/// bound to it.
fn profile_map(
    profile: &softplc_io::devices::profile::Profile,
    module: usize,
    tags: &[crate::project::TagConfig],
) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(out, "    profile {}: {}", profile.model, profile.source);
    let t = &profile.timing;
    let groups: Vec<String> = profile
        .groups
        .iter()
        .map(|g| match g.period {
            Some(p) => format!("{} every {}", g.name, fmt_duration(p)),
            None => format!("{} every cycle", g.name),
        })
        .collect();
    let _ =
        writeln!(
        out,
        "    timing: reply delay {}, reply timeout {}, frame gap {}; at most {} registers / {} \
         bits per read{}; poll groups: {}",
        fmt_duration(t.reply_delay),
        t.reply_timeout.map_or("the line's".into(), fmt_duration),
        t.frame_gap.map_or("t3.5".into(), fmt_duration),
        profile.limits.max_registers,
        profile.limits.max_bits,
        if profile.limits.read_gaps { ", gaps read" } else { "" },
        groups.join(", ")
    );
    for (e, entry) in profile.entries().into_iter().enumerate() {
        let p = &profile.points[entry.point];
        let name = match entry.bits {
            Some(b) => &p.bits[b].name,
            None => &p.name,
        };
        let bound: Vec<&crate::project::TagConfig> = tags
            .iter()
            .filter(|t| t.binding == Binding::Point { module, point: e })
            .collect();
        let tag = if bound.is_empty() {
            String::new()
        } else {
            let names: Vec<&str> = bound.iter().map(|t| t.name.as_str()).collect();
            let words: String = bound
                .iter()
                .map(|t| described(t.description.as_ref()))
                .collect();
            format!(" → tag {}{words}", names.join(", "))
        };
        let _ = writeln!(
            out,
            "      {name:<14} {}{tag}",
            softplc_io::devices::profile::describe(profile, entry)
        );
    }
    out
}

/// The floor of a line's Collect round, for a line with modules in event mode (MiniMod
/// manual, "The Modbus function Collect"; `line/collect/floor.rs`), with what it includes.
fn collect_floor_line(
    settings: softplc_io::line::LineSettings,
    adapter: AdapterTiming,
    drivers: &[(String, Box<dyn softplc_io::driver::Driver>, Vec<Access>)],
) -> Option<String> {
    let members: Vec<_> = drivers
        .iter()
        .filter_map(|(_, d, _)| d.collect_membership())
        .collect();
    let floor = members_floor(settings, adapter, &members)?;
    let (first, last) = floor.window();
    let held = latency_clause(adapter, "per Collect ");
    // RDELAYM: a member that waits longer for a request's end starts its slot that much later.
    let late = if floor.frame_timeout().is_zero() {
        String::new()
    } else {
        format!(
            ", the members' longest RDELAYM {} per Collect",
            fmt_duration(floor.frame_timeout())
        )
    };
    Some(format!(
        "collect floor (event mode, window {first}–{last}, {} member(s)): idle round {} (a \
         Collect request of {} characters, {} slot{} × 3 ms + 1 ms, t3.5{held}{late}); each event \
         {} more (its {}-character reply from the start of its slot, t3.5, the next Collect; \
         less from address {last}, which ends the round); no reply delay applies",
        members.len(),
        fmt_duration(floor.idle()),
        softplc_io::line::COLLECT_REQUEST_LEN,
        floor.slots(),
        if floor.slots() == 1 { "" } else { "s" },
        fmt_duration(floor.per_event()),
        softplc_io::line::COLLECT_REPLY_LEN,
    ))
}

/// `, {each}up to L of adapter latency` when the line's adapter holds bytes back, else nothing.
fn latency_clause(adapter: AdapterTiming, each: &str) -> String {
    if adapter.latency.is_zero() {
        String::new()
    } else {
        format!(
            ", {each}up to {} of adapter latency",
            fmt_duration(adapter.latency)
        )
    }
}

mod cycle_mix;
mod plan;
mod plant;
mod programs;
mod tasks;
mod tcp;
#[cfg(test)]
mod tests;
mod turnaround;
mod unit_network;
