//! The schema of a profile file's word-valued keys: the words validation accepts, for an
//! editor's completion.

use schemars::{Schema, SchemaGenerator};

use crate::project::raw_schema::{nullable, words};

/// `points[].table`.
pub(crate) fn table(_: &mut SchemaGenerator) -> Schema {
    words(&super::TABLES.map(|t| t.name()))
}

/// `points[].type`.
pub(crate) fn data_type(_: &mut SchemaGenerator) -> Schema {
    nullable(words(
        &softplc_io::devices::profile::DataType::ALL.map(|t| t.name()),
    ))
}

/// `points[].order`.
pub(crate) fn order(_: &mut SchemaGenerator) -> Schema {
    nullable(words(
        &softplc_io::devices::profile::WordOrder::ALL.map(|o| o.name()),
    ))
}

/// `points[].access`.
pub(crate) fn access(_: &mut SchemaGenerator) -> Schema {
    nullable(words(&super::ACCESS.map(|a| a.name())))
}

/// `points[].write`.
pub(crate) fn write(_: &mut SchemaGenerator) -> Schema {
    nullable(words(&super::WRITES.map(|(w, _)| w)))
}
