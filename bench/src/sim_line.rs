//! A simulated RS-485 line of MiniMods driven by the runtime's bus owner in real time, with the
//! wire-time floor of its poll plan computed by the same code `softplc check` uses. The floors
//! of a single module ([`read_floor`], [`write_floor`]) take any catalog model.
//!
//! Drivers are built from the catalog with the project file's textual settings (`RDELAYT`,
//! `events`, ...), and the owner runs their start-up exchange, as `Plc::build` does.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use softplc_io::devices::minimod::{self, MiniModSim};
use softplc_io::devices::{ModelSpec, Protocol};
use softplc_io::driver::{Driver, Outgoing, Transaction};
use softplc_io::line::{
    line_budget, modbus_reply_len, transaction_time, BusCommand, BusEvent, BusOwner, BusThread,
    Discipline, LineBudget, LineSettings, Module, OutputFrame,
};
use softplc_io::point::{Access, Value};
use softplc_io::sim::{SharedWorld, SimWorld, VirtualPort};
use softplc_io::time::Clock;

/// A line ready to run.
#[derive(Debug)]
pub(crate) struct MiniModLine {
    /// The bus owner, start-up done (not yet on its thread).
    pub owner: BusOwner,
    /// The simulated world behind the line: device `i` is the module at address `i + 1`.
    pub world: SharedWorld,
    /// The line's budget: the floor of a read cycle and of a full write.
    pub budget: LineBudget,
    /// Floor of the writes of one cycle in which Y1 of every module changes.
    pub toggle_write_floor: Duration,
}

/// A MiniMod driver at `address` with the project file's `settings`.
pub(crate) fn driver(address: u8, settings: &[(&str, &str)]) -> Box<dyn Driver> {
    model_driver(&minimod::MODEL, address, settings)
}

/// A Modbus driver of catalog `model` at `address` with the project file's `settings`.
pub(crate) fn model_driver(
    model: &ModelSpec,
    address: u8,
    settings: &[(&str, &str)],
) -> Box<dyn Driver> {
    match model.device_config(
        &format!("{}{address}", model.name),
        address,
        Protocol::Modbus,
        settings,
    ) {
        Ok(config) => (model.driver)(&config),
        // The callers check the settings first (`minimods`) or pass none.
        Err(e) => panic!("{}: {e}", model.name),
    }
}

/// `n` MiniMods at addresses 1..=n with the same `settings` (project-file keys and values, e.g.
/// `RDELAYT`, `events`) on one virtual line at `line`, in real time on `clock`.
pub(crate) fn minimods(
    n: u8,
    line: LineSettings,
    settings: &[(&str, &str)],
    clock: Arc<dyn Clock>,
) -> anyhow::Result<MiniModLine> {
    minimod::MODEL
        .device_config("mm1", 1, Protocol::Modbus, settings)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut modules = Vec::with_capacity(usize::from(n));
    let mut budget_drivers: Vec<(String, Box<dyn Driver>, Vec<Access>)> = Vec::new();
    let mut toggle_write_floor = Duration::ZERO;
    for address in 1..=n {
        let name = format!("mm{address}");
        modules.push((name.clone(), driver(address, settings)));
        let access = minimod::POINTS.iter().map(|p| p.access).collect();
        budget_drivers.push((name, driver(address, settings), access));
        toggle_write_floor += write_floor(&minimod::MODEL, line, settings, "Y1");
    }
    let budget = line_budget(line, &mut budget_drivers);
    let (owner, world) = line_of(modules, line, clock)?;
    Ok(MiniModLine {
        owner,
        world,
        budget,
        toggle_write_floor,
    })
}

/// A virtual line at `line` of one simulated MiniMod per driver (device `i` at the address
/// of driver `i`), their bus owner's start-up done, in real time on `clock`.
pub(crate) fn line_of(
    drivers: Vec<(String, Box<dyn Driver>)>,
    line: LineSettings,
    clock: Arc<dyn Clock>,
) -> anyhow::Result<(BusOwner, SharedWorld)> {
    let mut world = SimWorld::new(vec![line]);
    let mut modules = Vec::with_capacity(drivers.len());
    for (name, driver) in drivers {
        world.add_device(0, &name, Box::new(MiniModSim::new(driver.address())));
        modules.push(Module::new(name, driver));
    }
    let world = world.shared();
    let port = VirtualPort::new(world.clone(), 0, line, clock);
    let mut owner = BusOwner::new("bench", Box::new(port), Discipline::default(), modules);
    owner
        .startup()
        .context("module start-up on the bench line")?;
    Ok((owner, world))
}

