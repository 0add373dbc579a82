//! Whether each module on a line can be heard at all: a module starts its reply only after
//! its reply delay (a MiniMod's RDELAYT hundredths of a second plus RDELAYM tenths of a
//! millisecond, manual "Setting the reply delay" and "Setting the Modbus communication
//! timeout"), and the bus owner waits the response timeout for the reply's first byte. A
//! module whose first byte comes no sooner than that is never heard: it is lost from its
//! first exchange, which `run` can only report as silence.

use softplc_io::driver::Driver;
use softplc_io::line::AdapterTiming;

use crate::project::BusConfig;
use crate::scan::fmt_duration;

/// One warning for each of `drivers` (its name, its driver) on `bus` whose reply's first
/// byte, after its reply delay, one character and the adapter's latency, would come no sooner
/// than the response timeout the bus owner waits for it.
pub(super) fn warnings<'a>(
    bus: &BusConfig,
    adapter: AdapterTiming,
    drivers: impl Iterator<Item = (&'a str, &'a dyn Driver)>,
) -> Vec<String> {
    drivers
        .filter_map(|(name, driver)| {
            let delay = driver.reply_delay();
            let first_byte = delay + bus.settings.char_time() + adapter.latency;
            let timeout = driver.response_timeout().unwrap_or(bus.response_timeout);
            (first_byte >= timeout).then(|| {
                format!(
                    "warning: module {name}: its reply delay {} puts its reply's first byte at \
                     {} or later, not within the response timeout {} of bus {}: none of its \
                     replies would be heard; a longer response_timeout or a shorter reply \
                     delay (a MiniMod's RDELAYT and RDELAYM) let it answer",
                    fmt_duration(delay),
                    fmt_duration(first_byte),
                    fmt_duration(timeout),
                    bus.name
                )
            })
        })
        .collect()
}
