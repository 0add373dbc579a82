//! The kinds of cycle a line runs, what each costs on the wire and how often it comes, and the
//! overruns that follow at a scan period: what `check` predicts a run to show.
//!
//! A line's cycles are not all alike (DESIGN.md "Timing model"): an ordinary one reads the
//! modules' inputs (each polled module's reads, one idle Collect round for the event-mode
//! members) and writes nothing when no output changed; a cycle that carries a periodic
//! refresh is longer by one whole exchange with its reply delay (a module's rewrite of every
//! output, a member's full read); one that carries an input change is longer by what the
//! Collect round's reply costs. A cycle overruns when its line's work (its read, then its
//! write, in the line's order) ends after the cycle's period, and a line still busy at the
//! next cycle's start delays that one's read too.
//!
//! [`CycleMix::predict`] plays those rules forward in time with the timing model's costs and
//! the bus owner's own choice of refreshes (`line/housekeeping.rs`: from three quarters of a
//! period, one module a cycle per kind), for a line whose inputs stay idle and whose outputs
//! the program leaves as they are: the floor of what a run overruns. Every input change and
//! every output the program changes adds its own cost to the cycle that carries it
//! ([`CycleMix::per_event`], each module's write); `check` prints those beside the prediction.

use std::time::Duration;

use crate::time::LineInstant;

use crate::driver::{Driver, Transaction};
use crate::line::budget::{input_floor_of, members_floor, plan_time, AdapterTiming};
use crate::line::housekeeping::{Pick, Urgency};
use crate::line::settings::LineSettings;
use crate::point::Value;

/// A module as [`CycleMix::of`] takes it: its name, its driver, and what the program drives of
/// its points (`Some` for every output it drives).
pub type DrivenModule = (String, Box<dyn Driver>, Vec<Option<Value>>);

/// One module's share of a line's cycle mix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModuleMix {
    /// The module's name.
    pub name: String,
    /// What a rewrite of every output the program drives costs (`None`: it drives none).
    pub rewrite: Option<Duration>,
    /// As a member of the line's Collect round: its full read.
    pub full_read: Option<FullRead>,
}

/// An event-mode member's full read and when it comes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FullRead {
    /// Its cost on the wire.
    pub cost: Duration,
    /// The longest the module goes without an answered exchange addressed to it
    /// (`event_refresh`).
    pub answer_within: Duration,
    /// The longest it goes without a full read (`event_resync`).
    pub resync: Duration,
    /// It is asked something every cycle besides the round (its status, counters), so it is
    /// never silent that long.
    pub read_each_cycle: bool,
}

/// The kinds of cycle of one line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CycleMix {
    /// An ordinary cycle: each module's own reads and one idle Collect round; nothing
    /// written.
    pub ordinary: Duration,
    /// What each input change reported by the Collect round adds (`None`: no event mode).
    pub per_event: Option<Duration>,
    /// The period of each module's rewrite of every output (`output_refresh`).
    pub output_refresh: Duration,
    /// The silence the line keeps between two exchanges (t3.5). Each cost above counts it
    /// after the reply; the bus owner keeps it before its next request, so an answer is in
    /// that much before its cost ends.
    pub gap: Duration,
    /// Per module.
    pub modules: Vec<ModuleMix>,
}

/// What [`CycleMix::predict`] expects of a run at one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The period.
    pub period: Duration,
    /// Whether an ordinary cycle's read ends within the nine tenths of the period the scan
    /// waits for inputs. When it does not, the line's inputs come in every other cycle at
    /// best (stale between) and about every other cycle overruns.
    pub inputs_in_time: bool,
    /// Cycles that overrun per minute, once the start-up's first cycle is over.
    pub per_minute: f64,
    /// The share of cycles that overrun (0 to 1).
    pub share: f64,
    /// The longest cycle (from its start to the end of its line's work), once the start-up's
    /// first cycle is over.
    pub longest: Duration,
    /// The first cycle: every member read and every module written in full.
    pub first: Duration,
}

/// How long the prediction plays the line forward: long enough for each refresh period to
/// come many times, and a member's resync once.
const HORIZON: Duration = Duration::from_secs(60);

