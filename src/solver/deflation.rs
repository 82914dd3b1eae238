//! Coarse space for the contact-set solve: one vector per island of contact.
//!
//! The FFT preconditioner (the inverse kernel restricted to the contact set) handles everything
//! inside an island, but misjudges how load is shared between islands: the preconditioned
//! operator has eigenvalues >= 1 with outliers that grow with N (about 23 at N = 1,024 and 72 at
//! N = 4,096 on a self-affine profile), one per island. Deflating the island-mean modes removes
//! them: with every island deflated the condition number drops to about 2 at both sizes
//! (measured on dense matrices). When there are too many islands to assemble E in the budget,
//! islands are grouped or only the largest kept, and the gain shrinks (N >= 2^17 in practice).
//!
//! The coarse matrix E = Z^T C Z needs the kernel summed over pairs of intervals; with second
//! prefix sums of the kernel each entry costs O(1), so E costs O(islands^2), never an FFT.

use super::factor::{cholesky, cholesky_solve};
use super::wide::wide_fn;

/// Second prefix sums of a kernel c(d), d in (-N, N), for sums of c(i - l) over interval pairs.
pub(crate) struct PairSums {
    /// Unique per instance: a coarse space kept in a workspace is reused only with the sums it
    /// was built from.
    id: u64,
    n: usize,
    /// H(k) for k in [1 - N, N + 1], stored at k + N - 1.
    second: Vec<f64>,
}

impl PairSums {
    pub fn new(n: usize, kernel_at: impl Fn(isize) -> f64) -> Self {
        let ni = n as isize;
        // F(k) = sum_{0 <= j < k} c(j) for k >= 0, -sum_{k <= j < 0} c(j) for k < 0; k in [1-N, N].
        let mut first = vec![0.0; 2 * n];
        let f_at = |k: isize| (k + ni - 1) as usize;
        for k in 1..=ni {
            first[f_at(k)] = first[f_at(k - 1)] + kernel_at(k - 1);
        }
        for k in (1 - ni..0).rev() {
            first[f_at(k)] = first[f_at(k + 1)] - kernel_at(k);
        }
        let mut second = vec![0.0; 2 * n + 1];
        for k in 1..=ni + 1 {
            second[f_at(k)] = second[f_at(k - 1)] + first[f_at(k - 1)];
        }
        for k in (1 - ni..0).rev() {
            second[f_at(k)] = second[f_at(k + 1)] - first[f_at(k)];
        }
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let id = NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Self { id, n, second }
    }

    pub fn id(&self) -> u64 {
        self.id
    }

    #[cfg(test)]
    fn h(&self, k: isize) -> f64 {
        self.second[(k + self.n as isize - 1) as usize]
    }

    /// The runs as the hot loop reads them: (N - start, N - end) (see [`tile_sums`]).
    fn mirrored(&self, runs: &[(usize, usize)]) -> Vec<(usize, usize)> {
        runs.iter().map(|&(c, d)| (self.n - c, self.n - d)).collect()
    }

    /// Sum of c(i - l) over i in the run `r` and l in the runs whose [`PairSums::mirrored`] form is
    /// `others` (all inside [0, N]).
    fn sum_over(&self, run: (usize, usize), others: &[(usize, usize)]) -> f64 {
        let mut out = [0.0];
        tile_sums(&self.second, self.n, &[run], others, &[0, others.len()], &mut out);
        out[0]
    }

    /// The sums of c(i - l) over i in each run of `tile` and l in each group of runs, given
    /// [`PairSums::mirrored`]: group g holds mirrored[bounds[g]..bounds[g + 1]]; out (resized)
    /// holds the sum for (group g, tile run j) at g * tile.len() + j, added over the group's runs
    /// in order (as [`PairSums::sum_over`]).
    fn tile_sums(&self, tile: &[(usize, usize)], mirrored: &[(usize, usize)], bounds: &[usize], out: &mut Vec<f64>) {
        out.resize(tile.len() * (bounds.len() - 1), 0.0);
        tile_sums(&self.second, self.n, tile, mirrored, bounds, out);
    }

