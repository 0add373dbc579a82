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

use super::ir::{BoolExpr, RungShape};
use super::planner::{Feature, ModulePlacement, Reason, Site, TableEntry};
use crate::project::ModuleConfig;

/// The model's catalog name.
pub const MODEL: &str = "resi-16di8ro";
/// The module's input sample (10.1.1: inputs are sampled every 10 ms).
pub const TICK: Duration = Duration::from_millis(10);
/// What its logic checks.
const CHECKS: &str = "only DI1..DI16";
/// The mask registers of a relay, in the module's order.
const FUNCTIONS: [&str; 5] = ["SWITCH", "TOGGLE", "SWITCH_ON", "SWITCH_OFF", "PULSE"];

/// Maps a rung writing a RESI-16DI8RO relay, or says why it stays central.
pub(crate) fn map(shape: &RungShape, site: &Site) -> Result<ModulePlacement, Reason> {
    let relay = relay_number(site.coil_point().name).ok_or(Reason::Unsupported {
        why: "the RESI-16DI8RO's logic drives its relays RO1..RO8 only",
    })?;
    let mut masks = [0u16; 5];
    let mut pulse_time = None;
    let feature = match shape {
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
            masks[0] = input_bit(site, *tag)?;
            Feature::Switch
        }
        RungShape::Toggle { trigger } => {
            masks[1] = edge_mask(site, trigger)?;
            Feature::Toggle
        }
        RungShape::EdgeSetReset { set, reset } => {
            masks[2] = edge_mask(site, set)?;
            masks[3] = edge_mask(site, reset)?;
            Feature::SwitchOnOff
        }
        RungShape::StairPulse { trigger, time } => {
            masks[4] = edge_mask(site, trigger)?;
            pulse_time = Some(tenths(*time)?);
            Feature::Pulse
        }
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
        RungShape::Blink { .. } => {
            return Err(Reason::Unsupported {
                why: "the RESI-16DI8RO has no blinker",
            })
        }
        RungShape::Opaque { reason } => return Err(Reason::Opaque(reason.clone())),
    };
    let mut tables = Vec::with_capacity(6);
    for (f, mask) in FUNCTIONS.iter().zip(masks) {
        tables.push(TableEntry {
            register: format!("{f}_RO{relay}"),
            value: u32::from(mask),
            mask: true,
            meaning: if mask == 0 {
                "unused".into()
            } else {
                inputs_text(mask)
            },
        });
    }
    if let Some(t) = pulse_time {
        tables.push(TableEntry {
            register: format!("PULSE_TIME_RO{relay}"),
            value: t,
            mask: false,
            meaning: format!("{} s", f64::from(t) / 10.0),
        });
    }
    for t in &tables {
        if site.setting_taken(&t.register) {
            return Err(Reason::SettingTaken {
                register: t.register.clone(),
            });
        }
    }
    let enable = site
        .config()
        .device
        .settings
        .iter()
        .find(|(k, _)| k.trim().eq_ignore_ascii_case("ENABLE_LOGIC_FUNCTIONS"));
    if enable.is_some_and(|(_, v)| v.trim() != "1") {
        return Err(Reason::SettingTaken {
            register: "ENABLE_LOGIC_FUNCTIONS".into(),
        });
    }
    Ok(ModulePlacement {
        module: site.module,
        point: site.point,
        feature,
        tables,
        command: None,
        tick: TICK,
        // The planner sets it from the rung's shape (`planner::initial`).
        initial: None,
    })
}

/// `RO3` → 3.
fn relay_number(name: &str) -> Option<u8> {
    name.strip_prefix("RO")
        .and_then(|n| n.parse::<u8>().ok())
        .filter(|n| (1..=8).contains(n))
}

/// The mask bit of a condition tag bound to DIk.
fn input_bit(site: &Site, tag: crate::image::TagId) -> Result<u16, Reason> {
    let spec = site.input(tag, CHECKS)?;
    spec.name
        .strip_prefix("DI")
        .and_then(|n| n.parse::<u8>().ok())
        .filter(|n| (1..=16).contains(n))
        .map(|n| 1u16 << (n - 1))
        .ok_or(Reason::NotCheckable {
            tag: site.name(tag),
            point: spec.name,
            checks: CHECKS,
        })
}

/// The mask of a list of rising edges, each of one input.
fn edge_mask(site: &Site, edges: &[BoolExpr]) -> Result<u16, Reason> {
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
        mask |= input_bit(site, *tag)?;
    }
    if mask == 0 {
        return Err(Reason::Unsupported {
            why: "the rung has no input edge to map",
        });
    }
    Ok(mask)
}

/// PULSE TIME in tenths of a second.
fn tenths(time: Duration) -> Result<u32, Reason> {
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
        .filter(|&t| t <= i32::MAX as u32)
        .ok_or(bad)
}

/// `DI1 DI4` for a mask.
fn inputs_text(mask: u16) -> String {
    (0..16)
        .filter(|i| mask & (1 << i) != 0)
        .map(|i| format!("DI{}", i + 1))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Settings a RESI-16DI8RO with pushed-down rungs needs besides the tables: ENABLE LOGIC
/// FUNCTIONS = 1, and its relays in the poll list (read back every cycle).
pub(crate) fn module_settings(
    module: &ModuleConfig,
    placements: &[&ModulePlacement],
) -> Vec<(String, String)> {
    let mut out = Vec::new();
    if placements.is_empty() {
        return out;
    }
    let setting = |key: &str| {
        module
            .device
            .settings
            .iter()
            .find(|(k, _)| k.trim().eq_ignore_ascii_case(key))
            .map(|(_, v)| v.clone())
    };
    if setting("ENABLE_LOGIC_FUNCTIONS").is_none() {
        out.push(("ENABLE_LOGIC_FUNCTIONS".into(), "1".into()));
    }
    // The default poll list reads every relay; a project's own list gets the relays added.
    if let Some(poll) = setting("poll") {
        let listed = |name: &str| {
            poll.split(',').any(|p| {
                let p = p.trim().to_ascii_uppercase();
                p == name || p == "RO*"
            })
        };
        let missing: Vec<&str> = placements
            .iter()
            .filter_map(|p| module.model.points.get(p.point).map(|s| s.name))
            .filter(|n| !listed(n))
            .collect();
        if !missing.is_empty() {
            out.push(("poll".into(), format!("{poll}, {}", missing.join(", "))));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pulse_time_in_tenths() {
        assert_eq!(tenths(Duration::from_secs(30)), Ok(300));
        assert_eq!(tenths(Duration::from_millis(100)), Ok(1));
        assert!(tenths(Duration::from_millis(150)).is_err());
        assert!(tenths(Duration::ZERO).is_err());
    }

    #[test]
    fn names() {
        assert_eq!(relay_number("RO8"), Some(8));
        assert_eq!(relay_number("RO9"), None);
        assert_eq!(relay_number("ROS"), None);
        assert_eq!(inputs_text(0b1001), "DI1 DI4");
    }
}
