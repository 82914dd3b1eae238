//! Far-field sums for the coarse matrix: two groups of contact runs far apart meet through an
//! interpolated kernel instead of through every pair of their runs.
//!
//! An entry of the group matrix is G[a, b] = sum over i in group a, l in group b of c(i - l). When
//! the offsets i - l the two groups span stay [`SEPARATION`] half-widths away from every offset
//! where the kernel is singular (0, and +-N for the periodic model), c(x - y) is smooth in x over
//! a's points and in y over b's. Interpolating it in both at [`NODES`] integer points near the
//! Chebyshev points of each group's range,
//!
//!   c(x - y) ~ sum_s sum_t c(x_s - y_t) L_s(x) M_t(y),
//!
//! gives G[a, b] ~ sum_s sum_t m_a(s) c(x_s - y_t) m_b(t) with the moments m_a(s) = sum over the
//! points i of a of L_s(i): NODES^2 kernel values instead of runs_a x runs_b block sums (at
//! N = 2^20, some 30 x 30 runs per group and 1,024 groups, the assembly was a third of a solve).
//! The nodes are integers, so every value is one the kernel table holds, and the interpolation
//! reproduces constants exactly (the zero-sum coarse vectors do not see the kernel's mean).
//!
//! The error: for a kernel analytic off its singular offsets (the element kernels, built from
//! logarithms and Clausen functions), Chebyshev interpolation of degree NODES - 1 converges as
//! rho^-NODES with rho = 1 + S + sqrt((1 + S)^2 - 1) = 13.9 at S = 6: some 1e-9 of an entry. A
//! kernel that is not smooth between integers (the spectral kernel: its sharp cut-off at the
//! Nyquist wavenumber leaves a tail alternating in sign) fails [`smooth_enough`], and its matrix is
//! summed exactly. The coarse matrix only shapes the deflation: the stopping rule is tested on
//! fresh products, so an interpolated entry changes iteration counts at most, never the answer's
//! accuracy.

use std::f64::consts::PI;

/// Interpolation points per group (polynomial degree NODES - 1).
pub(crate) const NODES: usize = 8;

/// How far apart two groups must be: the offsets they span stay at least SEPARATION times the
/// larger half-width away from every singular offset of the kernel.
pub(crate) const SEPARATION: f64 = 6.0;

/// Largest relative error of an interpolated entry, on a test pair at the separation limit, for a
/// kernel to be summed with the far field ([`smooth_enough`]).
const MAX_TEST_ERROR: f64 = 1e-8;

/// One group's interpolation: the points it spans, its nodes and their moments.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Expansion {
    /// The group's points and nodes lie in [lo, hi).
    lo: usize,
    hi: usize,
    /// The interpolation points, multiples of the lattice step, decreasing: node / step.
    cells: Vec<usize>,
    /// m(s) = sum over the group's points i of L_s(i).
    moments: Vec<f64>,
    /// Runs of contact in the group (what an exact entry costs); 0 when the group has no
    /// expansion (fewer than NODES lattice points across it): its entries are summed exactly.
    runs: usize,
}