    /// Entry (a, a) of the group matrix, for group a holding `runs_a` (`mirrored_a` in
    /// [`PairSums::mirrored`] form): the pair (j, j) once, the pairs (j, k > j) twice.
    fn diagonal_entry(&self, runs_a: &[(usize, usize)], mirrored_a: &[(usize, usize)]) -> f64 {
        (0..runs_a.len())
            .map(|j| self.sum_over(runs_a[j], &mirrored_a[j..j + 1]) + 2.0 * self.sum_over(runs_a[j], &mirrored_a[j + 1..]))
            .sum()
    }

    /// Row `a` of the group matrix, entries b in `range`, into `g` (row-major, groups x groups)
    /// and its mirror: group a holds runs[bounds[a]..bounds[a + 1]], `mirrored` is
    /// [`PairSums::mirrored`] of `runs`; `out` is scratch.
    fn group_row(
        &self,
        (runs, mirrored): Runs<'_>,
        bounds: &[usize],
        a: usize,
        range: std::ops::Range<usize>,
        g: &mut [f64],
        out: &mut Vec<f64>,
    ) {
        let groups = bounds.len() - 1;
        let tile = &runs[bounds[a]..bounds[a + 1]];
        self.tile_sums(tile, mirrored, &bounds[range.start..=range.end], out);
        for (b, sums) in range.zip(out.chunks_exact(tile.len())) {
            // The tile's runs added in order (as `Iterator::sum` does).
            let value: f64 = sums.iter().sum();
            g[a * groups + b] = value;
            g[b * groups + a] = value;
        }
    }

    fn check_runs(&self, runs: &[(usize, usize)]) {
        assert!(runs.iter().all(|&(a, b)| a <= b && b <= self.n), "runs must lie in [0, N]");
    }

    /// G = Z^T C Z for the indicators Z of groups of consecutive runs (group g holds
    /// runs[bounds[g]..bounds[g + 1]]), row-major groups x groups.
    ///
    /// O(runs^2) block sums, the hot loop of the coarse space: for each group, one pass of all its
    /// runs together over the runs of the later groups (see [`tile_sums`]), one write per group.
    pub fn group_matrix(&self, runs: &[(usize, usize)], bounds: &[usize]) -> Vec<f64> {
        let groups = bounds.len() - 1;
        self.check_runs(runs);
        let mut g = vec![0.0; groups * groups];
        let mut out = Vec::new();
        let mirrored = self.mirrored(runs);
        for ga in 0..groups {
            let members = bounds[ga]..bounds[ga + 1];
            g[ga * groups + ga] = self.diagonal_entry(&runs[members.clone()], &mirrored[members]);
            if ga + 1 < groups {
                self.group_row((runs, &mirrored), bounds, ga, ga + 1..groups, &mut g, &mut out);
            }
        }
        g
    }

    /// sum over i in [a, b), l in [c, d) of c(i - l); all bounds in [0, N].
    #[cfg(test)]
    pub fn block(&self, (a, b): (usize, usize), (c, d): (usize, usize)) -> f64 {
        let (a, b, c, d) = (a as isize, b as isize, c as isize, d as isize);
        self.h(b - c + 1) - self.h(a - c + 1) - self.h(b - d + 1) + self.h(a - d + 1)
    }
}

/// Runs [start, end) and their [`PairSums::mirrored`] form.
type Runs<'a> = (&'a [(usize, usize)], &'a [(usize, usize)]);

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
fn tile_sums(h: &[f64], n: usize, tile: &[(usize, usize)], others: &[(usize, usize)], bounds: &[usize], out: &mut [f64]) {
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

/// Maximal runs [start, end) of `true` in `mask` (no wrap-around: an island that crosses the
/// periodic boundary is two runs, which only adds a deflation vector).
pub(crate) fn runs(mask: &[bool]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, &m) in mask.iter().enumerate() {
        match (m, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                out.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, mask.len()));
    }
    out
}

