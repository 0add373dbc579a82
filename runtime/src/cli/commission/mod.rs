//! `softplc commission PORT --address A ...`: sets a module's address, baud/format and reply
//! delay and makes them permanent by the module's own means, then reads them back at the new
//! settings. One core for every family: the family that answers at the address
//! (`softplc_io::devices::Family::plan_commissioning`) reads what it needs through the
//! session, refuses what its manual forbids (before anything is written) and returns a
//! [`Plan`]; the core prints the plan, asks, runs it step by step printing every frame and
//! answer, and stops at the first answer that is not the expected one.
//!
//! Nothing is written without `--yes` or a "yes" typed at a terminal. Steps that need the
//! engineer's hands (the EX-9053's INIT* terminal and its power-on) are printed as
//! instructions; the core then asks the module at the settings it will have, until it answers
//! or `--wait` runs out.

use std::io::{BufRead, IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use softplc_io::devices::{
    families, Check, CommissionRequest, Conversation, Expect, Family, LineFailed, Plan, Step,
};
use softplc_io::line::{LineSettings, SerialFormat, SerialTransport};
use softplc_io::time::{Clock, MonotonicClock};

use super::discover::ask;
use super::out::outln;

/// Arguments of `softplc commission`.
#[derive(Debug, clap::Args)]
pub(crate) struct CommissionArgs {
    /// The serial device the module is on.
    port: PathBuf,
    /// The module's address now.
    #[arg(long)]
    address: u8,
    /// The module's baud rate now.
    #[arg(long, default_value_t = 19200)]
    baud: u32,
    /// The module's character format now (8E1, 8N1, 8O1, 8N2).
    #[arg(long, default_value = "8E1")]
    format: SerialFormat,
    /// EX-9053: the module checks and sends DCON checksums now (data format bit 6).
    #[arg(long)]
    checksum: bool,
    /// The new address (MiniMod and RESI: 1..=247; EX-9053: 0..=255).
    #[arg(long)]
    set_address: Option<u8>,
    /// The new baud rate (MiniMod: 4800..57600; EX-9053: 1200..115200; RESI: DIP switches).
    #[arg(long)]
    set_baud: Option<u32>,
    /// The new character format (MiniMod: 8E1, 8O1, 8N2, 8N1; RESI: DIP switches).
    #[arg(long)]
    set_format: Option<SerialFormat>,
    /// EX-9053: DCON checksums on or off from the next power-on.
    #[arg(long, value_enum)]
    set_checksum: Option<OnOff>,
    /// The new reply delay (MiniMod: 0..=2s in steps of 10ms).
    #[arg(long, value_parser = super::args::parse_duration)]
    set_reply_delay: Option<Duration>,
    /// Make the changes without asking.
    #[arg(long)]
    yes: bool,
    /// How long to wait for each answer.
    #[arg(long, default_value = "200ms", value_parser = super::args::parse_duration)]
    timeout: Duration,
    /// How long to wait for the module after asking the engineer to rewire or power-cycle it.
    #[arg(long, default_value = "10m", value_parser = super::args::parse_duration)]
    wait: Duration,
}

/// A switch given on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum OnOff {
    On,
    Off,
}

impl OnOff {
    fn is_on(self) -> bool {
        self == OnOff::On
    }
}

/// The line to the module, and how long answers may take.
pub(super) struct Session {
    port: PathBuf,
    clock: Arc<dyn Clock>,
    /// `None` only between closing the port and opening it at other settings.
    transport: Option<SerialTransport>,
    settings: LineSettings,
    timeout: Duration,
}

impl Conversation for Session {
    fn ask(&mut self, what: &str, frame: &[u8]) -> Result<Option<String>, LineFailed> {
        Session::ask(self, what, frame).map_err(|e| LineFailed(e.into()))
    }

    fn settings(&self) -> LineSettings {
        self.settings
    }

    fn note(&mut self, line: &str) -> Result<(), LineFailed> {
        outln(line).map_err(|e| LineFailed(e.into()))
    }
}

/// A frame as printed.
pub(super) fn show(frame: &[u8]) -> String {
    format!("{:?}", String::from_utf8_lossy(frame))
}

impl Session {
    fn open(port: PathBuf, settings: LineSettings, timeout: Duration) -> anyhow::Result<Self> {
        let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
        let transport = SerialTransport::open(&port, settings, clock.clone())
            .with_context(|| format!("{} at {settings}", port.display()))?;
        Ok(Self {
            port,
            clock,
            transport: Some(transport),
            settings,
            timeout,
        })
    }