impl Expansion {
    /// The expansion of a group of runs [start, end) (in order, not empty, inside [0, N)) on the
    /// lattice of `step` points: Chebyshev points of its range rounded to multiples of `step`.
    pub fn new(runs: &[(usize, usize)], step: usize, n: usize) -> Self {
        let (lo, hi) = (runs[0].0, runs[runs.len() - 1].1);
        let span = hi - lo;
        let count = runs.len();
        if step == 1 && span <= NODES {
            // Every point a node: the moments are the indicator itself (exact).
            let cells: Vec<usize> = (lo..hi).rev().collect();
            let mut moments = vec![0.0; span];
            for &(s, e) in runs {
                (s..e).for_each(|i| moments[hi - 1 - i] += 1.0);
            }
            return Self { lo, hi, cells, moments, runs: count };
        }
        let centre = (lo + hi - 1) as f64 / 2.0;
        let half = (hi - 1 - lo) as f64 / 2.0;
        let last_cell = (n - 1) / step;
        let mut cells: Vec<usize> = (0..NODES)
            .map(|s| ((centre + half * ((2 * s + 1) as f64 * PI / (2 * NODES) as f64).cos()) / step as f64).round() as usize)
            .map(|c| c.min(last_cell))
            .collect();
        cells.dedup();
        if cells.len() < NODES {
            return Self { lo, hi, cells: Vec::new(), moments: Vec::new(), runs: 0 };
        }
        let nodes: Vec<usize> = cells.iter().map(|&c| c * step).collect();
        // Normalised coordinates u = (x - centre) / half-width, about [-1, 1].
        let u: Vec<f64> = nodes.iter().map(|&x| (x as f64 - centre) / half).collect();
        let q = nodes.len();
        // Barycentric weights 1 / prod_{t != s} (u_s - u_t): L_s(u) = l(u) w_s / (u - u_s), l = prod (u - u_t).
        let weights: Vec<f64> = (0..q).map(|s| 1.0 / (0..q).filter(|&t| t != s).map(|t| u[s] - u[t]).product::<f64>()).collect();
        let mut moments = vec![0.0; q];
        for &(s, e) in runs {
            for i in s..e {
                if let Some(k) = nodes.iter().position(|&x| x == i) {
                    moments[k] += 1.0;
                    continue;
                }
                let x = (i as f64 - centre) / half;
                let ell: f64 = u.iter().map(|&ut| x - ut).product();
                for k in 0..q {
                    moments[k] += ell * weights[k] / (x - u[k]);
                }
            }
        }
        let (lo, hi) = (lo.min(nodes[q - 1]), hi.max(nodes[0] + 1));
        Self { lo, hi, cells, moments, runs: count }
    }

    /// Whether G[a, b] is taken from the expansions: both have one, the groups are far apart (see
    /// the module docs; `n` the kernel's size, whose offsets 0 and +-N are singular) and the
    /// interpolation costs fewer kernel values than the exact entry costs blocks.
    pub fn is_far(&self, other: &Self, n: usize) -> bool {
        if self.cells.len() * other.cells.len() >= self.runs * other.runs {
            return false;
        }
        // Offsets x - y span [lo, hi].
        let lo = self.lo as isize - (other.hi as isize - 1);
        let hi = self.hi as isize - 1 - other.lo as isize;
        let n = n as isize;
        let distance = [-n, 0, n].iter().map(|&s| (lo - s).max(s - hi).max(0)).min().unwrap_or(0);
        let half_width = (self.hi - self.lo).max(other.hi - other.lo) as f64 / 2.0;
        distance as f64 >= SEPARATION * half_width
    }

    /// The interpolated G[a, b] of this group a and `other` b, both on `lattice`.
    pub fn far_sum(&self, other: &Self, lattice: &Lattice) -> f64 {
        let last = lattice.values.len() - 1;
        assert!(self.cells.iter().chain(&other.cells).all(|&c| c <= lattice.offset) && 2 * lattice.offset == last);
        let mut total = 0.0;
        for (&x, &ma) in self.cells.iter().zip(&self.moments) {
            // c((x - y) step) sits at x - y + offset: from x on, at offset - y.
            let column = &lattice.values[x..];
            let mut row = 0.0;
            for (&y, &mb) in other.cells.iter().zip(&other.moments) {
                // SAFETY: x, y <= offset (asserted above), so x + offset - y <= 2 offset, inside the
                // values. Unchecked: the far field's hot loop.
                row += unsafe { column.get_unchecked(lattice.offset - y) } * mb;
            }
            total += ma * row;
        }
        total
    }
}

/// The kernel on a lattice of `step` points: values[m + offset] = c(m step), |m step| < N. Coarse
/// enough, it fits the cache, where the whole kernel (16 MiB at N = 2^20) does not: the far field's
/// reads of it were a tenth of a 2^20 solve.
pub(crate) struct Lattice {
    step: usize,
    offset: usize,
    values: Vec<f64>,
}

impl Lattice {
    /// `kernel[d + N - 1]` = c(d) for -N < d < N.
    pub fn new(kernel: &[f64], n: usize, step: usize) -> Self {
        let offset = (n - 1) / step;
        let values = (0..=2 * offset).map(|j| kernel[j * step + (n - 1) - offset * step]).collect();
        Self { step, offset, values }
    }