/// The group matrix of the last grouped coarse space of one solve. Between sweeps most runs of
/// the contact set stay where they were; keeping the groups by position (group g takes the runs
/// that start at or after `starts[g]` and before `starts[g + 1]`) instead of re-splitting them
/// into equal counts, the next space recomputes only the rows of the groups whose runs changed:
/// O(changed runs x runs) instead of O(runs^2). One cache serves one solve only, so that no result
/// depends on an earlier solve.
pub(crate) struct GroupCache {
    max_dim: usize,
    starts: Vec<usize>,
    runs: Vec<(usize, usize)>,
    bounds: Vec<usize>,
    g: Vec<f64>,
}

impl GroupCache {
    /// The bounds of `runs` in the cached groups, or None when a group would be empty or the
    /// dimension differs (then the space is built afresh).
    fn regroup(&self, runs: &[(usize, usize)], max_dim: usize) -> Option<Vec<usize>> {
        if self.max_dim != max_dim {
            return None;
        }
        let groups = self.starts.len();
        let mut bounds = Vec::with_capacity(groups + 1);
        bounds.push(0);
        let mut g = 0;
        for (j, &(start, _)) in runs.iter().enumerate() {
            while g + 1 < groups && start >= self.starts[g + 1] {
                g += 1;
                bounds.push(j);
            }
        }
        while bounds.len() < groups + 1 {
            bounds.push(runs.len());
        }
        bounds.windows(2).all(|w| w[0] < w[1]).then_some(bounds)
    }

    /// The group matrix for `runs` grouped by `bounds` (from [`GroupCache::regroup`]): rows of
    /// unchanged groups kept, the others summed again. Consumes the cached matrix.
    fn update(&mut self, pair_sums: &PairSums, runs: &[(usize, usize)], bounds: &[usize]) -> Vec<f64> {
        pair_sums.check_runs(runs);
        let groups = bounds.len() - 1;
        let group = |g: usize| &runs[bounds[g]..bounds[g + 1]];
        let changed: Vec<bool> = (0..groups).map(|g| group(g) != &self.runs[self.bounds[g]..self.bounds[g + 1]]).collect();
        let mut g = std::mem::take(&mut self.g);
        let mut out = Vec::new();
        let mirrored = pair_sums.mirrored(runs);
        for a in (0..groups).filter(|&a| changed[a]) {
            g[a * groups + a] = pair_sums.diagonal_entry(group(a), &mirrored[bounds[a]..bounds[a + 1]]);
            // Row a against every group but the changed ones before it (their rows did it): the
            // unchanged groups before a in maximal ranges, then all groups after it.
            let mut b = 0;
            while b < a {
                let end = (b..a).find(|&e| changed[e]).unwrap_or(a);
                if end > b {
                    pair_sums.group_row((runs, &mirrored), bounds, a, b..end, &mut g, &mut out);
                }
                b = end + 1;
            }
            if a + 1 < groups {
                pair_sums.group_row((runs, &mirrored), bounds, a, a + 1..groups, &mut g, &mut out);
            }
        }
        g
    }
}

/// Zero-sum island vectors Z0_g = 1_{group g} - (|group g| / m) 1_A, where a group is one run
/// of contact or, when there are more runs than `max_dim`, several consecutive runs; with the
/// Cholesky factor of E = Z0^T C Z0.
pub(crate) struct CoarseSpace {
    runs: Vec<(usize, usize)>,
    /// Group g holds runs[bounds[g]..bounds[g + 1]].
    bounds: Vec<usize>,
    /// `bounds` with the last group too (left out of the space when every run is covered).
    all_bounds: Vec<usize>,
    weights: Vec<f64>,
    /// Lower-triangular Cholesky factor L of E (row-major, dim x dim): faer factors, the
    /// per-iteration solves with one right-hand side are done here (cheaper at these sizes).
    factor: Vec<f64>,
    /// The `max_dim` it was built with, and whether every run of the set is in it.
    max_dim: usize,
    complete: bool,
    /// Whether the groups are equal counts of runs (what a space built afresh has), not the
    /// positions kept from an earlier space of the same solve ([`GroupCache`]).
    equal_groups: bool,
}

