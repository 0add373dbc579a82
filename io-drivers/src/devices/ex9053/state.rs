//! The inside of an EX-9053D / EX-9053D-M, protocol-free: what is stored as in EEPROM, what
//! runs from the last power-on, and the inputs with their latches, counters and synchronized
//! sample. The DCON and Modbus sides of the simulator ([`super::sim_dcon`],
//! [`super::sim_modbus`]) both act on it.
//!
//! Behaviour, by the manual's sections, and the choices where it is silent:
//! - **EEPROM** (§1.4): address, baud code, data format, protocol (-M), name, host watchdog
//!   enable/value and its timeout status ("set and store into EEPROM", §1.8) survive a power
//!   cycle. Counters, latches, the synchronized sample and the reset status are RAM.
//! - **Power-on** (§1.4, §1.7): the running address, baud code, checksum and protocol are taken
//!   from EEPROM, or from INIT* (address 00, 9600 Bd, no checksum, DCON) when the INIT* switch
//!   is on; the reset status is set. The INIT* switch is read only at power-on (§1.4 steps 1..3,
//!   quick start step 4).
//! - **Changes**: a new baud code or checksum bit takes effect at the next power-on (§2.1); a
//!   new address given by DCON `%AANN...` at once (the §2.1 example answers from the new
//!   address), one given over Modbus (40485, FC 0x46 sub-function 04) after the reboot as the
//!   map says; the counter edge (FF bit 7) at once.
//! - **Inputs** change only when set (a terminal level, from `softplc sim` or a plant), so the
//!   model is event-driven: a pulse between two polls is seen by the latches and counters
//!   however short it is.
//! - **Latches** are level latches, as the Modbus map words them ("level already high/low"):
//!   a latch-high bit is set while its input is high and stays set until cleared (`$AAC`,
//!   coil 00264); clearing re-seeds it from the present level. They start seeded at power-on.
//! - **Counters** count the edge selected by FF bit 7 (§1.10; 0 = falling, the factory
//!   value), wrap at 100000 while the module runs DCON (§2.3) and 65536 while it runs Modbus.
//! - **Host watchdog** (§1.5, §1.6, §2.18..§2.21): when enabled with a value VV > 0, it expires
//!   VV × 0.1 s after the last host OK (`~**`, Modbus 312345/412345), the last arming or the
//!   power-on; then the timeout status is set and the watchdog disabled — the manual's own
//!   example reads `!0104` and `!01064` after a timeout — so status 84 appears only when the
//!   host enables it again before `~AA1`. The EX-9053D has no outputs, so "outputs go to safe
//!   values" changes nothing but the status. VV = 0 never expires.

use std::time::Duration;

use super::tables::{
    baud_of_code, CHANNELS, DCON_COUNTER_MODULUS, DEFAULT_ADDRESS, DEFAULT_BAUD_CODE,
    DEFAULT_FORMAT, DEFAULT_NAME, FF_CHECKSUM, FF_RISING_EDGE, INIT_ADDRESS, INIT_BAUD_CODE,
    MAX_NAME_LEN, MODBUS_COUNTER_MODULUS, STATUS_WDT_ENABLED, STATUS_WDT_TIMEOUT, TYPE_DIO,
    WDT_TICK_MS,
};

/// Which of the two modules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// EX-9053D: DCON only.
    D,
    /// EX-9053D-M: Modbus RTU by default, DCON in INIT* or when stored (§1.3, §2.15).
    M,
}

impl Variant {
    /// The catalog name.
    pub fn model(self) -> &'static str {
        match self {
            Variant::D => "ex9053d",
            Variant::M => "ex9053d-m",
        }
    }
}

/// The protocol a module runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireProtocol {
    /// DCON ASCII ("Normal mode", §2.15).
    Dcon,
    /// Modbus RTU (EX-9053D-M only).
    Modbus,
}

