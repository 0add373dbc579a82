//! Building a PLC from a validated project.

use std::sync::Arc;
use std::time::Duration;

use softplc_io::line::{
    echo_margin, BusOwner, Counters, Discipline, EchoDiscard, EchoMode, LineError, LineLink,
    ModbusTcpTransport, Module, NetFraming, OutputFrame, RtuOverTcpTransport, SerialTransport,
    SysfsRoot, Transport, CONNECT_TIMEOUT,
};
use softplc_io::point::{Access, Quality};
use softplc_io::sim::{SharedWorld, SimWorld, VirtualPort};
use softplc_io::wire::WireTap;

use crate::clock::Clock;
use crate::image::{ProcessImage, TagId};
use crate::logic::load;
use crate::offload::{self, runtime::Offloaded};
use crate::project::{Binding, PortConfig, Project};

use super::*;
use softplc_io::time::ScanInstant;

impl Plc {
    /// Builds the PLC for `project` on `clock`: compiles the program, opens every line (and the
    /// simulated world for `port: sim`), and runs every module's start-up configuration.
    pub fn build(project: Project, clock: Arc<dyn Clock>) -> Result<Self, BuildError> {
        Self::build_on(project, clock, None)
    }

    /// Builds the PLC on a simulated world that already exists (`None`: a new one, as
    /// [`Plc::build`] does): the modules keep whatever state an earlier PLC left in them, as
    /// real modules do across a restart of the host (a `kill -9`, a crash, a reboot). The
    /// world must hold a device of the project's name for every module on a `port: sim` line.
    pub fn build_on(
        project: Project,
        clock: Arc<dyn Clock>,
        world: Option<SharedWorld>,
    ) -> Result<Self, BuildError> {
        Self::build_traced(project, clock, world, None)
    }

    /// [`Plc::build_on`], with every line's bus owner reporting its traffic (frames sent and
    /// received, timeouts, discarded bytes) to `tap`, the start-up sequences included
    /// (`softplc run --trace-bus`).
    pub fn build_traced(
        project: Project,
        clock: Arc<dyn Clock>,
        world: Option<SharedWorld>,
        tap: Option<Arc<dyn WireTap>>,
    ) -> Result<Self, BuildError> {
        Self::build_lines_in(project, clock, world, tap, None)
    }