/// One MiniMod's desired outputs with only Y1 driven, at `on`.
pub(crate) fn y1_frame(on: bool) -> Vec<Option<Value>> {
    let mut desired = vec![None; minimod::POINTS.len()];
    if let Some(i) = minimod::point_index("Y1") {
        desired[i] = Some(Value::Bool(on));
    }
    desired
}

/// The floor of the writes of one cycle in which output `point` of one `model` module at
/// `line` with `settings` changes: planned on a scratch driver and priced on the wire.
pub(crate) fn write_floor(
    model: &ModelSpec,
    line: LineSettings,
    settings: &[(&str, &str)],
    point: &str,
) -> Duration {
    let (plan, delay) = planned_write(model, settings, point);
    plan.iter()
        .map(|tx| transaction_time(line, tx, delay))
        .sum()
}

/// The writes a scratch `model` driver with `settings` plans when output `point` changes, and
/// its reply delay.
fn planned_write(
    model: &ModelSpec,
    settings: &[(&str, &str)],
    point: &str,
) -> (Vec<Transaction>, Duration) {
    let mut desired = vec![None; model.points.len()];
    if let Some(i) = model.point_index(point) {
        desired[i] = Some(Value::Bool(true));
    }
    let mut scratch = model_driver(model, 1, settings);
    let mut plan: Vec<Transaction> = Vec::new();
    scratch.plan_write(&desired, false, &mut plan);
    (plan, scratch.reply_delay())
}

/// The output frame of a line of `n` modules with every Y1 at `on`.
pub(crate) fn all_y1(n: usize, on: bool) -> OutputFrame {
    OutputFrame {
        modules: vec![y1_frame(on); n],
    }
}

/// The floor of one read cycle of a single MiniMod at `line` with `settings`, and the part of
/// it from the end of the request to the end of the reply (reply delay + reply characters).
pub(crate) fn single_read_floor(
    line: LineSettings,
    settings: &[(&str, &str)],
) -> (Duration, Duration) {
    read_floor(&minimod::MODEL, line, settings)
}

/// [`single_read_floor`] of one module of catalog `model`.
pub(crate) fn read_floor(
    model: &ModelSpec,
    line: LineSettings,
    settings: &[(&str, &str)],
) -> (Duration, Duration) {
    let mut driver = model_driver(model, 1, settings);
    let delay = driver.reply_delay();
    let mut plan = Vec::new();
    driver.plan_read(&mut plan);
    let floor = plan
        .iter()
        .map(|tx| transaction_time(line, tx, delay))
        .sum();
    (floor, round_trip(line, delay, &plan))
}

/// The part of `plan`'s transactions from the end of each request to the end of its reply:
/// reply delay + reply characters, what paces a master on a pty (which has no baud rate).
fn round_trip(line: LineSettings, delay: Duration, plan: &[Transaction]) -> Duration {
    plan.iter()
        .map(|tx| match &tx.frame {
            Outgoing::Modbus { request, .. } => delay + line.chars(modbus_reply_len(request)),
            // Text replies and broadcasts: their length is not known here.
            _ => delay,
        })
        .sum()
}

/// [`round_trip`] of the writes of one cycle in which output `point` of one MiniMod at `line`
/// with `settings` changes.
pub(crate) fn write_round_trip(
    line: LineSettings,
    settings: &[(&str, &str)],
    point: &str,
) -> Duration {
    let (plan, delay) = planned_write(&minimod::MODEL, settings, point);
    round_trip(line, delay, &plan)
}

/// One read of every module on `bus`: how many of them failed it. An error when the bus thread
/// does not answer within `wait`.
pub(crate) fn read_failures(bus: &mut BusThread, wait: Duration) -> anyhow::Result<u64> {
    bus.send(BusCommand::Read);
    match bus.recv(wait) {
        Some(BusEvent::Inputs(frame)) => Ok(frame
            .modules
            .iter()
            .filter(|m| m.last_error.is_some())
            .count() as u64),
        _ => anyhow::bail!("the bus thread did not answer a read within {wait:?}"),
    }
}