/// What the module keeps across a power cycle.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Eeprom {
    /// Module address.
    pub address: u8,
    /// CC (§1.10).
    pub baud_code: u8,
    /// FF (§1.10), kept as written.
    pub format: u8,
    /// Protocol at the next power-on (-M; always DCON on the EX-9053D).
    pub protocol: WireProtocol,
    /// Module name (§2.14).
    pub name: String,
    /// Host watchdog enabled (§2.21).
    pub wdt_enabled: bool,
    /// Host watchdog value, 0.1 s (§2.21).
    pub wdt_value: u8,
    /// Host watchdog timeout status (§1.8).
    pub wdt_timeout: bool,
}

/// What runs since the last power-on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Running {
    /// The address answered at (DCON changes it at once, Modbus after a reboot).
    pub address: u8,
    /// CC the module listens at.
    pub baud_code: u8,
    /// Checksum in both directions.
    pub checksum: bool,
    /// Protocol spoken.
    pub protocol: WireProtocol,
    /// INIT* mode (§1.4).
    pub init: bool,
}

/// Why a configuration change was refused (the DCON answer is `?AA`, Modbus exception 03).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// CC outside 03..0A (§1.10).
    #[error("baud code {0:02X} is not in 03..0A")]
    BaudCode(u8),
    /// A baud or checksum change, or a protocol change by DCON, outside INIT* (§2.1, §2.16).
    #[error("the change needs INIT* mode")]
    NeedsInit,
    /// A name of 0 or more than 6 characters (§2.14).
    #[error("a name has 1 to {MAX_NAME_LEN} characters, not {0}")]
    NameLength(usize),
    /// The EX-9053D speaks DCON only.
    #[error("the EX-9053D has no Modbus")]
    NoModbus,
    /// A Modbus address outside 1..=247 (40485, FC 0x46 sub-function 04).
    #[error("Modbus address {0} is not in 1..=247")]
    ModbusAddress(u16),
}

/// The module.
#[derive(Debug, Clone)]
pub struct Ex9053State {
    variant: Variant,
    eeprom: Eeprom,
    running: Running,
    init_switch: bool,
    now: Duration,
    inputs: u16,
    latch_high: u16,
    latch_low: u16,
    counters: [u32; CHANNELS],
    sync_sample: Option<u16>,
    sync_first: bool,
    reset_status: bool,
    wdt_since: Duration,
}

impl Ex9053State {
    /// A module with its factory settings (§1.3) but answering at `address`, just powered on
    /// at time zero with all inputs low.
    pub fn new(variant: Variant, address: u8) -> Self {
        let protocol = match variant {
            Variant::D => WireProtocol::Dcon,
            Variant::M => WireProtocol::Modbus,
        };
        let eeprom = Eeprom {
            address,
            baud_code: DEFAULT_BAUD_CODE,
            format: DEFAULT_FORMAT,
            protocol,
            name: DEFAULT_NAME.to_string(),
            wdt_enabled: false,
            wdt_value: 0,
            wdt_timeout: false,
        };
        let mut s = Self {
            variant,
            running: running_from(&eeprom, false),
            eeprom,
            init_switch: false,
            now: Duration::ZERO,
            inputs: 0,
            latch_high: 0,
            latch_low: 0,
            counters: [0; CHANNELS],
            sync_sample: None,
            sync_first: false,
            reset_status: true,
            wdt_since: Duration::ZERO,
        };
        s.power_on();
        s
    }

    /// A module straight from the factory: address 01 (§1.3).
    pub fn factory(variant: Variant) -> Self {
        Self::new(variant, DEFAULT_ADDRESS)
    }

    /// Which module this is.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// The stored settings.
    pub fn eeprom(&self) -> &Eeprom {
        &self.eeprom
    }

    /// The settings in force.
    pub fn running(&self) -> Running {
        self.running
    }

    /// The module's time.
    pub fn now(&self) -> Duration {
        self.now
    }

    /// Switches the module off and on: EEPROM settings and the INIT* switch take effect, RAM
    /// starts afresh, the reset status is set (§1.7).
    pub fn power_cycle(&mut self) {
        self.power_on();
    }

    fn power_on(&mut self) {
        self.running = running_from(&self.eeprom, self.init_switch);
        if self.variant == Variant::D {
            self.running.protocol = WireProtocol::Dcon;
        }
        self.latch_high = self.inputs;
        self.latch_low = !self.inputs;
        self.counters = [0; CHANNELS];
        self.sync_sample = None;
        self.sync_first = false;
        self.reset_status = true;
        self.wdt_since = self.now;
    }