    /// [`Plc::build_traced`], where bus `b` of `project` is line `world_lines[b]` of `world`
    /// (a task's view of a project whose world holds every task's lines; `None`: line `b`).
    pub(super) fn build_lines_in(
        project: Project,
        clock: Arc<dyn Clock>,
        world: Option<SharedWorld>,
        tap: Option<Arc<dyn WireTap>>,
        world_lines: Option<&[usize]>,
    ) -> Result<Self, BuildError> {
        if project.multitask() {
            return Err(BuildError::SeveralTasks {
                tasks: project.tasks.len(),
            });
        }
        let image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
        let mut logic = load::load_program(&project, &image)?;
        for w in logic.shared_writes() {
            // Legal (the later program's value stands) but rarely meant: said at every start.
            tracing::warn!(
                "{}: tag `{}` is also written by an earlier program of the task at {}; the \
                 later program's value stands at the cycle's end",
                w.then,
                image.name(w.tag),
                w.first
            );
        }
        // Push-down: the modules run the rungs the plan places there; their drivers get the
        // tables as start-up settings (written and verified before the first scan).
        let plan = offload::plan_program(&project, logic.as_ref());
        let failures = plan.require_failures();
        if !failures.is_empty() {
            return Err(BuildError::Offload(failures));
        }
        for (r, _) in plan.pushed() {
            logic.release(r.rung.coil);
        }
        let devices = plan.device_configs(&project);
        let mut image = image;
        for (i, t) in project.tags.iter().enumerate() {
            if t.binding == Binding::Memory {
                image.set(TagId(i as u32), t.initial, ScanInstant::ZERO);
            }
        }
        let (retain, notes) = crate::retain::Retainer::open(&project, &mut image);
        for note in notes {
            match note {
                n if n.is_warning() => tracing::warn!("{n}"),
                n @ crate::retain::LoadNote::Missing(_) => tracing::debug!("{n}"),
                n => tracing::info!("{n}"),
            }
        }

        // A world that exists keeps its plant running: the machine does not restart with its PLC.
        let new_world = world.is_none();
        let mut world = world.or_else(|| build_world(&project));
        let mut bus_modules: Vec<Vec<usize>> = vec![Vec::new(); project.buses.len()];
        for (m, module) in project.modules.iter().enumerate() {
            bus_modules[module.bus].push(m);
        }
        let mut lines = Vec::with_capacity(project.buses.len());
        for (b, bus) in project.buses.iter().enumerate() {
            // The adapter's latency timer holds an echo back as it holds a reply.
            let mut adapter_latency = Duration::ZERO;
            // Why the port could not be opened, when it could not (the line starts lost).
            let mut port_down = None;
            let transport: Box<dyn Transport> = match &bus.port {
                PortConfig::Sim => {
                    // build_world makes a world whenever a bus is `port: sim`.
                    let world = world.get_or_insert_with(|| SimWorld::new(Vec::new()).shared());
                    Box::new(VirtualPort::new(
                        world.clone(),
                        world_lines.and_then(|w| w.get(b).copied()).unwrap_or(b),
                        bus.settings,
                        clock.clone(),
                    ))
                }
                PortConfig::Serial(path) => {
                    let port_error = |source| BuildError::Port {
                        bus: bus.name.clone(),
                        source,
                    };
                    match SerialTransport::open(path, bus.settings, clock.clone()) {
                        Ok(mut port) => {
                            if let Some(mode) = bus.rs485 {
                                port.set_rs485(mode).map_err(port_error)?;
                            }
                            adapter_latency = port
                                .set_adapter_latency(bus.adapter_latency, SysfsRoot::default())
                                .map_err(port_error)?;
                            Box::new(port)
                        }
                        // Absent or not openable yet (a USB adapter that enumerates late at
                        // boot): the line starts lost, as an unplugged one is, and the bus
                        // owner takes the port when it appears. What the port refuses once
                        // open (RS-485 mode, a latency ceiling) is the project's error.
                        Err(e @ LineError::Open { .. }) => {
                            adapter_latency = bus.adapter_latency.before_open();
                            port_down = Some(e);
                            Box::new(SerialTransport::open_later(
                                path,
                                bus.settings,
                                clock.clone(),
                                bus.rs485,
                                (bus.adapter_latency, SysfsRoot::default()),
                            ))
                        }
                        Err(e) => return Err(port_error(e)),
                    }
                }
                // Nothing is connected here: a server that is not up yet leaves its modules
                // lost at start-up, and the bus owner connects when its backoff allows.
                PortConfig::Tcp(endpoint) => match endpoint.framing {
                    NetFraming::ModbusTcp => Box::new(
                        ModbusTcpTransport::new(endpoint.clone(), CONNECT_TIMEOUT, clock.clone())
                            .map_err(|source| BuildError::Thread {
                            bus: bus.name.clone(),
                            source,
                        })?,
                    ),
                    NetFraming::RtuOverTcp => Box::new(RtuOverTcpTransport::new(
                        endpoint.clone(),
                        bus.settings,
                        CONNECT_TIMEOUT,
                        clock.clone(),
                    )),
                },
            };
            let transport: Box<dyn Transport> = match bus.echo {
                EchoMode::None => transport,
                EchoMode::Discard => Box::new(EchoDiscard::new(
                    transport,
                    echo_margin(bus.settings, adapter_latency),
                )),
            };
            let modules: Vec<Module> = bus_modules[b]
                .iter()
                .map(|&m| {
                    let cfg = &project.modules[m];
                    Module::new(cfg.name.clone(), (cfg.model.driver)(&devices[m]))
                })
                .collect();
            if bus.port.is_modbus_tcp() {
                if let Some(m) = modules
                    .iter()
                    .find(|m| m.driver.collect_membership().is_some())
                {
                    return Err(BuildError::EventsOnModbusTcp {
                        bus: bus.name.clone(),
                        module: m.name.clone(),
                    });
                }
            }
            let discipline = Discipline {
                response_timeout: bus.response_timeout,
                retries: bus.retries,
                output_refresh: bus.output_refresh,
                adapter_latency,
                ..Discipline::default()
            };
            let mut owner = BusOwner::new(bus.name.clone(), transport, discipline, modules);
            if let Some(tap) = &tap {
                owner.set_wire_tap(tap.clone());
            }
            owner.sync(clock.now().on_line_clock());
            if let Some(e) = &port_down {
                owner.port_down_at_start(e);
            }
            owner.startup().map_err(|source| BuildError::Startup {
                bus: bus.name.clone(),
                source,
            })?;
            // The first cycle starts once the start-up traffic (tables, settings) and the t3.5
            // after it are over, so it finds an idle line; on the real clock that time has
            // passed already.
            clock.sleep_until(owner.free_at().on_scan_clock());
            // The one place the clock decides how lines run: the scan runs them itself in
            // virtual time (a project replays bit for bit), each has its thread in real time.
            lines.push(if clock.is_virtual() {
                LineLink::inline(owner)
            } else {
                LineLink::thread(owner, clock.clone()).map_err(|source| BuildError::Thread {
                    bus: bus.name.clone(),
                    source,
                })?
            });
        }

        if let (true, Some(world)) = (new_world, &world) {
            attach_plant(&project, world, clock.now());
        }
        let mut inputs = Vec::new();
        let mut outputs = Vec::new();
        for (i, tag) in project.tags.iter().enumerate() {
            let Binding::Point { module, point } = tag.binding else {
                continue;
            };
            let cfg = &project.modules[module];
            let bus = cfg.bus;
            let in_bus = bus_modules[bus]
                .iter()
                .position(|&m| m == module)
                .unwrap_or(0);
            let id = TagId(i as u32);
            match cfg.model.points[point].access {
                // The module drives it (see `offload`).
                Access::Output if plan.is_pushed(id) => {}
                Access::Output => outputs.push(OutputBinding {
                    tag: id,
                    bus,
                    module: in_bus,
                    point,
                    safe: tag.safe.unwrap_or(tag.ty.zero()),
                }),
                Access::Input | Access::ReadWrite => inputs.push(InputBinding {
                    tag: id,
                    bus,
                    module: in_bus,
                    point,
                }),
            }
        }
        let frames = bus_modules
            .iter()
            .map(|mods| OutputFrame {
                modules: mods
                    .iter()
                    .map(|&m| vec![None; project.modules[m].model.points.len()])
                    .collect::<Vec<_>>(),
            })
            .collect();
        let status = project
            .modules
            .iter()
            .map(|m| ModuleStatus {
                name: m.name.clone(),
                bus: project.buses[m.bus].name.clone(),
                quality: Quality::Bad,
                outputs: Quality::Bad,
                counters: Counters::default(),
                last_error: None,
                reported: false,
            })
            .collect();
        let line_wait = project.scan.watchdog.time * project.scan.watchdog.sensitivity.max(1)
            + project.scan.period;
        let read_budget = project.scan.period * 9 / 10;
        let late_logged = vec![None; lines.len()];
        let offload = Offloaded::new(&plan, &project, &bus_modules);
        Ok(Self {
            project,
            clock,
            image,
            logic,
            lines,
            bus_modules,
            inputs,
            outputs,
            frames,
            status,
            world,
            line_wait,
            read_budget,
            cycle_start: ScanInstant::ZERO,
            cycle_grid: None,
            io_wait: Duration::ZERO,
            unfinished: Default::default(),
            open_work: Default::default(),
            late_logged,
            retain,
            plan,
            offload,
            dead_lines: Vec::new(),
            kept_forces: None,
            recorder: None,
            task: None,
        })
    }
}

