//! One table per model. Each file holds the model's register map, its own ASCII commands, its
//! points and its hardware, and ends with `catalog_entry!` (defined in `resi/mod.rs`), which
//! makes its catalog entry `SPEC` from them.

pub mod m14ri;
pub mod m16di8ro;
pub mod m1led;
pub mod m1ro;
pub mod m2ri;
pub mod m2rtd;
pub mod m32di;
pub mod m4led;
pub mod m8co;
