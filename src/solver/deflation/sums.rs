//! The coarse space's hot loops: the island matrix's block sums (from the kernel's second prefix
//! sums), its mirror and row sums, and the coarse matrix E formed from it.

use crate::solver::factor::pairs_above_diagonal;
use crate::solver::wide::wide_fn;

wide_fn! {
/// out[g * tile.len() + j] = the block sums of `tile[j]` against the runs of group g of `others`
/// (runs bounds[g]..bounds[g + 1], given as (N - start, N - end)), added in order from -0.0 (as
/// `Iterator::sum`); `h` holds the second prefix sums of a kernel of size `n`.
///
/// The hot loop of the coarse space. The whole tile (a group's runs, neighbours on the profile)
/// meets each run of `others` at once: the entries of `h` it reads for one run lie in a window of
/// about the tile's span, which the next run shifts by one run only. So `h` (16 MiB at N = 2^20)
/// streams through the cache once per tile instead of once per run, and the tile's sums are
/// independent chains, four at a time in registers. The block of the runs [a, b) and [c, d) is
/// H(b - c + 1) - H(a - c + 1) - H(b - d + 1) + H(a - d + 1), and H(k) sits at k + N - 1: at
/// b + (N - c) and so on, one load each from the tile run's own base (no index arithmetic).
pub(super) fn tile_sums(h: &[f64], n: usize, tile: &[(usize, usize)], others: &[(usize, usize)], bounds: &[usize], out: &mut [f64]) {
    let t = tile.len();
    assert!(h.len() > 2 * n && out.len() == t * (bounds.len() - 1) && bounds[bounds.len() - 1] <= others.len());
    assert!(tile.iter().all(|&(a, b)| a <= b && b <= n), "runs must lie in [0, N]");
    // SAFETY (every `block` below): its slices begin at a tile run's start or end, at most N into
    // `h` (more than 2N entries: at least N + 1 left, asserted above), and c, d <= N, as
    // `others` holds PairSums::mirrored of runs inside [0, N] (every caller asserts it through
    // PairSums::check_runs).
    debug_assert!(others.iter().all(|&(c, d)| c >= d && c <= n), "runs must lie in [0, N]");
    let groups = bounds.len() - 1;
    if t == 1 && bounds[groups] - bounds[0] == groups {
        // One run against single runs (a coarse space of ungrouped runs, all N = 1,000 segments):
        // one block each, in one pass.
        let (end, start) = (&h[tile[0].1..], &h[tile[0].0..]);
        for (o, &(c, d)) in out.iter_mut().zip(&others[bounds[0]..bounds[groups]]) {
            *o = -0.0 + unsafe { block(end, start, c, d) };
        }
        return;
    }
    if t < LANES && bounds.windows(2).all(|w| w[0] < w[1] && w[1] - w[0] <= 2) {
        // Groups of one or two runs (a space of a few more runs than vectors): per tile run the
        // blocks of all the groups' runs in one pass, then each group's sum from them with no
        // branch on its size (a branch the sizes' irregular mix mispredicted), the same additions:
        // -0.0 + the first block, then + the second (or + -0.0, which leaves any value as it is).
        let (first, last) = (bounds[0], bounds[groups]);
        let mut blocks = Vec::with_capacity(last - first);
        for (j, &(a, b)) in tile.iter().enumerate() {
            let (end, start) = (&h[b..], &h[a..]);
            blocks.clear();
            blocks.extend(others[first..last].iter().map(|&(c, d)| -0.0 + unsafe { block(end, start, c, d) }));
            for (o, w) in out[j..].iter_mut().step_by(t).zip(bounds.windows(2)) {
                let (at, size) = (w[0] - first, w[1] - w[0]);
                let second = if size == 2 { blocks[at + 1] } else { -0.0 };
                *o = blocks[at] + second;
            }
        }
        return;
    }
    let whole = t / LANES * LANES;
    for (group, sums) in bounds.windows(2).zip(out.chunks_exact_mut(t)) {
        let group = &others[group[0]..group[1]];
        for (o, lanes) in sums[..whole].chunks_exact_mut(LANES).zip(tile.chunks_exact(LANES)) {
            let mut acc = [-0.0; LANES];
            let ends = [&h[lanes[0].1..], &h[lanes[1].1..], &h[lanes[2].1..], &h[lanes[3].1..]];
            let starts = [&h[lanes[0].0..], &h[lanes[1].0..], &h[lanes[2].0..], &h[lanes[3].0..]];
            for &(c, d) in group {
                for k in 0..LANES {
                    acc[k] += unsafe { block(ends[k], starts[k], c, d) };
                }
            }
            o.copy_from_slice(&acc);
        }
        for (o, &(a, b)) in sums[whole..].iter_mut().zip(&tile[whole..]) {
            let (end, start) = (&h[b..], &h[a..]);
            let mut acc = -0.0;
            for &(c, d) in group {
                acc += unsafe { block(end, start, c, d) };
            }
            *o = acc;
        }
    }
}
}

const LANES: usize = 4;

/// `g[j][i] = g[i][j]` for j > i (row-major, n x n), in square blocks that stay in cache.
pub(super) fn mirror_upper(g: &mut [f64], n: usize) {
    pairs_above_diagonal(n, |i, j| g[j * n + i] = g[i * n + j]);
}

wide_fn! {
/// The row sums of the symmetric `g` (groups x groups), each added in order from -0.0 (as
/// `Iterator::sum`). Taken down the columns (the same entries in the same order, g being exactly
/// symmetric as [`super::PairSums::group_matrix`] and [`super::GroupCache`] write it): independent chains that
/// vectorise, where one row's sum is a chain of dependent adds.
pub(super) fn row_sums(g: &[f64], groups: usize) -> Vec<f64> {
    let mut sums = vec![-0.0; groups];
    for g_row in g.chunks_exact(groups) {
        for (s, &v) in sums.iter_mut().zip(g_row) {
            *s += v;
        }
    }
    sums
}
}

wide_fn! {
/// E = G - row w^T - w row^T + total w w^T on the first `columns` groups, row-major, every entry
/// written once (no zeroed matrix first).
pub(super) fn coarse_matrix(g: &[f64], groups: usize, columns: usize, row: &[f64], weights: &[f64], total: f64) -> Vec<f64> {
    let mut e = Vec::with_capacity(columns * columns);
    let (row, weights) = (&row[..columns], &weights[..columns]);
    for a in 0..columns {
        let (ra, wa) = (row[a], weights[a]);
        let g_row = &g[a * groups..a * groups + columns];
        e.extend(g_row.iter().zip(row).zip(weights).map(|((&g, &rb), &wb)| g - ra * wb - wa * rb + total * wa * wb));
    }
    e
}
}

/// (H at end + c - H at start + c) - (H at end + d - H at start + d), with `end`, `start` the
/// second prefix sums from a run's end and start on, and c, d a mirrored run (N - its ends).
/// Unchecked because this is the coarse space's hot loop.
///
/// # Safety
/// c and d must be less than both slices' lengths.
#[inline(always)]
unsafe fn block(end: &[f64], start: &[f64], c: usize, d: usize) -> f64 {
    (end.get_unchecked(c) - start.get_unchecked(c)) - (end.get_unchecked(d) - start.get_unchecked(d))
}
