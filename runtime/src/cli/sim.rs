//! `softplc sim`: simulated modules on a serial device, played from standard input.

use std::io::BufRead;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context};
use softplc_io::devices;
use softplc_io::line::{
    open_tty, pty_pair, LineSettings, NetFraming, Parity, SerialFormat, TTYPort, TcpEndpoint,
};
use softplc_io::point::Value;
use softplc_io::sim::plant::PlantHealth;
use softplc_io::sim::{
    serve_following, serve_tcp, tty_settings, Fault, FaultRule, Frequency, SharedWorld, SimWorld,
    SERVED_LINE,
};
use softplc_io::time::{Clock, MonotonicClock};

pub(super) const LONG_HELP: &str = "\
Serves simulated modules on a serial device so that any Modbus master (mbpoll, pymodbus, a
SCADA) or a terminal can talk to them. Each MODEL@ADDR is one module at that unit address,
e.g. minimod@5. MODEL@ADDR:BAUD:FORMAT (minimod@5:9600:8N1) sets the module's own baud
and format: a master at other settings is then heard by it as garbage (on a --pty, the
settings the master gave its end are followed frame by frame). With --pty, softplc creates a pseudo-terminal pair itself and prints the path
to give to the master. --option DEVICE:NAME=VALUE sets a simulator's option before serving,
as `DEVICE option NAME VALUE` would: where a manual can be read two ways, the simulator
serves either (minimod@5:watchdog-registers=aliased keeps WDTTIME/WDTYMASK at holding
registers 8/9, the coil/register aliasing rule, instead of the register table's 128/144;
`DEVICE options` lists a module's options). --profile FILE adds the device a profile file
describes, served by its model name: `--profile sdm120.yaml sdm120@3` (docs/devices.md); its
points are set and read like any module's, and it follows its profile's `simulate:` lags.
--project FILE serves the modules of a project's `port: sim` bus (--bus NAME, default the
first) at their addresses and the bus's baud and format, named as the project names them
(`set door.DI1 1`), with the project's plant model running (docs/plant.md): a master on the
pty sees the machine move as `run` does.

