//! MiniMod: which rungs its own logic runs, and the registers that make it do so.
//!
//! Manual, "Automatic output management": every millisecond, for each output, if one of its
//! three OFF conditions holds the output turns off, else if one of its three ON conditions
//! holds it turns on, else it keeps its state. A condition is a product of the cooked inputs
//! X1..X3, each checked high or low (the mask's low byte selects inputs, its high byte inverts
//! them). The scan sees the same cooked inputs (discrete inputs 0..2), so both run the same
//! function of the same signal, the module within a millisecond of the change.
//!
//! A rung whose central step is, for each combination `x` of X1..X3, one of "on", "off" or
//! "keep" is run exactly when OFF = {x : off} and ON ⊇ {x : on}, ON ∩ {x : keep} = ∅ (ON may
//! cover "off" combinations, where OFF wins):
//! - `y = f(x)`: on where f, off elsewhere;
//! - a latch, reset dominant: off where R, else on where S, else keep;
//! - a latch, set dominant: on where S, else off where R, else keep.
//!
//! Both sets are minimised exactly (`push_down::minimize`); each must fit in three conditions.
//!
//! Manual, "Pulse generation": writing N to YPULSEn turns Yn on for exactly N ms (1..=65000).
//! A TP rung keeps its trigger central: on the trigger's edge the scan writes YPULSEn instead
//! of the output, so the pulse width is the module's, to the millisecond, instead of a whole
//! number of scans.
//!
//! Manual, "Automatic continuous blinking": a LAMP block (and a BLINK whose phase the engineer
//! freed) keeps its enable central: the scan writes the mask to YLAMPn when the enable rises
//! and 0 when it falls, and the module plays it on its own steps (see `lamp`).

use std::time::Duration;

use super::{lamp, AutoOutput, Condition, Output, PulseWidth, CONDITIONS, MAX_PULSE_MS};
use crate::devices::Protocol;
use crate::push_down::minimize::{minimize, Cube};
use crate::push_down::{Command, Feature, ModulePlacement, Pushed, Reason, Site, TableEntry};
use crate::rung::{BoolExpr, RungShape, TagId};

/// The module's sampling tick ("Input conditioning": inputs are sampled once a millisecond).
const TICK: Duration = Duration::from_millis(1);
/// What the module's conditions can check.
const CHECKS: &str = "only X1..X3";

/// What a rung does to its output for one combination of X1..X3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Action {
    On,
    Off,
    Keep,
}

/// Maps a rung writing a MiniMod output, or says why it stays central.
pub(super) fn map(shape: &RungShape, site: &dyn Site) -> Result<ModulePlacement, Reason> {
    let y = Output::named(site.coil_point().name).ok_or(Reason::Unsupported {
        why: "the MiniMod's logic drives its outputs Y1..Y4 only",
    })?;
    match shape {
        RungShape::Combinational { expr } => {
            let bits = bits_of(site, &[expr])?;
            let table = actions(|m| {
                if expr.eval(&mut |t| value(&bits, t, m)) {
                    Action::On
                } else {
                    Action::Off
                }
            });
            auto_on_off(site, y, &table)
        }
        RungShape::Latch {
            set,
            reset,
            reset_dominant,
        } => {
            let bits = bits_of(site, &[set, reset])?;
            let table = actions(|m| {
                let s = set.eval(&mut |t| value(&bits, t, m));
                let r = reset.eval(&mut |t| value(&bits, t, m));
                match (s, r, reset_dominant) {
                    (_, true, true) | (false, true, false) => Action::Off,
                    (true, _, _) => Action::On,
                    (false, false, _) => Action::Keep,
                }
            });
            auto_on_off(site, y, &table)
        }
        RungShape::Pulse { trigger, width } => pulse(site, y, trigger, *width),
        RungShape::StairPulse { .. } => Err(Reason::Unsupported {
            why: "the MiniMod's pulser cannot be retriggered by an input (no staircase pulse)",
        }),
        RungShape::Toggle { .. } | RungShape::EdgeSetReset { .. } => Err(Reason::Unsupported {
            why: "the MiniMod's conditions are levels: it has no edge-triggered functions",
        }),
        RungShape::Lamp { enable, mask } => lamp::lamp(site, y, enable, *mask),
        RungShape::Blink { enable, on, off } => {
            let mask = lamp::on_off_mask(*on, *off)?;
            phase_freed(site, mask)?;
            lamp::lamp(site, y, enable, mask)
        }
        RungShape::BlinkPattern {
            enable,
            pattern,
            step,
        } => {
            let mask = lamp::pattern_mask(pattern, *step)?;
            phase_freed(site, mask)?;
            lamp::lamp(site, y, enable, mask)
        }
        RungShape::Opaque { reason } => Err(Reason::Opaque(reason.clone())),
    }
}

