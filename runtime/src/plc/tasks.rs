//! A project of several tasks built into one PLC per task, sharing an exchange and a world.
//!
//! Each task's PLC is built from its view of the project (`Project::task_view`): its
//! period, its program, its buses and their modules. The programs are compiled together
//! first, so a tag with two writing tasks stops the build as it stops `check`. Each task
//! starts its cycles once its own lines have started: a slow line's start-up never keeps a
//! fast line's modules waiting for their first command (their watchdogs are derived from
//! their own line's start-up). On the real clock the tasks are built side by side, each on
//! its scan thread ([`TaskBuilder::build`]); on virtual clocks each task keeps time on a clock
//! of its own, so a slow line's wire time never moves a fast task's clock, and the
//! scheduler (`scan::tasks`) runs their cycles in order.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use softplc_io::sim::SharedWorld;
use softplc_io::time::ScanInstant;
use softplc_io::wire::WireTap;

use crate::clock::{Clock, VirtualClock};
use crate::image::{ProcessImage, TagId};
use crate::logic::{load, Ownership};
use crate::project::Project;

use super::build::{attach_plant, build_world};
use super::exchange::{Exchange, TaskLink};
use super::task_reload::{TaskOwners, TaskReload};
use super::{BuildError, Plc};

/// One task's PLC.
#[derive(Debug)]
pub struct TaskPlc {
    /// The task's name.
    pub name: String,
    /// Its PLC, on its clock.
    pub plc: Plc,
}

/// A task's programs as its PLC runs them ([`TaskBuilder::planned`]).
#[derive(Debug)]
pub struct TaskPlan {
    /// The task's view of the project.
    pub view: Project,
    /// Its push-down plan.
    pub plan: crate::offload::Plan,
    /// Per program, its block instances as the running engine numbers them.
    pub instance_counts: Vec<u32>,
}

/// What the tasks of one project share while each is built: the ownership of the tags,
/// the exchange, the world of the simulated lines.
pub struct TaskBuilder {
    project: Project,
    ownership: Ownership,
    /// The owners and names again, for each task's reloads.
    owners: Arc<TaskOwners>,
    exchange: Arc<Exchange>,
    /// The real clock the tasks share; `None`: a virtual clock per task.
    clock: Option<Arc<dyn Clock>>,
    tap: Option<Arc<dyn WireTap>>,
    /// The one world of every task's simulated lines, when they share one.
    world: Option<SharedWorld>,
    /// The tasks whose modules the plant is wired to.
    plant_tasks: Vec<usize>,
    /// Tasks built so far: the last one attaches the plant.
    built: AtomicUsize,
}

impl std::fmt::Debug for TaskBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TaskBuilder")
            .field("project", &self.project.name)
            .field("tasks", &self.project.tasks.len())
            .finish_non_exhaustive()
    }
}

impl TaskBuilder {
    /// Compiles every task's program and finds the tags' owners (two writers of a tag are
    /// refused here); `clock`: the real clock, or `None` for a virtual clock per task.
    pub fn new(
        project: &Project,
        clock: Option<Arc<dyn Clock>>,
        tap: Option<Arc<dyn WireTap>>,
    ) -> Result<Self, BuildError> {
        let image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
        let (_, ownership) = load::load_tasks(project, &image).map_err(BuildError::Program)?;
        let mut plant_tasks: Vec<usize> = project.plant.as_ref().map_or_else(Vec::new, |p| {
            p.wiring
                .iter()
                .map(|(_, m, _)| project.task_of_bus(project.modules[*m].bus))
                .collect()
        });
        plant_tasks.sort_unstable();
        plant_tasks.dedup();
        // On the real clock one world holds every task's lines; the lines keep real time.
        // On virtual clocks each task's lines are a world of their own, so a slow line's
        // virtual time (its world runs ahead to it) never holds a fast task's modules back,
        // unless a plant joins modules of several tasks: they then share one world, and the
        // plant sees the lines' times as the cycles run (docs/programming.md, "Tasks").
        let shared = clock.is_some() || plant_tasks.len() > 1;
        let world = if shared { build_world(project) } else { None };
        let owners = Arc::new(TaskOwners {
            ownership: ownership.clone(),
            names: project.tasks.iter().map(|t| t.name.clone()).collect(),
            tag_names: project.tags.iter().map(|t| t.name.clone()).collect(),
        });
        Ok(Self {
            project: project.clone(),
            owners,
            exchange: Exchange::new(&image, clock.is_none()),
            ownership,
            clock,
            tap,
            world,
            plant_tasks,
            built: AtomicUsize::new(0),
        })
    }