Commands on standard input (one per line):
  set DEVICE.POINT VALUE   set a simulated input (the terminal's level) or any point
                           e.g.  set minimod@5.X1 1
  get DEVICE.POINT         print a point's value, e.g.  get minimod@5.Y1
  list                     every device and the value of each of its points
  fault DEVICE|all FAULT [xN | nth N | rate P | always]
                           inject a line fault into the device's replies: FAULT is one of
                           garbage N | crc | flip-bit BYTE BIT | truncate N | late 80ms |
                           duplicate | wrong-address N | babble N | silent; applies to the
                           next reply unless xN (next N), nth N (the N-th next reply only),
                           rate P (probability 0..1) or always is given
  fault DEVICE|all clear   remove the injected faults
  faults                   list the injected faults
  line dead | line alive   cut the line (nothing in, nothing out) or restore it
  echo on | echo off       the adapter hears its own transmission: every frame the
                           master sends comes back to it (see --echo) or stops doing so
  echo corrupt N           the next N echoes come back with a bit flipped
  plant                    the served plant's states, and whether it runs (--project)
  plant fault NAME on|off  switch one of the plant model's faults
  power-cycle              switch the line's power supply off and on: every module
                           powers up again with what it saved (MiniMod WCONF, RESI
                           FLASH/FRAM, EX-9053 EEPROM) and loses what it did not
  DEVICE COMMAND ...       a model's own command (fault injection, power cycle, ...);
                           `help DEVICE` lists them
  help                     this text
  quit                     stop serving
DEVICE is MODEL@ADDR as given on the command line. Values: 1/0, true/false, or numbers
(0x.. for hex). Standard input closing (EOF) does not stop the server; SIGINT/SIGTERM does.";

/// Arguments of `softplc sim`.
#[derive(Debug, clap::Args)]
pub(crate) struct SimArgs {
    /// The serial device to serve on (e.g. one end of a pty pair).
    #[arg(long, required_unless_present_any = ["pty", "tcp", "rtu_tcp"], conflicts_with_all = ["pty", "tcp", "rtu_tcp"])]
    port: Option<PathBuf>,
    /// Create a pty pair and serve on it; the path for the master is printed on stdout.
    #[arg(long, conflicts_with_all = ["tcp", "rtu_tcp"])]
    pty: bool,
    /// Serve as a Modbus TCP gateway on HOST:PORT (port 0: any free port), each unit id
    /// answered by the module at that address; the address bound is printed as
    /// tcp://HOST:PORT, for a bus's `port:`.
    #[arg(long, value_name = "HOST:PORT", conflicts_with = "rtu_tcp")]
    tcp: Option<std::net::SocketAddr>,
    /// Serve as a serial device server in transparent mode on HOST:PORT: RTU frames (and text
    /// lines) pass through as on the line; printed as rtu+tcp://HOST:PORT.
    #[arg(long = "rtu-tcp", value_name = "HOST:PORT")]
    rtu_tcp: Option<std::net::SocketAddr>,
    /// Baud rate (the wire-time model uses it; a pty does not enforce it).
    #[arg(long, default_value_t = 19200)]
    baud: u32,
    /// Parity.
    #[arg(long, value_enum, default_value_t = ParityArg::Even)]
    parity: ParityArg,
    /// Stop bits.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    stop_bits: u8,
    /// Send every frame the master writes back to it, as an RS-485 adapter that hears its own
    /// transmission does (for a master's `echo: discard`).
    #[arg(long)]
    echo: bool,
    /// Modules to simulate, as MODEL@ADDR or MODEL@ADDR:BAUD:FORMAT (minimod@5:9600:8N1);
    /// MODEL is a built-in model or the `model:` of a --profile.
    #[arg(required_unless_present = "project", conflicts_with = "project")]
    devices: Vec<String>,
    /// Serve the modules of a project's `port: sim` bus, with its plant model.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["profiles", "options"])]
    project: Option<PathBuf>,
    /// With --project: the bus to serve (default: its first `port: sim` bus).
    #[arg(long, value_name = "NAME", requires = "project")]
    bus: Option<String>,
    /// A device profile file whose model the devices may name (sdm120@3); repeatable.
    #[arg(long = "profile", value_name = "FILE")]
    profiles: Vec<PathBuf>,
    /// A simulator option, DEVICE:NAME=VALUE (minimod@5:watchdog-registers=aliased);
    /// repeatable.
    #[arg(long = "option", value_name = "DEVICE:NAME=VALUE")]
    options: Vec<String>,
}

/// Applies `--option DEVICE:NAME=VALUE` to the device it names, as its console command
/// `option NAME VALUE` does.
fn apply_option(world: &mut SimWorld, option: &str) -> anyhow::Result<()> {
    let parsed = option
        .split_once(':')
        .and_then(|(dev, rest)| rest.split_once('=').map(|(name, value)| (dev, name, value)));
    let Some((dev, name, value)) = parsed else {
        bail!("--option {option:?}: expected DEVICE:NAME=VALUE, e.g. minimod@5:watchdog-registers=aliased");
    };
    let i = find(world, dev).with_context(|| format!("--option {option:?}"))?;
    let d = world.device_mut(i).context("device vanished")?;
    d.command(&["option", name, value])
        .with_context(|| format!("--option {option:?}"))?;
    Ok(())
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum ParityArg {
    None,
    Even,
    Odd,
}

/// A module to serve: its model, address and own line settings (if not the line's).
type DeviceSpec = (&'static devices::ModelSpec, u8, Option<LineSettings>);

/// The models of the `--profile` files, each read and checked as a project reads it; every
/// error of every file.
fn profile_models(
    files: &[PathBuf],
) -> Result<Vec<&'static devices::ModelSpec>, crate::project::ProjectErrors> {
    let mut models = Vec::new();
    let mut errors = Vec::new();
    for file in files {
        match crate::project::profile::load(file) {
            Ok(profile) => models.push(devices::profile::model_of(profile)),
            Err(e) => errors.extend(e.errors),
        }
    }
    if errors.is_empty() {
        Ok(models)
    } else {
        Err(crate::project::ProjectErrors { errors })
    }
}

/// Parses `minimod@5` or `minimod@5:9600:8N1` into the model (a built-in one or one of
/// `profiles`), the address and the settings.
fn parse_device(
    spec: &str,
    profiles: &[&'static devices::ModelSpec],
) -> anyhow::Result<DeviceSpec> {
    let (head, own) = match spec.split_once(':') {
        None => (spec, None),
        Some((head, line)) => {
            let Some((baud, format)) = line.split_once(':') else {
                bail!("{spec:?}: expected MODEL@ADDR:BAUD:FORMAT, e.g. minimod@5:9600:8N1");
            };
            let baud: u32 = baud
                .parse()
                .ok()
                .filter(|b| *b > 0)
                .with_context(|| format!("{spec:?}: baud {baud:?} is not a positive number"))?;
            let format: SerialFormat = format
                .parse()
                .with_context(|| format!("{spec:?}: format {format:?}"))?;
            (head, Some(LineSettings { baud, format }))
        }
    };
    let Some((model, addr)) = head.split_once('@') else {
        bail!("{spec:?}: expected MODEL@ADDR, e.g. minimod@5");
    };
    let found = profiles.iter().copied().find(|m| m.name == model);
    let Some(m) = found.or_else(|| devices::model(model)) else {
        let known: Vec<_> = profiles
            .iter()
            .chain(devices::catalog())
            .map(|m| m.name)
            .collect();
        bail!(
            "{spec:?}: unknown model {model:?} (known: {})",
            known.join(", ")
        );
    };
    let a: u8 = addr
        .parse()
        .with_context(|| format!("{spec:?}: address {addr:?} is not a number"))?;
    if !m.addresses.contains(&a) {
        bail!(
            "{spec:?}: address {a} is outside {}..={} for {}",
            m.addresses.start(),
            m.addresses.end(),
            m.name
        );
    }
    Ok((m, a, own))
}

pub(super) fn sim(args: SimArgs) -> anyhow::Result<ExitCode> {
    let parity = match args.parity {
        ParityArg::None => Parity::None,
        ParityArg::Even => Parity::Even,
        ParityArg::Odd => Parity::Odd,
    };
    let found = match &args.project {
        Some(file) => project_world(file, args.bus.as_deref())?,
        None => devices_world(&args, parity)?,
    };
    let Some((mut world, settings, served)) = found else {
        return Ok(ExitCode::FAILURE);
    };
    world.set_echo(SERVED_LINE, args.echo);
    let world = world.shared();
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());

    let stop = Arc::new(AtomicBool::new(false));
    if let Some((bind, framing)) = args
        .tcp
        .map(|a| (a, NetFraming::ModbusTcp))
        .or(args.rtu_tcp.map(|a| (a, NetFraming::RtuOverTcp)))
    {
        let listener = std::net::TcpListener::bind(bind)
            .with_context(|| format!("cannot listen on {bind}"))?;
        let bound = listener.local_addr()?;
        let endpoint = TcpEndpoint {
            framing,
            host: bound.ip().to_string(),
            port: bound.port(),
        };
        let what = match framing {
            NetFraming::ModbusTcp => "a Modbus TCP gateway",
            NetFraming::RtuOverTcp => "a transparent serial server",
        };
        super::out::outln(&format!(
            "serving {served} on {endpoint} ({what}; the line behind it at {settings})"
        ))?;
        spawn_console(&world, &stop, &clock)?;
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            signal_hook::flag::register(sig, stop.clone())
                .context("cannot install signal handlers")?;
        }
        let stats = serve_tcp(listener, world, framing, settings, clock, &stop)
            .context("serving over TCP failed")?;
        super::out::outln(&format!(
            "served {} frames, {} replies, {} noise bytes",
            stats.frames, stats.replies, stats.noise_bytes
        ))?;
        return Ok(ExitCode::SUCCESS);
    }

    // With --pty the slave end stays open here, so the pty lives while no master is connected.
    let (port, _slave, path) = if args.pty {
        let (master, slave, name) = pty_pair().context("cannot create a pty pair")?;
        (master, Some(slave), name)
    } else {
        let path = args.port.clone().unwrap_or_default();
        (open_tty(&path, settings)?, None, path.display().to_string())
    };
    super::out::outln(&format!("serving {served} on {path} at {settings}"))?;

    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone()).context("cannot install signal handlers")?;
    }
    spawn_console(&world, &stop, &clock)?;
    let follow = |slave: &TTYPort| tty_settings(slave);
    let master = _slave.as_ref().map(|slave| move || follow(slave));
    let master_ref = master
        .as_ref()
        .map(|m| m as &dyn Fn() -> Option<LineSettings>);
    let stats = serve_following(port, world, settings, clock, &stop, master_ref)
        .context("serial line failed")?;
    super::out::outln(&format!(
        "served {} frames, {} replies, {} noise bytes",
        stats.frames, stats.replies, stats.noise_bytes
    ))?;
    Ok(ExitCode::SUCCESS)
}