    /// The INIT* switch (§1.4), read at the next power-on.
    pub fn init_switch(&self) -> bool {
        self.init_switch
    }

    /// Slides the INIT* switch; it takes effect at the next power-on.
    pub fn set_init_switch(&mut self, on: bool) {
        self.init_switch = on;
    }

    /// Runs the module up to `t`: the host watchdog expires if its time has come. Earlier
    /// times are ignored.
    pub fn advance_to(&mut self, t: Duration) {
        if t <= self.now {
            return;
        }
        if let Some(deadline) = self.wdt_deadline() {
            if deadline <= t {
                self.eeprom.wdt_timeout = true;
                self.eeprom.wdt_enabled = false;
            }
        }
        self.now = t;
    }

    fn wdt_deadline(&self) -> Option<Duration> {
        let e = &self.eeprom;
        (e.wdt_enabled && e.wdt_value > 0 && !e.wdt_timeout)
            .then(|| self.wdt_since + Duration::from_millis(u64::from(e.wdt_value) * WDT_TICK_MS))
    }

    // --- inputs, latches, counters -----------------------------------------------------------

    /// The input levels, bit n = DIn.
    pub fn inputs(&self) -> u16 {
        self.inputs
    }

    /// Sets one terminal's level (channel 0..=15; others are ignored).
    pub fn set_input(&mut self, channel: usize, high: bool) {
        if channel < CHANNELS {
            let bit = 1u16 << channel;
            let levels = if high {
                self.inputs | bit
            } else {
                self.inputs & !bit
            };
            self.set_inputs(levels);
        }
    }

    /// Sets every terminal's level at once, bit n = DIn.
    pub fn set_inputs(&mut self, levels: u16) {
        let changed = self.inputs ^ levels;
        let counted = if self.counter_rising() {
            changed & levels
        } else {
            changed & !levels
        };
        let modulus = self.counter_modulus();
        for (ch, counter) in self.counters.iter_mut().enumerate() {
            if counted & (1 << ch) != 0 {
                *counter = (*counter + 1) % modulus;
            }
        }
        self.inputs = levels;
        self.latch_high |= levels;
        self.latch_low |= !levels;
    }

    /// Latch-high bits: bit n set = DIn has been high since the last clear.
    pub fn latch_high(&self) -> u16 {
        self.latch_high
    }

    /// Latch-low bits: bit n set = DIn has been low since the last clear.
    pub fn latch_low(&self) -> u16 {
        self.latch_low
    }

    /// Clears both latches (§2.10, coil 00264); they restart from the present levels.
    pub fn clear_latches(&mut self) {
        self.latch_high = self.inputs;
        self.latch_low = !self.inputs;
    }

    /// A channel's counter (0 for a channel that does not exist).
    pub fn counter(&self, channel: usize) -> u32 {
        self.counters.get(channel).copied().unwrap_or(0)
    }

    /// Clears a channel's counter (§2.11, coils 00513..00528).
    pub fn clear_counter(&mut self, channel: usize) {
        if let Some(c) = self.counters.get_mut(channel) {
            *c = 0;
        }
    }

    fn counter_modulus(&self) -> u32 {
        match self.running.protocol {
            WireProtocol::Dcon => DCON_COUNTER_MODULUS,
            WireProtocol::Modbus => MODBUS_COUNTER_MODULUS,
        }
    }

    /// Counters count rising edges (FF bit 7 = 1, coil 02251 = 1).
    pub fn counter_rising(&self) -> bool {
        self.eeprom.format & FF_RISING_EDGE != 0
    }

    /// Selects the counted edge, at once.
    pub fn set_counter_rising(&mut self, rising: bool) {
        if rising {
            self.eeprom.format |= FF_RISING_EDGE;
        } else {
            self.eeprom.format &= !FF_RISING_EDGE;
        }
    }

    // --- synchronized sampling, reset status ---------------------------------------------------

    /// `#**`: takes a sample of the inputs; its first read will say so (§2.2).
    pub fn sync_sample(&mut self) {
        self.sync_sample = Some(self.inputs);
        self.sync_first = true;
    }

