//! The modules' own watchdogs: armed by default, so a host that dies (`kill -9`, a crash, a
//! pulled cable) still leaves the outputs in their safe state (DESIGN, principle 7).
//!
//! A module entry may say `watchdog: off` (or `auto`, the default); see [`super::raw`].
//!
//! # MiniMod
//!
//! Manual, "Internal watch-dog (security and coherency check)" and the register table: with
//! WDTTIME (40129, 1/100 s, 1..=65535) non-zero "Minimod expects messages from the master at
//! least every WDTTIME time; if no messages are received in that time, the watch-dog fires",
//! and the outputs take WDTYMASK (40145: "Bitmask for the outputs Y1..Y4 when the watch-dog is
//! firing"). The driver sets and reads back both by name through the text protocol, since the
//! manual's other bit/word pairs would put them at holding registers 8 and 9 (see
//! `softplc_io::devices::minimod` driver docs, "Registers the manual gives two ways"). Unless
//! the project sets them:
//! - **WDTYMASK** is built from the tags' safe values: bit n−1 is 1 when the tag bound to Yn
//!   has `safe: true` (or a tag bound to YWORD has it in its safe value), else 0. The mask has
//!   no "leave as is": an output without a safe value goes off, which `check` says.
//! - **WDTTIME** = 3 × the scan period + the line's worst time between two exchanges with the
//!   module, rounded up to 1/100 s, at most 65535 (655.35 s). The line's worst time is the sum
//!   of
//!   - the cycle floor: every module's reads and a full output write ([`line_budget`]);
//!   - the line's whole start-up traffic: modules are configured one after another before the
//!     first scan, and a module that comes back is configured again in the middle of a cycle;
//!   - for every other module of the line, a read and a write that time out with all retries
//!     (what a failing module costs each cycle until it is declared lost; once lost it costs
//!     one probe at a time), each attempt costing the request, the response timeout and the
//!     guard after it ([`failed_attempt`]);
//!   - one retry of an exchange of the module's own (a CRC error).
//!
//!   Three periods cover a cycle that overruns and is skipped to the next deadline, and the
//!   scan's own jitter. So a healthy line, or one with failing neighbours, never fires it,
//!   while a dead host (or a dead line) gets the outputs safe within that time.
//! - **Event mode** (`events: true`): the bus owner sends a broadcast Collect every cycle, and
//!   a message addressed to the module (a write, or its full read when nothing addressed to
//!   it was answered) at least every `event_refresh` (default 1 s). The manual counts
//!   "messages from the master", and a Collect is one (the simulator feeds the watchdog with
//!   it), but it does not say a broadcast counts; so the time also covers one `event_refresh`,
//!   and an idle event-mode line never fires it even on a module that counts only messages
//!   addressed to it.
//! - `watchdog: off` writes WDTTIME = 0 at start-up (a watchdog armed by an earlier run is
//!   disarmed), and `check` warns. An explicit `WDTTIME` (or `WDTYMASK`) in the settings wins;
//!   `WDTTIME: 0` is the same as `watchdog: off`; `watchdog: off` with a `WDTTIME` is refused.
//!
//! # EX-9053D / EX-9053D-M
//!
//! Not armed by default: its host watchdog's only effect is on outputs ("Host Watchdog
//! Timeout will let all output goto Safe Value", §1.5; §1.8), and the EX-9053D has none, so
//! there is no safe value to give it; arming it would cost a host OK broadcast and a status
//! read every cycle for a diagnostic the PLC has anyway (the module is lost). Its `watchdog`
//! setting (100ms..=25.5s) still arms it (see the driver); `check` prints it.
//!
//! # RESI
//!
//! resi-spec.md §5.4 and its summary: the RESI modules have no communication watchdog and no
//! module-side safe state, except the RESI-1RO, whose off-delay (`SOFFDLY`) drops the relay
//! when no command retriggers it. That off-delay is a way of driving DO1 (through a timer,
//! retriggered every cycle), not a safe state to reset: nothing locks when it expires, and the
//! relay follows the program again with the next cycle. It stays opt-in (`SOFFDLY` in the
//! settings); `check` says it is not armed.

use std::time::Duration;

use softplc_io::devices::minimod::{Setting as MiniModSetting, Settings as MiniModSettings};
use softplc_io::devices::ModuleSettings;
use softplc_io::line::{failed_attempt, line_budget_on, transaction_time, SysfsRoot};
use softplc_io::point::{Access, Value};

