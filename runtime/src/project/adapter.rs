//! What a bus's adapter adds to its transactions: the latency timer of a USB adapter (read
//! from sysfs, or the project's `adapter_latency`) and the echo it may hear. Every figure made
//! from a line's timing counts it (check's budget, the push-down report's reaction times, the
//! MiniMod watchdog's WDTTIME), so it is found in one place (`softplc_io::line::latency` says
//! how).

use softplc_io::line::{AdapterTiming, Assumed, SysfsRoot};

use super::model::{BusConfig, PortConfig};

impl BusConfig {
    /// The adapter's timing and where its latency comes from, with sysfs under `sysfs`: the
    /// latency timer of a serial port's adapter, or `adapter_latency` when the project gives
    /// one; nothing on the simulated line.
    pub fn adapter(&self, sysfs: &SysfsRoot) -> (Assumed, AdapterTiming) {
        let assumed = match &self.port {
            // No USB adapter on this host's side of a network bus.
            PortConfig::Sim | PortConfig::Tcp(_) => Assumed::simulated(),
            PortConfig::Serial(p) => Assumed::for_port(self.adapter_latency, p, sysfs),
        };
        let timing = AdapterTiming {
            latency: assumed.latency,
            echo: self.echo,
        };
        (assumed, timing)
    }
}
