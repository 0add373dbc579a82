//! MiniMod blinkers: which blinkers its YLAMP registers play, and the mask that makes them.
//!
//! Manual, "Automatic continuous blinking": "Minimod can also continuously flash an output,
//! using a 16 bit rotating mask which indicates the on- and off- state with speed of about a
//! tenth of a second ... Every output has its own mask, named from Y1LAMP to Y4LAMP";
//! "Power outputs, blinkers, pulsers, and feedbacks": "a bitmask different from 0 imposes a
//! flashing to the output and disables the normal usage", and the pulsers "have higher
//! priority than the blinkers". The manual says neither when a pattern starts nor which bit
//! comes first; the module's step is common to its four outputs and runs freely from its
//! power-on, bit k shown during step k (`state.rs`, the simulator: step = (ms / 100) mod 16).
//!
//! So a blinker is played exactly when its period is a whole number of 100 ms steps dividing
//! 16 (1, 2, 4, 8 or 16 steps: 400/400 ms, 800/800 ms, 200/200 ms, a 1.6 s pattern), and only
//! with a free phase: the mask written when the enable rises shows the bit of the module's
//! current step, not the pattern's first. A LAMP block means exactly that (its central engine
//! steps from the PLC's start); a BLINK means "on when enabled", so it goes down only where
//! the engineer frees its phase (`blink_phase: free` on the tag).
//!
//! The manual is silent on what the status of a blinking output reads ("Y1..Y4: Shows the
//! status of the indicated output"), and the simulator keeps the commanded bit there, so the
//! scan cannot read the lamp back: the output's tag shows the enable.

use std::time::Duration;

use super::Output;
use crate::push_down::{Command, Feature, ModulePlacement, Pushed, Reason, Site};
use crate::rung::BoolExpr;

/// One blinker step ("with speed of about a tenth of a second").
pub(crate) const STEP: Duration = Duration::from_millis(100);
/// Steps in a mask ("a 16 bit rotating mask").
const STEPS: u32 = 16;
/// The periods, in steps, a 16-step mask repeats exactly.
const PERIODS: [u32; 5] = [1, 2, 4, 8, 16];

/// `d` in whole steps, if it is one.
fn steps(d: Duration) -> Option<u32> {
    let step = STEP.as_nanos();
    (d.as_nanos() % step == 0)
        .then(|| u32::try_from(d.as_nanos() / step).ok())
        .flatten()
}

/// The mask whose bit k is `bit(k)`.
fn mask_of(bit: impl Fn(u32) -> bool) -> u16 {
    (0..STEPS)
        .filter(|&k| bit(k))
        .fold(0u16, |acc, k| acc | (1 << k))
}

/// The mask of a BLINK of `on` then `off`, or why the module cannot play it (with the on/off
/// times nearby that it can). A zero period (both zero) is on, as the central BLINK is.
pub(crate) fn on_off_mask(on: Duration, off: Duration) -> Result<u16, Reason> {
    let timing = |why| Reason::BlinkTiming {
        blink: format!("{}ms on, {}ms off", on.as_millis(), off.as_millis()),
        why,
        nearby: nearby(on, off),
    };
    let (Some(a), Some(b)) = (steps(on), steps(off)) else {
        return Err(timing(
            "the module's steps are 100ms, and each time must be a whole number of them",
        ));
    };
    match a + b {
        0 => Ok(u16::MAX),
        n if STEPS % n == 0 => Ok(mask_of(|k| k % n < a)),
        _ => Err(timing(
            "its period is not 1, 2, 4, 8 or 16 steps of 100ms, the periods the module's \
             16-step mask repeats",
        )),
    }
}

/// The mask of a BLINK playing `pattern`, one bit per `step`, or why the module cannot.
pub(crate) fn pattern_mask(pattern: &[bool], step: Duration) -> Result<u16, Reason> {
    let bits: String = pattern.iter().map(|&b| if b { '1' } else { '0' }).collect();
    let timing = |why| Reason::BlinkTiming {
        blink: format!("pattern {bits} at {}ms a bit", step.as_millis()),
        why,
        nearby: Vec::new(),
    };
    let Some(m) = steps(step).filter(|&m| m > 0) else {
        return Err(timing(
            "the module's steps are 100ms, and a bit must last a whole number of them",
        ));
    };
    let len = u32::try_from(pattern.len()).unwrap_or(u32::MAX);
    match len.checked_mul(m) {
        Some(n) if n > 0 && STEPS % n == 0 => Ok(mask_of(|k| {
            let i = (k / m) % len;
            pattern.get(i as usize).copied().unwrap_or(false)
        })),
        _ => Err(timing(
            "the pattern's length times its step is not 1, 2, 4, 8 or 16 steps of 100ms, the \
             periods the module's 16-step mask repeats",
        )),
    }
}

/// The on/off times of the periods the module repeats next to `on` + `off` (the longest not
/// above it and the shortest not below it), with about the same share on.
fn nearby(on: Duration, off: Duration) -> Vec<(Duration, Duration)> {
    let period = (on + off).as_secs_f64() / STEP.as_secs_f64();
    if period <= 0.0 {
        return Vec::new();
    }
    let total = (on + off).as_nanos();
    let usable = PERIODS.iter().copied().filter(|&n| n >= 2);
    let below = usable.clone().filter(|&n| f64::from(n) <= period).max();
    let above = usable.filter(|&n| f64::from(n) >= period).min();
    let mut out: Vec<(Duration, Duration)> = Vec::new();
    for n in [below, above].into_iter().flatten() {
        // Both parts at least one step: a blinker, not a constant.
        // on × n / total, rounded half up, in whole nanoseconds (no float error at halves).
        let share = (2 * on.as_nanos() * u128::from(n) + total) / (2 * total);
        let a = u32::try_from(share).unwrap_or(n).clamp(1, n - 1);
        let pair = (STEP * a, STEP * (n - a));
        if !out.contains(&pair) {
            out.push(pair);
        }
    }
    out
}

