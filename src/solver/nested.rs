//! A coarse-to-fine (nested) initial guess for large cold CG solves, of profiles and of surfaces.
//!
//! The heights are restricted to the same model at half the points along each halved direction and
//! twice the element size (the mean of each block of neighbours: the same area, the same load),
//! solved there, and its pressure prolonged back (each coarse value on every element of its block)
//! as the warm start of the fine solve. The coarse level is itself solved the same way while it is
//! large enough, to a looser tolerance ([`NESTED_TOL`]); only the finest level is solved to the
//! requested one, with the same stopping rule, so the answer meets exactly the test a cold solve
//! meets.
//!
//! A profile is a 1 x N grid whose N is halved ([`Blocks::line`]); a surface's two sides are halved
//! together, 2 x 2 blocks ([`Blocks::grid`]). A side is halved only when even (blocks must not
//! straddle the periodic seam or leave an element over): a profile with an odd N (a prime N from a
//! CAPTIF segment, say) is solved cold at that level; a surface with one odd side is halved along
//! the other one only, and with two odd sides it is solved cold.

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

/// One level's coarsening of a row-major `ny` x `nx` grid: blocks of `fy` rows by `fx` columns
/// (each 1 or 2) become one element of the coarser level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Blocks {
    pub ny: usize,
    pub nx: usize,
    pub fy: usize,
    pub fx: usize,
}

impl Blocks {
    /// A profile of `n` points (`n` even) halved: pairs of neighbours.
    pub fn line(n: usize) -> Self {
        debug_assert!(n % 2 == 0);
        Blocks { ny: 1, nx: n, fy: 1, fx: 2 }
    }

    /// A surface of `ny` x `nx` points halved along each side that is even and keeps at least
    /// `min_side` points; None when neither side can be halved.
    pub fn grid(ny: usize, nx: usize, min_side: usize) -> Option<Self> {
        let halves = |n: usize| n % 2 == 0 && n / 2 >= min_side;
        let (fy, fx) = (1 + halves(ny) as usize, 1 + halves(nx) as usize);
        (fy * fx > 1).then_some(Blocks { ny, nx, fy, fx })
    }

    /// The coarser level's (rows, columns).
    pub fn coarse_shape(&self) -> (usize, usize) {
        (self.ny / self.fy, self.nx / self.fx)
    }
}

/// The heights of the coarser level (m): the mean of each block, relative to their highest (the
/// solvers' convention, see `ContactSolver::solve_with`).
pub(crate) fn restrict(z: &[f64], blocks: Blocks) -> Vec<f64> {
    let Blocks { nx, fy, fx, .. } = blocks;
    debug_assert_eq!(z.len(), blocks.ny * nx);
    let (cy, cx) = blocks.coarse_shape();
    // 1/2 or 1/4: exact.
    let weight = 1.0 / (fy * fx) as f64;
    let row_sum = |row: usize, ix: usize| {
        let start = row * nx + ix * fx;
        if fx == 2 {
            z[start] + z[start + 1]
        } else {
            z[start]
        }
    };
    let mut coarse = Vec::with_capacity(cy * cx);
    for iy in 0..cy {
        for ix in 0..cx {
            let mut sum = row_sum(iy * fy, ix);
            if fy == 2 {
                sum += row_sum(iy * fy + 1, ix);
            }
            coarse.push(sum * weight);
        }
    }
    let top = coarse.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    coarse.into_iter().map(|h| h - top).collect()
}

/// The pressure of the finer level: each coarse value on every element of its block (the same
/// mean).
pub(crate) fn prolong(p: &[f64], blocks: Blocks) -> Vec<f64> {
    let Blocks { ny, nx, fy, fx } = blocks;
    let (cy, cx) = blocks.coarse_shape();
    debug_assert_eq!(p.len(), cy * cx);
    let mut fine = Vec::with_capacity(ny * nx);
    for iy in 0..ny {
        let row = &p[(iy / fy) * cx..(iy / fy + 1) * cx];
        fine.extend((0..nx).map(|ix| row[ix / fx]));
    }
    fine
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restriction_keeps_pairs_and_prolongation_keeps_the_mean() {
        let z = [0.0, -2.0, -1.0, -3.0, -4.0, -4.0];
        assert_eq!(restrict(&z, Blocks::line(6)), vec![0.0, -1.0, -3.0]);
        let p = [1.0, 0.0, 2.5];
        let fine = prolong(&p, Blocks::line(6));
        assert_eq!(fine, vec![1.0, 1.0, 0.0, 0.0, 2.5, 2.5]);
        assert_eq!(fine.iter().sum::<f64>() / 6.0, p.iter().sum::<f64>() / 3.0);
    }

    #[test]
    fn surfaces_are_averaged_over_blocks_and_odd_sides_are_kept() {
        // 4 x 4: 2 x 2 blocks.
        let z: Vec<f64> = (0..16).map(|i| -(i as f64)).collect();
        let blocks = Blocks::grid(4, 4, 2).unwrap();
        assert_eq!((blocks.fy, blocks.fx), (2, 2));
        // Block means -2.5, -4.5, -10.5, -12.5, relative to the highest.
        assert_eq!(restrict(&z, blocks), vec![0.0, -2.0, -8.0, -10.0]);
        assert_eq!(
            prolong(&[1.0, 2.0, 3.0, 4.0], blocks),
            vec![1.0, 1.0, 2.0, 2.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0, 4.0, 4.0, 3.0, 3.0, 4.0, 4.0]
        );
        // 3 x 4: the odd side (rows) is kept, the columns are halved.
        let blocks = Blocks::grid(3, 4, 2).unwrap();
        assert_eq!((blocks.fy, blocks.fx, blocks.coarse_shape()), (1, 2, (3, 2)));
        assert_eq!(restrict(&z[..12], blocks), vec![0.0, -2.0, -4.0, -6.0, -8.0, -10.0]);
        // 4 x 5: rows halved only; 5 x 7: none; a half below the smallest side: not halved.
        assert_eq!(Blocks::grid(4, 5, 2).map(|b| (b.fy, b.fx)), Some((2, 1)));
        assert_eq!(Blocks::grid(5, 7, 2), None);
        assert_eq!(Blocks::grid(6, 8, 4).map(|b| (b.fy, b.fx)), Some((1, 2)));
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