impl CoarseSpace {
    /// None when there is nothing to deflate (a single island) or E is not numerically positive.
    /// `displacement_of_set` is C 1_A, the displacement under unit pressure on the whole set; it is
    /// read only when not every run is deflated (see [`CoarseSpace::needs_displacement_of_set`]).
    pub fn new(
        pair_sums: &PairSums,
        mut runs: Vec<(usize, usize)>,
        mask: &[bool],
        displacement_of_set: Option<&[f64]>,
        max_dim: usize,
        max_run_pairs: usize,
        cache: &mut Option<GroupCache>,
    ) -> Option<Self> {
        let all_runs = runs.len();
        if Self::truncates(all_runs, max_dim, max_run_pairs) {
            runs.sort_by_key(|&(s, e)| std::cmp::Reverse(e - s));
            runs.truncate(max_dim);
            runs.sort_unstable();
        }
        let groups = runs.len().min(max_dim);
        if groups < 2 {
            return None;
        }
        let complete = runs.len() == all_runs;
        // Grouped runs (every run kept): the groups of the solve's last space where they still fit.
        let grouped = complete && runs.len() > max_dim;
        let kept = cache.take().filter(|_| grouped);
        let regrouped = kept.as_ref().and_then(|c| c.regroup(&runs, max_dim));
        let equal_groups = regrouped.is_none();
        let (bounds, g_matrix) = match (regrouped, kept) {
            (Some(bounds), Some(mut c)) => {
                let g = c.update(pair_sums, &runs, &bounds);
                (bounds, g)
            }
            _ => {
                let bounds: Vec<usize> = (0..=groups).map(|g| g * runs.len() / groups).collect();
                let g = pair_sums.group_matrix(&runs, &bounds);
                (bounds, g)
            }
        };
        let m = mask.iter().filter(|&&m| m).count() as f64;
        let group_len = |g: usize| runs[bounds[g]..bounds[g + 1]].iter().map(|(s, e)| e - s).sum::<usize>();
        let weights: Vec<f64> = (0..groups).map(|g| group_len(g) as f64 / m).collect();
        // When every run is covered the group indicators sum to 1_A: one zero-sum vector is redundant.
        let columns = if complete { groups - 1 } else { groups };
        // E = G - row w^T - w row^T + total w w^T, G = Z^T C Z, row = Z^T C 1_A, total = 1_A^T C 1_A.
        let (row, total): (Vec<f64>, f64) = if complete {
            // 1_A is the sum of the group indicators, so Z^T C 1_A are the row sums of G.
            let row: Vec<f64> = (0..groups).map(|a| g_matrix[a * groups..(a + 1) * groups].iter().sum()).collect();
            let total = row.iter().sum();
            (row, total)
        } else {
            let u = displacement_of_set.expect("C 1_A is needed when some runs are left out");
            let row = (0..groups).map(|g| runs[bounds[g]..bounds[g + 1]].iter().map(|&(s, e)| u[s..e].iter().sum::<f64>()).sum()).collect();
            let total = u.iter().zip(mask).filter(|(_, &m)| m).map(|(u, _)| u).sum();
            (row, total)
        };
        // E in place of G (symmetric, so row- and column-major alike), then its Cholesky factor.
        let mut e = vec![0.0; columns * columns];
        for a in 0..columns {
            let (ra, wa) = (row[a], weights[a]);
            let g_row = &g_matrix[a * groups..a * groups + columns];
            let e_row = &mut e[a * columns..(a + 1) * columns];
            for b in 0..columns {
                e_row[b] = g_row[b] - ra * weights[b] - wa * row[b] + total * wa * weights[b];
            }
        }
        let factor = cholesky(e, columns);
        if grouped {
            let mut starts: Vec<usize> = bounds[..groups].iter().map(|&j| runs[j].0).collect();
            starts[0] = 0;
            *cache = Some(GroupCache { max_dim, starts, runs: runs.clone(), bounds: bounds.clone(), g: g_matrix });
        }
        let factor = factor?;
        let all_bounds = bounds.clone();
        let mut bounds = bounds;
        bounds.truncate(columns + 1);
        Some(Self { runs, bounds, all_bounds, weights: weights[..columns].to_vec(), factor, max_dim, complete, equal_groups })
    }