use super::model::{Binding, Project};

/// The module entry's key.
pub(crate) const KEY: &str = "watchdog";

/// What the module entry asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WatchdogPolicy {
    /// Armed by default where the model has a watchdog that makes outputs safe.
    #[default]
    Auto,
    /// `watchdog: off`.
    Off,
}

/// Parses the module entry's `watchdog:` value.
pub(crate) fn parse_policy(text: &str) -> Result<WatchdogPolicy, String> {
    match text.trim().to_ascii_lowercase().as_str() {
        "auto" | "on" | "true" | "yes" => Ok(WatchdogPolicy::Auto),
        "off" | "false" | "no" => Ok(WatchdogPolicy::Off),
        _ => Err(
            "takes auto (the default: the module's own watchdog armed with a time derived from \
             the scan and the line) or off"
                .into(),
        ),
    }
}

/// Where a value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// The module's settings.
    Project,
    /// Worked out here.
    Derived,
}

/// How a derived time was found (for `check`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Derivation {
    /// 3 × the scan period.
    pub periods: Duration,
    /// The line's cycle floor.
    pub floor: Duration,
    /// The line's start-up traffic.
    pub startup: Duration,
    /// Failing exchanges of the other modules, and one retry of the module's own.
    pub failures: Duration,
    /// Event mode: one `event_refresh`.
    pub event_refresh: Option<Duration>,
}

impl Derivation {
    /// The sum.
    pub fn total(&self) -> Duration {
        self.periods
            + self.floor
            + self.startup
            + self.failures
            + self.event_refresh.unwrap_or_default()
    }
}

/// What a module's own watchdog does in this project.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Armed {
    /// Not worked out yet (during validation).
    #[default]
    Pending,
    /// MiniMod: WDTTIME and WDTYMASK written at start-up.
    MiniMod {
        /// WDTTIME, 1/100 s (non-zero).
        time: u16,
        /// Where it comes from.
        time_from: Origin,
        /// The derivation, when derived.
        derivation: Option<Derivation>,
        /// WDTYMASK (bits 0..3 = Y1..Y4).
        mask: u16,
        /// Where it comes from.
        mask_from: Origin,
        /// Outputs that go off without a safe value saying so (derived mask only).
        no_safe: Vec<&'static str>,
    },
    /// The EX-9053D's host watchdog, by its `watchdog` setting.
    HostWatchdog {
        /// The timeout, 0.1 s.
        tenths: u8,
    },
    /// The RESI-1RO's off-delay, by its `SOFFDLY` setting.
    OffDelay {
        /// ms.
        ms: u16,
    },
    /// Turned off by the project (`watchdog: off`, or `WDTTIME: 0`): `check` warns.
    Off,
    /// Not armed: why.
    NotArmed(&'static str),
}

/// A module's watchdog: what the entry asked for, what it is.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ModuleWatchdog {
    /// The entry's `watchdog:`.
    pub policy: WatchdogPolicy,
    /// What it is (filled in by `arm`).
    pub armed: Armed,
    /// The settings arming adds to a MiniMod's own (`WDTTIME`, `WDTYMASK`), for its driver
    /// (the other models' watchdogs add none).
    pub settings: Vec<MiniModSetting>,
}

impl super::model::ModuleConfig {
    /// What the module's driver is built from: its settings as written, then what arming its
    /// watchdog adds (see `arm`).
    pub fn device_with_watchdog(&self) -> softplc_io::devices::DeviceConfig {
        let mut device = self.device.clone();
        if let ModuleSettings::MiniMod(s) = &mut device.settings {
            for added in &self.watchdog.settings {
                s.push(*added);
            }
        }
        device
    }
}

/// A MiniMod's settings, if `settings` are one's.
fn minimod(settings: &ModuleSettings) -> Option<&MiniModSettings> {
    match settings {
        ModuleSettings::MiniMod(s) => Some(s),
        _ => None,
    }
}