impl CycleMix {
    /// The mix of a line whose modules are `modules`: each a driver and what the program
    /// drives of its points (`Some` for every output it drives, as the scan hands the bus
    /// owner each cycle).
    pub fn of(
        settings: LineSettings,
        adapter: AdapterTiming,
        output_refresh: Duration,
        modules: &mut [DrivenModule],
    ) -> Self {
        let mut plan: Vec<Transaction> = Vec::new();
        let mut members = Vec::new();
        let mut mixes = Vec::with_capacity(modules.len());
        for (name, driver, desired) in modules.iter_mut() {
            let rewrite = if desired.iter().any(Option::is_some) {
                plan.clear();
                driver.plan_write(desired, true, &mut plan);
                Some(plan_time(settings, adapter, driver.as_ref(), &plan))
            } else {
                None
            };
            let full_read = driver.collect_membership().map(|membership| {
                members.push(membership);
                plan.clear();
                driver.plan_read(&mut plan);
                let read_each_cycle = !plan.is_empty();
                plan.clear();
                driver.plan_refresh(&mut plan);
                FullRead {
                    cost: plan_time(settings, adapter, driver.as_ref(), &plan),
                    answer_within: membership.answer_within,
                    resync: membership.resync,
                    read_each_cycle,
                }
            });
            mixes.push(ModuleMix {
                name: name.clone(),
                rewrite,
                full_read,
            });
        }
        let ordinary = input_floor_of(
            settings,
            adapter,
            modules.iter_mut().map(|(_, d, _)| d.as_mut()),
        );
        let per_event = members_floor(settings, adapter, &members).map(|f| f.per_event());
        Self {
            ordinary,
            per_event,
            output_refresh,
            gap: settings.t3_5(),
            modules: mixes,
        }
    }

    /// The overruns of a run at `period` with idle inputs and unchanged outputs, from playing
    /// the line's rules forward for a minute on the scan's grid.
    pub fn predict(&self, period: Duration) -> Prediction {
        Self::predict_together([self], period)
    }

    /// The overruns of a scan driving all of `lines` at `period` (a task's lines, or a
    /// project's without tasks): each line plays its own rules as in [`CycleMix::predict`],
    /// and they meet where the scan joins them. Every line's read starts at the cycle's
    /// start, the program runs once the slowest has delivered (or at the one deadline, nine
    /// tenths of the period), each line's write follows it behind that line's own work, and
    /// the cycle overruns when any line's work ends after the period. So two lines whose
    /// refreshes fall on different cycles overrun on both sets, and a slow line's read delays
    /// a fast line's write.
    pub fn predict_together<'a>(
        lines: impl IntoIterator<Item = &'a CycleMix>,
        period: Duration,
    ) -> Prediction {
        let mut models: Vec<Model<'a>> = lines.into_iter().map(Model::new).collect();
        let period = period.max(Duration::from_micros(100));
        let cycles = (HORIZON.as_nanos() / period.as_nanos()).max(2) as u64;
        let mut overruns = 0u64;
        let mut longest = Duration::ZERO;
        let mut first = Duration::ZERO;
        for k in 0..cycles {
            // The model's lines keep the scan's grid: they are the lines a virtual clock runs.
            let start = LineInstant::after_origin(period * u32::try_from(k).unwrap_or(u32::MAX));
            let end = cycle(&mut models, start, period);
            let took = end - start;
            if k == 0 {
                first = took;
                continue;
            }
            longest = longest.max(took);
            if end > start + period {
                overruns += 1;
            }
        }
        let counted = cycles - 1;
        Prediction {
            period,
            inputs_in_time: models.iter().all(|l| l.mix.ordinary <= period * 9 / 10),
            per_minute: overruns as f64 * 60.0 / (counted as f64 * period.as_secs_f64()),
            share: overruns as f64 / counted as f64,
            longest,
            first,
        }
    }
}