    /// Whether only the largest runs are kept (then C 1_A is needed to build the space).
    fn truncates(runs: usize, max_dim: usize, max_run_pairs: usize) -> bool {
        runs > max_dim && runs * (runs + 1) / 2 > max_run_pairs
    }

    /// Whether [`CoarseSpace::new`] reads `displacement_of_set` for this many runs.
    pub fn needs_displacement_of_set(runs: usize, max_dim: usize, max_run_pairs: usize) -> bool {
        Self::truncates(runs, max_dim, max_run_pairs)
    }

    /// Whether `new(runs, .., max_dim, cache)` would build this very space again: one of equal
    /// groups, or one whose groups `cache` (this solve's, see [`GroupCache`]) holds for these very
    /// runs (the regrouping then finds the same bounds and no changed row, so the same E).
    pub fn is_same(&self, runs: &[(usize, usize)], max_dim: usize, cache: Option<&GroupCache>) -> bool {
        let cached = || cache.is_some_and(|c| c.max_dim == max_dim && c.runs == runs && c.bounds == self.bounds_of_groups());
        self.complete
            && self.runs == runs
            && (self.max_dim == max_dim || runs.len() <= max_dim.min(self.max_dim))
            && (self.equal_groups || (self.max_dim == max_dim && cached()))
    }

    /// The bounds of every group (the space keeps one group fewer when all runs are covered).
    fn bounds_of_groups(&self) -> &[usize] {
        &self.all_bounds
    }

    pub fn dim(&self) -> usize {
        self.weights.len()
    }

    /// When every run of the set is in the space: all its groups as (runs, bounds: group g holds
    /// runs[bounds[g]..bounds[g + 1]]), the last one too (which the space leaves out), and the
    /// weights |group g| / |A| of the first [`CoarseSpace::dim`].
    #[allow(clippy::type_complexity)]
    pub fn covering_groups(&self) -> Option<(&[(usize, usize)], &[usize], &[f64])> {
        self.complete.then_some((&self.runs[..], &self.all_bounds[..], &self.weights[..]))
    }

    fn group(&self, g: usize) -> &[(usize, usize)] {
        &self.runs[self.bounds[g]..self.bounds[g + 1]]
    }

    /// Z0^T v for v supported on the contact set (its sum over the set is `v_total`), into `out`.
    pub fn restrict(&self, v: &[f64], v_total: f64, out: &mut Vec<f64>) {
        out.clear();
        out.extend(
            (0..self.dim())
                .map(|g| self.group(g).iter().map(|&(s, e)| v[s..e].iter().sum::<f64>()).sum::<f64>() - self.weights[g] * v_total),
        );
    }

    /// E^-1 y in place.
    pub fn solve(&self, y: &mut [f64]) {
        cholesky_solve(&self.factor, self.dim(), y);
    }

