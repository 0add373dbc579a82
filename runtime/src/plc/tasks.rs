//! A project of several tasks built into one PLC per task, sharing an exchange and a world.
//!
//! Each task's PLC is built from its view of the project (`Project::task_view`): its
//! period, its program, its buses and their modules. The programs are compiled together
//! first, so a tag with two writing tasks stops the build as it stops `check`. The
//! simulated world holds every task's lines (a task's bus is the world's line of the same
//! bus in the project) and the plant, attached once every line has started. On a virtual
//! clock each task keeps time on a clock of its own, so a slow line's wire time never moves
//! a fast task's clock; the scheduler (`scan::tasks`) runs their cycles in order.

use std::sync::Arc;

use softplc_io::sim::SharedWorld;
use softplc_io::time::ScanInstant;
use softplc_io::wire::WireTap;

use crate::clock::{Clock, VirtualClock};
use crate::image::{ProcessImage, TagId};
use crate::logic::load;
use crate::project::Project;

use super::build::{attach_plant, build_world};
use super::exchange::{Exchange, TaskLink};
use super::{BuildError, Plc};

/// One task's PLC.
#[derive(Debug)]
pub struct TaskPlc {
    /// The task's name.
    pub name: String,
    /// Its PLC, on its clock.
    pub plc: Plc,
}

impl Plc {
    /// One PLC per task of `project`, linked by one exchange. `clock` is the real clock the
    /// tasks share, or `None` for a virtual clock per task. A project with one task gives one
    /// PLC, unlinked, as [`Plc::build_traced`] does.
    pub fn build_tasks(
        project: &Project,
        clock: Option<Arc<dyn Clock>>,
        tap: Option<Arc<dyn WireTap>>,
    ) -> Result<Vec<TaskPlc>, BuildError> {
        let clock_of = || -> Arc<dyn Clock> {
            match &clock {
                Some(c) => c.clone(),
                None => Arc::new(VirtualClock::new()),
            }
        };
        if !project.multitask() {
            let plc = Plc::build_traced(project.clone(), clock_of(), None, tap)?;
            let name = project
                .tasks
                .first()
                .map_or_else(String::new, |t| t.name.clone());
            return Ok(vec![TaskPlc { name, plc }]);
        }
        let image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
        // Compiled together first: two writers of a tag stop the build, as they stop `check`.
        let (_, ownership) = load::load_tasks(project, &image).map_err(BuildError::Program)?;
        // On the real clock one world holds every task's lines; the lines keep real time.
        // On virtual clocks each task's lines are a world of their own, so a slow line's
        // virtual time (its world runs ahead to it) never holds a fast task's modules back,
        // unless a plant joins modules of several tasks: they then share one world, and the
        // plant sees the lines' times as the cycles run (docs/programming.md, "Tasks").
        let plant_tasks: Vec<usize> = project.plant.as_ref().map_or_else(Vec::new, |p| {
            let mut t: Vec<usize> = p
                .wiring
                .iter()
                .map(|(_, m, _)| project.task_of_bus(project.modules[*m].bus))
                .collect();
            t.sort_unstable();
            t.dedup();
            t
        });
        let own_worlds = clock.is_none() && plant_tasks.len() <= 1;
        let world: Option<SharedWorld> = if own_worlds {
            None
        } else {
            build_world(project)
        };
        let exchange = Exchange::new(&image, clock.is_none());
        let build = |i: usize| -> Result<TaskPlc, BuildError> {
            let task = &project.tasks[i];
            let view = project.task_view(i, |t| ownership.owner(TagId(t as u32)) == Some(i));
            let mut lines = task.buses.clone();
            lines.sort_unstable();
            let (world, lines) = match &world {
                Some(w) => (Some(w.clone()), Some(lines.as_slice())),
                None => (build_world(&view), None),
            };
            let mut plc = Plc::build_lines_in(view, clock_of(), world, tap.clone(), lines)?;
            plc.task = Some(TaskLink {
                exchange: exchange.clone(),
                owned: ownership.owned_by(i),
                foreign: ownership.foreign_to(i),
            });
            Ok(TaskPlc {
                name: task.name.clone(),
                plc,
            })
        };
        // The tasks' lines start up at once, as they run: on the real clock each task's on a
        // thread of its own (a slow line's start-up must not keep a fast line's modules
        // waiting for their first command past their watchdog); on virtual clocks each from
        // its own clock's zero.
        let results: Vec<Result<TaskPlc, BuildError>> = if clock.is_some() {
            std::thread::scope(|scope| {
                let handles: Vec<_> = (0..project.tasks.len())
                    .map(|i| scope.spawn(move || build(i)))
                    .collect();
                handles
                    .into_iter()
                    .map(|h| {
                        h.join().unwrap_or_else(|_| {
                            Err(BuildError::Thread {
                                bus: String::new(),
                                source: std::io::Error::other("a task's start-up panicked"),
                            })
                        })
                    })
                    .collect()
            })
        } else {
            (0..project.tasks.len()).map(build).collect()
        };
        let built = results.into_iter().collect::<Result<Vec<_>, _>>()?;
        // On virtual clocks each task's first cycle comes once its own lines have started, a
        // fast line's never held back by a slow line's start-up (its modules' watchdogs are
        // derived from their own line's). On the real clock the builds ran side by side and
        // every task starts now, once the slowest line has started.
        let start = built
            .iter()
            .map(|t| t.plc.clock.now())
            .min()
            .unwrap_or(ScanInstant::ZERO);
        // Every task starts from what its owners hold at start-up (retained values, the
        // initial values of memory tags), visible to every first cycle.
        for t in &built {
            if let Some(link) = &t.plc.task {
                link.exchange
                    .publish(&link.owned, &t.plc.image, ScanInstant::ZERO);
            }
        }
        // The plant starts with the first cycles, in the world holding its modules.
        let plant_world = match (&world, plant_tasks.first()) {
            (Some(w), _) => Some(w.clone()),
            (None, Some(&t)) => built.get(t).and_then(|t| t.plc.world.clone()),
            (None, None) => None,
        };
        if let Some(world) = &plant_world {
            attach_plant(project, world, start);
        }
        Ok(built)
    }
}
