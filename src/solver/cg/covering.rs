//! The deflation step of the inner CG for a coarse space that covers every run of the contact
//! set (issue 18, sixth pass): the projections and the coarse correction in passes over the set's
//! runs, not over all N points.
//!
//! Tried and dropped in the same pass: the coarse right-hand side's group sums of C y without the
//! FFT pair, from the vectors C 1_g on the set (first prefix sums of the kernel, C symmetric):
//! groups x |A| products per iteration plus runs x |A| to build them for every new coarse space.
//! On the road segments (N = 1,000, some 50 groups on 600 points) the products took 4.3 us an
//! iteration against 3.8 us for the FFT pair, and their builds 18 % of the time: 111 FFT pairs
//! per solve instead of 88 (26.9 pairs applied instead of 35.5); used only below 2 N log2 N
//! operations, 91 instead of 88.

use super::mask_bits::mask_and_sum_bits;
use super::precision::steering_product;
use super::Work;
use crate::compliance::Compliance;
use crate::solver::deflation::CoarseSpace;
use crate::solver::reduce::sum4;

/// y = M r made zero off the set and zero-sum on it, then deflated, P^T y = y - Z0 E^-1 Z0^T C y,
/// for a coarse space that covers every run of the set (`w.preconditioned` holds y, `w.mask_bits`
/// the set). One pass over
/// N (the zeroing), the rest over the set's runs only: the mean, then Z0 q per group (each point
/// of the set in one group), and Z0^T C y from the group sums of C y (their total is the sum over
/// the set, with no pass over N).
pub(super) fn deflate_covering<Op: Compliance>(op: &Op, w: &mut Work<Op::Scratch>, coarse: &CoarseSpace, count: usize, low: bool) {
    let (runs, bounds, weights) = coarse.covering_groups().expect("a space covering the set");
    let group = |g: usize| &runs[bounds[g]..bounds[g + 1]];
    let y = &mut w.preconditioned[..];
    let mean = mask_and_sum_bits(y, &w.mask_bits) / count as f64;
    for &(s, e) in runs {
        y[s..e].iter_mut().for_each(|x| *x -= mean);
    }
    steering_product(op, low, y, &mut w.applied, &mut w.scratch);
    w.group_sums.clear();
    let applied = &w.applied;
    w.group_sums.extend((0..bounds.len() - 1).map(|g| group(g).iter().map(|&(s, e)| sum4(&applied[s..e])).sum::<f64>()));
    let total: f64 = w.group_sums.iter().sum();
    let dim = coarse.dim();
    w.coarse_rhs.clear();
    w.coarse_rhs.extend(w.group_sums[..dim].iter().zip(weights).map(|(&s, &wg)| s - wg * total));
    coarse.solve(&mut w.coarse_rhs);
    add_prolonged_covering(coarse, &w.coarse_rhs, -1.0, y);
}