/// Why `watchdog: off` cannot go with the module's settings, if it cannot.
pub(crate) fn conflict(settings: &ModuleSettings) -> Option<String> {
    let (key, value) = match settings {
        ModuleSettings::MiniMod(s) => (
            "WDTTIME",
            s.register("WDTTIME").filter(|&t| t != 0)?.to_string(),
        ),
        ModuleSettings::Ex9053(s) => ("watchdog", format!("{}s", f64::from(s.watchdog?) / 10.0)),
        ModuleSettings::Resi(s) => ("SOFFDLY", s.off_delay()?.to_string()),
        // A profiled device's watchdog, if it has one, is not in its profile.
        ModuleSettings::Profile(_) => return None,
    };
    Some(format!(
        "off contradicts the setting {key}: {value}; remove one of them"
    ))
}

/// Rounds `d` up to whole hundredths of a second, within WDTTIME's range.
fn hundredths(d: Duration) -> u16 {
    let h = d.as_nanos().div_ceil(10_000_000);
    u16::try_from(h).unwrap_or(u16::MAX).max(1)
}

/// Why a MiniMod on a Modbus TCP bus has no watchdog armed by softplc.
pub(crate) const MINIMOD_ON_MODBUS_TCP: &str = "a MiniMod's watchdog is armed by name with text \
     commands (>WDTTIME=), which a Modbus TCP bus cannot carry; arm it in the module's flash \
     (WCONF) on a line of its own, or put it on an rtu+tcp:// bus";

/// Works out every module's watchdog and the settings that arm it
/// ([`ModuleWatchdog::settings`]; the module's own settings stay as written): at the end of
/// validation, once the project is whole.
pub(crate) fn arm(project: &mut Project) {
    let derivations = derive_all(project);
    for (m, derivation) in derivations.into_iter().enumerate() {
        let mask = safe_mask(project, m);
        let on_modbus_tcp = project
            .modules
            .get(m)
            .and_then(|module| project.buses.get(module.bus))
            .is_some_and(|bus| bus.port.is_modbus_tcp());
        let Some(module) = project.modules.get_mut(m) else {
            continue;
        };
        let settings = &module.device.settings;
        let added = &mut module.watchdog.settings;
        let mm = minimod(settings);
        let policy = module.watchdog.policy;
        module.watchdog.armed = match module.model.name {
            // The driver arms it by name (`>WDTTIME=`, read back with `?WDTTIME`; `?WFLAGS`
            // after a restart): text commands, which Modbus TCP cannot carry.
            "minimod" if on_modbus_tcp => Armed::NotArmed(MINIMOD_ON_MODBUS_TCP),
            "minimod" => {
                let time = mm.and_then(|s| s.register("WDTTIME"));
                let explicit_mask = mm.and_then(|s| s.register("WDTYMASK"));
                match (policy, time) {
                    (_, Some(0)) => Armed::Off,
                    (WatchdogPolicy::Off, _) => {
                        added.extend(MiniModSetting::holding("WDTTIME", 0));
                        Armed::Off
                    }
                    (WatchdogPolicy::Auto, time) => {
                        let (time, time_from, derivation) = match time {
                            Some(t) => (t, Origin::Project, None),
                            None => {
                                let t = hundredths(derivation.total());
                                added.extend(MiniModSetting::holding("WDTTIME", t));
                                (t, Origin::Derived, Some(derivation))
                            }
                        };
                        let (mask, mask_from, no_safe) = match explicit_mask {
                            Some(v) => (v, Origin::Project, Vec::new()),
                            None => {
                                added.extend(MiniModSetting::holding("WDTYMASK", mask.0));
                                (mask.0, Origin::Derived, mask.1)
                            }
                        };
                        Armed::MiniMod {
                            time,
                            time_from,
                            derivation,
                            mask,
                            mask_from,
                            no_safe,
                        }
                    }
                }
            }
            "ex9053d" | "ex9053d-m" => {
                let watchdog = match settings {
                    ModuleSettings::Ex9053(s) => s.watchdog,
                    _ => None,
                };
                match (policy, watchdog) {
                    (WatchdogPolicy::Off, _) => Armed::NotArmed("watchdog: off"),
                    (_, Some(tenths)) => Armed::HostWatchdog { tenths },
                    (_, None) => Armed::NotArmed(
                        "the EX-9053D has no outputs for its host watchdog to make safe \
                         (§1.5, §1.8); setting watchdog: 2s arms it",
                    ),
                }
            }
            "resi-1ro" => match (policy, settings) {
                (WatchdogPolicy::Off, _) => Armed::NotArmed("watchdog: off"),
                (_, ModuleSettings::Resi(s)) if s.off_delay().is_some() => Armed::OffDelay {
                    ms: s.off_delay().unwrap_or_default(),
                },
                _ => Armed::NotArmed(
                    "the off-delay SOFFDLY is opt-in (it drives DO1 through a timer); setting \
                     SOFFDLY: <ms> arms it",
                ),
            },
            _ if matches!(settings, ModuleSettings::Profile(_)) => Armed::NotArmed(
                "a device profile arms no watchdog (configure the device's own, if it has one)",
            ),
            _ => Armed::NotArmed("the model has no communication watchdog (resi-spec §5.4)"),
        };
    }
}