    /// The settings the port is at.
    pub(super) fn settings(&self) -> LineSettings {
        self.settings
    }

    fn line(&mut self) -> anyhow::Result<&mut SerialTransport> {
        self.transport
            .as_mut()
            .with_context(|| format!("{} is closed", self.port.display()))
    }

    /// Reopens the port at `settings` (nothing to do if it is at them).
    fn switch(&mut self, settings: LineSettings) -> anyhow::Result<()> {
        if self.settings() == settings {
            return Ok(());
        }
        // The port is opened exclusively: the old one is closed first.
        self.transport = None;
        self.transport = Some(
            SerialTransport::open(&self.port, settings, self.clock.clone())
                .with_context(|| format!("{} at {settings}", self.port.display()))?,
        );
        self.settings = settings;
        outln(&format!("   now talking at {settings}"))?;
        Ok(())
    }

    /// Sends `frame`, printing it and the answer; the answer (without its CR).
    pub(super) fn ask(&mut self, what: &str, frame: &[u8]) -> anyhow::Result<Option<String>> {
        outln(&format!("-> {} ({what})", show(frame)))?;
        let timeout = self.timeout;
        let reply = ask(self.line()?, frame, timeout)?;
        outln(&match &reply {
            Some(r) => format!("<- {r:?}"),
            None => "<- (no answer)".into(),
        })?;
        Ok(reply)
    }

    fn ask_quietly(&mut self, frame: &[u8]) -> anyhow::Result<Option<String>> {
        let timeout = self.timeout;
        ask(self.line()?, frame, timeout)
    }
}

pub(super) fn commission(args: CommissionArgs) -> anyhow::Result<ExitCode> {
    if args.set_address.is_none()
        && args.set_baud.is_none()
        && args.set_format.is_none()
        && args.set_checksum.is_none()
        && args.set_reply_delay.is_none()
    {
        bail!("nothing to change: give --set-address, --set-baud, --set-format, --set-checksum or --set-reply-delay");
    }
    let now = LineSettings {
        baud: args.baud,
        format: args.format,
    };
    let mut session = Session::open(args.port.clone(), now, args.timeout)?;
    let (family, model) = identify(&mut session, &args)?;
    outln(&format!("{model} at address {} at {now}", args.address))?;
    if !family.has_checksum() && args.set_checksum.is_some() {
        bail!("refused: --set-checksum: only the EX-9053 has a checksum setting (data format bit 6, EX-9053 manual §1.10); the {} protocol has none to switch", family.name());
    }
    let request = CommissionRequest {
        address: args.address,
        now,
        checksum: args.checksum,
        set_address: args.set_address,
        set_baud: args.set_baud,
        set_format: args.set_format,
        set_checksum: args.set_checksum.map(OnOff::is_on),
        set_reply_delay: args.set_reply_delay,
    };
    let plan = family.plan_commissioning(&mut session, &request, model)?;
    run(&mut session, plan, &args)
}

/// Who answers at `--address`: each family by its own identification, at the settings given.
fn identify(
    session: &mut Session,
    args: &CommissionArgs,
) -> anyhow::Result<(&'static dyn Family, &'static str)> {
    let now = session.settings();
    for &fam in families() {
        if !fam.supports(now, args.address) {
            continue;
        }
        let Some(question) = fam.who_are_you(args.address, args.checksum) else {
            continue;
        };
        let what = format!("who are you? {}", fam.name());
        let reply = session
            .ask(&what, &question)?
            .and_then(|r| fam.answer_body(&r, args.checksum));
        match reply.as_deref().and_then(|r| fam.identify(args.address, r)) {
            Some(Ok(model)) => return Ok((fam, model)),
            Some(Err(why)) => bail!("address {}: {why}", args.address),
            None => {}
        }
    }
    bail!(
        "no module answers at address {} at {now} on {}{} (modules are asked by their text protocols: an EX-9053D-M running Modbus RTU, its factory protocol, is not commissioned by softplc commission)",
        args.address,
        args.port.display(),
        if args.checksum {
            " (asked with DCON checksums)"
        } else {
            ""
        }
    )
}