/// How long after its mask is written a blinker shows its first on-step, at most: the mask's
/// longest run of off-steps (around the end of the 16, since the mask repeats) plus one step,
/// since the write may land anywhere in the module's free-running steps. `None` for the mask
/// 0, which never shows one.
pub fn first_on_within(mask: u16) -> Option<Duration> {
    if mask == 0 {
        return None;
    }
    let off = |k: u32| mask & (1 << (k % STEPS)) == 0;
    let longest = (0..STEPS)
        .map(|start| (0..STEPS).take_while(|&j| off(start + j)).count())
        .max()
        .unwrap_or(0);
    Some(STEP * (u32::try_from(longest).unwrap_or(STEPS) + 1))
}

/// YLAMPn = `mask` while `enable`, 0 otherwise, written by the scan on each change of the
/// enable.
pub(crate) fn lamp(
    site: &dyn Site,
    y: Output,
    enable: &BoolExpr,
    mask: u16,
) -> Result<ModulePlacement, Reason> {
    let register = format!("YLAMP{}", y.number());
    if site.setting_taken(&register) {
        return Err(Reason::SettingTaken { register });
    }
    super::placement::evaluated_after_logic(site, std::slice::from_ref(enable))?;
    let point = site
        .model()
        .point_index(&register)
        .ok_or(Reason::Unsupported {
            why: "the model has no blinker register",
        })?;
    Ok(ModulePlacement {
        module: site.module(),
        point: site.point(),
        feature: Feature::Lamp,
        tables: Vec::new(),
        pushed: Pushed::Nothing,
        command: Some(Command::Lamp {
            point,
            enable: enable.clone(),
            mask,
        }),
        tick: STEP,
        // The planner sets it from the rung's shape (`planner::initial`).
        initial: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn periods_dividing_16_steps_become_masks() {
        // 400/400 ms: 4 on, 4 off, repeated (the manual's "1010..." is 100/100 ms).
        assert_eq!(on_off_mask(ms(400), ms(400)), Ok(0x0F0F));
        assert_eq!(on_off_mask(ms(100), ms(100)), Ok(0x5555));
        // The manual's slow flashing, 255: 800 ms on, 800 ms off.
        assert_eq!(on_off_mask(ms(800), ms(800)), Ok(0x00FF));
        assert_eq!(on_off_mask(ms(200), ms(600)), Ok(0x0303));
        assert_eq!(on_off_mask(ms(0), ms(0)), Ok(0xFFFF));
        assert_eq!(on_off_mask(ms(0), ms(400)), Ok(0));
    }

    #[test]
    fn other_periods_stay_central_with_the_nearby_ones() {
        let Err(reason) = on_off_mask(ms(500), ms(500)) else {
            panic!("10 steps do not divide 16");
        };
        assert_eq!(
            reason.to_string(),
            "a blinker the module cannot play: 500ms on, 500ms off: its period is not 1, 2, 4, \
             8 or 16 steps of 100ms, the periods the module's 16-step mask repeats; \
             400ms/400ms or 800ms/800ms would go down"
        );
        let Err(Reason::BlinkTiming { nearby, .. }) = on_off_mask(ms(150), ms(250)) else {
            panic!("150 ms is no whole step");
        };
        assert_eq!(nearby, vec![(ms(200), ms(200))]);
        let Err(Reason::BlinkTiming { nearby, .. }) = on_off_mask(ms(1000), ms(2000)) else {
            panic!("30 steps");
        };
        assert_eq!(nearby, vec![(ms(500), ms(1100))]);
    }

    #[test]
    fn the_first_on_step_comes_within_the_longest_off_run_and_a_step() {
        assert_eq!(first_on_within(0x0F0F), Some(ms(500)));
        assert_eq!(first_on_within(0x00FF), Some(ms(900)));
        // The manual's "couple of short flashes": off from bit 3 round to bit 15, 13 steps.
        assert_eq!(first_on_within(0x0005), Some(ms(1400)));
        assert_eq!(first_on_within(0x8001), Some(ms(1500)));
        assert_eq!(first_on_within(0xFFFF), Some(ms(100)));
        assert_eq!(first_on_within(0), None);
    }

    #[test]
    fn patterns_repeat_over_16_steps() {
        let p = |s: &str| s.chars().map(|c| c == '1').collect::<Vec<_>>();
        // "0000000000000101 (5 in decimal) does continuously a couple of short flashes".
        assert_eq!(
            pattern_mask(&p("1010000000000000"), ms(100)),
            Ok(0b0000_0000_0000_0101)
        );
        assert_eq!(pattern_mask(&p("1101"), ms(200)), Ok(0xCFCF));
        assert!(matches!(
            pattern_mask(&p("110"), ms(100)),
            Err(Reason::BlinkTiming { .. })
        ));
        assert!(matches!(
            pattern_mask(&p("10"), ms(150)),
            Err(Reason::BlinkTiming { .. })
        ));
    }
}