/// WDTYMASK from the tags' safe values, and the outputs that have none.
fn safe_mask(project: &Project, m: usize) -> (u16, Vec<&'static str>) {
    let Some(module) = project.modules.get(m) else {
        return (0, Vec::new());
    };
    let mut known = [None::<bool>; 4];
    for tag in &project.tags {
        let Binding::Point { module: tm, point } = tag.binding else {
            continue;
        };
        if tm != m {
            continue;
        }
        let Some(spec) = module.model.points.get(point) else {
            continue;
        };
        match (spec.name, tag.safe) {
            ("YWORD", Some(v)) => {
                let word = match v {
                    Value::U16(w) => w,
                    other => u16::from(other.as_bool()),
                };
                for (y, k) in known.iter_mut().enumerate() {
                    if k.is_none() {
                        *k = Some(word & (1 << y) != 0);
                    }
                }
            }
            (name, Some(v)) => {
                if let Some(y) = ["Y1", "Y2", "Y3", "Y4"].iter().position(|n| *n == name) {
                    known[y] = Some(v.as_bool());
                }
            }
            _ => {}
        }
    }
    let mask = known
        .iter()
        .enumerate()
        .fold(0u16, |acc, (y, k)| acc | (u16::from(*k == Some(true)) << y));
    let no_safe = ["Y1", "Y2", "Y3", "Y4"]
        .into_iter()
        .zip(known)
        .filter(|(_, k)| k.is_none())
        .map(|(n, _)| n)
        .collect();
    (mask, no_safe)
}

/// The derived time's parts for every module (index = module).
fn derive_all(project: &Project) -> Vec<Derivation> {
    let period = project.scan.period;
    let mut out = vec![
        Derivation {
            periods: period * 3,
            floor: Duration::ZERO,
            startup: Duration::ZERO,
            failures: Duration::ZERO,
            event_refresh: None,
        };
        project.modules.len()
    ];
    for (b, bus) in project.buses.iter().enumerate() {
        // A USB adapter's latency timer stretches every exchange, so the module's timeout
        // must too, or the watchdog fires on a healthy line.
        let (_, adapter) = bus.adapter(&SysfsRoot::default());
        let members: Vec<usize> = (0..project.modules.len())
            .filter(|&m| project.modules[m].bus == b)
            .collect();
        let mut drivers: Vec<_> = members
            .iter()
            .map(|&m| {
                let module = &project.modules[m];
                let access: Vec<Access> = module.model.points.iter().map(|p| p.access).collect();
                // As it will run: a MiniMod's start-up with its watchdog settings (their
                // values do not change its traffic).
                let mut device = module.device.clone();
                if let ModuleSettings::MiniMod(s) = &mut device.settings {
                    for key in ["WDTTIME", "WDTYMASK"] {
                        if s.register(key).is_none() {
                            s.extend(MiniModSetting::holding(key, 1));
                        }
                    }
                }
                (module.name.clone(), (module.model.driver)(&device), access)
            })
            .collect();
        let mut startup = Duration::ZERO;
        let mut plan = Vec::new();
        for (_, driver, _) in drivers.iter_mut() {
            plan.clear();
            driver.plan_startup(&mut plan);
            let delay = driver.reply_delay();
            startup += plan
                .iter()
                .map(|tx| transaction_time(bus.settings, tx, delay) + adapter.latency)
                .sum::<Duration>();
        }
        let floor = line_budget_on(bus.settings, adapter, &mut drivers).cycle_floor();
        // One attempt that gets no answer: the request, the response timeout, the guard.
        let attempt = failed_attempt(bus.settings, bus.response_timeout);
        let attempts = u32::from(bus.retries) + 1;
        let others = u32::try_from(members.len().saturating_sub(1)).unwrap_or(u32::MAX);
        let failures = attempt * attempts * 2 * others + attempt * u32::from(bus.retries);
        for &m in &members {
            let event_refresh = minimod(&project.modules[m].device.settings)
                .filter(|s| s.events())
                .map(MiniModSettings::event_refresh);
            if let Some(d) = out.get_mut(m) {
                d.floor = floor;
                d.startup = startup;
                d.failures = failures;
                d.event_refresh = event_refresh;
            }
        }
    }
    out
}

