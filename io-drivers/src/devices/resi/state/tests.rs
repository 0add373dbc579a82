use super::*;
use crate::devices::resi::item::Func;
use crate::devices::resi::models::{m16di8ro, m1ro, m2ri, m32di, m8co};
use crate::devices::resi::options::PulseAtBoot;

fn item(kind: Kind, index: u8) -> Item {
    Item::new(kind, index)
}

fn int(m: &Module, kind: Kind, index: u8) -> i64 {
    m.read(item(kind, index)).unwrap().int()
}

fn set(m: &mut Module, kind: Kind, index: u8, v: i64) {
    m.write(item(kind, index), Num::Int(v)).unwrap();
}

#[test]
fn inputs_are_seen_at_the_next_10_ms_sample() {
    let mut m = Module::new(&m16di8ro::MODEL, 1);
    m.advance_to(3);
    m.set_terminal(4, true);
    m.advance_to(9);
    assert_eq!(int(&m, Kind::Di, 4), 0);
    m.advance_to(10);
    assert_eq!(int(&m, Kind::Di, 4), 1);
    assert_eq!(int(&m, Kind::Dis, 0), 0x10);
    assert_eq!(int(&m, Kind::Rise, 4), 1);
    m.set_terminal(4, false);
    m.advance_to(20);
    assert_eq!(int(&m, Kind::Fall, 4), 1);
    // A pulse shorter than the sampling period between two samples is not seen.
    m.advance_to(21);
    m.set_terminal(4, true);
    m.set_terminal(4, false);
    m.advance_to(40);
    assert_eq!(int(&m, Kind::Rise, 4), 1);
}

#[test]
fn idle_hours_cost_nothing_and_long_pulses_end_on_time() {
    let mut m = Module::new(&m16di8ro::MODEL, 1);
    set(&mut m, Kind::Mask(Func::Pulse), 0, 1);
    set(&mut m, Kind::PulseTime, 0, 36_000 * 24 * 365); // a year, in 1/10 s
    set(&mut m, Kind::EnableLogic, 0, 1);
    m.set_terminal(0, true);
    let start = std::time::Instant::now();
    m.advance_to(10);
    assert_eq!(int(&m, Kind::Ro, 0), 1);
    let year_ms = 3_600_000 * 24 * 365;
    m.advance_to(10 + year_ms - 10);
    assert_eq!(int(&m, Kind::Ro, 0), 1);
    assert_eq!(int(&m, Kind::PulseTimer, 0), 1);
    m.advance_to(10 + year_ms);
    assert_eq!(int(&m, Kind::Ro, 0), 0);
    m.advance_to(u64::MAX / 2);
    assert!(start.elapsed() < std::time::Duration::from_secs(1));
}

#[test]
fn power_cycle_keeps_fram_and_clears_edge_counters() {
    let mut m = Module::new(&m16di8ro::MODEL, 1);
    set(&mut m, Kind::Mask(Func::Toggle), 3, 3);
    set(&mut m, Kind::PulseTime, 2, 300);
    set(&mut m, Kind::EnableLogic, 0, 1);
    set(&mut m, Kind::Ro, 5, 1);
    m.set_terminal(0, true);
    m.advance_to(10);
    assert_eq!(int(&m, Kind::Ro, 3), 1, "toggled");
    assert_eq!(int(&m, Kind::Rise, 0), 1);
    m.power_cycle();
    assert_eq!(
        int(&m, Kind::Rise, 0),
        0,
        "edge counters 0 after power-on (L20312)"
    );
    assert_eq!(int(&m, Kind::Ro, 3), 1, "bistable relay kept");
    assert_eq!(int(&m, Kind::Ro, 5), 1);
    assert_eq!(int(&m, Kind::RoCounter, 3), 1);
    assert_eq!(int(&m, Kind::RoCounter, 5), 1);
    assert_eq!(int(&m, Kind::Mask(Func::Toggle), 3), 3);
    assert_eq!(int(&m, Kind::PulseTime, 2), 300);
    assert_eq!(int(&m, Kind::EnableLogic, 0), 1);
    // DI1 still high at boot: not a rising edge.
    m.advance_to(100);
    assert_eq!(int(&m, Kind::Rise, 0), 0);
    assert_eq!(int(&m, Kind::Ro, 3), 1);
    // Counters survive CLEAR ALL as well; the logic does not.
    set(&mut m, Kind::ClearLogic, 0, 0);
    assert_eq!(int(&m, Kind::EnableLogic, 0), 0);
    assert_eq!(int(&m, Kind::PulseTime, 2), 0);
    assert_eq!(int(&m, Kind::RoCounter, 3), 1);
}