/// One cycle of the scan starting at `start` over `lines`: each line's read (unless its last
/// one still runs), the program once every line delivered or at the deadline, then each
/// line's write behind whatever that line is doing; returns when the last line's work for it
/// ends (`start` with no line).
fn cycle(lines: &mut [Model<'_>], start: LineInstant, period: Duration) -> LineInstant {
    let deadline = start + period * 9 / 10;
    let delivered = lines
        .iter_mut()
        .map(|line| line.deliver(start))
        .max()
        .unwrap_or(start);
    let scan = delivered.min(deadline).max(start);
    lines
        .iter_mut()
        .map(|line| line.write(scan))
        .max()
        .unwrap_or(start)
}

/// A line as [`CycleMix::predict_together`] plays it: when its work ends, and each module's
/// refresh times, as the bus owner keeps them.
///
/// Each exchange's cost counts the line's silence (t3.5) after its reply, but the bus owner
/// keeps that silence before its next request: an answer is in (a read delivered, a write
/// acknowledged) a gap before its cost ends, and the next exchange starts no sooner than a
/// gap after it. At 9600 Bd that is 4 ms, the difference between a read that makes the
/// scan's deadline and one that does not.
struct Model<'a> {
    mix: &'a CycleMix,
    /// The end of the line's last exchange (its answer in).
    last_byte: LineInstant,
    /// The earliest the next exchange starts: the last one's end and the line's silence.
    ready: LineInstant,
    /// The end of the last read started.
    read_end: LineInstant,
    last_full_read: Vec<Option<LineInstant>>,
    last_rewrite: Vec<Option<LineInstant>>,
    last_answered: Vec<Option<LineInstant>>,
}

impl<'a> Model<'a> {
    fn new(mix: &'a CycleMix) -> Self {
        let n = mix.modules.len();
        Self {
            mix,
            last_byte: LineInstant::ZERO,
            ready: LineInstant::ZERO,
            read_end: LineInstant::ZERO,
            last_full_read: vec![None; n],
            last_rewrite: vec![None; n],
            last_answered: vec![None; n],
        }
    }

    /// Exchanges costing `cost` in all, asked for at `at`: they start once the line is free
    /// and its silence kept; returns when the last one's answer is in (with none: `at`, or
    /// the end of the line's last exchange if later, as the owner answers at once).
    fn exchange(&mut self, at: LineInstant, cost: Duration) -> LineInstant {
        if cost.is_zero() {
            return self.last_byte.max(at);
        }
        let begin = at.max(self.ready);
        self.ready = begin + cost;
        self.last_byte = (self.ready - self.mix.gap).max(begin);
        self.last_byte
    }

    /// The cycle starting at `start`'s input from this line: a read (unless the last one
    /// still runs, whose answer is then this cycle's if in time); returns when it delivers.
    fn deliver(&mut self, start: LineInstant) -> LineInstant {
        if self.read_end > start {
            self.read_end
        } else {
            self.read(start)
        }
    }

    /// A read asked for at `at`: the ordinary reads and round, then the members' full reads
    /// the owner picks after the round (line/collect.rs).
    fn read(&mut self, at: LineInstant) -> LineInstant {
        let begin = at.max(self.ready);
        let after = begin + self.mix.ordinary;
        let mut pick = Pick::default();
        for (m, module) in self.mix.modules.iter().enumerate() {
            let Some(full) = module.full_read else {
                continue;
            };
            let Some(last_full) = self.last_full_read[m] else {
                pick.offer(m, Urgency::Due);
                continue;
            };
            let answered = if full.read_each_cycle {
                Some(after)
            } else {
                self.last_answered[m].max(Some(last_full))
            };
            let urgency = Urgency::of(Some(last_full), full.resync, after).max(Urgency::of(
                answered,
                full.answer_within,
                after,
            ));
            pick.offer(m, urgency);
        }
        let mut cost = self.mix.ordinary;
        let mut chosen = Vec::new();
        for m in pick.chosen().collect::<Vec<_>>() {
            if let Some(full) = self.mix.modules[m].full_read {
                cost += full.cost;
                self.last_full_read[m] = Some(after);
                chosen.push(m);
            }
        }
        let end = self.exchange(begin, cost);
        for m in chosen {
            self.last_answered[m] = Some(end);
        }
        self.read_end = end;
        end
    }

