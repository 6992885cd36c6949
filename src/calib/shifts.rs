//! What the bird's-eye search (`bev`) and the global stage (`correlate`) do alike on their
//! bird's-eye grids: each cell's closeness to the occupied cells, and the scores of every
//! shift in a window (the inner loop of the search and of the stage's fine step).

use std::ops::{AddAssign, Mul};

/// A grid of `rows` × `columns` values, row-major.
pub(super) struct Rows<'a, T> {
    pub values: &'a [T],
    pub rows: usize,
    pub columns: usize,
}

/// Raises each cell of `values` (`size[0]` rows × `size[1]` columns, row-major) to its
/// closeness to every cell of `occupied` (repeats allowed): `weight(exp(-d^2 / 2 sigma^2))`
/// at `d` cells, out to 3 sigma, so 1 on an occupied cell. A maximum rather than a sum, so that where a surface
/// is sampled densely it weighs no more than where it is sampled sparsely. The weights come
/// from a table by offset, computed once.
pub(super) fn raise_closeness<T: Copy + PartialOrd>(
    values: &mut [T],
    size: [usize; 2],
    mut occupied: Vec<[i64; 2]>,
    sigma_cells: f64,
    weight: impl Fn(f64) -> T,
) {
    let radius = (3.0 * sigma_cells).ceil() as i64;
    let width = 2 * radius + 1;
    let kernel: Vec<T> = (-radius..=radius)
        .flat_map(|a| (-radius..=radius).map(move |b| (a, b)))
        .map(|(a, b)| weight((-0.5 * (a * a + b * b) as f64 / (sigma_cells * sigma_cells)).exp()))
        .collect();
    occupied.sort_unstable();
    occupied.dedup();
    let [rows, columns] = size.map(|n| n as i64);
    for [i, j] in occupied {
        for a in (i - radius).max(0)..=(i + radius).min(rows - 1) {
            for b in (j - radius).max(0)..=(j + radius).min(columns - 1) {
                let w = kernel[((a - i + radius) * width + (b - j + radius)) as usize];
                let cell = &mut values[(a * columns + b) as usize];
                if w > *cell {
                    *cell = w;
                }
            }
        }
    }
}

/// The shifts [`shift_scores`] scores, in its order: `a` within `steps` of `centre[0]` (outer),
/// `b` within `steps` of `centre[1]`.
pub(super) fn shifts(centre: [i64; 2], steps: i64) -> impl Iterator<Item = [i64; 2]> {
    let around = move |c: i64| c - steps..=c + steps;
    around(centre[0]).flat_map(move |a| around(centre[1]).map(move |b| [a, b]))
}

