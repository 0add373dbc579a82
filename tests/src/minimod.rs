//! The real MiniMod driver, built the way a project builds it, and its points by name.

use softplc_io::devices::{self, ModelSpec, Protocol};
use softplc_io::driver::Driver;
use softplc_io::point::Value;

/// The MiniMod model of the catalog.
pub fn model() -> &'static ModelSpec {
    devices::model("minimod").expect("minimod is in the catalog")
}

/// A MiniMod driver at `address` with default settings, through the catalog's constructor.
pub fn driver(name: &str, address: u8) -> Box<dyn Driver> {
    let config = model()
        .device_config(name, address, Protocol::Modbus, &[])
        .expect("a MiniMod address");
    (model().driver)(&config)
}

/// Index of a point by the manual's name.
pub fn point(name: &str) -> usize {
    model()
        .point_index(name)
        .unwrap_or_else(|| panic!("minimod has no point {name}"))
}

/// An output frame for one MiniMod: the named outputs driven, everything else `None`.
pub fn desired(outputs: &[(&str, bool)]) -> Vec<Option<Value>> {
    let mut v = vec![None; model().points.len()];
    for (name, on) in outputs {
        v[point(name)] = Some(Value::Bool(*on));
    }
    v
}