/// The world of the modules named on the command line: it, the line's settings and the
/// devices' names; `None` after printing a profile's errors.
fn devices_world(
    args: &SimArgs,
    parity: Parity,
) -> anyhow::Result<Option<(SimWorld, LineSettings, String)>> {
    let settings = LineSettings {
        baud: args.baud,
        format: SerialFormat {
            data_bits: 8,
            parity,
            stop_bits: args.stop_bits,
        },
    };
    if settings.baud == 0 {
        bail!("--baud must be above 0");
    }
    let mut world = SimWorld::new(vec![settings]);
    let mut seen = Vec::new();
    let profiles = match profile_models(&args.profiles) {
        Ok(models) => models,
        Err(errors) => {
            super::out::errln(&errors.to_string());
            return Ok(None);
        }
    };
    for spec in &args.devices {
        let (model, addr, own) = parse_device(spec, &profiles)?;
        if seen.contains(&addr) {
            bail!("{spec:?}: address {addr} is given twice");
        }
        seen.push(addr);
        let i = world.add_device(
            SERVED_LINE,
            &format!("{}@{addr}", model.name),
            model.simulate(addr),
        );
        match own {
            Some(own) => world.set_device_settings(i, own),
            // Installed for this line: a module that models its own UART (RESI DIP switches,
            // EX-9053 EEPROM) gets the line's settings as its own.
            None => {
                world.install_device_uart(i, settings);
            }
        }
    }
    for option in &args.options {
        apply_option(&mut world, option)?;
    }
    Ok(Some((world, settings, args.devices.join(", "))))
}

