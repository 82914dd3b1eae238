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
//! prefix sums of the kernel each entry costs O(1), so E costs O(islands^2), never an FFT. When the
//! islands are grouped (many per coarse vector), two groups far apart meet through an interpolated
//! kernel instead ([`super::far_field`]): O(groups^2) beyond the neighbours of each group.

use super::factor::{cholesky, cholesky_solve};
use super::far_field::{Expansion, FarField, Lattice, Singular, NODES};

mod group_cache;
mod sums;
pub(crate) use group_cache::GroupCache;
use sums::{coarse_matrix, mirror_upper, row_sums, tile_sums};

/// Second prefix sums of a kernel c(d), d in (-N, N), for sums of c(i - l) over interval pairs.
pub(crate) struct PairSums {
    /// Unique per instance: a coarse space kept in a workspace is reused only with the sums it
    /// was built from.
    id: u64,
    n: usize,
    /// H(k) for k in [1 - N, N + 1], stored at k + N - 1.
    second: Vec<f64>,
    /// c(d) for d in [0, N) (the kernels are even), read by the far field; empty without it.
    kernel: Vec<f64>,
    /// The kernel's singular offsets when groups far apart are summed through their expansions
    /// ([`super::far_field`]); None: every entry is summed exactly.
    far: Option<Singular>,
}

impl PairSums {
    /// The sums of the kernel `kernel_at` (d in (-N, N)), with the far field for `far` (a kernel
    /// smooth between integers off those singular offsets; None for one that is not, such as the
    /// spectral kernel).
    pub fn new(n: usize, kernel_at: impl Fn(isize) -> f64, far: Option<Singular>) -> Self {
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
        let kernel: Vec<f64> = if far.is_some() { (0..ni).map(&kernel_at).collect() } else { Vec::new() };
        Self { id, n, second, kernel, far }
    }

