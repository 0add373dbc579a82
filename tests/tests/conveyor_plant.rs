//! The quick start's plant (the conveyor and its operator, a Rhai model built in) with a
//! controller of any speed: the operator takes every box away at the exit, however soon the
//! belt stops.

use std::time::Duration;

use softplc_io::point::ValueType;
use softplc_io::sim::plant::{Plant, PlantIo};
use softplc_io::time::LineInstant;

/// The plant's wires, by role: motor, start_button, sensor_entry, sensor_exit.
#[derive(Debug, Default)]
struct Wires([bool; 4]);

const MOTOR: usize = 0;
const START: usize = 1;
const EXIT: usize = 3;

impl PlantIo for Wires {
    fn read(&self, role: usize) -> bool {
        self.0[role]
    }

    fn write(&mut self, role: usize, value: bool) {
        self.0[role] = value;
    }
}

/// Runs the plant for `seconds` with the quick start's program reacting `reaction` after each
/// change it sees (start press latches the motor, the exit sensor stops it); returns how many
/// boxes were taken away from the exit.
fn boxes_delivered(reaction: Duration, seconds: u64) -> usize {
    let conveyor = softplc::plant::builtin("conveyor").expect("the conveyor plant");
    assert_eq!(
        conveyor
            .terminals()
            .map(|(name, _)| name)
            .collect::<Vec<_>>(),
        ["motor", "start_button", "sensor_entry", "sensor_exit"]
    );
    let mut plant = conveyor.instantiate(vec![ValueType::Bool; 3], 0);
    let mut io = Wires::default();
    let (mut was_start, mut was_exit) = (false, false);
    let mut pending: Option<(LineInstant, bool)> = None;
    let mut delivered = 0;
    for ms in 1..=seconds * 1000 {
        let t = LineInstant::after_origin(Duration::from_millis(ms));
        plant.step(t, &mut io);
        let (start, exit) = (io.0[START], io.0[EXIT]);
        if start && !was_start {
            pending = Some((t + reaction, true));
        }
        if exit && !was_exit {
            pending = Some((t + reaction, false));
        }
        if !exit && was_exit {
            delivered += 1;
        }
        (was_start, was_exit) = (start, exit);
        if let Some((at, on)) = pending {
            if t >= at {
                io.0[MOTOR] = on;
                pending = None;
            }
        }
    }
    delivered
}

#[test]
fn every_box_is_taken_away_however_fast_the_belt_stops() {
    // A box needs about 4.8 s per round (load, press, 1.8 s travel, 1.5 s wait): at least 5
    // in 30 s, whatever the controller's reaction time.
    for reaction_ms in [1, 5, 20, 50, 120, 200] {
        let n = boxes_delivered(Duration::from_millis(reaction_ms), 30);
        assert!(
            n >= 5,
            "with a {reaction_ms} ms reaction only {n} boxes were taken away: the box stopped \
             before the point the operator waits for"
        );
    }
}
