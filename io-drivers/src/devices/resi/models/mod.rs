//! One table per model. Each file holds the model's register map, its own ASCII commands, its
//! points and its hardware, and ends with `catalog_entry!` (defined in `resi/mod.rs`), which
//! makes its catalog entry `SPEC` from them.

pub(crate) mod m14ri;
pub mod m16di8ro;
pub(crate) mod m1led;
pub(crate) mod m1ro;
pub(crate) mod m2ri;
pub(crate) mod m2rtd;
pub(crate) mod m32di;
pub(crate) mod m4led;
pub(crate) mod m8co;

/// Every RESI model.
pub(crate) static ALL: [&super::model::Model; 9] = [
    &m16di8ro::MODEL,
    &m32di::MODEL,
    &m14ri::MODEL,
    &m8co::MODEL,
    &m2ri::MODEL,
    &m1ro::MODEL,
    &m2rtd::MODEL,
    &m1led::MODEL,
    &m4led::MODEL,
];

/// A RESI model by its project-file name (`resi-16di8ro`).
pub fn by_name(name: &str) -> Option<&'static super::model::Model> {
    ALL.iter().copied().find(|m| m.name == name)
}