/// A BLINK starts on when its enable rises; the module's blinker steps run freely, so it goes
/// down only where the engineer said its phase is free (see `lamp`).
fn phase_freed(site: &dyn Site, mask: u16) -> Result<(), Reason> {
    if site.blink_phase_free() {
        Ok(())
    } else {
        Err(Reason::BlinkPhase { mask })
    }
}

/// Conditions the scan evaluates after the logic (a pulse's trigger, a blinker's enable) must
/// not read a coil written by this rung or a later one: the scan would see this cycle's value
/// where the central rung saw the previous one.
pub(super) fn evaluated_after_logic(site: &dyn Site, exprs: &[BoolExpr]) -> Result<(), Reason> {
    for e in exprs {
        if let Some(tag) = e.tags().into_iter().find(|t| site.later().contains(t)) {
            return Err(Reason::TriggerReadsLater {
                tag: site.name(tag),
            });
        }
    }
    Ok(())
}

/// Each condition tag and its input bit (X1 = 0), or why a tag cannot be checked.
fn bits_of(site: &dyn Site, exprs: &[&BoolExpr]) -> Result<Vec<(TagId, u8)>, Reason> {
    let mut out = Vec::new();
    for e in exprs {
        for tag in e.tags() {
            let spec = site.input(tag, CHECKS)?;
            let bit = match spec.name {
                "X1" => 0,
                "X2" => 1,
                "X3" => 2,
                point => {
                    return Err(Reason::NotCheckable {
                        tag: site.name(tag),
                        point,
                        checks: CHECKS,
                    })
                }
            };
            out.push((tag, bit));
        }
    }
    Ok(out)
}

/// A tag's value in combination `m` (bit i = X(i+1)).
fn value(bits: &[(TagId, u8)], tag: TagId, m: u8) -> bool {
    bits.iter()
        .find(|(t, _)| *t == tag)
        .is_some_and(|(_, b)| m & (1 << b) != 0)
}

fn actions(mut f: impl FnMut(u8) -> Action) -> [Action; 8] {
    let mut out = [Action::Keep; 8];
    for (m, slot) in (0u8..).zip(out.iter_mut()) {
        *slot = f(m);
    }
    out
}

/// The condition of a product term ("Automatic output management": low byte = inputs
/// checked, high byte = inputs inverted before the check).
fn condition(cube: Cube) -> Condition {
    Condition::product(cube.care, cube.value)
}

/// The masks of a minimal cover. A mask with no input checked is never true, so the constant
/// true (the empty product) is written as one literal that covers `on` within `allowed`, or as
/// `X1` and `-X1`.
fn masks(cover: &[Cube], on: u8, allowed: u8) -> Vec<Condition> {
    if cover != [Cube { care: 0, value: 0 }] {
        return cover.iter().map(|&c| condition(c)).collect();
    }
    for bit in 0..3u8 {
        for value in [1u8 << bit, 0] {
            let c = Cube {
                care: 1 << bit,
                value,
            };
            let covered = c.minterms(3);
            if covered & on == on && covered & !allowed == 0 {
                return vec![condition(c)];
            }
        }
    }
    vec![
        condition(Cube { care: 1, value: 1 }),
        condition(Cube { care: 1, value: 0 }),
    ]
}

