//! One strict row reader for every CSV input: readings and cable-delta streams, load
//! cells, thesis tables, calibration recordings, `identify`'s pull recordings,
//! cross-validation groups and `reach`'s targets.
//!
//! Every reader splits its lines here, with the tokenizer of the `csv` crate
//! (`csv-core`; RFC 4180: a quoted cell keeps its commas and its doubled quotes), so a quoted `"0,001"` is one cell
//! everywhere; skips the same lines (blank, `#` comments); strips the same byte-order
//! mark and CR line ends; refuses the same headers (a column given twice, named by both
//! positions); and shortens the same long cells in its messages ([`shorten`]). A quote
//! left open at the end of a line is an error, not a cell that swallows the rest: a
//! record never spans lines, so a stream reader can report a bad line and go on.

use std::borrow::Cow;

/// Longest cell echoed whole in an error message (characters); a longer one is
/// shown by its start and its length, so a 10 MB bad cell does not become a 10 MB
/// error line.
pub const MAX_ECHO_CHARS: usize = 200;

/// `cell` for an error message: whole up to [`MAX_ECHO_CHARS`] characters, else its
/// first [`MAX_ECHO_CHARS`] characters and its length.
pub fn shorten(cell: &str) -> Cow<'_, str> {
    match cell.char_indices().nth(MAX_ECHO_CHARS) {
        None => Cow::Borrowed(cell),
        Some((end, _)) => Cow::Owned(format!(
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

/// A line as the readers see it: without a leading byte-order mark, a CR line end and
/// surrounding white space; `None` when nothing is left to read (blank, or a `#`
/// comment).
pub fn content(text: &str) -> Option<&str> {
    let t = text.trim_start_matches('\u{feff}').trim();
    (!t.is_empty() && !t.starts_with('#')).then_some(t)
}

/// The lines of a whole text that carry content, with their 1-based line numbers
/// (see [`content`]; the numbers count every line, so messages point into the file).
pub fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .enumerate()
        .filter_map(|(i, l)| content(l).map(|t| (i + 1, t)))
}

thread_local! {
    /// The CSV tokenizer, built once a thread: building one costs ~270 k instructions
    /// (its state machine), ~1 000 times the splitting of a row.
    static TOKENIZER: std::cell::RefCell<csv_core::Reader> =
        std::cell::RefCell::new(csv_core::Reader::new());
}

/// The cells of one CSV line, each trimmed of white space outside and inside its
/// quotes. Errors name what is wrong with the line (an unterminated quote).
pub fn split(line: &str) -> Result<Vec<String>, String> {
    let line = line.trim_end_matches(['\r', '\n']);
    if line.is_empty() {
        // a line without a comma has one cell, an empty line one empty cell
        return Ok(vec![String::new()]);
    }
    if line.bytes().filter(|&b| b == b'"').count() % 2 == 1 {
        return Err(format!(
            "a quote is not closed on this line: `{}`",
            shorten(line)
        ));
    }
    // the line and its terminator in one input, so the tokenizer ends the record in
    // one call; a cell's bytes are at most the line's, the cells at most its bytes + 1
    let mut input = Vec::with_capacity(line.len() + 1);
    input.extend_from_slice(line.as_bytes());
    input.push(b'\n');
    let mut out = vec![0u8; input.len()];
    let mut ends = vec![0usize; input.len() + 1];
    let (res, _, _, n) = TOKENIZER.with(|t| {
        let mut t = t.borrow_mut();
        t.reset();
        t.read_record(&input, &mut out, &mut ends)
    });
    if res != csv_core::ReadRecordResult::Record {
        return Err(format!("not a CSV line ({res:?}): `{}`", shorten(line)));
    }
    let mut start = 0;
    Ok(ends[..n]
        .iter()
        .map(|&end| {
            let cell = String::from_utf8_lossy(&out[start..end]).trim().to_string();
            start = end;
            cell
        })
        .collect())
}

/// The names of a header line: split, and refused when a name is given twice.
pub fn header(line: &str) -> Result<Vec<String>, String> {
    let names = split(line)?;
    match duplicate_column(&names) {
        Some((a, b, name)) => Err(format!(
            "column `{name}` is given twice (columns {a} and {b})"
        )),
        None => Ok(names),
    }
}

/// A whole CSV text read by the rules above: its header's names and line, and its data
/// rows with their line numbers. Empty input (no header) is an error; so is a header
/// without rows when `rows_required`. Rows are not checked against the header's width
/// here: each reader says what a short or long row means for it.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvText {
    /// Column names, in order.
    pub names: Vec<String>,
    /// 1-based line number of the header.
    pub header_line: usize,
    /// Data rows: 1-based line number and cells.
    pub rows: Vec<(usize, Vec<String>)>,
}

impl CsvText {
    /// Read `text`; errors carry the 1-based line they are about.
    pub fn parse(text: &str, rows_required: bool) -> Result<Self, (usize, String)> {
        let mut lines = data_lines(text);
        let Some((header_line, h)) = lines.next() else {
            return Err((1, "empty input: no header and no rows".into()));
        };
        let names = header(h).map_err(|why| (header_line, why))?;
        let rows = lines
            .map(|(line, l)| split(l).map(|cells| (line, cells)).map_err(|w| (line, w)))
            .collect::<Result<Vec<_>, _>>()?;
        if rows_required && rows.is_empty() {
            return Err((header_line, "a header and no data rows".into()));
        }
        Ok(Self {
            names,
            header_line,
            rows,
        })
    }

    /// Position of the column `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_cells_keep_their_commas_and_quotes() {
        assert_eq!(
            split(r#"1,"0,001","a ""b""""#).unwrap(),
            ["1", "0,001", r#"a "b""#]
        );
        assert_eq!(split(" 1 , 2 ").unwrap(), ["1", "2"]);
        assert_eq!(split("a,,b").unwrap(), ["a", "", "b"]);
        assert_eq!(split("").unwrap(), [""]);
        assert_eq!(split("x\r").unwrap(), ["x"]);
    }

    #[test]
    fn an_open_quote_is_an_error_naming_the_line() {
        let e = split(r#"1,"2,3"#).unwrap_err();
        assert!(e.contains("quote") && e.contains(r#"1,"2,3"#), "{e}");
    }

    #[test]
    fn bom_crlf_comments_and_blank_lines() {
        let t = "\u{feff}# a comment\r\n\r\nt_s,a\r\n1,2\r\n\n# x\n3,4";
        let c = CsvText::parse(t, true).unwrap();
        assert_eq!(c.names, ["t_s", "a"]);
        assert_eq!(c.header_line, 3);
        assert_eq!(
            c.rows,
            [
                (4, vec!["1".into(), "2".into()]),
                (7, vec!["3".into(), "4".into()])
            ]
        );
        assert_eq!(c.column("a"), Some(1));
    }

    #[test]
    fn empty_input_duplicate_columns_and_no_rows_are_errors() {
        assert_eq!(CsvText::parse(" \n# only\n", false).unwrap_err().0, 1);
        let (line, why) = CsvText::parse("\nt,a,b,a\n1,2,3,4", false).unwrap_err();
        assert_eq!(line, 2);
        assert!(
            why.contains("`a`") && why.contains("columns 2 and 4"),
            "{why}"
        );
        let (line, why) = CsvText::parse("t,a\n", true).unwrap_err();
        assert_eq!(line, 1);
        assert!(why.contains("no data rows"), "{why}");
        assert!(CsvText::parse("t,a\n", false).unwrap().rows.is_empty());
    }

    #[test]
    fn long_cells_are_shortened() {
        let cell = "x".repeat(10_000);
        let s = shorten(&cell);
        assert!(s.len() < 300 && s.contains("10000 characters"), "{s}");
        let e = split(&format!("\"{cell}")).unwrap_err();
        assert!(e.len() < 400, "{}", e.len());
    }
}