    /// `$AA4`: the last sample and whether this is its first read (§2.5). Before any sample:
    /// not first, all zero (the manual is silent).
    pub fn read_sync(&mut self) -> (bool, u16) {
        let first = std::mem::replace(&mut self.sync_first, false);
        (first, self.sync_sample.unwrap_or(0))
    }

    /// Whether a sample is waiting for its first read.
    pub fn sync_first(&self) -> bool {
        self.sync_first
    }

    /// `$AA5`: the reset status, cleared by this read (§1.7, §2.6).
    pub fn take_reset_status(&mut self) -> bool {
        std::mem::replace(&mut self.reset_status, false)
    }

    /// The reset status, without clearing it.
    pub fn reset_status(&self) -> bool {
        self.reset_status
    }

    // --- host watchdog -----------------------------------------------------------------------

    /// Host OK (`~**`, Modbus 312345/412345): the watchdog restarts its interval.
    pub fn host_ok(&mut self) {
        self.wdt_since = self.now;
    }

    /// `~AA3EVV`: enable or disable, with the value in 0.1 s; the interval restarts.
    pub fn set_watchdog(&mut self, enabled: bool, value: u8) {
        self.eeprom.wdt_enabled = enabled;
        self.eeprom.wdt_value = value;
        self.wdt_since = self.now;
    }

    /// Coil 00261: enable or disable; the interval restarts.
    pub fn set_watchdog_enabled(&mut self, enabled: bool) {
        self.set_watchdog(enabled, self.eeprom.wdt_value);
    }

    /// Register 40489: the value in 0.1 s; the interval restarts.
    pub fn set_watchdog_value(&mut self, value: u8) {
        self.set_watchdog(self.eeprom.wdt_enabled, value);
    }

    /// `~AA2`: (enabled, value in 0.1 s).
    pub fn watchdog(&self) -> (bool, u8) {
        (self.eeprom.wdt_enabled, self.eeprom.wdt_value)
    }

    /// The host watchdog timeout status (§1.8).
    pub fn watchdog_timeout(&self) -> bool {
        self.eeprom.wdt_timeout
    }

    /// `~AA0` SS: 00, 80 or 84 (§2.18), 04 after a timeout (§1.5 and the §2.21 example).
    pub fn module_status(&self) -> u8 {
        let e = &self.eeprom;
        (if e.wdt_enabled { STATUS_WDT_ENABLED } else { 0 })
            | (if e.wdt_timeout { STATUS_WDT_TIMEOUT } else { 0 })
    }

    /// `~AA1`, coil 00270 ← 0xFF00: clears the timeout status (§2.19).
    pub fn reset_module_status(&mut self) {
        self.eeprom.wdt_timeout = false;
        self.wdt_since = self.now;
    }

    // --- configuration -----------------------------------------------------------------------

    /// `$AA2`: TT, CC, FF as stored (§1.4 step 4 reads "the Configuration stored in the
    /// module's EEPROM").
    pub fn config(&self) -> (u8, u8, u8) {
        (TYPE_DIO, self.eeprom.baud_code, self.eeprom.format)
    }

    /// `%AANNTTCCFF` (§2.1). A new baud code or checksum bit needs INIT* and waits for the
    /// next power-on; the address changes at once (in INIT* only in EEPROM). TT is not checked:
    /// the module has one type, and the manual's own example sends 24.
    pub fn configure(
        &mut self,
        new_address: u8,
        baud_code: u8,
        format: u8,
    ) -> Result<(), ConfigError> {
        if baud_of_code(baud_code).is_none() {
            return Err(ConfigError::BaudCode(baud_code));
        }
        let serial_change =
            baud_code != self.eeprom.baud_code || (format ^ self.eeprom.format) & FF_CHECKSUM != 0;
        if serial_change && !self.running.init {
            return Err(ConfigError::NeedsInit);
        }
        self.eeprom.address = new_address;
        if !self.running.init {
            self.running.address = new_address;
        }
        self.eeprom.baud_code = baud_code;
        self.eeprom.format = format;
        Ok(())
    }