/// `0b0010 (Y1 off, Y2 on; no safe value, so off: Y3, Y4)`.
fn fmt_mask(mask: u16, no_safe: &[&str]) -> String {
    let outputs: Vec<String> = ["Y1", "Y2", "Y3", "Y4"]
        .iter()
        .enumerate()
        .filter(|(_, name)| !no_safe.contains(name))
        .map(|(y, name)| {
            let on = if mask & (1 << y) != 0 { "on" } else { "off" };
            format!("{name} {on}")
        })
        .collect();
    let mut text = outputs.join(", ");
    if !no_safe.is_empty() {
        if !text.is_empty() {
            text.push_str("; ");
        }
        text.push_str("no safe value, so off: ");
        text.push_str(&no_safe.join(", "));
    }
    format!("{:#06b} ({text})", mask & 0x0F)
}

/// `1.18s`.
fn fmt_secs(d: Duration) -> String {
    format!("{:.2}s", d.as_secs_f64())
}

/// The line `check` prints for a module's watchdog, and a warning when it is off.
pub(crate) fn report(module: &super::model::ModuleConfig) -> (String, Option<String>) {
    let name = &module.name;
    match &module.watchdog.armed {
        Armed::MiniMod {
            time,
            time_from,
            derivation,
            mask,
            mask_from,
            no_safe,
        } => {
            let t = fmt_secs(Duration::from_millis(u64::from(*time) * 10));
            let how = match (time_from, derivation) {
                (Origin::Derived, Some(d)) => {
                    let mut parts = vec![
                        format!("3 × period {}", fmt_secs(d.periods / 3)),
                        format!("line floor {}", fmt_secs(d.floor)),
                        format!("start-up {}", fmt_secs(d.startup)),
                        format!("failing neighbours {}", fmt_secs(d.failures)),
                    ];
                    if let Some(r) = d.event_refresh {
                        parts.push(format!("event_refresh {}", fmt_secs(r)));
                    }
                    format!("{t} ≥ {}", parts.join(" + "))
                }
                _ => format!("{t}, from the settings"),
            };
            let mask = match mask_from {
                Origin::Derived => fmt_mask(*mask, no_safe),
                Origin::Project => format!("{:#06b}, from the settings", mask & 0x0F),
            };
            (
                format!(
                    "    module watchdog: WDTTIME {time} ({how}); WDTYMASK {mask}: outputs the module \
                     sets by itself after that long without a command"
                ),
                None,
            )
        }
        Armed::HostWatchdog { tenths } => (
            format!(
                "    module watchdog: host watchdog armed, {} (the module has no outputs: its timeout \
                 shows as WDT_TIMEOUT)",
                fmt_secs(Duration::from_millis(u64::from(*tenths) * 100))
            ),
            None,
        ),
        Armed::OffDelay { ms } => (
            format!(
                "    module watchdog: off-delay SOFFDLY {}: DO1 drops when no command retriggers it",
                fmt_secs(Duration::from_millis(u64::from(*ms)))
            ),
            None,
        ),
        Armed::Off => (
            "    module watchdog: OFF".into(),
            Some(format!(
                "warning: module {name}: its watchdog is off: if this process dies or the line \
                 breaks, its outputs keep their last state"
            )),
        ),
        Armed::NotArmed(why) if *why == MINIMOD_ON_MODBUS_TCP => (
            format!("    module watchdog: not armed: {why}"),
            Some(format!(
                "warning: module {name}: no watchdog armed on a Modbus TCP bus: if this process \
                 dies or the connection breaks, its outputs keep their last state"
            )),
        ),
        Armed::NotArmed(why) => (format!("    module watchdog: not armed: {why}"), None),
        Armed::Pending => ("    module watchdog: not worked out".into(), None),
    }
}