/// The world of a project's `port: sim` bus (`bus`, or its first) with the project's plant:
/// it, the bus's settings and the modules' names; `None` after printing the project's errors.
fn project_world(
    file: &std::path::Path,
    bus: Option<&str>,
) -> anyhow::Result<Option<(SimWorld, LineSettings, String)>> {
    let project = match crate::project::load(file) {
        Ok(p) => p,
        Err(errors) => {
            super::out::errln(&errors.to_string());
            return Ok(None);
        }
    };
    let sim_buses: Vec<usize> = (0..project.buses.len())
        .filter(|&b| project.buses[b].port == crate::project::PortConfig::Sim)
        .collect();
    let chosen = match bus {
        Some(name) => project.buses.iter().position(|b| b.name == name),
        None => sim_buses.first().copied(),
    };
    let Some(b) = chosen.filter(|b| sim_buses.contains(b)) else {
        let names: Vec<&str> = sim_buses
            .iter()
            .map(|&b| project.buses[b].name.as_str())
            .collect();
        bail!(
            "{}: no `port: sim` bus {}(its simulated buses: {})",
            file.display(),
            bus.map(|n| format!("named {n} ")).unwrap_or_default(),
            if names.is_empty() {
                "none".to_owned()
            } else {
                names.join(", ")
            }
        );
    };
    let settings = project.buses[b].settings;
    let mut world = SimWorld::new(vec![settings]);
    let mut names = Vec::new();
    for module in project.modules.iter().filter(|m| m.bus == b) {
        let address = module.device.address.get();
        let mut sim = module.model.simulate(address);
        if module.device.protocol != module.model.protocols[0] {
            // Validation checked the model speaks it.
            drop(sim.set_protocol(module.device.protocol));
        }
        let i = world.add_device(SERVED_LINE, &module.name, sim);
        world.install_device_uart(i, settings);
        names.push(format!("{}={}@{address}", module.name, module.model.name));
    }
    crate::plant::attach(&project, &mut world)
        .with_context(|| format!("cannot serve the plant of {}", file.display()))?;
    let mut served = names.join(", ");
    if let Some(p) = &project.plant {
        served.push_str(&format!(
            " with plant {} ({})",
            p.model.name,
            p.model.file.display()
        ));
    }
    Ok(Some((world, settings, served)))
}

