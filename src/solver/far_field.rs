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
//! The nodes are integers on a lattice of a power-of-two step (so that the kernel values read fit
//! the cache), and the interpolation reproduces constants exactly (the zero-sum coarse vectors do
//! not see the kernel's mean).
//!
//! The error: for a kernel analytic off its singular offsets (the element kernels, built from
//! logarithms and Clausen functions), Chebyshev interpolation of degree NODES - 1 converges as
//! rho^-NODES with rho = 1 + S + sqrt((1 + S)^2 - 1) = 13.9 at S = 6. Measured (the tests), an
//! entry is within 1e-10 of the larger of itself and |a| |b| times the kernel's range over the
//! offsets the pair spans (1e-11 to 1e-12 for the element kernels, periodic and finite). A kernel
//! that is not smooth between integers (the spectral kernel: its sharp cut-off at the Nyquist
//! wavenumber leaves a tail alternating in sign, 6e-10 to 1.3e-6 off on the same measure) is
//! summed exactly: the solver passes no [`Singular`] for it. The coarse matrix only shapes the deflation: the stopping
//! rule is tested on fresh products, so an interpolated entry changes iteration counts at most,
//! never the answer's accuracy.

use std::f64::consts::PI;

/// Interpolation points per group (polynomial degree NODES - 1).
pub(crate) const NODES: usize = 8;

/// How far apart two groups must be: the offsets they span stay at least SEPARATION times the
/// larger half-width away from every singular offset of the kernel.
pub(crate) const SEPARATION: f64 = 6.0;

