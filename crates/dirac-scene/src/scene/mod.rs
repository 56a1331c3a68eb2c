//! The scene format's parts: the data model, the parser, the builder and their errors.

pub(crate) mod build;
pub(crate) mod error;
pub(crate) mod model;
pub(crate) mod parse;
