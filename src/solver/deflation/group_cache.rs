//! The group matrix kept between the sweeps of one solve, so that the next coarse space sums
//! again only the groups whose runs changed.

use super::{FarField, PairSums};

/// The group matrix of the last grouped coarse space of one solve. Between sweeps most runs of
/// the contact set stay where they were; keeping the groups by position (group g takes the runs
/// that start at or after `starts[g]` and before `starts[g + 1]`) instead of re-splitting them
/// into equal counts, the next space recomputes only the rows of the groups whose runs changed:
/// O(changed runs x runs) instead of O(runs^2). One cache serves one solve only, so that no result
/// depends on an earlier solve.
pub(crate) struct GroupCache {
    pub(super) max_dim: usize,
    pub(super) starts: Vec<usize>,
    pub(super) runs: Vec<(usize, usize)>,
    pub(super) bounds: Vec<usize>,
    pub(super) g: Vec<f64>,
    /// The groups' far field (None: the kernel is summed exactly).
    pub(super) far: Option<FarField>,
}

impl GroupCache {
    /// The bounds of `runs` in the cached groups, or None when a group would be empty or the
    /// dimension differs (then the space is built afresh).
    pub(super) fn regroup(&self, runs: &[(usize, usize)], max_dim: usize) -> Option<Vec<usize>> {
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
    pub(super) fn update(&mut self, pair_sums: &PairSums, runs: &[(usize, usize)], bounds: &[usize]) -> Vec<f64> {
        pair_sums.check_runs(runs);
        let groups = bounds.len() - 1;
        let group = |g: usize| &runs[bounds[g]..bounds[g + 1]];
        let changed: Vec<bool> = (0..groups).map(|g| group(g) != &self.runs[self.bounds[g]..self.bounds[g + 1]]).collect();
        let mut g = std::mem::take(&mut self.g);
        let kept = self.far.take();
        self.far = kept.and_then(|k| pair_sums.far_field(runs, bounds, Some(k), |g| changed[g]));
        let far = self.far.as_ref();
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
                    pair_sums.group_row((runs, &mirrored), bounds, a, b..end, far, &mut g, &mut out);
                }
                b = end + 1;
            }
            if a + 1 < groups {
                pair_sums.group_row((runs, &mirrored), bounds, a, a + 1..groups, far, &mut g, &mut out);
            }
        }
        g
    }
}
