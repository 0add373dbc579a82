//! RESI-16DI8RO: which rungs its internal logic runs (manual 10.1.1, `resi-spec.md` §4.5).
//!
//! At every 10 ms input sample, while ENABLE LOGIC FUNCTIONS is 1, for each relay: SWITCH
//! makes it take the level of its input; TOGGLE inverts it on a rising edge of a mapped input
//! (once per sample); SWITCH ON sets it on a rising edge; SWITCH OFF resets it on a rising
//! edge (after SWITCH ON, so reset wins); PULSE sets it on a rising edge and (re)starts a timer
//! of PULSE TIME tenths of a second, at whose end it drops. Each mask has bit n = DI(n+1).
//!
//! The central forms these run exactly (up to the 10 ms sampling):
//! - `relay = DIk` → SWITCH (one input: the manual leaves several inputs in one SWITCH mask
//!   open, `resi-spec.md` §4.4);
//! - edge set / edge reset, reset winning → SWITCH ON / SWITCH OFF;
//! - impulse relay → TOGGLE;
//! - staircase pulse of a multiple of 0.1 s → PULSE + PULSE TIME (retriggered by every edge,
//!   like the STAIR block; an IEC TP is not retriggerable and stays central).
//!
//! Edges are rising edges of single inputs; several inputs in one list are one mask.

use std::time::Duration;

use super::{m16di8ro, Inputs, LogicRow, Num, PulseTime, Relay, RelayFunction};
use crate::devices::ModuleSettings;
use crate::push_down::{Feature, ModulePlacement, Pushed, Reason, Site, TableEntry};
use crate::rung::{BoolExpr, RungShape, TagId};

/// The model whose logic runs rungs: the only RESI with internal logic functions.
pub(super) const MODEL: &str = "resi-16di8ro";
/// The module's input sample (10.1.1: inputs are sampled every 10 ms).
const TICK: Duration = Duration::from_millis(10);
/// What its logic checks.
const CHECKS: &str = "only DI1..DI16";

/// Maps a rung writing a RESI-16DI8RO relay, or says why it stays central.
pub(super) fn map(shape: &RungShape, site: &dyn Site) -> Result<ModulePlacement, Reason> {
    let relay = Relay::named(site.coil_point().name).ok_or(Reason::Unsupported {
        why: "the RESI-16DI8RO's logic drives its relays RO1..RO8 only",
    })?;
    let (feature, function) = match shape {
        RungShape::Combinational { expr } => {
            let BoolExpr::Tag(tag) = expr else {
                for t in expr.tags() {
                    site.input(t, CHECKS)?;
                }
                return Err(Reason::Unsupported {
                    why: "the RESI-16DI8RO's SWITCH makes a relay follow one input; this \
                          condition is not a single input",
                });
            };
            (
                Feature::Switch,
                RelayFunction::Switch(input_bit(site, *tag)?),
            )
        }
        RungShape::Toggle { trigger } => (
            Feature::Toggle,
            RelayFunction::Toggle(edge_mask(site, trigger)?),
        ),
        RungShape::EdgeSetReset { set, reset } => (
            Feature::SwitchOnOff,
            RelayFunction::SwitchOnOff {
                on: edge_mask(site, set)?,
                off: edge_mask(site, reset)?,
            },
        ),
        RungShape::StairPulse { trigger, time } => (
            Feature::Pulse,
            RelayFunction::Pulse {
                inputs: edge_mask(site, trigger)?,
                time: tenths(*time)?,
            },
        ),
        RungShape::Latch { .. } => {
            return Err(Reason::Unsupported {
                why: "the RESI-16DI8RO has no level set/reset: SWITCH ON and SWITCH OFF take \
                      rising edges",
            })
        }
        RungShape::Pulse { .. } => {
            return Err(Reason::Unsupported {
                why: "the RESI-16DI8RO's PULSE is retriggerable (a staircase pulse); a TP \
                      pulse ignores edges while it runs",
            })
        }
        RungShape::Blink { .. } | RungShape::BlinkPattern { .. } | RungShape::Lamp { .. } => {
            return Err(Reason::Unsupported {
                why: "the RESI-16DI8RO has no blinker",
            })
        }
        RungShape::Opaque { reason } => return Err(Reason::Opaque(reason.clone())),
    };
    let row = LogicRow { relay, function };
    let tables: Vec<TableEntry> = row
        .registers(&m16di8ro::MODEL)
        .into_iter()
        .map(|reg| TableEntry {
            register: reg.name,
            value: reg.value,
            mask: reg.inputs.is_some(),
            meaning: match reg.inputs {
                Some(inputs) => inputs.to_string(),
                None => format!("{} s", f64::from(reg.value) / 10.0),
            },
        })
        .collect();
    for t in &tables {
        if site.setting_taken(t.register) {
            return Err(Reason::SettingTaken {
                register: t.register.into(),
            });
        }
    }
    let enable = match &site.settings() {
        ModuleSettings::Resi(s) => s.write_value("ENABLE_LOGIC_FUNCTIONS"),
        _ => None,
    };
    if enable.is_some_and(|v| v != Num::Int(1)) {
        return Err(Reason::SettingTaken {
            register: "ENABLE_LOGIC_FUNCTIONS".into(),
        });
    }
    Ok(ModulePlacement {
        module: site.module(),
        point: site.point(),
        feature,
        tables,
        pushed: Pushed::Resi(row),
        command: None,
        tick: TICK,
        // The planner sets it from the rung's shape (`planner::initial`).
        initial: None,
    })
}

