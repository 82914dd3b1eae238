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

use super::Work;
use crate::compliance::Compliance;
use crate::solver::deflation::CoarseSpace;
use crate::solver::reduce::{mask_and_sum, sum4};

/// y = M r made zero off the set and zero-sum on it, then deflated, P^T y = y - Z0 E^-1 Z0^T C y,
/// for a coarse space that covers every run of the set (`w.preconditioned` holds y). One pass over
/// N (the zeroing), the rest over the set's runs only: the mean, then Z0 q per group (each point
/// of the set in one group), and Z0^T C y from the group sums of C y (their total is the sum over
/// the set, with no pass over N).
pub(super) fn deflate_covering<Op: Compliance>(op: &Op, w: &mut Work<Op::Scratch>, coarse: &CoarseSpace, count: usize) {
    let (runs, bounds, weights) = coarse.covering_groups().expect("a space covering the set");
    let groups = bounds.len() - 1;
    let group = |g: usize| &runs[bounds[g]..bounds[g + 1]];
    let y = &mut w.preconditioned[..];
    let mean = mask_and_sum(y, &w.mask) / count as f64;
    for &(s, e) in runs {
        y[s..e].iter_mut().for_each(|x| *x -= mean);
    }
    op.displacement(y, &mut w.applied, &mut w.scratch);
    w.group_sums.clear();
    let applied = &w.applied;
    w.group_sums.extend((0..groups).map(|g| group(g).iter().map(|&(s, e)| sum4(&applied[s..e])).sum::<f64>()));
    let total: f64 = w.group_sums.iter().sum();
    let dim = coarse.dim();
    w.coarse_rhs.clear();
    w.coarse_rhs.extend(w.group_sums[..dim].iter().zip(weights).map(|(&s, &wg)| s - wg * total));
    coarse.solve(&mut w.coarse_rhs);
    // y -= Z0 q: q_g on group g (0 on the last, outside the space), less sum_g q_g w_g on the set.
    let shift: f64 = w.coarse_rhs.iter().zip(weights).map(|(q, wg)| q * wg).sum();
    for g in 0..groups {
        let value = shift - w.coarse_rhs.get(g).copied().unwrap_or(0.0);
        for &(s, e) in group(g) {
            y[s..e].iter_mut().for_each(|x| *x += value);
        }
    }
}