/// Plays standard input's commands against `world` on a thread of their own; `quit` sets
/// `stop`.
fn spawn_console(
    world: &SharedWorld,
    stop: &Arc<AtomicBool>,
    clock: &Arc<dyn Clock>,
) -> anyhow::Result<()> {
    let world = world.clone();
    let stop = stop.clone();
    let clock = clock.clone();
    std::thread::Builder::new()
        .name("sim-stdin".into())
        .spawn(move || {
            let stdin = std::io::stdin();
            for line in stdin.lock().lines() {
                let Ok(line) = line else { break };
                match execute(&world, clock.as_ref(), &line) {
                    Ok(Reply::Quit) => {
                        stop.store(true, Ordering::Relaxed);
                        break;
                    }
                    // A closed stdout leaves the simulators serving, silently.
                    Ok(Reply::Text(t)) if !t.is_empty() => {
                        drop(super::out::outln(&t));
                    }
                    Ok(Reply::Text(_)) => {}
                    Err(e) => {
                        drop(super::out::outln(&format!("error: {e}")));
                    }
                }
            }
        })?;
    Ok(())
}

/// What a command line produced.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Reply {
    /// Text to print.
    Text(String),
    /// Stop serving.
    Quit,
}

/// Executes one command line against `world` (see [`LONG_HELP`]).
pub(crate) fn execute(world: &SharedWorld, clock: &dyn Clock, line: &str) -> anyhow::Result<Reply> {
    let words: Vec<&str> = line.split_whitespace().collect();
    let mut w = world.lock().unwrap_or_else(|e| e.into_inner());
    w.advance_to(clock.line_now());
    let text = match words.as_slice() {
        [] => String::new(),
        ["help"] => LONG_HELP
            .lines()
            .skip_while(|l| !l.starts_with("Commands"))
            .collect::<Vec<_>>()
            .join("\n"),
        ["help", dev] => {
            let i = find(&w, dev)?;
            let d = w.device_mut(i).context("device vanished")?;
            let help = d.command_help();
            if help.is_empty() {
                format!("{dev} has no commands of its own")
            } else {
                help.to_string()
            }
        }
        ["quit"] | ["exit"] => return Ok(Reply::Quit),
        ["plant"] => {
            let plant = w.plant().context("no plant is served (see --project)")?;
            let states: Vec<String> = plant
                .states()
                .into_iter()
                .map(|(n, v)| format!("{n}={v}"))
                .collect();
            match plant.health() {
                PlantHealth::Running => format!("running: {}", states.join(" ")),
                PlantHealth::Stopped(why) => format!("stopped: {why}; {}", states.join(" ")),
            }
        }
        ["plant", "fault", name, level] => {
            let on = match level.to_ascii_lowercase().as_str() {
                "on" | "1" | "true" => true,
                "off" | "0" | "false" => false,
                other => bail!("plant fault {name} {other}: expected on or off"),
            };
            let plant = w
                .plant_mut()
                .context("no plant is served (see --project)")?;
            plant.set_fault(name, on)?;
            format!("fault {name} {}", if on { "on" } else { "off" })
        }
        ["list"] => {
            let mut out = Vec::new();
            for (i, name) in w.names().into_iter().enumerate() {
                let Some(d) = w.device_mut(i) else { continue };
                let values: Vec<String> = d
                    .points()
                    .iter()
                    .map(|p| {
                        format!(
                            "{}={}",
                            p.name,
                            d.get(p.name)
                                .map(|v| v.to_string())
                                .unwrap_or_else(|_| "?".into())
                        )
                    })
                    .collect();
                out.push(format!("{name}: {}", values.join(" ")));
            }
            out.join("\n")
        }
        ["get", target] => {
            let (dev, point) = split_target(target)?;
            let i = find(&w, dev)?;
            let v = w.get(i, point)?;
            format!("{dev}.{point}={v}")
        }
        ["set", target, value] => {
            let (dev, point) = split_target(target)?;
            let i = find(&w, dev)?;
            let d = w.device_mut(i).context("device vanished")?;
            let Some(spec) = d.points().iter().find(|p| p.name == point) else {
                bail!("{dev} has no point {point}");
            };
            let Some(v) = Value::parse(spec.ty, value) else {
                bail!("{point} is {}, {value:?} is not", spec.ty);
            };
            w.set(i, point, v)?;
            format!("{dev}.{point}={v}")
        }
        ["fault", target, "clear"] => {
            let device = if *target == "all" {
                None
            } else {
                Some(find(&w, target)?)
            };
            w.faults_mut().clear(device);
            format!("faults cleared for {target}")
        }
        ["fault", target, spec @ ..] => {
            let device = if *target == "all" {
                None
            } else {
                Some(find(&w, target)?)
            };
            let (fault_words, frequency) = split_frequency(spec)?;
            let fault = Fault::parse(fault_words).map_err(|e| anyhow::anyhow!(e))?;
            w.faults_mut().add(FaultRule {
                device,
                fault,
                frequency,
            });
            format!("fault {fault} on {target} ({frequency:?})")
        }
        ["faults"] => {
            let names = w.names();
            let rules: Vec<String> = w
                .faults()
                .rules()
                .iter()
                .map(|r| {
                    let who = r
                        .device
                        .and_then(|d| names.get(d).cloned())
                        .unwrap_or_else(|| "all".into());
                    format!("{who}: {} ({:?})", r.fault, r.frequency)
                })
                .collect();
            if rules.is_empty() {
                "no faults".to_string()
            } else {
                rules.join("\n")
            }
        }
        ["power-cycle"] => {
            let mut out = Vec::new();
            for (i, name) in w.names().into_iter().enumerate() {
                let Some(d) = w.device_mut(i) else { continue };
                out.push(format!("{name}: {}", d.command(&["power-cycle"])?));
            }
            out.join("\n")
        }
        ["line", state @ ("dead" | "alive")] => {
            w.faults_mut().set_dead(SERVED_LINE, *state == "dead");
            format!("line {state}")
        }
        ["echo", state @ ("on" | "off")] => {
            w.set_echo(SERVED_LINE, *state == "on");
            format!("echo {state}")
        }
        ["echo", "corrupt", n] => {
            let n: u32 = n
                .parse()
                .map_err(|_| anyhow::anyhow!("echo corrupt {n:?}: expected a count, e.g. 1"))?;
            w.corrupt_next_echoes(SERVED_LINE, n);
            format!("the next {n} echo(es) come back corrupted")
        }
        [dev, "line", spec] if dev.contains('@') => {
            let i = find(&w, dev)?;
            // The model checks the words and says what its module makes of them.
            let device = w.device_mut(i).context("device vanished")?;
            let text = device.command(&["line", spec])?;
            // The master's settings are the line's: every module hears every frame at them
            // from now on, until the served port's own settings change (`sim/serve.rs`).
            if let Some(settings) = device.master_settings() {
                w.set_master_settings(SERVED_LINE, settings);
            }
            text
        }
        [dev, rest @ ..] if dev.contains('@') => {
            let i = find(&w, dev)?;
            let d = w.device_mut(i).context("device vanished")?;
            d.command(rest)?
        }
        _ => bail!("unknown command {line:?}; try `help`"),
    };
    Ok(Reply::Text(text))
}

