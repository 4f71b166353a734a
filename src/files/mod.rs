//! Files layer: scene files (TOML or JSON) and the thesis reference tables.
//! The core (everything above this module) never reads files.

pub mod demo;
pub(crate) mod json;
pub mod load_cells;
pub mod measure;
pub mod readings;
pub mod rows;
pub mod svg;
pub mod thesis;

pub use crate::scene::{Scene, SceneError};

pub use rows::{duplicate_column, shorten, MAX_ECHO_CHARS};
