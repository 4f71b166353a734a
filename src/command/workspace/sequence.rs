//! The Halton sequence and the greedy nearest-neighbour order of the samples
//! (module docs of [`super`]).

/// The `n`-th prime (0-based: 2, 3, 5, ...).
pub(super) fn nth_prime(n: usize) -> u64 {
    let mut found = 0;
    let mut c = 2u64;
    loop {
        if (2..c).take_while(|d| d * d <= c).all(|d| c % d != 0) {
            if found == n {
                return c;
            }
            found += 1;
        }
        c += 1;
    }
}

/// Radical inverse of `k` in base `b` (Halton 1960): the digits of `k` mirrored
/// about the radix point, in `[0, 1)`.
pub fn radical_inverse(mut k: u64, b: u64) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    let inv = 1.0 / b as f64;
    while k > 0 {
        f *= inv;
        r += f * (k % b) as f64;
        k /= b;
    }
    r
}

/// Point `k` of the `dim`-dimensional Halton sequence (bases the first `dim` primes),
/// in the unit cube.
pub fn halton(k: u64, dim: usize) -> Vec<f64> {
    (0..dim).map(|i| radical_inverse(k, nth_prime(i))).collect()
}

/// Greedy nearest-neighbour order of `points` (each `dim` long, flat), starting
/// from the point nearest `start`. `O(n^2)` distance evaluations.
pub fn nearest_neighbour_order(points: &[f64], dim: usize, start: &[f64]) -> Vec<usize> {
    let n = points.len() / dim.max(1);
    let d2 = |i: usize, x: &[f64]| -> f64 {
        points[i * dim..(i + 1) * dim]
            .iter()
            .zip(x)
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    };
    let mut visited = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut here = start.to_vec();
    for _ in 0..n {
        let mut best = (f64::INFINITY, usize::MAX);
        for (j, v) in visited.iter().enumerate() {
            if !v {
                let d = d2(j, &here);
                if d < best.0 {
                    best = (d, j);
                }
            }
        }
        let j = best.1;
        visited[j] = true;
        order.push(j);
        here.copy_from_slice(&points[j * dim..(j + 1) * dim]);
    }
    order
}

/// Up to `k` indices `i != j` with `solved[i]` set, nearest point `j` of `points`
/// (each `dim` long, flat; Euclidean), nearest first, ties by index.
pub(super) fn nearest_solved<T>(
    points: &[f64],
    dim: usize,
    j: usize,
    solved: &[Option<T>],
    k: usize,
) -> Vec<usize> {
    let x = &points[j * dim..(j + 1) * dim];
    let mut near: Vec<(f64, usize)> = solved
        .iter()
        .enumerate()
        .filter(|(i, s)| *i != j && s.is_some())
        .map(|(i, _)| {
            let d: f64 = points[i * dim..(i + 1) * dim]
                .iter()
                .zip(x)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            (d, i)
        })
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    near.into_iter().take(k).map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radical_inverse_digits() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert_eq!(radical_inverse(6, 2), 0.375); // 110 -> 0.011
        assert!((radical_inverse(5, 3) - 7.0 / 9.0).abs() < 1e-15); // 12 -> 0.21
        assert_eq!(nth_prime(8), 23);
    }

    #[test]
    fn nn_order_visits_all_once() {
        let pts = [0.0, 0.0, 5.0, 5.0, 1.0, 1.0, 4.0, 4.0];
        let o = nearest_neighbour_order(&pts, 2, &[0.0, 0.0]);
        assert_eq!(o, vec![0, 2, 3, 1]);
    }

    #[test]
    fn nearest_solved_skips_itself_and_the_unsolved() {
        let pts = [0.0, 0.0, 5.0, 5.0, 1.0, 1.0, 4.0, 4.0];
        let solved = [Some(()), Some(()), None, Some(())];
        assert_eq!(nearest_solved(&pts, 2, 2, &solved, 2), vec![0, 3]);
        assert_eq!(nearest_solved(&pts, 2, 0, &solved, 5), vec![3, 1]);
    }
}