/// The mask bit of a condition tag bound to DIk.
fn input_bit(site: &dyn Site, tag: TagId) -> Result<Inputs, Reason> {
    let spec = site.input(tag, CHECKS)?;
    spec.name
        .strip_prefix("DI")
        .and_then(|n| n.parse::<u8>().ok())
        .filter(|n| (1..=16).contains(n))
        .map(|n| Inputs(1u16 << (n - 1)))
        .ok_or(Reason::NotCheckable {
            tag: site.name(tag),
            point: spec.name,
            checks: CHECKS,
        })
}

/// The mask of a list of rising edges, each of one input.
fn edge_mask(site: &dyn Site, edges: &[BoolExpr]) -> Result<Inputs, Reason> {
    let mut mask = 0;
    for e in edges {
        let BoolExpr::Tag(tag) = e else {
            for t in e.tags() {
                site.input(t, CHECKS)?;
            }
            return Err(Reason::Unsupported {
                why: "the RESI-16DI8RO's edge functions take rising edges of single inputs",
            });
        };
        mask |= input_bit(site, *tag)?.0;
    }
    if mask == 0 {
        return Err(Reason::Unsupported {
            why: "the rung has no input edge to map",
        });
    }
    Ok(Inputs(mask))
}

/// PULSE TIME in tenths of a second.
fn tenths(time: Duration) -> Result<PulseTime, Reason> {
    let bad = Reason::Time {
        time,
        takes: "a multiple of 0.1s from 0.1s (PULSE TIME)",
    };
    let nanos = time.as_nanos();
    if nanos == 0 || nanos % 100_000_000 != 0 {
        return Err(bad);
    }
    u32::try_from(nanos / 100_000_000)
        .ok()
        .and_then(PulseTime::from_tenths)
        .ok_or(bad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pulse_time_in_tenths() {
        let t = |d| tenths(d).map(PulseTime::tenths);
        assert_eq!(t(Duration::from_secs(30)), Ok(300));
        assert_eq!(t(Duration::from_millis(100)), Ok(1));
        assert!(tenths(Duration::from_millis(150)).is_err());
        assert!(tenths(Duration::ZERO).is_err());
    }

    #[test]
    fn names() {
        assert_eq!(Relay::named("RO8").map(Relay::number), Some(8));
        assert_eq!(Relay::named("RO9"), None);
        assert_eq!(Relay::named("ROS"), None);
        assert_eq!(Inputs(0b1001).to_string(), "DI1 DI4");
    }
}