/// Splits a trailing `xN`, `rate P` or `always` off a fault spec.
fn split_frequency<'a, 'b>(spec: &'a [&'b str]) -> anyhow::Result<(&'a [&'b str], Frequency)> {
    match spec {
        [head @ .., "always"] => Ok((head, Frequency::Always)),
        [head @ .., "nth", n] => {
            let n: u32 = n
                .parse()
                .map_err(|_| anyhow::anyhow!("nth {n:?}: expected a number, e.g. nth 7"))?;
            Ok((head, Frequency::Nth(n.max(1))))
        }
        [head @ .., "rate", p] => {
            let p: f64 = p
                .parse()
                .map_err(|_| anyhow::anyhow!("rate {p:?}: expected a probability 0..1"))?;
            if !(0.0..=1.0).contains(&p) {
                bail!("rate {p}: expected a probability 0..1");
            }
            Ok((head, Frequency::Rate(p)))
        }
        [head @ .., n] if n.starts_with('x') && n.len() > 1 => {
            let n: u32 = n[1..]
                .parse()
                .map_err(|_| anyhow::anyhow!("{n:?}: expected xN, e.g. x5"))?;
            Ok((head, Frequency::Next(n.max(1))))
        }
        _ => Ok((spec, Frequency::Next(1))),
    }
}

