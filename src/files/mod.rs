//! Files layer: scene files (TOML or JSON) and the thesis reference tables.
//! The core (everything above this module) never reads files.

pub mod demo;
pub(crate) mod json;
pub mod load_cells;
pub mod measure;
pub mod readings;
pub mod svg;
pub mod thesis;

pub use crate::scene::{Scene, SceneError};

/// Longest cell echoed whole in an error message (characters); a longer one is
/// shown by its start and its length, so a 10 MB bad cell does not become a 10 MB
/// error line.
pub const MAX_ECHO_CHARS: usize = 200;

/// `cell` for an error message: whole up to [`MAX_ECHO_CHARS`] characters, else its
/// first [`MAX_ECHO_CHARS`] characters and its length.
pub fn shorten(cell: &str) -> std::borrow::Cow<'_, str> {
    match cell.char_indices().nth(MAX_ECHO_CHARS) {
        None => std::borrow::Cow::Borrowed(cell),
        Some((end, _)) => std::borrow::Cow::Owned(format!(
            "{}... ({} characters)",
            &cell[..end],
            cell.chars().count()
        )),
    }
}

/// The first column name given twice in a header: `(first, second, name)` with the
/// 1-based positions of both. A duplicated column would be read as its last copy.
pub fn duplicate_column<S: AsRef<str>>(names: &[S]) -> Option<(usize, usize, String)> {
    for (j, b) in names.iter().enumerate() {
        let b = b.as_ref();
        if b.is_empty() {
            continue;
        }
        if let Some(i) = names[..j].iter().position(|a| a.as_ref() == b) {
            return Some((i + 1, j + 1, b.to_string()));
        }
    }
    None
}
