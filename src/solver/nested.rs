//! A coarse-to-fine (nested) initial guess for large cold CG solves.
//!
//! The profile is restricted to the same model at half the points and twice the element width (the
//! mean of each pair of neighbours: the same length, the same load), solved there, and its pressure
//! prolonged back (each coarse value on both of its fine elements) as the warm start of the fine
//! solve. The coarse level is itself solved the same way while it is large enough, to a looser
//! tolerance ([`NESTED_TOL`]); only the finest level is solved to the requested one, with the same
//! stopping rule, so the answer meets exactly the test a cold solve meets.
//!
//! A level is halved only when its N is even (pairs must not straddle the periodic seam or leave an
//! element over): an odd N (a prime N from a CAPTIF segment, say) is solved cold at that level.

/// Cold CG solves of at least this many points (and every coarser level down to half of it) start
/// from the nested guess; the coarsest level, below it, is solved cold.
///
/// Self-affine profiles (seeds 0-2), one thread: see README "Performance", fourth pass.
pub const NESTED_MIN_ELEMENTS: usize = 1 << 14;

/// The tolerance of the coarser levels (when the requested one is looser, that one): a looser one
/// (1e-3) left the fine level more iterations to do than it saved below.
pub const NESTED_TOL: f64 = 1e-4;

/// Whether a cold solve of `n` points, with nesting from `min_elements` on, starts from a coarser
/// level.
pub(crate) fn nests(n: usize, min_elements: usize) -> bool {
    n >= min_elements && n % 2 == 0 && n / 2 >= super::MIN_ELEMENTS
}

/// The heights of the coarser level (m): the mean of each pair of neighbours, relative to their
/// highest (the solver's convention, see `ContactSolver::solve_with`). `z.len()` must be even.
pub(crate) fn restrict(z: &[f64]) -> Vec<f64> {
    debug_assert!(z.len() % 2 == 0);
    let coarse: Vec<f64> = z.chunks_exact(2).map(|pair| 0.5 * (pair[0] + pair[1])).collect();
    let top = coarse.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    coarse.into_iter().map(|h| h - top).collect()
}

/// The pressure of the finer level: each coarse value on both of its elements (the same mean).
pub(crate) fn prolong(p: &[f64]) -> Vec<f64> {
    p.iter().flat_map(|&x| [x, x]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restriction_keeps_pairs_and_prolongation_keeps_the_mean() {
        let z = [0.0, -2.0, -1.0, -3.0, -4.0, -4.0];
        assert_eq!(restrict(&z), vec![0.0, -1.0, -3.0]);
        let p = [1.0, 0.0, 2.5];
        let fine = prolong(&p);
        assert_eq!(fine, vec![1.0, 1.0, 0.0, 0.0, 2.5, 2.5]);
        assert_eq!(fine.iter().sum::<f64>() / 6.0, p.iter().sum::<f64>() / 3.0);
    }

    #[test]
    fn only_even_sizes_above_the_threshold_nest() {
        assert!(nests(1 << 16, 1 << 15));
        assert!(!nests((1 << 16) + 1, 1 << 15));
        assert!(!nests(1 << 14, 1 << 15));
        assert!(!nests(14, 8));
        assert!(nests(16, 8));
    }
}