/// Writes to `scores` the score of every shift `[a, b]` with `a` within `steps` of
/// `centre[0]` and `b` of `centre[1]`, row by row (`a` outer): `sum w * grid[i + a][j + b]`
/// over `cells`' `([i, j], w)`, off the grid 0. Each cell adds its weight times a row of the
/// grid to a row of the scores, a contiguous loop, where summing each shift alone would look
/// up every cell once per shift; the sums still grow in `cells`' order, so they are the same
/// bit for bit (what lies off the grid adds exactly 0 and is skipped).
pub(super) fn shift_scores<T>(
    grid: &Rows<T>,
    cells: &[([i64; 2], T)],
    centre: [i64; 2],
    steps: i64,
    scores: &mut Vec<T>,
) where
    T: Copy + Default + AddAssign + Mul<Output = T>,
{
    let side = (2 * steps + 1) as usize;
    scores.clear();
    scores.resize(side * side, T::default());
    let (rows, columns) = (grid.rows as i64, grid.columns as i64);
    for &([i, j], w) in cells {
        let first_column = j + centre[1] - steps;
        let (lo, hi) = (first_column.max(0), (first_column + 2 * steps).min(columns - 1));
        if lo > hi {
            continue;
        }
        let skipped = (lo - first_column) as usize;
        for (a, out) in (-steps..=steps).zip(scores.chunks_exact_mut(side)) {
            let row = i + centre[0] + a;
            if !(0..rows).contains(&row) {
                continue;
            }
            let start = (row * columns) as usize;
            let values = &grid.values[start + lo as usize..=start + hi as usize];
            for (o, &v) in out[skipped..].iter_mut().zip(values) {
                *o += w * v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A maximum of Gaussian weights out to 3 sigma, clipped at the grid's edges: 1 on an
    /// occupied cell, the nearer one's weight between two, a repeated cell no heavier.
    #[test]
    fn closeness_is_the_nearest_occupied_cells_weight() {
        let (size, sigma) = ([3, 9], 1.0);
        let mut values = vec![0.0f64; 27];
        raise_closeness(&mut values, size, vec![[1, 0], [1, 5], [1, 5]], sigma, |w| w);
        let weight = |d2: f64| (-0.5 * d2 / (sigma * sigma)).exp();
        assert_eq!(values[9], 1.0);
        assert_eq!(values[14], 1.0);
        assert_eq!(values[10], weight(1.0));
        assert_eq!(values[12], weight(4.0)); // 3 from [1, 0], 2 from [1, 5]
        assert_eq!(values[0], weight(1.0));
        assert_eq!(values[8], weight(1.0 + 9.0));
        let mut f32s = vec![0.0f32; 27];
        raise_closeness(&mut f32s, size, vec![[1, 5]], sigma, |w| w as f32);
        assert_eq!(f32s[9], 0.0); // 5 cells away: beyond 3 sigma
        assert_eq!(f32s[15], weight(1.0) as f32);
    }

    /// Every shift's score is the sum for that shift alone, bit for bit: cells off the grid,
    /// at its corners and windows reaching past its edges included, in f64 and f32.
    #[test]
    fn every_shift_scores_as_it_would_alone() {
        let (rows, columns) = (40usize, 55usize);
        let values: Vec<f64> =
            (0..rows * columns).map(|k| ((k as f64 * 0.61).sin() * 0.7).max(0.0)).collect();
        let mut cells: Vec<([i64; 2], f64)> = (0..400i64)
            .map(|k| ([(k * 7) % 70 - 15, (k * 13) % 85 - 15], 1.0 + (k % 3) as f64))
            .collect();
        cells.extend([([0, 0], 2.0), ([39, 54], 3.0), ([-20, -20], 1.0)]);
        cells.sort_by_key(|c| c.0);
        let at = |i: i64, j: i64| {
            let inside = (0..rows as i64).contains(&i) && (0..columns as i64).contains(&j);
            if inside { values[i as usize * columns + j as usize] } else { 0.0 }
        };
        let grid = Rows { values: &values, rows, columns };
        for (centre, steps) in [([0, 0], 15), ([3, -4], 6)] {
            let mut scores = Vec::new();
            shift_scores(&grid, &cells, centre, steps, &mut scores);
            let side = (2 * steps + 1) as usize;
            assert_eq!(scores.len(), side * side);
            let mut scoring = 0;
            for (n, got) in scores.iter().enumerate() {
                let a = centre[0] - steps + (n / side) as i64;
                let b = centre[1] - steps + (n % side) as i64;
                let alone: f64 = cells.iter().map(|([i, j], w)| w * at(i + a, j + b)).sum();
                assert_eq!(*got, alone, "shift {a} {b}");
                scoring += usize::from(alone > 0.0);
            }
            assert!(scoring > side, "{scoring} shifts score");
        }
        let narrow: Vec<f32> = values.iter().map(|&v| v as f32).collect();
        let ones: Vec<([i64; 2], f32)> = cells.iter().map(|&(c, _)| (c, 1.0)).collect();
        let mut scores = Vec::new();
        shift_scores(&Rows { values: &narrow, rows, columns }, &ones, [2, 2], 5, &mut scores);
        let alone: f32 = ones.iter().map(|([i, j], _)| at(i - 3, j - 3) as f32).sum();
        assert_eq!(scores[0], alone);
    }
}