    /// The far field of the groups (group g holds runs[bounds[g]..bounds[g + 1]]): `kept`'s lattice
    /// and its expansions of the groups that have not `changed`, when given; None when the kernel
    /// is summed exactly.
    fn far_field(
        &self,
        runs: &[(usize, usize)],
        bounds: &[usize],
        kept: Option<FarField>,
        changed: impl Fn(usize) -> bool,
    ) -> Option<FarField> {
        let singular = self.far?;
        let (lattice, old) = match kept {
            Some(FarField { lattice, expansions, .. }) => (lattice, expansions),
            None => (Lattice::new(&self.kernel, Lattice::step_for(runs, bounds)), Vec::new()),
        };
        let mut old: Vec<Option<Expansion>> = old.into_iter().map(Some).collect();
        let step = lattice.step();
        let expansions = bounds
            .windows(2)
            .enumerate()
            .map(|(g, w)| match old.get_mut(g).filter(|_| !changed(g)).and_then(Option::take) {
                Some(e) => e,
                None => Expansion::new(&runs[w[0]..w[1]], step, self.n),
            })
            .collect();
        Some(FarField { expansions, lattice, singular })
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
    /// and, when `mirror`, its mirror (column a); `out` is scratch. Groups far from a (see
    /// [`super::far_field`]) take their entries from the far field; the others, in maximal ranges,
    /// are summed exactly.
    fn group_row(&self, groups: &Groups<'_>, a: usize, range: std::ops::Range<usize>, g: &mut [f64], out: &mut Vec<f64>, mirror: bool) {
        let Groups { runs, mirrored, bounds, far } = *groups;
        let groups = bounds.len() - 1;
        let tile = &runs[bounds[a]..bounds[a + 1]];
        let is_far = |b: usize| far.is_some_and(|f| f.is_far(a, b, self.n));
        let mut b = range.start;
        while b < range.end {
            if let Some(f) = far.filter(|_| is_far(b)) {
                let value = f.far_sum(a, b);
                g[a * groups + b] = value;
                if mirror {
                    g[b * groups + a] = value;
                }
                b += 1;
                continue;
            }
            let end = (b + 1..range.end).find(|&e| is_far(e)).unwrap_or(range.end);
            self.tile_sums(tile, mirrored, &bounds[b..=end], out);
            for (c, sums) in (b..end).zip(out.chunks_exact(tile.len())) {
                // The tile's runs added in order (as `Iterator::sum` does).
                let value: f64 = sums.iter().sum();
                g[a * groups + c] = value;
                if mirror {
                    g[c * groups + a] = value;
                }
            }
            b = end;
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
    pub fn group_matrix(&self, runs: &[(usize, usize)], bounds: &[usize], far: Option<&FarField>) -> Vec<f64> {
        let groups = bounds.len() - 1;
        self.check_runs(runs);
        let mut g = vec![0.0; groups * groups];
        let mut out = Vec::new();
        let mirrored = self.mirrored(runs);
        let all = Groups { runs, mirrored: &mirrored, bounds, far };
        if far.is_none() && groups == runs.len() {
            // One run a group (every road segment's space below `coarse_dim`'s cap): each row's
            // entries are one block each, summed straight into the row in one pass of `tile_sums`
            // (the values `group_row` gives, -0.0 + x being x, without its per-row bookkeeping).
            let single: Vec<usize> = (0..=groups).collect();
            for a in 0..groups {
                g[a * groups + a] = self.diagonal_entry(&runs[a..a + 1], &mirrored[a..a + 1]);
                let row = &mut g[a * groups + a + 1..(a + 1) * groups];
                tile_sums(&self.second, self.n, &runs[a..a + 1], &mirrored, &single[a + 1..], row);
            }
        } else {
            for ga in 0..groups {
                let members = bounds[ga]..bounds[ga + 1];
                g[ga * groups + ga] = self.diagonal_entry(&runs[members.clone()], &mirrored[members]);
                if ga + 1 < groups {
                    self.group_row(&all, ga, ga + 1..groups, &mut g, &mut out, false);
                }
            }
        }
        // The lower triangle from the upper, by blocks (a column written entry by entry as the
        // rows are summed strides the whole matrix once per row).
        mirror_upper(&mut g, groups);
        g
    }

    /// sum over i in [a, b), l in [c, d) of c(i - l); all bounds in [0, N].
    #[cfg(test)]
    pub fn block(&self, (a, b): (usize, usize), (c, d): (usize, usize)) -> f64 {
        let (a, b, c, d) = (a as isize, b as isize, c as isize, d as isize);
        self.h(b - c + 1) - self.h(a - c + 1) - self.h(b - d + 1) + self.h(a - d + 1)
    }
}

/// Groups of runs as the group matrix is summed: runs [start, end), their [`PairSums::mirrored`]
/// form, group g holding runs[bounds[g]..bounds[g + 1]], and the groups' far field if any.
pub(crate) struct Groups<'a> {
    pub runs: &'a [(usize, usize)],
    pub mirrored: &'a [(usize, usize)],
    pub bounds: &'a [usize],
    pub far: Option<&'a FarField>,
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
        let (bounds, g_matrix, far) = match (regrouped, kept) {
            (Some(bounds), Some(mut c)) => {
                let g = c.update(pair_sums, &runs, &bounds);
                (bounds, g, c.far)
            }
            _ => {
                let bounds: Vec<usize> = (0..=groups).map(|g| g * runs.len() / groups).collect();
                // Groups of a few runs gain nothing from the far field (an entry of fewer than NODES^2
                // blocks is cheaper exact), and building it costs O(set) (at N = 1,000, more than
                // the whole matrix): none then, for the rest of the solve too (the cache keeps it).
                let far = if runs.len() > NODES * groups { pair_sums.far_field(&runs, &bounds, None, |_| true) } else { None };
                let g = pair_sums.group_matrix(&runs, &bounds, far.as_ref());
                (bounds, g, far)
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
            let row = row_sums(&g_matrix, groups);
            let total = row.iter().sum();
            (row, total)
        } else {
            let u = displacement_of_set.expect("C 1_A is needed when some runs are left out");
            let row = (0..groups).map(|g| runs[bounds[g]..bounds[g + 1]].iter().map(|&(s, e)| u[s..e].iter().sum::<f64>()).sum()).collect();
            let total = u.iter().zip(mask).filter(|(_, &m)| m).map(|(u, _)| u).sum();
            (row, total)
        };
        // E (symmetric, so row- and column-major alike), then its Cholesky factor.
        let factor = cholesky(coarse_matrix(&g_matrix, groups, columns, &row, &weights, total), columns);
        if grouped {
            let mut starts: Vec<usize> = bounds[..groups].iter().map(|&j| runs[j].0).collect();
            starts[0] = 0;
            *cache = Some(GroupCache { max_dim, starts, runs: runs.clone(), bounds: bounds.clone(), g: g_matrix, far });
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
        let sums = PairSums::new(n, kernel, None);
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
        let sums = PairSums::new(n, kernel, None);
        let runs = [(0usize, 3usize), (5, 6), (8, 15), (20, 21), (22, 30), (33, 41)];
        for bounds in [vec![0usize, 1, 2, 3, 4, 5, 6], vec![0, 2, 3, 6], vec![0, 6]] {
            let groups = bounds.len() - 1;
            let g = sums.group_matrix(&runs, &bounds, None);
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
    fn the_matrix_is_symmetric_and_its_row_sums_are_each_rows_own_sum_bitwise() {
        // Sizes across the mirror's blocks (32): the lower triangle is the upper's, entry for
        // entry, and the column-wise sums are the rows' own sums (Iterator::sum) to the bit.
        let kernel = |d: isize| 1.0 / (1.0 + (d as f64).abs()).sqrt() + 0.3 * (0.7 * d as f64).cos();
        for count in [2usize, 31, 32, 33, 70] {
            let n = 4 * count + 3;
            let sums = PairSums::new(n, kernel, None);
            let runs: Vec<(usize, usize)> = (0..count).map(|j| (4 * j + 1, 4 * j + 2 + j % 3)).collect();
            let bounds: Vec<usize> = (0..=count).collect();
            let g = sums.group_matrix(&runs, &bounds, None);
            for a in 0..count {
                for b in 0..count {
                    assert_eq!(g[a * count + b].to_bits(), g[b * count + a].to_bits(), "{count}: ({a}, {b})");
                }
            }
            let rows = row_sums(&g, count);
            for (a, row) in rows.iter().enumerate() {
                let own: f64 = g[a * count..(a + 1) * count].iter().sum();
                assert_eq!(row.to_bits(), own.to_bits(), "{count}: row {a}");
            }
        }
    }

    #[test]
    fn single_run_matrices_are_the_tile_sums_bit_for_bit() {
        let n = 500;
        let kernel = |d: isize| 1.0 / (1.0 + (d as f64).abs()).sqrt() - 1e-5 * (d * d) as f64;
        let sums = PairSums::new(n, kernel, None);
        let runs: Vec<(usize, usize)> = (0..90).map(|j| (5 * j + 2, 5 * j + 3 + j % 3)).chain([(460, 500)]).collect();
        let count = runs.len();
        let g = sums.group_matrix(&runs, &(0..=count).collect::<Vec<_>>(), None);
        let mirrored = sums.mirrored(&runs);
        for a in 0..count {
            let diagonal = sums.diagonal_entry(&runs[a..a + 1], &mirrored[a..a + 1]);
            assert_eq!(g[a * count + a].to_bits(), diagonal.to_bits(), "({a}, {a})");
            for b in a + 1..count {
                let summed: f64 = [sums.sum_over(runs[a], &mirrored[b..b + 1])].iter().sum();
                assert_eq!(g[a * count + b].to_bits(), summed.to_bits(), "({a}, {b})");
                assert_eq!(g[b * count + a].to_bits(), summed.to_bits(), "({b}, {a})");
            }
        }
    }

    #[test]
    fn grouped_matrices_add_their_blocks_in_order_bit_for_bit() {
        // Groups of one and two runs (the branch-free path) and with a group of three (the
        // general one): entry (a, b) is, from -0.0, the sum over a's runs in order of each one's
        // sum, from -0.0, of its blocks against b's runs in order.
        let n = 400;
        let kernel = |d: isize| 1.0 / (1.0 + (d as f64).abs()).sqrt() + 0.2 * (0.3 * d as f64).sin();
        let sums = PairSums::new(n, kernel, None);
        let runs: Vec<(usize, usize)> = (0..60).map(|j| (6 * j + 1, 6 * j + 3 + j % 4)).collect();
        let h = |k: usize| sums.second[k];
        let block = |(s, e): (usize, usize), (c, d): (usize, usize)| (h(e + n - c) - h(s + n - c)) - (h(e + n - d) - h(s + n - d));
        let sizes_small: Vec<usize> = (0..60)
            .scan(0, |at, j| {
                (*at < 60).then(|| {
                    *at = (*at + 1 + (j * 7 % 3 == 0) as usize).min(60);
                    *at
                })
            })
            .collect();
        let mut sizes_mixed = sizes_small.clone();
        sizes_mixed.remove(3);
        for ends in [sizes_small, sizes_mixed] {
            let bounds: Vec<usize> = std::iter::once(0).chain(ends).collect();
            let groups = bounds.len() - 1;
            let g = sums.group_matrix(&runs, &bounds, None);
            for a in 0..groups {
                for b in a + 1..groups {
                    let expected = runs[bounds[a]..bounds[a + 1]]
                        .iter()
                        .map(|&j| runs[bounds[b]..bounds[b + 1]].iter().fold(-0.0, |acc, &l| acc + block(j, l)))
                        .fold(-0.0, |acc, v| acc + v);
                    assert_eq!(g[a * groups + b].to_bits(), expected.to_bits(), "{groups} groups: ({a}, {b})");
                    assert_eq!(g[b * groups + a].to_bits(), expected.to_bits(), "{groups} groups: ({b}, {a})");
                }
            }
        }
    }

    #[test]
    fn runs_of_a_mask() {
        let mask = [true, true, false, true, false, false, true];
        assert_eq!(runs(&mask), vec![(0, 2), (3, 4), (6, 7)]);
        assert!(runs(&[false; 4]).is_empty());
    }
}