    /// Whether a DCON command to `address` is for this module. In INIT* the module answers at
    /// 00 and, so that the manual's `$01P1` example (§2.16, a command that needs INIT*) can
    /// work, also at its stored address.
    pub fn dcon_addressed(&self, address: u8) -> bool {
        address == self.running.address || (self.running.init && address == self.eeprom.address)
    }

    /// Register 40485, FC 0x46 sub-function 04: the address after the next reboot.
    pub fn set_stored_address(&mut self, address: u16) -> Result<(), ConfigError> {
        match u8::try_from(address) {
            Ok(a @ 1..=247) => {
                self.eeprom.address = a;
                Ok(())
            }
            _ => Err(ConfigError::ModbusAddress(address)),
        }
    }

    /// The module installed at `code` (its stored and running baud, as the installer left
    /// it before it was put on the line); `false` for a code outside §1.10's table.
    pub fn install_baud_code(&mut self, code: u8) -> bool {
        if baud_of_code(code).is_none() {
            return false;
        }
        self.eeprom.baud_code = code;
        if !self.running.init {
            self.running.baud_code = code;
        }
        true
    }

    /// Register 40486: the baud code after the next reboot.
    pub fn set_stored_baud_code(&mut self, code: u16) -> Result<(), ConfigError> {
        match u8::try_from(code)
            .ok()
            .filter(|c| baud_of_code(*c).is_some())
        {
            Some(c) => {
                self.eeprom.baud_code = c;
                Ok(())
            }
            None => Err(ConfigError::BaudCode(u8::try_from(code).unwrap_or(u8::MAX))),
        }
    }

    /// `$AAPN` (§2.16, needs INIT*) and coil 00257: the protocol at the next power-on.
    pub fn set_stored_protocol(
        &mut self,
        protocol: WireProtocol,
        by_dcon: bool,
    ) -> Result<(), ConfigError> {
        if self.variant == Variant::D {
            return Err(ConfigError::NoModbus);
        }
        if by_dcon && !self.running.init {
            return Err(ConfigError::NeedsInit);
        }
        self.eeprom.protocol = protocol;
        Ok(())
    }

    /// The module name (§2.9).
    pub fn name(&self) -> &str {
        &self.eeprom.name
    }

    /// `~AAO(Data)` (§2.14): 1..=6 characters.
    pub fn set_name(&mut self, name: &str) -> Result<(), ConfigError> {
        let n = name.chars().count();
        if !(1..=MAX_NAME_LEN).contains(&n) {
            return Err(ConfigError::NameLength(n));
        }
        self.eeprom.name = name.to_string();
        Ok(())
    }
}