/// Where a kernel smooth between integers is singular: its offsets the far field keeps away from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Singular {
    /// At 0 only (the finite model).
    AtZero,
    /// At 0 and +-N (the periodic model).
    Periodic,
}

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
    /// The lattice step its nodes lie on.
    step: usize,
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
            return Self { lo, hi, cells, moments, runs: count, step };
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
            return Self { lo, hi, cells: Vec::new(), moments: Vec::new(), runs: 0, step };
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
        Self { lo, hi, cells, moments, runs: count, step }
    }

    /// Whether G[a, b] is taken from the expansions: both have one, the groups are far apart from
    /// the kernel's `singular` offsets (see the module docs; `n` the kernel's size) and the
    /// interpolation costs fewer kernel values than the exact entry costs blocks.
    pub fn is_far(&self, other: &Self, n: usize, singular: Singular) -> bool {
        if self.cells.len() * other.cells.len() >= self.runs * other.runs {
            return false;
        }
        // Offsets x - y span [lo, hi].
        let lo = self.lo as isize - (other.hi as isize - 1);
        let hi = self.hi as isize - 1 - other.lo as isize;
        let n = n as isize;
        let offsets: &[isize] = match singular {
            Singular::AtZero => &[0],
            Singular::Periodic => &[-n, 0, n],
        };
        let distance = offsets.iter().map(|&s| (lo - s).max(s - hi).max(0)).min().unwrap_or(0);
        let half_width = (self.hi - self.lo).max(other.hi - other.lo) as f64 / 2.0;
        distance as f64 >= SEPARATION * half_width
    }

    /// The interpolated G[a, b] of this group a and `other` b, both on `lattice`.
    pub fn far_sum(&self, other: &Self, lattice: &Lattice) -> f64 {
        assert!(self.step == lattice.step && other.step == lattice.step, "expansions on the lattice's step");
        let mut total = 0.0;
        for (&x, &ma) in self.cells.iter().zip(&self.moments) {
            // c((x - y) step) sits at x - y + offset: from x on, at offset - y.
            let column = &lattice.values[x..];
            let row: f64 = other.cells.iter().zip(&other.moments).map(|(&y, &mb)| column[lattice.offset - y] * mb).sum();
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
    /// `kernel[d]` = c(d) = c(-d) for 0 <= d < N.
    pub fn new(kernel: &[f64], step: usize) -> Self {
        let offset = (kernel.len() - 1) / step;
        let values = (0..=2 * offset).map(|j| kernel[j.abs_diff(offset) * step]).collect();
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

/// The groups' expansions on one lattice, for a kernel with these singular offsets.
pub(crate) struct FarField {
    pub expansions: Vec<Expansion>,
    pub lattice: Lattice,
    pub singular: Singular,
}

impl FarField {
    /// Whether entry (a, b) is interpolated ([`Expansion::is_far`]).
    pub fn is_far(&self, a: usize, b: usize, n: usize) -> bool {
        self.expansions[a].is_far(&self.expansions[b], n, self.singular)
    }

    /// The interpolated entry (a, b).
    pub fn far_sum(&self, a: usize, b: usize) -> f64 {
        self.expansions[a].far_sum(&self.expansions[b], &self.lattice)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compliance::{FiniteCompliance, PeriodicCompliance};
    use crate::kernel::KernelKind;

    /// c(d) for 0 <= d < N (the kernels are even).
    fn table(n: usize, c: impl Fn(isize) -> f64) -> Vec<f64> {
        (0..n as isize).map(c).collect()
    }

    fn points(runs: &[(usize, usize)]) -> Vec<usize> {
        runs.iter().flat_map(|&(s, e)| s..e).collect()
    }

    /// The double sum over every pair of points, the independent check.
    fn direct(kernel: &[f64], a: &[(usize, usize)], b: &[(usize, usize)]) -> f64 {
        let pb = points(b);
        points(a).iter().map(|&i| pb.iter().map(|&l| kernel[i.abs_diff(l)]).sum::<f64>()).sum()
    }

    /// The larger of the entry and |a| |b| times the kernel's range over the offsets the two groups
    /// span: the entry may be near zero (the finite kernel changes sign), and the range vanishes
    /// where the periodic kernel is flat (offsets near N / 2).
    fn scale(kernel: &[f64], a: &[(usize, usize)], b: &[(usize, usize)]) -> f64 {
        let (pa, pb) = (points(a), points(b));
        let (lo, hi) = (pa[0] as isize - *pb.last().unwrap() as isize, *pa.last().unwrap() as isize - pb[0] as isize);
        let values: Vec<f64> = (lo..=hi).map(|d| kernel[d.unsigned_abs()]).collect();
        let range = values.iter().fold(f64::NEG_INFINITY, |m, &v| m.max(v)) - values.iter().fold(f64::INFINITY, |m, &v| m.min(v));
        ((pa.len() * pb.len()) as f64 * range).max(direct(kernel, a, b).abs())
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
            // Near the end of a profile of 4,096 points: the last nodes rounded beyond the group.
            (vec![(3300, 3310), (4000, 4090)], 32),
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
            // The range the distance test uses covers the nodes too.
            assert!(e.cells.iter().all(|&c| (e.lo..e.hi).contains(&(c * step))), "{runs:?} step {step}");
        }
        // Too few lattice points across the group: no expansion, so never far.
        let coarse = Expansion::new(&[(100, 110), (130, 140)], 16, 4096);
        let far_away = Expansion::new(&[(3000, 3010), (3030, 3040)], 16, 4096);
        assert!(coarse.cells.is_empty() && !coarse.is_far(&far_away, 4096, Singular::Periodic));
    }

    #[test]
    fn far_entries_match_the_double_sum_for_the_element_kernels() {
        let n = 65536;
        let periodic = PeriodicCompliance::new(n, 1e-4, KernelKind::Element);
        let finite = FiniteCompliance::new(n, 1e-4);
        let a: Vec<(usize, usize)> = (0..12).map(|k| (200 + 37 * k, 200 + 37 * k + 11 + k)).collect();
        let cases = [
            (table(n, |d| periodic.kernel_at(d)), Singular::Periodic, 1),
            (table(n, |d| periodic.kernel_at(d)), Singular::Periodic, 16),
            (table(n, |d| finite.kernel_at(d)), Singular::AtZero, 1),
            (table(n, |d| finite.kernel_at(d)), Singular::AtZero, 16),
        ];
        for (kernel, singular, step) in cases {
            let lattice = Lattice::new(&kernel, step);
            let ea = Expansion::new(&a, step, n);
            let mut far_seen = 0;
            // b from just inside the separation limit (exact) to far away, and across the periodic seam.
            for start in [800usize, 9000, 30000, 64900] {
                let b: Vec<(usize, usize)> = (0..10).map(|k| (start + 41 * k, start + 41 * k + 20)).collect();
                let eb = Expansion::new(&b, step, n);
                if ea.is_far(&eb, n, singular) {
                    far_seen += 1;
                    let (exact, approx) = (direct(&kernel, &a, &b), ea.far_sum(&eb, &lattice));
                    assert!(
                        (approx - exact).abs() <= 1e-10 * scale(&kernel, &a, &b),
                        "{singular:?} step {step}, b at {start}: {approx} vs {exact}"
                    );
                }
            }
            // 800 is too close; 64,900 lies across the seam from a, close for the periodic kernel only.
            assert_eq!(far_seen, if singular == Singular::Periodic { 2 } else { 3 }, "{singular:?}");
        }
    }

    #[test]
    fn groups_near_the_periodic_seam_are_near_for_the_periodic_kernel_only() {
        let n = 10_000;
        let left = Expansion::new(&(0..20).map(|k| (10 * k, 10 * k + 5)).collect::<Vec<_>>(), 1, n);
        let right = Expansion::new(&(0..20).map(|k| (9700 + 10 * k, 9700 + 10 * k + 5)).collect::<Vec<_>>(), 1, n);
        let middle = Expansion::new(&(0..20).map(|k| (5000 + 10 * k, 5000 + 10 * k + 5)).collect::<Vec<_>>(), 1, n);
        assert!(!left.is_far(&right, n, Singular::Periodic) && !right.is_far(&left, n, Singular::Periodic));
        assert!(left.is_far(&right, n, Singular::AtZero));
        assert!(left.is_far(&middle, n, Singular::Periodic) && middle.is_far(&right, n, Singular::Periodic));
        // A group of one short run: an exact block is cheaper than the expansion.
        let single = Expansion::new(&[(5000, 5003)], 1, n);
        assert!(!left.is_far(&single, n, Singular::Periodic));
    }

    #[test]
    fn the_spectral_kernel_is_not_smooth_enough_to_interpolate() {
        // Groups of single points three apart (contiguous runs would hide a tail alternating in
        // sign), at the separation limit: the element kernels interpolate to within 1e-10 of the
        // scale, the spectral one (which the solver sums exactly) is off by far more (its
        // alternating tail aliases differently at every step).
        for n in [4096usize, 65536] {
            let element = PeriodicCompliance::new(n, 1e-4, KernelKind::Element);
            let spectral = PeriodicCompliance::new(n, 1e-4, KernelKind::Spectral);
            let finite = FiniteCompliance::new(n, 1e-4);
            let width = 96;
            let gap = (SEPARATION * width as f64 / 2.0).ceil() as usize + 1;
            let comb = |start: usize| -> Vec<(usize, usize)> { (start..start + width).step_by(3).map(|i| (i, i + 1)).collect() };
            let (a, b) = (comb(n / 8), comb(n / 8 + width + gap));
            for step in [1, 2] {
                let error = |kernel: &[f64]| {
                    let (ea, eb) = (Expansion::new(&a, step, n), Expansion::new(&b, step, n));
                    assert!(ea.is_far(&eb, n, Singular::Periodic));
                    (ea.far_sum(&eb, &Lattice::new(kernel, step)) - direct(kernel, &a, &b)).abs() / scale(kernel, &a, &b)
                };
                let (e, f, s) = (
                    error(&table(n, |d| element.kernel_at(d))),
                    error(&table(n, |d| finite.kernel_at(d))),
                    error(&table(n, |d| spectral.kernel_at(d))),
                );
                let label = format!("N = {n}, step {step}: element {e:e}, finite {f:e}, spectral {s:e}");
                assert!(e <= 1e-10 && f <= 1e-10, "{label}");
                // Measured: 6e-10 to 1.3e-6, some 200 times the element kernels' error or more.
                assert!(s > 1e-10 && s > 20.0 * e.max(f), "{label}");
            }
        }
    }
}
