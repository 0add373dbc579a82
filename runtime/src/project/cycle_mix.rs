//! A project's lines as `check`'s cycle mix sees them (`softplc_io::line::CycleMix`): each
//! module's driver with the outputs the program drives on it.

use softplc_io::line::{AdapterTiming, CycleMix};
use softplc_io::point::Access;

use super::{Binding, Project};

impl Project {
    /// The cycle mix of bus `bus` (an index into [`Project::buses`]) on an adapter with
    /// `adapter`'s timing: its modules' drivers, each with every output or read/write point a
    /// tag is bound to, as the scan hands them to the bus owner.
    pub fn cycle_mix(&self, bus: usize, adapter: AdapterTiming) -> CycleMix {
        let mut modules = Vec::new();
        for (m, module) in self
            .modules
            .iter()
            .enumerate()
            .filter(|(_, m)| m.bus == bus)
        {
            let desired = module
                .model
                .points
                .iter()
                .enumerate()
                .map(|(p, point)| {
                    let driven = point.access != Access::Input
                        && self.tags.iter().any(|t| {
                            t.binding
                                == Binding::Point {
                                    module: m,
                                    point: p,
                                }
                        });
                    driven.then(|| point.ty.zero())
                })
                .collect();
            modules.push((
                module.name.clone(),
                (module.model.driver)(&module.device),
                desired,
            ));
        }
        let line = &self.buses[bus];
        CycleMix::of(line.settings, adapter, line.output_refresh, &mut modules)
    }
}