fn split_target(target: &str) -> anyhow::Result<(&str, &str)> {
    target
        .rsplit_once('.')
        .ok_or_else(|| anyhow::anyhow!("{target:?}: expected DEVICE.POINT, e.g. minimod@5.X1"))
}

fn find(world: &SimWorld, dev: &str) -> anyhow::Result<usize> {
    world
        .find(dev)
        .ok_or_else(|| anyhow::anyhow!("no device {dev:?} (devices: {})", world.names().join(", ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use softplc_io::modbus::append_crc;
    use std::time::Duration;

    /// `minimod@5 line 9600E` said on the console still holds after the next frames, which
    /// the served line hands the modules at its master's settings.
    #[test]
    fn the_line_command_stands_over_the_next_frames() {
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        let model = devices::model("minimod").expect("the MiniMod model");
        let i = world.add_device(SERVED_LINE, "minimod@5", model.simulate(5));
        world.install_device_uart(i, LineSettings::DEFAULT);
        let world = world.shared();
        let clock = MonotonicClock::new();
        let said = match execute(&world, &clock, "minimod@5 line 9600E").expect("a command") {
            Reply::Text(t) => t,
            Reply::Quit => String::new(),
        };
        assert!(
            said.starts_with("master at 9600E; module at 19200E"),
            "{said}"
        );
        let mut fc2 = vec![5, 0x02, 0x00, 0x00, 0x00, 0x0A];
        append_crc(&mut fc2);
        for k in 1..=3u64 {
            let mut w = world.lock().expect("the world");
            let t = w.now() + Duration::from_millis(100 * k);
            w.deliver(SERVED_LINE, &fc2, t);
            w.settle(SERVED_LINE, t + Duration::from_millis(50));
            assert_eq!(
                w.next_arrival(SERVED_LINE),
                None,
                "a deaf module answers nothing"
            );
        }
        let status = match execute(&world, &clock, "minimod@5 status").expect("a command") {
            Reply::Text(t) => t,
            Reply::Quit => String::new(),
        };
        assert!(status.contains("master 9600E (mismatch: deaf)"), "{status}");
        // Back at the module's own settings, it answers again.
        execute(&world, &clock, "minimod@5 line 19200E").expect("a command");
        let mut w = world.lock().expect("the world");
        let t = w.now() + Duration::from_millis(100);
        w.deliver(SERVED_LINE, &fc2, t);
        let mut reply = Vec::new();
        w.take_arrived(SERVED_LINE, t + Duration::from_millis(100), &mut reply);
        assert_eq!(reply.len(), 7, "{reply:02X?}");
    }

    #[test]
    fn a_line_command_the_model_does_not_take_is_refused_with_its_reason() {
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        let model = devices::model("minimod").expect("the MiniMod model");
        world.add_device(SERVED_LINE, "minimod@5", model.simulate(5));
        let world = world.shared();
        let e = execute(&world, &MonotonicClock::new(), "minimod@5 line 9600Q")
            .expect_err("no such parity letter");
        assert!(e.to_string().contains("9600Q"), "{e}");
        let master = world
            .lock()
            .expect("the world")
            .master_settings(SERVED_LINE);
        assert_eq!(master, Some(LineSettings::DEFAULT), "the line is as it was");
    }
}