#[test]
fn a_pulse_across_a_power_loss() {
    for (rule, after) in [(PulseAtBoot::Keep, 1), (PulseAtBoot::Off, 0)] {
        let mut m = Module::new(&m16di8ro::MODEL, 1);
        m.opts.pulse_at_boot = rule;
        set(&mut m, Kind::Mask(Func::Pulse), 0, 1);
        set(&mut m, Kind::PulseTime, 0, 300);
        set(&mut m, Kind::EnableLogic, 0, 1);
        m.set_terminal(0, true);
        m.advance_to(10);
        assert_eq!(int(&m, Kind::PulseTimer, 0), 300);
        m.power_cycle();
        assert_eq!(int(&m, Kind::PulseTimer, 0), 0);
        assert_eq!(int(&m, Kind::Ro, 0), after, "{rule:?}");
        m.advance_to(60_000);
        assert_eq!(int(&m, Kind::Ro, 0), after);
    }
}

#[test]
fn host_writes_and_counters() {
    let mut m = Module::new(&m16di8ro::MODEL, 1);
    set(&mut m, Kind::Ros, 0, 0x00FF);
    assert_eq!(int(&m, Kind::Ros, 0), 0xFF);
    set(&mut m, Kind::Ros, 0, 0x00FF);
    set(&mut m, Kind::Ro, 0, 0);
    assert_eq!(int(&m, Kind::RoCounter, 0), 2);
    assert_eq!(int(&m, Kind::RoCounter, 1), 1);
    assert_eq!(
        m.write(item(Kind::Dis, 0), Num::Int(1)),
        Err(AccessError::ReadOnly)
    );
    assert_eq!(
        m.write(item(Kind::Ro, 8), Num::Int(1)),
        Err(AccessError::Absent)
    );
    assert_eq!(
        m.write(item(Kind::Mask(Func::Switch), 0), Num::Int(70_000)),
        Err(AccessError::OutOfRange)
    );
    m.set_terminal(2, true);
    m.advance_to(10);
    set(&mut m, Kind::ResetCounter, 0, 0);
    assert_eq!(int(&m, Kind::Rise, 2), 1, "a write of 0 does not reset");
    set(&mut m, Kind::ResetCounter, 0, 1);
    assert_eq!(int(&m, Kind::Rise, 2), 0);
    assert_eq!(int(&m, Kind::ResetCounter, 0), 0, "reads 0 (L20285)");
}

#[test]
fn thirty_two_inputs_in_two_words() {
    let mut m = Module::new(&m32di::MODEL, 1);
    m.set_terminal(0, true);
    m.set_terminal(16, true);
    m.set_terminal(31, true);
    m.advance_to(10);
    assert_eq!(int(&m, Kind::DisWord, 0), 1);
    assert_eq!(int(&m, Kind::DisWord, 1), 0x8001);
    assert_eq!(int(&m, Kind::Dis, 0), 0x8001_0001);
    assert_eq!(int(&m, Kind::Rise, 31), 1);
}

#[test]
fn two_inputs_and_their_logic() {
    let mut m = Module::new(&m2ri::MODEL, 1);
    m.set_terminal(1, true);
    m.advance_to(10);
    assert_eq!(
        [
            Kind::NegDi,
            Kind::OrDis,
            Kind::XorDis,
            Kind::AndDis,
            Kind::NegDis
        ]
        .map(|k| int(&m, k, 0)),
        [1, 1, 1, 0, 1]
    );
    m.set_terminal(0, true);
    m.advance_to(20);
    assert_eq!(
        [Kind::OrDis, Kind::XorDis, Kind::AndDis, Kind::NegDis].map(|k| int(&m, k, 0)),
        [1, 0, 1, 0]
    );
}