fn running_from(eeprom: &Eeprom, init: bool) -> Running {
    if init {
        Running {
            address: INIT_ADDRESS,
            baud_code: INIT_BAUD_CODE,
            checksum: false,
            protocol: WireProtocol::Dcon,
            init: true,
        }
    } else {
        Running {
            address: eeprom.address,
            baud_code: eeprom.baud_code,
            checksum: eeprom.format & FF_CHECKSUM != 0,
            protocol: eeprom.protocol,
            init: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn level_latches_catch_a_pulse_and_restart_from_the_level() {
        let mut m = Ex9053State::factory(Variant::D);
        assert_eq!(m.latch_low(), 0xFFFF, "all inputs low at power-on");
        m.clear_latches();
        assert_eq!((m.latch_high(), m.latch_low()), (0, 0xFFFF));
        m.set_input(3, true);
        m.set_input(3, false);
        assert_eq!(m.latch_high(), 0x0008);
        m.clear_latches();
        assert_eq!(m.latch_high(), 0);
    }

    #[test]
    fn counters_count_the_selected_edge_and_wrap() {
        let mut m = Ex9053State::factory(Variant::D);
        m.set_input(0, true);
        assert_eq!(m.counter(0), 0, "factory: falling edge");
        m.set_input(0, false);
        assert_eq!(m.counter(0), 1);
        m.set_counter_rising(true);
        m.set_inputs(0xFFFF);
        assert_eq!(m.counter(0), 2);
        assert_eq!(m.counter(15), 1);
        m.clear_counter(0);
        assert_eq!(m.counter(0), 0);
        assert_eq!(m.counter(16), 0);
        m.counters[1] = DCON_COUNTER_MODULUS - 1;
        m.set_inputs(0);
        m.set_inputs(0xFFFF);
        assert_eq!(m.counter(1), 0, "DCON wraps after 99999");
    }

    #[test]
    fn watchdog_expires_disables_itself_and_persists() {
        let mut m = Ex9053State::factory(Variant::D);
        m.set_watchdog(true, 0x64);
        assert_eq!(m.module_status(), 0x80);
        m.advance_to(s(9_000));
        m.host_ok();
        m.advance_to(s(18_999));
        assert_eq!(m.module_status(), 0x80);
        m.advance_to(s(19_000));
        assert_eq!(m.module_status(), 0x04);
        assert_eq!(m.watchdog(), (false, 0x64));
        m.power_cycle();
        assert!(m.watchdog_timeout(), "stored in EEPROM");
        m.set_watchdog(true, 0x64);
        assert_eq!(m.module_status(), 0x84);
        m.reset_module_status();
        assert_eq!(m.module_status(), 0x80);
    }

    #[test]
    fn baud_and_checksum_wait_for_init_and_the_next_power_on() {
        let mut m = Ex9053State::factory(Variant::D);
        assert_eq!(m.configure(2, 0x07, 0x00), Err(ConfigError::NeedsInit));
        assert_eq!(m.configure(2, 0x06, 0x40), Err(ConfigError::NeedsInit));
        assert_eq!(m.configure(2, 0x0B, 0x00), Err(ConfigError::BaudCode(0x0B)));
        assert_eq!(m.configure(2, 0x06, 0x80), Ok(()));
        assert_eq!(m.running().address, 2, "address at once");
        assert!(m.counter_rising(), "edge at once");
        m.set_init_switch(true);
        m.power_cycle();
        assert_eq!(m.running().address, 0);
        assert!(m.dcon_addressed(0) && m.dcon_addressed(2) && !m.dcon_addressed(1));
        assert_eq!(m.configure(2, 0x0A, 0xC0), Ok(()));
        assert_eq!(m.running().baud_code, 0x06, "not before the next power-on");
        assert!(!m.running().checksum);
        m.set_init_switch(false);
        m.power_cycle();
        assert_eq!(m.running().baud_code, 0x0A);
        assert!(m.running().checksum);
        assert!(m.take_reset_status());
        assert!(!m.take_reset_status());
    }

    #[test]
    fn sync_sample_first_read_flag() {
        let mut m = Ex9053State::factory(Variant::D);
        assert_eq!(m.read_sync(), (false, 0));
        m.set_inputs(0x0F00);
        m.sync_sample();
        m.set_inputs(0);
        assert_eq!(m.read_sync(), (true, 0x0F00));
        assert_eq!(m.read_sync(), (false, 0x0F00));
    }

    #[test]
    fn protocol_is_for_the_m_only_and_needs_init_by_dcon() {
        let mut d = Ex9053State::factory(Variant::D);
        assert_eq!(
            d.set_stored_protocol(WireProtocol::Modbus, false),
            Err(ConfigError::NoModbus)
        );
        let mut m = Ex9053State::factory(Variant::M);
        assert_eq!(m.running().protocol, WireProtocol::Modbus);
        assert_eq!(
            m.set_stored_protocol(WireProtocol::Dcon, true),
            Err(ConfigError::NeedsInit)
        );
        assert_eq!(m.set_stored_protocol(WireProtocol::Dcon, false), Ok(()));
        m.power_cycle();
        assert_eq!(m.running().protocol, WireProtocol::Dcon);
        assert_eq!(
            m.set_stored_address(248),
            Err(ConfigError::ModbusAddress(248))
        );
        assert_eq!(
            m.set_stored_baud_code(0x0B),
            Err(ConfigError::BaudCode(0x0B))
        );
        assert_eq!(m.set_name(""), Err(ConfigError::NameLength(0)));
        assert_eq!(m.set_name("1234567"), Err(ConfigError::NameLength(7)));
    }
}