/// The simulated world for the project's `port: sim` lines, with its plant.
pub(super) fn build_world(project: &Project) -> Option<SharedWorld> {
    if !project.buses.iter().any(|b| b.port == PortConfig::Sim) {
        return None;
    }
    let mut world = SimWorld::new(project.buses.iter().map(|b| b.settings).collect());
    // The simulated adapter is the one the project describes: `echo: discard` hears itself.
    for (b, bus) in project.buses.iter().enumerate() {
        world.set_echo(
            b,
            bus.port == PortConfig::Sim && bus.echo == EchoMode::Discard,
        );
    }
    for module in &project.modules {
        if project.buses[module.bus].port == PortConfig::Sim {
            let mut sim = module.model.simulate(module.device.address.get());
            if module.device.protocol != module.model.protocols[0] {
                // Validation checked the model speaks it, so this cannot be refused.
                drop(sim.set_protocol(module.device.protocol));
            }
            world.add_device(module.bus, &module.name, sim);
        }
    }
    Some(world.shared())
}

/// Attaches the project's plant model to the simulated world, once the modules have started:
/// the machine's story (an operator loading a box) begins with the first scan, however long
/// the modules' start-up took, as it does when an operator waits for the PLC to run.
pub(super) fn attach_plant(project: &Project, world: &SharedWorld, now: ScanInstant) {
    let Ok(mut world) = world.lock() else { return };
    // The modules run up to now on their own; the plant's first step is the first scan's.
    world.advance_to(now.on_line_clock());
    // Validation wired every terminal to a module on a `port: sim` line: all are in the world.
    if let Err(e) = crate::plant::attach(project, &mut world) {
        tracing::error!("{e}");
    }
}