/// out += factor Z0 q for a space that covers every run of the set: factor (q_g - sum_h q_h w_h)
/// on group g (q_g = 0 on the last group, outside the space), in passes over the runs only.
pub(super) fn add_prolonged_covering(coarse: &CoarseSpace, q: &[f64], factor: f64, out: &mut [f64]) {
    let (runs, bounds, weights) = coarse.covering_groups().expect("a space covering the set");
    debug_assert_eq!(q.len(), bounds.len() - 2, "one value per group but the last");
    let shift: f64 = q.iter().zip(weights).map(|(q, wg)| q * wg).sum();
    for (g, group) in bounds.windows(2).enumerate() {
        let value = factor * (q.get(g).copied().unwrap_or(0.0) - shift);
        for &(s, e) in &runs[group[0]..group[1]] {
            out[s..e].iter_mut().for_each(|x| *x += value);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compliance::PeriodicCompliance;
    use crate::kernel::KernelKind;
    use crate::solver::deflation::{runs, PairSums};

    /// The deflated y is zero off the set, sums to zero on it, and is C-orthogonal to the coarse
    /// space (Z0^T C y = 0, from the dense matrix): what A-DEF2's projection P^T must give; with
    /// the low-precision product (single-precision transforms) to single precision, not better.
    #[test]
    fn deflated_vector_is_c_orthogonal_to_the_coarse_space() {
        let n = 64;
        let op = PeriodicCompliance::new(n, 1e-3, KernelKind::Element);
        let sums = PairSums::new(n, |d| op.kernel_at(d), None);
        let mask: Vec<bool> = (0..n).map(|i| matches!(i, 2..=6 | 9 | 14..=22 | 30..=31 | 40..=52 | 60..=63)).collect();
        let count = mask.iter().filter(|&&m| m).count();
        for (max_dim, low) in [(6, false), (3, false), (6, true)] {
            let coarse = CoarseSpace::new(&sums, runs(&mask), &mask, None, max_dim, usize::MAX, &mut None).expect("a coarse space");
            let (runs, bounds, _) = coarse.covering_groups().expect("every run kept");
            let mut w = Work::new(&op);
            w.mask.copy_from_slice(&mask);
            crate::solver::reduce::fill_mask_bits(&mask, &mut w.mask_bits);
            for (i, y) in w.preconditioned.iter_mut().enumerate() {
                *y = ((i * 7) as f64 * 0.31).sin() + 0.4;
            }
            deflate_covering(&op, &mut w, &coarse, count, low);
            let y = &w.preconditioned;
            let scale = y.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
            assert!(y.iter().zip(&mask).all(|(&v, &m)| m || v == 0.0), "zero off the set");
            assert!(y.iter().sum::<f64>().abs() <= 1e-13 * scale * n as f64, "zero-sum on the set");
            let cy: Vec<f64> = (0..n).map(|i| (0..n).map(|j| op.dense_entry(i, j) * y[j]).sum()).collect();
            let c_scale = cy.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
            let on = |g: usize| runs[bounds[g]..bounds[g + 1]].iter().flat_map(|&(s, e)| s..e).map(|i| cy[i]).sum::<f64>();
            let total: f64 = (0..n).filter(|&i| mask[i]).map(|i| cy[i]).sum();
            let bound = if low { 1e-5 } else { 1e-10 } * c_scale * n as f64;
            let mut worst = 0.0f64;
            for g in 0..bounds.len() - 1 {
                let size = runs[bounds[g]..bounds[g + 1]].iter().map(|(s, e)| e - s).sum::<usize>() as f64;
                // Z0_g^T C y = sum over the group - (|g| / |A|) sum over the set.
                let projection = on(g) - size / count as f64 * total;
                assert!(projection.abs() <= bound, "max_dim {max_dim}, low {low}, group {g}: {projection:e}");
                worst = worst.max(projection.abs());
            }
            if low {
                // Single-precision transforms really ran: the projection is off by their rounding.
                assert!(worst > 1e-12 * c_scale * n as f64, "low-precision deflation as exact as double: {worst:e}");
            }
        }
    }

    /// The run-wise deflation is the masked one (`mask_and_project`, `restrict`, `solve`,
    /// `add_prolonged`) to rounding: N odd and not a multiple of 4, a run touching the end, one
    /// vector per run and grouped runs.
    #[test]
    fn run_wise_deflation_is_the_masked_one() {
        for n in [64usize, 67, 1001] {
            let op = PeriodicCompliance::new(n, 1e-3, KernelKind::Element);
            let sums = PairSums::new(n, |d| op.kernel_at(d), None);
            let mask: Vec<bool> = (0..n).map(|i| (i * 7 + i / 5) % 11 < 4 || i + 3 >= n).collect();
            let count = mask.iter().filter(|&&m| m).count();
            let islands = runs(&mask);
            for max_dim in [islands.len(), 5, 2] {
                let coarse = CoarseSpace::new(&sums, islands.clone(), &mask, None, max_dim, usize::MAX, &mut None).expect("a coarse space");
                let start: Vec<f64> = (0..n).map(|i| ((i * 7) as f64 * 0.31).sin() + 0.4).collect();
                let mut w = Work::new(&op);
                w.mask.copy_from_slice(&mask);
                crate::solver::reduce::fill_mask_bits(&mask, &mut w.mask_bits);
                w.preconditioned.copy_from_slice(&start);
                deflate_covering(&op, &mut w, &coarse, count, false);
                // The masked path, as the solver takes it for sets it does not cover.
                let mut y = start.clone();
                crate::solver::reduce::mask_and_project(&mut y, &mask, count);
                let mut cy = vec![0.0; n];
                let mut scratch = op.scratch();
                op.displacement(&y, &mut cy, &mut scratch);
                let total = crate::solver::reduce::masked_sum(&cy, &mask);
                let mut rhs = Vec::new();
                coarse.restrict(&cy, total, &mut rhs);
                coarse.solve(&mut rhs);
                coarse.add_prolonged(&rhs, -1.0, &mask, &mut y);
                let scale = y.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
                let worst = y.iter().zip(&w.preconditioned).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(worst <= 1e-13 * scale, "n {n}, max_dim {max_dim}: {worst:e} of {scale:e}");
            }
        }
    }
}
