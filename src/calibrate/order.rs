//! The order in which a calibration solves its rows, each warm-started from the one
//! before ([`row_order`], [`chain_order`]).

use super::fit::RowOrder;
use super::recording::RecordingRow;

/// The order in which to solve `rows`, each warm-started from the one before: a
/// nearest-neighbour chain in input (readings) space. It starts at the row nearest
/// to zero inputs (the straight robot, where a cold solve is easiest) and goes on
/// to the unvisited row nearest to the last one (Euclidean distance of the inputs
/// as read). Ties, in distance and at the start, are broken by the row's inputs and
/// then its marker, compared value by value, never by its place in the file: the
/// chain of a shuffled copy of the rows visits the same rows in the same order
/// (rows equal in every value are interchangeable). A raster in file order jumps
/// across the whole range at every line end; this chain jumps only where no near
/// row is left. O(n^2) in the rows (24,200 rows of three inputs: about a second).
pub fn chain_order(rows: &[RecordingRow]) -> Vec<usize> {
    use std::cmp::Ordering;
    let n = rows.len();
    let key = |i: usize| -> Vec<f64> {
        let r = &rows[i];
        r.inputs
            .iter()
            .copied()
            .chain(r.marker_m.iter().copied())
            .collect()
    };
    let keys: Vec<Vec<f64>> = (0..n).map(key).collect();
    let lex = |a: usize, b: usize| -> Ordering {
        for (x, y) in keys[a].iter().zip(&keys[b]) {
            match x.total_cmp(y) {
                Ordering::Equal => continue,
                o => return o,
            }
        }
        Ordering::Equal
    };
    let d2 = |a: usize, b: usize| -> f64 {
        rows[a]
            .inputs
            .iter()
            .zip(&rows[b].inputs)
            .map(|(x, y)| (x - y) * (x - y))
            .sum()
    };
    let norm2 = |a: usize| -> f64 { rows[a].inputs.iter().map(|x| x * x).sum() };
    let Some(first) = (0..n).min_by(|&a, &b| norm2(a).total_cmp(&norm2(b)).then(lex(a, b))) else {
        return Vec::new();
    };
    let mut left: Vec<usize> = (0..n).filter(|&i| i != first).collect();
    let mut order = Vec::with_capacity(n);
    order.push(first);
    let mut last = first;
    while !left.is_empty() {
        let mut best = 0;
        let mut best_d = d2(last, left[0]);
        for (j, &i) in left.iter().enumerate().skip(1) {
            let d = d2(last, i);
            if d < best_d || (d == best_d && lex(i, left[best]) == Ordering::Less) {
                best = j;
                best_d = d;
            }
        }
        last = left.swap_remove(best);
        order.push(last);
    }
    order
}

/// The order in which a calibration solves `rows` ([`RowOrder`]): indices into
/// `rows`. [`RowOrder::Auto`] sorts a fully time-stamped recording by time (ties by
/// the rows' values), else chains it by [`chain_order`].
pub fn row_order(rows: &[RecordingRow], order: RowOrder) -> Vec<usize> {
    match order {
        RowOrder::File => (0..rows.len()).collect(),
        RowOrder::Nearest => chain_order(rows),
        RowOrder::Auto => {
            if rows.is_empty() || rows.iter().any(|r| r.t_s.is_none()) {
                return chain_order(rows);
            }
            let mut idx: Vec<usize> = (0..rows.len()).collect();
            let key = |r: &RecordingRow| -> Vec<f64> {
                r.t_s
                    .into_iter()
                    .chain(r.inputs.iter().copied())
                    .chain(r.marker_m.iter().copied())
                    .collect()
            };
            idx.sort_by(|&a, &b| {
                let (ka, kb) = (key(&rows[a]), key(&rows[b]));
                ka.iter()
                    .zip(&kb)
                    .map(|(x, y)| x.total_cmp(y))
                    .find(|o| o.is_ne())
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
            idx
        }
    }
}