    /// out += factor * Z0 q on the contact set `mask`.
    pub fn add_prolonged(&self, q: &[f64], factor: f64, mask: &[bool], out: &mut [f64]) {
        let shift: f64 = factor * q.iter().zip(&self.weights).map(|(q, w)| q * w).sum::<f64>();
        for (o, &m) in out.iter_mut().zip(mask) {
            if m {
                *o -= shift;
            }
        }
        for (g, &qg) in q[..self.dim()].iter().enumerate() {
            let value = factor * qg;
            for &(s, e) in self.group(g) {
                out[s..e].iter_mut().for_each(|o| *o += value);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_sums_match_direct_double_sums() {
        let n = 37;
        let kernel = |d: isize| ((d * 7 + 3) as f64).sin() + 0.1 * d as f64;
        let sums = PairSums::new(n, kernel);
        for &(a, b) in &[(0usize, 5usize), (3, 4), (10, 37), (0, 37)] {
            for &(c, d) in &[(0usize, 1usize), (2, 9), (30, 37), (0, 37)] {
                let direct: f64 = (a..b).flat_map(|i| (c..d).map(move |l| (i, l))).map(|(i, l)| kernel(i as isize - l as isize)).sum();
                assert!((sums.block((a, b), (c, d)) - direct).abs() < 1e-10, "{a} {b} {c} {d}");
            }
        }
    }

    #[test]
    fn group_matrix_matches_direct_double_sums() {
        let n = 41;
        // Symmetric, as every compliance kernel is (the matrix is assembled as symmetric).
        let kernel = |d: isize| 1.0 / (1.0 + (d as f64).abs()) - 0.01 * (d * d) as f64;
        let sums = PairSums::new(n, kernel);
        let runs = [(0usize, 3usize), (5, 6), (8, 15), (20, 21), (22, 30), (33, 41)];
        for bounds in [vec![0usize, 1, 2, 3, 4, 5, 6], vec![0, 2, 3, 6], vec![0, 6]] {
            let groups = bounds.len() - 1;
            let g = sums.group_matrix(&runs, &bounds);
            let members = |grp: usize| -> Vec<usize> { runs[bounds[grp]..bounds[grp + 1]].iter().flat_map(|&(s, e)| s..e).collect() };
            for a in 0..groups {
                for b in 0..groups {
                    let direct: f64 =
                        members(a).iter().flat_map(|&i| members(b).into_iter().map(move |l| kernel(i as isize - l as isize))).sum();
                    assert!((g[a * groups + b] - direct).abs() < 1e-9 * direct.abs().max(1.0), "{bounds:?} {a} {b}");
                }
            }
        }
    }

    #[test]
    fn group_cache_updates_only_changed_groups_to_the_direct_sums() {
        let n = 64;
        let kernel = |d: isize| 1.0 / (1.0 + (d as f64).abs()) - 0.01 * (d * d) as f64;
        let sums = PairSums::new(n, kernel);
        let before = [(0usize, 3usize), (5, 6), (8, 15), (20, 21), (22, 30), (33, 41), (45, 50), (55, 64)];
        let bounds = vec![0usize, 2, 4, 6, 8];
        let g = sums.group_matrix(&before, &bounds);
        let starts = vec![0, 8, 22, 45];
        let mut cache = GroupCache { max_dim: 4, starts, runs: before.to_vec(), bounds, g };
        // One run of the second group grows, one of the last shrinks, a run joins the third.
        let after = [(0usize, 3usize), (5, 6), (8, 17), (20, 21), (22, 30), (33, 41), (42, 43), (45, 50), (56, 64)];
        let new_bounds = cache.regroup(&after, 4).expect("every group keeps a run");
        assert_eq!(new_bounds, vec![0, 2, 4, 7, 9]);
        let g = cache.update(&sums, &after, &new_bounds);
        let members = |grp: usize| -> Vec<usize> { after[new_bounds[grp]..new_bounds[grp + 1]].iter().flat_map(|&(s, e)| s..e).collect() };
        for a in 0..4 {
            for b in 0..4 {
                let direct: f64 =
                    members(a).iter().flat_map(|&i| members(b).into_iter().map(move |l| kernel(i as isize - l as isize))).sum();
                assert!((g[a * 4 + b] - direct).abs() < 1e-9 * direct.abs().max(1.0), "{a} {b}");
            }
        }
        // A group left without runs, or another dimension: built afresh.
        assert!(cache.regroup(&after[..7], 4).is_none());
        assert!(cache.regroup(&after, 5).is_none());
    }

    #[test]
    fn runs_of_a_mask() {
        let mask = [true, true, false, true, false, false, true];
        assert_eq!(runs(&mask), vec![(0, 2), (3, 4), (6, 7)]);
        assert!(runs(&[false; 4]).is_empty());
    }
}
