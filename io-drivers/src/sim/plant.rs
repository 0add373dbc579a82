//! Plant models: the machine around the simulated modules, so inputs answer outputs.
//!
//! A plant is wired to module points by role (`motor: mm1.Y1`). It runs on the simulated
//! world's 1 ms tick, reads the outputs it is wired to and drives the inputs, so a newcomer's
//! project behaves like a machine with no hardware at all.

use std::fmt::Debug;
use std::time::Duration;

use crate::time::LineInstant;

use crate::point::Value;

/// A role a plant exposes for wiring.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlantRole {
    /// The role's name in the project file's `plant.wiring`.
    pub name: &'static str,
    /// True: the plant drives this point (it must be a module input). False: the plant reads it
    /// (a module output).
    pub drives_input: bool,
    /// What it is, for docs and `check`.
    pub doc: &'static str,
}

/// A plant model in the catalog.
#[derive(Debug)]
pub struct PlantSpec {
    /// The name in project files (`conveyor`).
    pub name: &'static str,
    /// One-line description.
    pub summary: &'static str,
    /// Every role; all must be wired.
    pub roles: &'static [PlantRole],
    /// Builds the model.
    pub build: fn() -> Box<dyn Plant>,
}

/// The plant's view of its wiring: values by role index (the order of [`PlantSpec::roles`]).
pub trait PlantIo {
    /// Reads the point wired to role `role`.
    fn read(&self, role: usize) -> bool;
    /// Drives the point wired to role `role`.
    fn write(&mut self, role: usize, value: bool);
}

/// A running plant model.
pub trait Plant: Send + Debug {
    /// One 1 ms step ending at time `t` (the simulated world's, a line's time).
    fn step(&mut self, t: LineInstant, io: &mut dyn PlantIo);
}

/// Every plant model.
pub fn catalog() -> &'static [&'static PlantSpec] {
    static CATALOG: [&PlantSpec; 1] = [&CONVEYOR];
    &CATALOG
}

/// A plant model by name.
pub fn spec(name: &str) -> Option<&'static PlantSpec> {
    catalog().iter().copied().find(|p| p.name == name)
}

/// Converts a point value to the plant's boolean view.
pub fn as_level(v: Value) -> bool {
    v.as_bool()
}

/// A belt conveyor with an operator.
pub static CONVEYOR: PlantSpec = PlantSpec {
    name: "conveyor",
    summary: "a 1 m belt at 0.5 m/s, an entry and an exit sensor, and an operator who loads a \
              box, presses start, and takes the box away at the exit",
    roles: &[
        PlantRole {
            name: "motor",
            drives_input: false,
            doc: "belt motor (module output)",
        },
        PlantRole {
            name: "start_button",
            drives_input: true,
            doc: "operator's start button",
        },
        PlantRole {
            name: "sensor_entry",
            drives_input: true,
            doc: "box at the loading end",
        },
        PlantRole {
            name: "sensor_exit",
            drives_input: true,
            doc: "box at the unloading end",
        },
    ],
    build: || Box::new(Conveyor::default()),
};

const MOTOR: usize = 0;
const START: usize = 1;
const ENTRY: usize = 2;
const EXIT: usize = 3;

/// Belt length and sensor windows, in millimetres; speed in mm per ms.
const BELT_MM: u32 = 1000;
const SENSOR_MM: u32 = 100;
const MM_PER_MS: u32 = 1; // 1 m/s would be 1; 0.5 m/s is one mm every second tick
const MS_PER_MM: u32 = 2;
/// The operator's habits.
const LOAD_AFTER: Duration = Duration::from_millis(1000);
const PRESS_AFTER: Duration = Duration::from_millis(300);
const PRESS_FOR: Duration = Duration::from_millis(200);
const UNLOAD_AFTER: Duration = Duration::from_millis(1500);

/// The conveyor's state: one box at most, its position on the belt.
#[derive(Debug, Default)]
pub struct Conveyor {
    /// Box position in mm from the loading end, if a box is on the belt.
    box_mm: Option<u32>,
    /// Time of the operator's next move.
    next_action: LineInstant,
    /// Millisecond ticks the motor has run since the box last moved a millimetre.
    motor_ticks: u32,
    /// When the start button is held down until.
    press_until: Option<LineInstant>,
    /// When the box reached the end stop.
    arrived_at: Option<LineInstant>,
}

impl Plant for Conveyor {
    fn step(&mut self, t: LineInstant, io: &mut dyn PlantIo) {
        match self.box_mm {
            None if t >= self.next_action => {
                self.box_mm = Some(0);
                self.next_action = t + PRESS_AFTER;
            }
            Some(0) if self.press_until.is_none() && t >= self.next_action && !io.read(MOTOR) => {
                self.press_until = Some(t + PRESS_FOR);
            }
            _ => {}
        }
        if let Some(until) = self.press_until {
            if t >= until {
                self.press_until = None;
                self.next_action = t + PRESS_AFTER * 10;
            }
        }
        if let Some(pos) = self.box_mm {
            if io.read(MOTOR) && pos < BELT_MM {
                self.motor_ticks += MM_PER_MS;
                if self.motor_ticks >= MS_PER_MM {
                    self.motor_ticks = 0;
                    self.box_mm = Some(pos + 1);
                }
            }
            if self.box_mm >= Some(BELT_MM - SENSOR_MM) && self.arrived_at.is_none() {
                self.arrived_at = Some(t);
            }
            if let Some(at) = self.arrived_at {
                if t >= at + UNLOAD_AFTER {
                    self.box_mm = None;
                    self.arrived_at = None;
                    self.next_action = t + LOAD_AFTER;
                }
            }
        }
        let pos = self.box_mm;
        io.write(START, self.press_until.is_some());
        io.write(ENTRY, pos.is_some_and(|p| p < SENSOR_MM));
        io.write(EXIT, pos.is_some_and(|p| p >= BELT_MM - SENSOR_MM));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Wires([bool; 4]);
    impl PlantIo for Wires {
        fn read(&self, role: usize) -> bool {
            self.0[role]
        }
        fn write(&mut self, role: usize, value: bool) {
            self.0[role] = value;
        }
    }

    /// With the motor following the start button (latched) and stopping at the exit, a box
    /// travels the belt in 2 s and is taken away.
    #[test]
    fn conveyor_moves_a_box_while_the_motor_runs() {
        let mut plant = (CONVEYOR.build)();
        let mut io = Wires([false; 4]);
        let mut saw_exit = false;
        for ms in 1..=6000u64 {
            plant.step(
                LineInstant::after_origin(Duration::from_millis(ms)),
                &mut io,
            );
            if io.0[START] {
                io.0[MOTOR] = true;
            }
            if io.0[EXIT] {
                io.0[MOTOR] = false;
                saw_exit = true;
            }
        }
        assert!(saw_exit);
    }
}
