//! The group matrix kept between the sweeps of one solve, so that the next coarse space sums
//! again only the groups whose runs changed.

use super::{FarField, Groups, PairSums};

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
        let mut out = Vec::new();
        let mirrored = pair_sums.mirrored(runs);
        let all = Groups { runs, mirrored: &mirrored, bounds, far: self.far.as_ref() };
        for a in (0..groups).filter(|&a| changed[a]) {
            g[a * groups + a] = pair_sums.diagonal_entry(group(a), &mirrored[bounds[a]..bounds[a + 1]]);
            // Row a against every group but the changed ones before it (their rows did it): the
            // unchanged groups before a in maximal ranges, then all groups after it.
            let mut b = 0;
            while b < a {
                let end = (b..a).find(|&e| changed[e]).unwrap_or(a);
                if end > b {
                    pair_sums.group_row(&all, a, b..end, &mut g, &mut out, true);
                }
                b = end + 1;
            }
            if a + 1 < groups {
                pair_sums.group_row(&all, a, a + 1..groups, &mut g, &mut out, true);
            }
        }
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::far_field::Singular;

    #[test]
    fn group_cache_updates_only_changed_groups_to_the_direct_sums() {
        let n = 64;
        let kernel = |d: isize| 1.0 / (1.0 + (d as f64).abs()) - 0.01 * (d * d) as f64;
        let sums = PairSums::new(n, kernel, None);
        let before = [(0usize, 3usize), (5, 6), (8, 15), (20, 21), (22, 30), (33, 41), (45, 50), (55, 64)];
        let bounds = vec![0usize, 2, 4, 6, 8];
        let g = sums.group_matrix(&before, &bounds, None);
        let starts = vec![0, 8, 22, 45];
        let mut cache = GroupCache { max_dim: 4, starts, runs: before.to_vec(), bounds, g, far: None };
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
    fn far_field_group_matrices_match_direct_double_sums_fresh_and_updated() {
        // Many runs per group, as at N = 2^20 (some 30), so that far groups take the expansions;
        // both models (the finite one has no singular offset at +-N).
        let n = 8192;
        let mut state = 12345u64;
        let mut next = |m: u64| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % m) as usize
        };
        let mut before = Vec::new();
        let mut at = 3;
        while at + 30 < n {
            let len = 1 + next(8);
            before.push((at, at + len));
            at += len + 2 + next(18);
        }
        let periodic = crate::compliance::PeriodicCompliance::new(n, 1e-4, crate::kernel::KernelKind::Element);
        let finite = crate::compliance::FiniteCompliance::new(n, 1e-4);
        let kernels: [(Vec<f64>, Singular); 2] = [
            ((1 - n as isize..n as isize).map(|d| periodic.kernel_at(d)).collect(), Singular::Periodic),
            ((1 - n as isize..n as isize).map(|d| finite.kernel_at(d)).collect(), Singular::AtZero),
        ];
        for (kernel, singular) in &kernels {
            let c = |d: isize| kernel[(d + n as isize - 1) as usize];
            let sums = PairSums::new(n, c, Some(*singular));
            let groups = 16;
            let bounds: Vec<usize> = (0..=groups).map(|g| g * before.len() / groups).collect();
            let check = |runs: &[(usize, usize)], bounds: &[usize], g: &[f64]| {
                let members = |grp: usize| -> Vec<usize> { runs[bounds[grp]..bounds[grp + 1]].iter().flat_map(|&(s, e)| s..e).collect() };
                let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for a in 0..groups {
                    for b in 0..groups {
                        let direct: f64 =
                            members(a).iter().flat_map(|&i| members(b).into_iter().map(move |l| c(i as isize - l as isize))).sum();
                        assert!(
                            (g[a * groups + b] - direct).abs() < 1e-10 * scale,
                            "{singular:?} {a} {b}: {} vs {direct}",
                            g[a * groups + b]
                        );
                    }
                }
            };
            let far = sums.far_field(&before, &bounds, None, |_| true);
            let f = far.as_ref().unwrap();
            assert!(f.lattice.step() > 1, "the lattice test needs a step above 1");
            let far_pairs = (0..groups).flat_map(|a| (0..groups).map(move |b| (a, b))).filter(|&(a, b)| f.is_far(a, b, n)).count();
            assert!(far_pairs > groups * groups / 3, "{far_pairs} far pairs of {}", groups * groups);
            let g = sums.group_matrix(&before, &bounds, far.as_ref());
            check(&before, &bounds, &g);
            // Edges move in a few groups: the cached rows of the others are kept, the changed ones
            // summed again (their expansions rebuilt on the same lattice).
            let starts: Vec<usize> = bounds[..groups].iter().map(|&j| if j == 0 { 0 } else { before[j].0 }).collect();
            let mut cache = GroupCache { max_dim: groups, starts, runs: before.clone(), bounds, g, far };
            let mut after = before.clone();
            for j in [5usize, 170, 171, 400] {
                after[j].1 += 1;
            }
            let new_bounds = cache.regroup(&after, groups).expect("every group keeps its runs");
            let g = cache.update(&sums, &after, &new_bounds);
            check(&after, &new_bounds, &g);
        }
    }
}