#[test]
fn eight_co_pulses_in_100_ms_units() {
    let mut m = Module::new(&m8co::MODEL, 1);
    set(&mut m, Kind::RelayPulse, 2, 15);
    assert_eq!(int(&m, Kind::Ro, 2), 1);
    m.advance_to(1000);
    assert_eq!(int(&m, Kind::RelayPulseLeft, 2), 500);
    assert_eq!(int(&m, Kind::RelayPulse, 2), 5);
    m.advance_to(1500);
    assert_eq!(int(&m, Kind::Ro, 2), 0);
    set(&mut m, Kind::RelayPulse, 2, 100);
    set(&mut m, Kind::Ro, 2, 1);
    m.advance_to(20_000);
    assert_eq!(
        int(&m, Kind::Ro, 2),
        1,
        "a host write took over from the pulse"
    );
    set(&mut m, Kind::RelayPulse, 1, 100);
    set(&mut m, Kind::RelayPulse, 1, 0);
    assert_eq!(int(&m, Kind::Ro, 1), 0, "0 ends the pulse");
    m.power_cycle();
    assert_eq!(int(&m, Kind::Ros, 0), 0, "monostable relays drop");
}

#[test]
fn one_ro_off_delay_is_the_watchdog() {
    let mut m = Module::new(&m1ro::MODEL, 1);
    set(&mut m, Kind::OffDelay, 0, 5000);
    assert_eq!((int(&m, Kind::Do, 0), int(&m, Kind::TrueDo, 0)), (0, 1));
    assert_eq!(int(&m, Kind::Dos, 0), 0b10);
    m.advance_to(4999);
    set(&mut m, Kind::OffDelay, 0, 5000);
    m.advance_to(9998);
    assert_eq!(int(&m, Kind::TrueDo, 0), 1);
    assert_eq!(int(&m, Kind::OffDelay, 0), 1);
    m.advance_to(9999);
    assert_eq!(
        (int(&m, Kind::TrueDo, 0), int(&m, Kind::OffDelayOn, 0)),
        (0, 0),
        "no command within 5 s: off (L4109)"
    );
    set(&mut m, Kind::Do, 0, 7);
    assert_eq!(int(&m, Kind::TrueDo, 0), 1, "!=0 is ON (L4092)");
    assert_eq!(int(&m, Kind::NegDos, 0), 0);
}

#[test]
fn address_and_reset() {
    let mut m = Module::new(&m16di8ro::MODEL, 20);
    set(&mut m, Kind::SmbAdr, 0, 21);
    assert_eq!(m.address(), 21);
    assert_eq!(int(&m, Kind::BusAddress, 0), 21);
    assert_eq!(
        m.write(item(Kind::SmbAdr, 0), Num::Int(256)),
        Err(AccessError::OutOfRange)
    );
    m.set_dip(0b1010_0011);
    assert_eq!(m.address(), 3);
    assert_eq!(int(&m, Kind::Dip, 0), 1);
    assert_eq!(int(&m, Kind::Dip, 7), 1);
    assert_eq!(int(&m, Kind::DipWord, 0), 0xA3);
}

#[test]
fn the_end_of_time_neither_hangs_nor_overflows() {
    let mut m = Module::new(&m16di8ro::MODEL, 1);
    set(&mut m, Kind::Mask(Func::Pulse), 0, 1);
    set(&mut m, Kind::PulseTime, 0, u32::MAX.into());
    set(&mut m, Kind::EnableLogic, 0, 1);
    m.advance_to(u64::MAX - 5);
    m.set_terminal(0, true);
    m.advance_to(u64::MAX);
    m.set_terminal(0, false);
    m.advance_to(u64::MAX);
    assert!(m.read(item(Kind::PulseTimer, 0)).is_ok());
    let mut co = Module::new(&m8co::MODEL, 1);
    co.advance_to(u64::MAX);
    set(&mut co, Kind::RelayPulse, 0, 0xFFFF);
    assert_eq!(int(&co, Kind::Ro, 0), 1);
    let mut ro = Module::new(&m1ro::MODEL, 1);
    ro.advance_to(u64::MAX);
    set(&mut ro, Kind::OffDelay, 0, 0xFFFF);
}