    /// A write asked for at `at` (the program's end): nothing changed, so only the rewrites
    /// the owner picks once the line has answered its read (bus.rs `output_refreshes`);
    /// returns when the write is acknowledged, the cycle's work done on this line.
    fn write(&mut self, at: LineInstant) -> LineInstant {
        let at = at.max(self.last_byte);
        let mut pick = Pick::default();
        for (m, module) in self.mix.modules.iter().enumerate() {
            if module.rewrite.is_some() {
                pick.offer(
                    m,
                    Urgency::of(self.last_rewrite[m], self.mix.output_refresh, at),
                );
            }
        }
        let mut cost = Duration::ZERO;
        let mut chosen = Vec::new();
        for m in pick.chosen().collect::<Vec<_>>() {
            if let Some(rewrite) = self.mix.modules[m].rewrite {
                cost += rewrite;
                self.last_rewrite[m] = Some(at);
                chosen.push(m);
            }
        }
        let end = self.exchange(at, cost);
        for m in chosen {
            self.last_answered[m] = Some(end);
        }
        end.max(at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// Two members at the quick start's costs: a 13.59 ms idle round, a 20.60 ms full read,
    /// a 21.17 ms rewrite, each module driving an output.
    fn quick_start() -> CycleMix {
        let module = |name: &str| ModuleMix {
            name: name.into(),
            rewrite: Some(Duration::from_micros(21_170)),
            full_read: Some(FullRead {
                cost: Duration::from_micros(20_600),
                answer_within: ms(1000),
                resync: ms(30_000),
                read_each_cycle: false,
            }),
        };
        CycleMix {
            ordinary: Duration::from_micros(13_590),
            per_event: Some(Duration::from_micros(8_740)),
            output_refresh: ms(1000),
            gap: Duration::from_micros(2_005),
            modules: vec![module("mm1"), module("mm2")],
        }
    }

    #[test]
    fn a_period_that_holds_every_refresh_never_overruns() {
        let p = quick_start().predict(ms(100));
        assert_eq!(p.per_minute, 0.0, "{p:?}");
        assert!(p.inputs_in_time);
        // The first cycle reads and writes every module in full; its last write is
        // acknowledged before the line's silence after it.
        assert_eq!(
            p.first,
            Duration::from_micros(13_590 + 2 * 20_600 + 2 * 21_170 - 2_005)
        );
    }

    #[test]
    fn at_20_ms_each_rewrite_costs_its_cycle_and_the_next() {
        // A rewrite cycle (34.76 ms) ends after its period, and the next cycle's read starts
        // behind it (48.35 ms > 40 ms): two overruns per rewrite, two modules, each every
        // 760 ms (the first grid point from three quarters of a second).
        let p = quick_start().predict(ms(20));
        let per_minute_expected = 2.0 * 2.0 * 60.0 / 0.76;
        assert!(
            (p.per_minute - per_minute_expected).abs() < 0.05 * per_minute_expected,
            "{p:?} against {per_minute_expected}"
        );
        assert!(p.longest >= Duration::from_micros(34_760), "{p:?}");
    }

    #[test]
    fn an_ordinary_read_longer_than_the_wait_for_inputs_overruns_every_other_cycle() {
        // 13.59 ms of reads against a 10 ms period: a cycle that starts a read ends after its
        // period; the next starts none (the read still runs), takes its answer and ends in
        // time.
        let p = quick_start().predict(ms(10));
        assert!(!p.inputs_in_time);
        assert!(p.share > 0.5 && p.share < 0.6, "{p:?}");
    }

    #[test]
    fn a_slow_line_beside_holds_back_the_other_lines_writes() {
        // A line of plain reads taking 20 ms never overruns at 34 ms alone. Beside the quick
        // start's line the program runs once the slow read is in (18 ms, not 11.59 ms), so
        // every rewrite on the quick start's line is acknowledged 6.4 ms later: rewrites that
        // fitted their cycle alone (from 13.59 ms, acknowledged at 32.76 ms) now run past it
        // (37.16 ms). The scan overruns more often than either line alone says.
        let slow = CycleMix {
            ordinary: ms(20),
            per_event: None,
            output_refresh: ms(1000),
            gap: Duration::from_micros(2_005),
            modules: Vec::new(),
        };
        let quick = quick_start();
        let alone = quick.predict(ms(34));
        assert_eq!(slow.predict(ms(34)).per_minute, 0.0);
        let both = CycleMix::predict_together([&quick, &slow], ms(34));
        assert!(
            both.per_minute > alone.per_minute + 50.0,
            "{both:?} against {alone:?}"
        );
        // The line played alone is the line played with nothing beside it.
        assert_eq!(CycleMix::predict_together([&quick], ms(34)), alone);
    }
}