    /// The tasks' names, in project order.
    pub fn names(&self) -> Vec<String> {
        self.project.tasks.iter().map(|t| t.name.clone()).collect()
    }

    /// Task `i`'s real-time options.
    pub fn realtime(&self, i: usize) -> crate::project::RealtimeConfig {
        self.project
            .tasks
            .get(i)
            .map(|t| t.scan.realtime)
            .unwrap_or_default()
    }

    /// The owner of every tag.
    pub fn ownership(&self) -> &Ownership {
        &self.ownership
    }

    /// Task `i`'s view of the project (its period, programs, buses and modules).
    fn view(&self, i: usize) -> Project {
        (self.project).task_view(i, |t| self.ownership.owner(TagId(t as u32)) == Some(i))
    }

    /// Task `i`'s programs as its PLC will run them, without starting a line: its view of
    /// the project, its push-down plan and its programs' block instance counts (what the
    /// web page draws, before the slowest line has started).
    pub fn planned(&self, i: usize) -> Result<TaskPlan, BuildError> {
        let view = self.view(i);
        let image = ProcessImage::new(view.tags.iter().map(|t| (t.name.clone(), t.initial)));
        let logic = load::load_program(&view, &image).map_err(BuildError::Program)?;
        let plan = crate::offload::plan_program(&view, logic.as_ref());
        Ok(TaskPlan {
            instance_counts: logic.instance_counts(),
            plan,
            view,
        })
    }

    /// Builds task `i`'s PLC: its lines and modules started, its owned tags published for
    /// the others' first cycles. Each task may be built on a thread of its own.
    pub fn build(&self, i: usize) -> Result<TaskPlc, BuildError> {
        let project = &self.project;
        let task = &project.tasks[i];
        let view = self.view(i);
        let mut lines = task.buses.clone();
        lines.sort_unstable();
        let clock: Arc<dyn Clock> = match &self.clock {
            Some(c) => c.clone(),
            None => Arc::new(VirtualClock::new()),
        };
        let (world, lines) = match &self.world {
            Some(w) => (Some(w.clone()), Some(lines.as_slice())),
            None => (build_world(&view), None),
        };
        let reload = TaskReload::new(i, self.owners.clone(), &view);
        let mut plc = Plc::build_lines_in(view, clock, world, self.tap.clone(), lines)?;
        let link = TaskLink {
            exchange: self.exchange.clone(),
            owned: self.ownership.owned_by(i),
            foreign: self.ownership.foreign_to(i),
            reload,
        };
        // What this task holds at start-up (retained values, initial values) is what the
        // others' first cycles see.
        link.exchange
            .publish(&link.owned, &plc.image, ScanInstant::ZERO);
        plc.task = Some(link);
        // The plant starts once the lines it is wired to have started: with the last task
        // built of those sharing its world.
        let done = self.built.fetch_add(1, Ordering::AcqRel) + 1;
        let plant_world = match &self.world {
            Some(w) if done == project.tasks.len() => Some(w.clone()),
            None if self.plant_tasks.first() == Some(&i) => plc.world.clone(),
            _ => None,
        };
        if let Some(world) = plant_world {
            attach_plant(project, &world, plc.clock.now());
        }
        Ok(TaskPlc {
            name: task.name.clone(),
            plc,
        })
    }
}

impl Plc {
    /// One PLC per task of `project`, linked by one exchange, built one after the other
    /// (each task's lines from its own clock's start on virtual clocks). `clock` is the real
    /// clock the tasks share, or `None` for a virtual clock per task. A project with one task
    /// gives one PLC, unlinked, as [`Plc::build_traced`] does.
    pub fn build_tasks(
        project: &Project,
        clock: Option<Arc<dyn Clock>>,
        tap: Option<Arc<dyn WireTap>>,
    ) -> Result<Vec<TaskPlc>, BuildError> {
        if !project.multitask() {
            let clock = clock.unwrap_or_else(|| Arc::new(VirtualClock::new()));
            let plc = Plc::build_traced(project.clone(), clock, None, tap)?;
            let name = project
                .tasks
                .first()
                .map_or_else(String::new, |t| t.name.clone());
            return Ok(vec![TaskPlc { name, plc }]);
        }
        let builder = TaskBuilder::new(project, clock, tap)?;
        (0..project.tasks.len()).map(|i| builder.build(i)).collect()
    }
}