/// AON/AOFF tables for an action table.
fn auto_on_off(site: &dyn Site, y: Output, table: &[Action; 8]) -> Result<ModulePlacement, Reason> {
    if site.protocol() == Protocol::Text {
        return Err(Reason::NotVerifiable {
            why: "on protocol text the MiniMod's driver cannot read the conditions back (the \
                  text read table has no YnAONm), so the tables could not be verified; use \
                  protocol modbus",
        });
    }
    let set = |a: Action| {
        (0u8..8)
            .filter(|&m| table[usize::from(m)] == a)
            .fold(0u8, |acc, m| acc | (1 << m))
    };
    let (on, off) = (set(Action::On), set(Action::Off));
    // Minimising three variables cannot fail.
    let on_cover = minimize(on, off, 3).unwrap_or_default();
    let off_cover = minimize(off, 0, 3).unwrap_or_default();
    let on_masks = masks(&on_cover, on, on | off);
    let off_masks = masks(&off_cover, off, off);
    if on_masks.len() > CONDITIONS || off_masks.len() > CONDITIONS {
        return Err(Reason::TooManyTerms {
            on: on_masks.len(),
            off: off_masks.len(),
        });
    }
    let pick = |list: &[Condition]| {
        let mut out = [Condition::UNUSED; CONDITIONS];
        for (slot, c) in out.iter_mut().zip(list) {
            *slot = *c;
        }
        out
    };
    let auto = AutoOutput {
        output: y,
        on: pick(&on_masks),
        off: pick(&off_masks),
    };
    let mut tables = Vec::with_capacity(2 * CONDITIONS);
    for (register, c) in auto.registers() {
        if site.setting_taken(register) {
            return Err(Reason::SettingTaken {
                register: register.into(),
            });
        }
        tables.push(TableEntry {
            register,
            value: u32::from(c.mask()),
            mask: true,
            meaning: c.to_string(),
        });
    }
    Ok(ModulePlacement {
        module: site.module(),
        point: site.point(),
        feature: Feature::AutoOnOff,
        tables,
        pushed: Pushed::MiniMod(auto),
        command: None,
        tick: TICK,
        // The planner sets it from the rung's shape (`planner::initial`).
        initial: None,
    })
}

/// YPULSEn on the trigger's edge.
fn pulse(
    site: &dyn Site,
    y: Output,
    trigger: &[BoolExpr],
    width: Duration,
) -> Result<ModulePlacement, Reason> {
    let takes = "whole milliseconds from 1ms to 65000ms (YPULSE)";
    let ms = (width.subsec_nanos() % 1_000_000 == 0)
        .then(|| u16::try_from(width.as_millis()).ok())
        .flatten()
        .filter(|ms| *ms <= MAX_PULSE_MS)
        .and_then(PulseWidth::from_ms)
        .ok_or(Reason::Time { time: width, takes })?;
    evaluated_after_logic(site, trigger)?;
    let point = site
        .model()
        .point_index(&format!("YPULSE{}", y.number()))
        .ok_or(Reason::Unsupported {
            why: "the model has no pulser register",
        })?;
    Ok(ModulePlacement {
        module: site.module(),
        point: site.point(),
        feature: Feature::Pulser,
        tables: Vec::new(),
        pushed: Pushed::Nothing,
        command: Some(Command::Pulse {
            point,
            trigger: trigger.to_vec(),
            width,
            width_ms: ms,
        }),
        tick: TICK,
        // The planner sets it from the rung's shape (`planner::initial`).
        initial: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::minimod::parse_condition;

    #[test]
    fn masks_match_the_manual() {
        // "X1=1, X2=0 ... can be expressed with the binary mask 0000.0010-0000.0011".
        let c = Cube {
            care: 0b011,
            value: 0b001,
        };
        assert_eq!(condition(c).mask(), 0x0203);
        assert_eq!(condition(c).to_string(), "X1-X2");
        assert_eq!(parse_condition(&condition(c).to_string()), Ok(0x0203));
        for m in 0..8u8 {
            assert_eq!(condition(c).holds(m), c.covers(m), "{m}");
        }
    }

    #[test]
    fn constant_true_needs_a_checked_input() {
        let mask_of = |list: Vec<Condition>| list.iter().map(|c| c.mask()).collect::<Vec<_>>();
        let always = masks(&[Cube { care: 0, value: 0 }], 0xFF, 0xFF);
        assert_eq!(mask_of(always.clone()), vec![0x0001, 0x0101]);
        for m in 0..8u8 {
            assert!(always.iter().any(|k| k.holds(m)));
        }
        // ON = "not X2" with X2 a don't-care: one literal does.
        let on = 0b0011_0011;
        assert_eq!(
            mask_of(masks(&[Cube { care: 0, value: 0 }], on, 0xFF)),
            vec![0x0202]
        );
    }
}