    /// The lattice step for groups of runs (group g holds runs[bounds[g]..bounds[g + 1]]): the
    /// largest power of two at most a sixteenth of the tenth-percentile group span (NODES
    /// Chebyshev points rounded to it stay distinct and close to their places), at least 1.
    pub fn step_for(runs: &[(usize, usize)], bounds: &[usize]) -> usize {
        let mut spans: Vec<usize> = bounds.windows(2).map(|w| runs[w[1] - 1].1 - runs[w[0]].0).collect();
        spans.sort_unstable();
        let short = spans[spans.len() / 10] / 16;
        if short < 2 {
            1
        } else {
            1 << (usize::BITS - 1 - short.leading_zeros())
        }
    }

    pub fn step(&self) -> usize {
        self.step
    }
}

/// The groups' expansions on one lattice.
pub(crate) struct FarField {
    pub expansions: Vec<Expansion>,
    pub lattice: Lattice,
}

/// Whether the far field may be used with this kernel (`kernel[d + N - 1]` = c(d), `exact(a, b)` the
/// exact G entry of two groups of runs): an interpolated entry of two groups of single points three
/// apart (contiguous runs would hide a tail alternating in sign) at the separation limit is within
/// [`MAX_TEST_ERROR`] of the exact one, relative to the exact entry, at two widths.
pub(crate) fn smooth_enough(kernel: &[f64], n: usize, exact: impl Fn(&[(usize, usize)], &[(usize, usize)]) -> f64) -> bool {
    let mut tested = false;
    // Two widths: the shortest groups it serves, and wider ones (at most 480 points: the exact
    // entry of the test costs (width / 3)^2 blocks).
    for width in [6 * NODES, (n / 64).min(60 * NODES)] {
        let gap = (SEPARATION * width as f64 / 2.0).ceil() as usize + 1;
        let comb = |start: usize| -> Vec<(usize, usize)> { (start..start + width).step_by(3).map(|i| (i, i + 1)).collect() };
        let (a, b) = (comb(n / 8), comb(n / 8 + width + gap));
        if width < 6 * NODES || n / 8 + 2 * (width + gap) > n {
            continue;
        }
        let (ea, eb) = (Expansion::new(&a, 1, n), Expansion::new(&b, 1, n));
        let exact = exact(&a, &b);
        let approx = ea.far_sum(&eb, &Lattice::new(kernel, n, 1));
        if !approx.is_finite() || (approx - exact).abs() > MAX_TEST_ERROR * exact.abs() {
            return false;
        }
        tested = true;
    }
    tested
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compliance::{FiniteCompliance, PeriodicCompliance};
    use crate::kernel::KernelKind;

    fn table(n: usize, c: impl Fn(isize) -> f64) -> Vec<f64> {
        (1 - n as isize..n as isize).map(c).collect()
    }

    fn points(runs: &[(usize, usize)]) -> Vec<usize> {
        runs.iter().flat_map(|&(s, e)| s..e).collect()
    }

    /// The double sum over every pair of points, the independent check.
    fn direct(kernel: &[f64], n: usize, a: &[(usize, usize)], b: &[(usize, usize)]) -> f64 {
        let pb = points(b);
        points(a).iter().map(|&i| pb.iter().map(|&l| kernel[i + n - 1 - l]).sum::<f64>()).sum()
    }

    #[test]
    fn moments_integrate_polynomials_below_the_degree_exactly() {
        // Interpolation at NODES points is exact for polynomials of degree < NODES: the moments
        // then give sum over the group's points of i^k (centred and scaled, to keep it exact enough).
        let cases = [
            (vec![(10usize, 14usize), (20, 33), (40, 41), (57, 90)], 1),
            (vec![(3, 7)], 1),
            (vec![(1000, 1003), (1500, 1800)], 1),
            (vec![(1000, 1003), (1500, 1800)], 16),
        ];
        for (runs, step) in cases {
            let e = Expansion::new(&runs, step, 4096);
            assert_eq!(e.cells.len(), if runs.len() == 1 { 4 } else { NODES });
            let (lo, hi) = (runs[0].0 as f64, runs[runs.len() - 1].1 as f64);
            let u = |x: f64| (x - lo) / (hi - lo);
            for k in 0..NODES as i32 {
                let exact: f64 = points(&runs).iter().map(|&i| u(i as f64).powi(k)).sum();
                let by_moments: f64 = e.cells.iter().zip(&e.moments).map(|(&x, &m)| m * u((x * step) as f64).powi(k)).sum();
                assert!((by_moments - exact).abs() <= 1e-9 * exact.abs().max(1.0), "{runs:?} k={k}: {by_moments} vs {exact}");
            }
        }
    }

    #[test]
    fn far_entries_match_the_double_sum_for_the_element_kernels() {
        let n = 65536;
        let periodic = PeriodicCompliance::new(n, 1e-4, KernelKind::Element);
        let finite = FiniteCompliance::new(n, 1e-4);
        let a: Vec<(usize, usize)> = (0..12).map(|k| (200 + 37 * k, 200 + 37 * k + 11 + k)).collect();
        for (kernel, step) in
            [(table(n, |d| periodic.kernel_at(d)), 1), (table(n, |d| finite.kernel_at(d)), 1), (table(n, |d| periodic.kernel_at(d)), 16)]
        {
            let lattice = Lattice::new(&kernel, n, step);
            let ea = Expansion::new(&a, step, n);
            let mut far_seen = 0;
            // b from just inside the separation limit (exact) to far away, and across the periodic seam.
            for start in [800usize, 9000, 30000, 64900] {
                let b: Vec<(usize, usize)> = (0..10).map(|k| (start + 41 * k, start + 41 * k + 20)).collect();
                let eb = Expansion::new(&b, step, n);
                let exact = direct(&kernel, n, &a, &b);
                if ea.is_far(&eb, n) {
                    far_seen += 1;
                    let approx = ea.far_sum(&eb, &lattice);
                    assert!((approx - exact).abs() <= 1e-10 * exact.abs(), "start {start}: {approx} vs {exact}");
                }
            }
            assert_eq!(far_seen, 2, "only 9000 and 30000 lie far from a (800 is too close, 64900 too across the seam)");
        }
    }

    #[test]
    fn groups_near_the_periodic_seam_are_near() {
        let n = 10_000;
        let left = Expansion::new(&(0..20).map(|k| (10 * k, 10 * k + 5)).collect::<Vec<_>>(), 1, n);
        let right = Expansion::new(&(0..20).map(|k| (9700 + 10 * k, 9700 + 10 * k + 5)).collect::<Vec<_>>(), 1, n);
        let middle = Expansion::new(&(0..20).map(|k| (5000 + 10 * k, 5000 + 10 * k + 5)).collect::<Vec<_>>(), 1, n);
        assert!(!left.is_far(&right, n) && !right.is_far(&left, n));
        assert!(left.is_far(&middle, n) && middle.is_far(&right, n));
        // A group of one short run: an exact block is cheaper than the expansion.
        let single = Expansion::new(&[(5000, 5003)], 1, n);
        assert!(!left.is_far(&single, n));
    }

    #[test]
    fn only_kernels_smooth_between_integers_use_the_far_field() {
        for n in [4096usize, 65536] {
            let element = PeriodicCompliance::new(n, 1e-4, KernelKind::Element);
            let spectral = PeriodicCompliance::new(n, 1e-4, KernelKind::Spectral);
            let finite = FiniteCompliance::new(n, 1e-4);
            for (name, kernel, smooth) in [
                ("element", table(n, |d| element.kernel_at(d)), true),
                ("finite", table(n, |d| finite.kernel_at(d)), true),
                ("spectral", table(n, |d| spectral.kernel_at(d)), false),
            ] {
                let exact = |a: &[(usize, usize)], b: &[(usize, usize)]| direct(&kernel, n, a, b);
                assert_eq!(smooth_enough(&kernel, n, exact), smooth, "{name} at N = {n}");
            }
        }
    }
}