fn describe(step: &Step) -> String {
    match step {
        Step::Send { what, frame, .. } => format!("  {what}: {}", show(frame)),
        Step::Switch(s) => format!("  then talk at {s}"),
        Step::Await {
            what,
            instructions,
            settings,
            frame,
            ..
        } => {
            let mut text = String::new();
            for (i, line) in instructions.iter().enumerate() {
                text += &format!("  you: {}. {line}\n", i + 1);
            }
            text.push_str(&format!("  wait for {what}: {} at {settings}", show(frame)));
            text
        }
    }
}

/// Prints the plan, asks, and runs it.
fn run(session: &mut Session, plan: Plan, args: &CommissionArgs) -> anyhow::Result<ExitCode> {
    outln("plan:")?;
    for step in &plan.steps {
        outln(&describe(step))?;
    }
    if !args.yes && !confirm()? {
        outln("nothing changed")?;
        return Ok(ExitCode::from(1));
    }
    // What the module has taken so far, for the engineer when a later step fails: it keeps
    // those changes (saved or in force) whatever happens next.
    let mut taken: Vec<String> = Vec::new();
    for step in plan.steps {
        let what = match &step {
            Step::Send { what, .. } | Step::Await { what, .. } => Some(what.clone()),
            Step::Switch(_) => None,
        };
        if let Err(e) = execute(session, step, args.wait) {
            if taken.is_empty() {
                return Err(e);
            }
            bail!("{e}\nalready done: {}", taken.join("; "));
        }
        taken.extend(what);
    }
    outln(&plan.done)?;
    Ok(ExitCode::SUCCESS)
}

/// Runs one step; an error says which and why, and that the run stopped there.
fn execute(session: &mut Session, step: Step, wait: Duration) -> anyhow::Result<()> {
    match step {
        Step::Send {
            what,
            frame,
            expect,
        } => {
            let reply = session.ask(&what, &frame)?;
            match (expect, reply) {
                (Expect::Answer(check), Some(r)) => {
                    if let Err(why) = check(&r) {
                        bail!("{what}: {why}; stopped here");
                    }
                }
                (Expect::Answer(_), None) => {
                    bail!("{what}: the module did not answer; stopped here")
                }
                (Expect::Silence, None) => {}
                (Expect::Silence, Some(r)) => {
                    bail!("{what}: the module answered {r:?} where its manual says it answers nothing; stopped here")
                }
            }
        }
        Step::Switch(s) => session.switch(s)?,
        Step::Await {
            what,
            instructions,
            settings,
            frame,
            check,
            within,
        } => await_module(
            session,
            &what,
            &instructions,
            settings,
            &frame,
            &check,
            within.unwrap_or(wait),
        )?,
    }
    Ok(())
}

/// Between two questions to a module that is not there yet.
const POLL_PAUSE: Duration = Duration::from_millis(300);

fn await_module(
    session: &mut Session,
    what: &str,
    instructions: &[String],
    settings: LineSettings,
    frame: &[u8],
    check: &Check,
    within: Duration,
) -> anyhow::Result<()> {
    if !instructions.is_empty() {
        outln("now, please:")?;
        for (i, line) in instructions.iter().enumerate() {
            outln(&format!("  {}. {line}", i + 1))?;
        }
    }
    session.switch(settings)?;
    outln(&format!(
        "-> {} (waiting up to {} for {what}, asking every {})",
        show(frame),
        crate::scan::fmt_duration(within),
        crate::scan::fmt_duration(session.timeout + POLL_PAUSE),
    ))?;
    let started = Instant::now();
    let mut last = String::from("no answer");
    loop {
        if let Some(r) = session.ask_quietly(frame)? {
            match check(&r) {
                Ok(()) => {
                    outln(&format!("<- {r:?}"))?;
                    return Ok(());
                }
                Err(why) => last = format!("{r:?}: {why}"),
            }
        }
        if started.elapsed() >= within {
            bail!(
                "{what}: nothing usable at {settings} within {} (last: {last}); stopped here",
                crate::scan::fmt_duration(within)
            );
        }
        std::thread::sleep(POLL_PAUSE);
    }
}

/// Asks at a terminal; anything but a terminal answering "yes" is a no.
fn confirm() -> anyhow::Result<bool> {
    if !std::io::stdin().is_terminal() {
        outln("not a terminal: give --yes to make these changes")?;
        return Ok(false);
    }
    print!("make these changes? type yes: ");
    std::io::stdout().flush()?;
    let mut line = String::new();
    std::io::stdin().lock().read_line(&mut line)?;
    Ok(line.trim() == "yes")
}
