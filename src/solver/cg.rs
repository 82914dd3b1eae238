//! Preconditioned conjugate gradients for the load-controlled contact problem.
//!
//! Outer loop: primal-dual active-set sweeps. A trial contact set A is kept fixed while the
//! contact equations C_AA p_A + h = z_A, sum p = N P are solved by an inner CG; then points with
//! p < 0 leave A and points that penetrate (gap < 0) join it. Early sweeps solve only roughly
//! (the set is still wrong); once a sweep changes nothing, the set is solved to `tol` and checked
//! again.
//!
//! Inner loop: CG on the zero-sum subspace of R^A with two accelerations that make its iteration
//! count nearly independent of N:
//! - the FFT preconditioner M = (C^-1)_AA (the inverse kernel, |k| E*/2, restricted to A), exact
//!   for full contact (Vollebregt's BCCG-FFT preconditioner);
//! - deflation of one vector per island of A ([`super::deflation`]), which removes the outlying
//!   eigenvalues M leaves (load shared between islands): the A-DEF2 variant of deflated PCG
//!   (Tang, Nabben, Vuik & Erlangga 2009), a coarse solve per iteration.
//!
//! Safety net: if the sweeps do not settle (they may cycle on pathological inputs), the
//! bound-constrained CG of Vollebregt (truncation at p = 0, Polak-Ribiere continuation, no
//! restarts) takes over from the current pressure. It converges on every case tried, only slower.
//!
//! Stopping rule: [`super::residual`] <= tol, computed from a fresh C p (not a recurrence): the
//! worst open gap on the contact set and the worst penetration off it, relative to the profile
//! height. Load balance holds to rounding at every step.

use super::deflation::{runs, CoarseSpace, GroupCache, PairSums};
use super::reduce::{
    cg_update, dot2, fill_mask_bits, gap_and_masked_sum, mask_and_project, masked_difference, masked_sum, masked_sum_and_dot, max_abs,
    new_direction, parallel, shift_gap_and_update, subtract_on_mask, sum4,
};
use super::{residual, Outcome};
use crate::compliance::Compliance;

mod bounded;
mod covering;
mod mask_bits;
mod precision;
mod space_size;
#[cfg(test)]
mod tests;

use covering::{add_prolonged_covering, deflate_covering};
use precision::{steering_precondition, steering_product, LOW_PRECISION_TOL};
use space_size::space_dim;

/// Active-set sweeps before the bound-constrained CG takes over.
const MAX_SWEEPS: usize = 40;
/// Inner solves of early sweeps, while the set is still changing, stop after reducing the
/// residual by this factor: measured best among 0.3, 0.1, 0.02 and 0.005 for time to solution
/// (and at 2^16 since the sixth pass: 0.3 took 8 % more time, 0.5 25 % more).
const ROUGH_REDUCTION: f64 = 0.1;
/// The same for the line solver's profiles of at most SMALL_PROFILE points, whose sweeps (a coarse
/// space of tens to hundreds of vectors, a set update) cost little against an inner iteration, so
/// that more, rougher sweeps pay: on the road segments of N = 1,000 (the data grid's unit of work,
/// four moduli warm-started) 0.3 took 8.0 iterations and 73 FFT pairs-equivalent per solve against
/// 9.4 and 77 at 0.1 (0.5: 7.7 and 73, alternately in one run). The model grid's segments (issue 39,
/// `cargo bench --bench fft_floor -- --only model --refine k`: the road segments joined linearly k
/// times finer, tol 1e-4): k = 4 (N = 4,000) 7.7 iterations and 79 pairs-equivalent against 10.4
/// and 94 at 0.1, k = 8 9.1 and 80-88 against 12.4 and 91-98, k = 16 10.7 and 88 against 14.1 and
/// 109 (0.5: 8.5 / 9.8 iterations, 81 / 89: no better); the self-affine 2^16 case (above the bound,
/// its nested levels below it) unchanged (378-395 against 381-400). Above 2^15 left at
/// ROUGH_REDUCTION (measured best there).
const SMALL_PROFILE_ROUGH_REDUCTION: f64 = 0.3;
const SMALL_PROFILE: usize = 1 << 15;
/// Most pairs of contact runs summed to assemble E (runs (runs + 1) / 2, about 1 ns a pair at
/// 2^20 with the tiled sums of [`PairSums`], 4 ns before them: up to some 63,000 runs). Beyond,
/// only the largest islands are deflated, and the sweeps then need many more iterations: on a
/// self-affine profile at N = 2^20 (some 30,000 runs once the set settles, up to 50,000 in the
/// first sweeps) 132 iterations in 15.1 s with this budget, 148 in 16.5 s when it was 10^9 pairs
/// (the first sweeps' 45,000 to 50,000 runs cut to the largest 2,048), 3,072 iterations in 279 s
/// when only 8,000 runs were assembled, over 300 s with 4,000.
const MAX_RUN_PAIRS: usize = 2_000_000_000;

/// An update changing more than 1 / UNSETTLED of the set marks it as still moving: the next space,
/// if above SMALL_UNSETTLED_DIM vectors, is halved. Self-affine, seeds 0-2: 2^16 as fast, 2^17
/// 15 % and 2^18 25 % faster (+0 to 8 iterations); a quarter gave less, and N = 1,000 (at most 62
/// vectors) lost with any cut. Not beyond 2^18: at 2^20 the group sums dominate and the switch
/// back costs a fresh assembly (173 iterations instead of 148, 20.5 s against 21.2 s).
const UNSETTLED: usize = 20;
const SMALL_UNSETTLED_DIM: usize = 256;
const MAX_UNSETTLED_N: usize = 1 << 18;

/// Most points whose pressure is dropped from the set between sweeps for which C p is updated
/// column by column (O(N) each) instead of by a fresh FFT product.
const MAX_COLUMN_UPDATES: usize = 24;

/// Bound-constrained CG steps before the active-set sweeps, by N: more help at larger N, where
/// each sweep costs more (measured on self-affine profiles, N = 1,000 to 65,536).
fn warm_up_iterations(n: usize) -> usize {
    let log2 = (usize::BITS - n.leading_zeros()) as usize;
    (3 * log2).saturating_sub(26).clamp(4, 30)
}

/// Work vectors of one solve (of length N). Every solve overwrites each of them before reading it,
/// so one `Work` can serve any number of solves (of the same N) with bitwise the same results.
pub(crate) struct Work<S> {
    scratch: S,
    /// The sweeps' trial contact set A.
    mask: Vec<bool>,
    /// Right-hand side, then solution, of the coarse solve (length: the coarse dimension).
    coarse_rhs: Vec<f64>,
    /// The last solve's coarse space and the [`PairSums::id`] it was built from: a warm start
    /// begins on the previous solution's contact set, whose coarse space is then the same (E*
    /// is scaled out), bitwise, so reusing it changes no result.
    coarse: Option<(u64, CoarseSpace)>,
    /// C p: fresh from an FFT product, or tracked through the CG updates.
    displacement: Vec<f64>,
    residual: Vec<f64>,
    preconditioned: Vec<f64>,
    /// C y for the preconditioned residual y (the deflation's coarse right-hand side).
    applied: Vec<f64>,
    direction: Vec<f64>,
    applied_direction: Vec<f64>,
    previous: Vec<f64>,
    /// 1_A, the indicator of the contact set, and C 1_A: only a coarse space that leaves runs out
    /// needs them (very many runs), so they are sized on first use.
    set_indicator: Vec<f64>,
    set_displacement: Vec<f64>,
    /// The group sums of C y ([`covering`]).
    group_sums: Vec<f64>,
    /// `mask` as [`mask_bits`], for the inner iterations of a covering space.
    mask_bits: Vec<u64>,
}

impl<S> Work<S> {
    pub fn new<Op: Compliance<Scratch = S>>(op: &Op) -> Self {
        let n = op.len();
        Work {
            scratch: op.scratch(),
            mask: vec![true; n],
            coarse_rhs: Vec::new(),
            coarse: None,
            displacement: vec![0.0; n],
            residual: vec![0.0; n],
            preconditioned: vec![0.0; n],
            applied: vec![0.0; n],
            direction: vec![0.0; n],
            applied_direction: vec![0.0; n],
            previous: vec![0.0; n],
            set_indicator: Vec::new(),
            set_displacement: Vec::new(),
            group_sums: Vec::new(),
            mask_bits: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.mask.len()
    }

    pub fn scratch(&self) -> &S {
        &self.scratch
    }
}

/// One contact problem in the solver's units, and when to stop.
pub(crate) struct Problem<'a> {
    /// Heights relative to the highest point (m).
    pub z: &'a [f64],
    /// The prescribed mean of p / E* (P / E*).
    pub mean_strain: f64,
    /// Height scale of the residual (m), see [`super::height_scale`].
    pub scale: f64,
    pub tol: f64,
    pub max_iterations: usize,
    /// Bound-constrained CG steps before the sweeps on a cold start; None: the line model's
    /// choice by N ([`warm_up_iterations`]).
    pub warm_up: Option<usize>,
    /// Bound-constrained CG steps from `initial` before the sweeps (a nested guess, whose contact
    /// set is only roughly right); 0: the sweeps start on the guess's set.
    pub guess_steps: usize,
}

/// Solves for pressure / E* on `problem`, started from `initial` (pressure / E*, e.g. the solution
/// under another modulus) when given. `pair_sums` must hold the interval sums of `op`'s kernel;
/// None solves without deflation (operators that are not 1-D Toeplitz, e.g. surfaces).
pub(crate) fn solve<Op: Compliance>(
    op: &Op,
    pair_sums: Option<&PairSums>,
    problem: &Problem<'_>,
    initial: Option<&[f64]>,
    work: &mut Work<Op::Scratch>,
) -> Outcome {
    let n = problem.z.len();
    assert_eq!(work.len(), n, "work vectors of the wrong size");
    // The workspace reuse tag: a kept coarse space is only offered to the sweeps when it was built
    // from these very pair sums (the same kernel and dx; another solver of the same N has other
    // sums). The sweeps then reuse it only for the same set and dimension (CoarseSpace::is_same).
    let coarse = work.coarse.take().filter(|(id, _)| pair_sums.is_some_and(|s| *id == s.id())).map(|(_, c)| c);
    let mut context = Context {
        op,
        pair_sums,
        z: problem.z,
        target_sum: problem.mean_strain * n as f64,
        scale: problem.scale,
        tol: problem.tol,
        coarse,
        groups: None,
        last_changes: 0,
        coarse_is_last: false,
        coarse_reused: false,
        low_products: Op::LOW_PRECISION_DISPLACEMENT && problem.tol >= LOW_PRECISION_TOL,
        w: work,
    };
    let warm_up = problem.warm_up.unwrap_or_else(|| warm_up_iterations(n));
    let outcome = context.solve(problem.mean_strain, initial, problem.max_iterations, (warm_up, problem.guess_steps));
    let Context { coarse, w, .. } = context;
    w.coarse = coarse.zip(pair_sums).map(|(c, s)| (s.id(), c));
    outcome
}

/// What the stages of one solve share: the operator and its kernel sums, the problem, the
/// options, the coarse space and the work vectors.
struct Context<'a, Op: Compliance> {
    op: &'a Op,
    /// None: no deflation.
    pair_sums: Option<&'a PairSums>,
    z: &'a [f64],
    /// sum p = N P / E*: every iterate carries the load exactly.
    target_sum: f64,
    scale: f64,
    tol: f64,
    /// The coarse space of the current contact set (None: no deflation).
    coarse: Option<CoarseSpace>,
    /// The group matrix of this solve's last grouped coarse space, see [`GroupCache`].
    groups: Option<GroupCache>,
    /// Points the last set update changed (0 before the first).
    last_changes: usize,
    /// Whether `coarse` is the space this solve's last set solve deflated with (not one kept from
    /// an earlier solve), and whether [`Context::coarse_space`] returned it again.
    coarse_is_last: bool,
    coarse_reused: bool,
    /// Whether the precise sweeps' and the bounded CG's C d may be low-precision products (see
    /// [`LOW_PRECISION_TOL`]; cleared when a precise sweep misses tol).
    low_products: bool,
    w: &'a mut Work<Op::Scratch>,
}

/// How one contact-set solve ([`Context::solve_on_set`]) runs.
#[derive(Clone, Copy)]
struct SetSolve {
    /// Stop at max|gap| <= abs_tol (m) on the set.
    abs_tol: f64,
    /// An early sweep: stop after a fixed reduction too, with a smaller coarse space.
    rough: bool,
    /// Deflate with the coarse space.
    deflate: bool,
    /// `w.displacement` already holds C p.
    displacement_known: bool,
    max_iterations: usize,
}

impl<Op: Compliance> Context<'_, Op> {
    /// Warm start (from `initial`, else a few bounded-CG steps), the sweeps, and the bounded CG
    /// again if they do not settle.
    fn solve(&mut self, mean_strain: f64, initial: Option<&[f64]>, max_iterations: usize, steps: (usize, usize)) -> Outcome {
        let (warm_up, guess_steps) = steps;
        let n = self.z.len();
        let target_sum = self.target_sum;
        let mut gap = vec![0.0; n];
        let (mut p, warm, known) = match initial.filter(|q| q.len() == n && q.iter().any(|&x| x > 0.0)) {
            // A neighbouring solution (the same profile under another modulus, or the coarser
            // level's of a nested solve): its contact set is close to this one, so the sweeps start
            // from it with its pressure scaled to this load.
            Some(q) => {
                let total: f64 = q.iter().map(|&x| x.max(0.0)).sum();
                let p: Vec<f64> = q.iter().map(|&x| x.max(0.0) * target_sum / total).collect();
                if guess_steps > 0 {
                    // A nested guess: bound-constrained steps from it first.
                    match self.bounded_start(p, guess_steps.min(max_iterations)) {
                        Ok(start) => start,
                        Err(done) => return done,
                    }
                } else {
                    for (m, &pi) in self.w.mask.iter_mut().zip(&p) {
                        *m = pi > 0.0;
                    }
                    // A guess that already meets tol is returned as it is, before any coarse space
                    // is assembled (seconds at N = 2^19). Else the product is the first sweep's,
                    // bitwise.
                    let w = &mut *self.w;
                    self.op.displacement(&p, &mut w.displacement, &mut w.scratch);
                    let mut trial = w.mask.clone();
                    if update_set(self.z, &p, &mut trial, &mut gap, &w.displacement) == 0 {
                        let res = residual(&p, &gap, self.scale);
                        if res <= self.tol {
                            return Outcome { pressure: p, gap, iterations: 0, residual: res, converged: true };
                        }
                    }
                    (p, 0, true)
                }
            }
            // A few bound-constrained CG steps from full contact shed most of the points that are
            // not in contact far more cheaply than active-set sweeps would.
            None => match self.bounded_start(vec![mean_strain; n], warm_up.min(max_iterations)) {
                Ok(start) => start,
                Err(done) => return done,
            },
        };
        let max_iterations = max_iterations - warm;
        match self.sweeps(&mut p, &mut gap, max_iterations, known) {
            Ok((iterations, res)) => Outcome { pressure: p, gap, iterations: iterations + warm, residual: res, converged: true },
            Err(iterations) => {
                let iterations = iterations + warm;
                // The sweeps did not settle: continue from here with the bound-constrained CG.
                for x in p.iter_mut() {
                    *x = x.max(0.0);
                }
                let total: f64 = p.iter().sum();
                p.iter_mut().for_each(|x| *x *= target_sum / total);
                let budget = (max_iterations + warm).saturating_sub(iterations);
                let fallback = self.bounded_cg(p, budget);
                Outcome { iterations: iterations + fallback.iterations, ..fallback }
            }
        }
    }

    /// `steps` bound-constrained CG steps from `p`, leaving their set (pressure or penetration) in
    /// `w.mask`: Ok((pressure, iterations, false)) to go on with, Err(outcome) when converged.
    fn bounded_start(&mut self, p: Vec<f64>, steps: usize) -> std::result::Result<(Vec<f64>, usize, bool), Outcome> {
        let start = self.bounded_cg(p, steps);
        if start.converged {
            return Err(start);
        }
        for (m, (&pi, &g)) in self.w.mask.iter_mut().zip(start.pressure.iter().zip(&start.gap)) {
            *m = pi > 0.0 || g < 0.0;
        }
        Ok((start.pressure, start.iterations, false))
    }

    /// The active-set sweeps from the set in `w.mask`: Ok((iterations, residual)) when converged,
    /// Err(iterations) when they did not settle.
    fn sweeps(&mut self, p: &mut [f64], gap: &mut [f64], max_iterations: usize, known: bool) -> std::result::Result<(usize, f64), usize> {
        let n = self.z.len();
        let mut iterations = 0usize;
        let mut rough = true;
        let mut deflate = true;
        // Whether w.displacement holds C p for the current p (tracked, not a fresh product).
        let mut known = known;
        // Whether that C p is a fresh product (the settled-set check just made one).
        let mut fresh = false;
        let mut leaving: Vec<(usize, f64)> = Vec::new();
        for _sweep in 0..MAX_SWEEPS {
            let budget = max_iterations.saturating_sub(iterations);
            if budget == 0 {
                break;
            }
            let abs_tol = 0.25 * self.tol * self.scale;
            // A precise solve starts from a fresh product, so that its stopping test is honest (when
            // the settled-set check has just made one, that one: the same product, bitwise).
            let how = SetSolve { abs_tol, rough, deflate, displacement_known: known && (rough || fresh), max_iterations: budget };
            fresh = false;
            iterations += self.solve_on_set(p, how);

            // Set update from the tracked C p; a set that looks settled is checked on a fresh one.
            let (op, z, w) = (self.op, self.z, &mut *self.w);
            let mut changes = update_set(z, p, &mut w.mask, gap, &w.displacement);
            if changes == 0 {
                op.displacement(p, &mut w.displacement, &mut w.scratch);
                changes = update_set(z, p, &mut w.mask, gap, &w.displacement);
            }
            let changed = changes > 0;
            self.last_changes = changes;
            if !changed {
                let res = residual(p, gap, self.scale);
                if res <= self.tol {
                    return Ok((iterations, res));
                }
                known = true;
                fresh = true;
                if !rough && self.low_products {
                    // Solved with low-precision products: again in double precision.
                    self.low_products = false;
                } else if !rough {
                    // A precise solve on a settled set missed tol. The coarse matrix is assembled
                    // from second prefix sums of the kernel (PairSums), differences of large
                    // numbers whose rounding can cap the attainable accuracy, and its far entries
                    // are interpolated (far_field, about 1e-10 off): retry without it.
                    if !deflate {
                        break;
                    }
                    deflate = false;
                }
                rough = false;
                continue;
            }
            if !w.mask.iter().any(|&m| m) {
                break;
            }
            // New trial set: keep the pressures of points that stay, start new points at zero. The
            // residual is then no longer orthogonal to any coarse space: no skipped A-DEF2 start
            // next, even on a set seen before.
            self.coarse_is_last = false;
            leaving.clear();
            for (i, (pi, &m)) in p.iter_mut().zip(&w.mask).enumerate() {
                let next = if m { pi.max(0.0) } else { 0.0 };
                if next != *pi {
                    leaving.push((i, next - *pi));
                }
                *pi = next;
            }
            let total = sum4(p);
            if total > 0.0 {
                let factor = self.target_sum / total;
                p.iter_mut().for_each(|x| *x *= factor);
                known = leaving.len() <= MAX_COLUMN_UPDATES;
                if known {
                    for &(j, delta) in &leaving {
                        op.add_column(j, delta, &mut w.displacement);
                    }
                    w.displacement.iter_mut().for_each(|u| *u *= factor);
                }
            } else {
                let count = w.mask.iter().filter(|&&m| m).count() as f64;
                (0..n).filter(|&i| w.mask[i]).for_each(|i| p[i] = self.target_sum / count);
                known = false;
            }
        }
        Err(iterations)
    }

    /// The coarse space for the set in `w.mask`: the current one when it would be built again,
    /// else a new one; None without deflation or with fewer than two runs.
    fn coarse_space(&mut self, deflate: bool) -> Option<CoarseSpace> {
        let current = self.coarse.take();
        let pair_sums = self.pair_sums.filter(|_| deflate)?;
        let islands = runs(&self.w.mask);
        if islands.len() < 2 {
            return None;
        }
        let n = self.z.len();
        let mut dim = space_dim(n, islands.len(), self.tol);
        // While the set still moves (the last update changed more than 1 / UNSETTLED of it), a
        // large space is halved: it is factored again every sweep and the set will change anyway.
        let count = self.w.mask.iter().filter(|&&m| m).count();
        if dim > SMALL_UNSETTLED_DIM && n <= MAX_UNSETTLED_N && self.last_changes * UNSETTLED > count {
            dim /= 2;
        }
        // The same set as the last sweep (a rough sweep that changed nothing, then the precise
        // one), or as the last solve (a warm start; `solve` kept only a space of these pair sums).
        if let Some(current) = current.filter(|c| c.is_same(&islands, dim, self.groups.as_ref())) {
            self.coarse_reused = true;
            return Some(current);
        }
        // CoarseSpace::new relies on: `islands` being exactly the runs of the mask it is given
        // (|A| is their total length, and when every run is kept their indicators sum to 1_A);
        // the pair sums being those of this operator's kernel (ContactSolver::new builds both from
        // one model), a symmetric one (it assembles one triangle of E); and, when it keeps only
        // the largest runs, `displacement_of_set` being C 1_A for this same mask.
        let w = &mut *self.w;
        let displacement_of_set = if CoarseSpace::needs_displacement_of_set(islands.len(), dim, MAX_RUN_PAIRS) {
            w.set_indicator.resize(n, 0.0);
            w.set_displacement.resize(n, 0.0);
            for (u, &m) in w.set_indicator.iter_mut().zip(&w.mask) {
                *u = if m { 1.0 } else { 0.0 };
            }
            self.op.displacement(&w.set_indicator, &mut w.set_displacement, &mut w.scratch);
            Some(&w.set_displacement[..])
        } else {
            None
        };
        CoarseSpace::new(pair_sums, islands, &w.mask, displacement_of_set, dim, MAX_RUN_PAIRS, &mut self.groups)
    }

    /// r = projected (z - C p) on the set: the gap the approach cannot close (C p fresh when
    /// `fresh`, else as tracked in `w.displacement`).
    fn set_residual(&mut self, p: &[f64], count: usize, fresh: bool) {
        let w = &mut *self.w;
        if fresh {
            self.op.displacement(p, &mut w.displacement, &mut w.scratch);
        }
        let sum = masked_difference(&mut w.residual, self.z, &w.displacement, &w.mask);
        subtract_on_mask(&mut w.residual, &w.mask, sum / count as f64);
    }

    /// Deflated PCG on the fixed set `w.mask`: C_AA p_A + h = z_A with sum p_A unchanged. Stops
    /// at max|gap| <= `how.abs_tol` on the set (or, when rough, after a fixed reduction). Returns
    /// the iterations used; p may turn negative on the set (the outer sweep deals with that).
    // `!(x > 0.0)` below is deliberate: it also stops on NaN. The update loop indexes six vectors in step.
    #[allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]
    fn solve_on_set(&mut self, p: &mut [f64], how: SetSolve) -> usize {
        let count = self.w.mask.iter().filter(|&&m| m).count();
        if count <= 1 {
            // One element carries the whole load: nothing to solve (and no deflated solve last).
            self.coarse_is_last = false;
            return 0;
        }
        // `w.mask` stays the set `coarse` was built for until this returns: add_prolonged shifts
        // exactly those points, and restrict's weights are run lengths over the set's size.
        self.coarse_reused = false;
        let coarse = self.coarse_space(how.deflate);
        self.set_residual(p, count, !how.displacement_known);
        // A-DEF2 start: the coarse solve puts the right load on every island at once. Not when
        // the last set solve deflated with this very space on this set (the precise sweep after a
        // rough one that changed nothing, p as it left it): its residual is already orthogonal to
        // the space (Z0^T C d = 0 for every direction), to rounding.
        let orthogonal = self.coarse_is_last && self.coarse_reused;
        // A space covering every run (all but very many runs) deflates in passes over the set.
        let covering = coarse.as_ref().filter(|c| c.covering_groups().is_some() && !parallel(self.z.len()));
        if let Some(coarse) = coarse.as_ref().filter(|_| !orthogonal) {
            let w = &mut *self.w;
            coarse.restrict(&w.residual, 0.0, &mut w.coarse_rhs);
            coarse.solve(&mut w.coarse_rhs);
            match covering {
                Some(_) => add_prolonged_covering(coarse, &w.coarse_rhs, 1.0, p),
                None => coarse.add_prolonged(&w.coarse_rhs, 1.0, &w.mask, p),
            }
            self.set_residual(p, count, true);
        }
        let (op, w) = (self.op, &mut *self.w);
        fill_mask_bits(&w.mask, &mut w.mask_bits);
        let start_norm = max_abs(&w.residual);
        // The areal solver (no pair sums) keeps ROUGH_REDUCTION at every size.
        let reduction =
            if self.pair_sums.is_some() && self.z.len() <= SMALL_PROFILE { SMALL_PROFILE_ROUGH_REDUCTION } else { ROUGH_REDUCTION };
        let stop = if how.rough { how.abs_tol.max(reduction * start_norm) } else { how.abs_tol };
        let low = (how.rough && Op::STEERS_LOW_AT_TIGHT_TOL) || self.low_products;

        let mut rho_before = 0.0;
        let mut iterations = 0;
        // max|r|, kept up to date by the update pass (no separate pass per iteration).
        let mut residual_norm = start_norm;
        while residual_norm > stop && iterations < how.max_iterations {
            // y = M r on A, zero-sum (M in low precision where the operator has it and `low` asks).
            steering_precondition(op, low, &w.residual, &mut w.preconditioned, &mut w.scratch);
            // P^T y = y - Z E^-1 Z^T C y.
            if let Some(coarse) = covering {
                deflate_covering(op, w, coarse, count, low);
            } else if let Some(coarse) = &coarse {
                mask_and_project(&mut w.preconditioned, &w.mask, count);
                steering_product(op, low, &w.preconditioned, &mut w.applied, &mut w.scratch);
                // restrict reads C y on the coarse space's runs only (all inside A) and takes its
                // sum over the whole set A as given: sum over the mask, not over all N points.
                let total = masked_sum(&w.applied, &w.mask);
                coarse.restrict(&w.applied, total, &mut w.coarse_rhs);
                coarse.solve(&mut w.coarse_rhs);
                coarse.add_prolonged(&w.coarse_rhs, -1.0, &w.mask, &mut w.preconditioned);
            } else {
                mask_and_project(&mut w.preconditioned, &w.mask, count);
            }
            // rho = r . y and, for the Polak-Ribiere beta, r . y_previous, in one pass (`previous`
            // is read only after this solve wrote it: iterations > 0).
            let (rho, r_previous) = dot2(&w.residual, &w.preconditioned, &w.previous);
            if !(rho > 0.0) {
                break;
            }
            // Polak-Ribiere (flexible) beta: equal to Fletcher-Reeves in exact arithmetic, and robust
            // when the coarse solve makes the preconditioner slightly inexact.
            let beta = if iterations == 0 { 0.0 } else { ((rho - r_previous) / rho_before).max(0.0) };
            // Not beta * d on the first iteration: d holds the last solve's direction (`+ 0.0` as
            // y + 0 * d would give).
            new_direction(&mut w.direction, &w.preconditioned, if iterations == 0 { None } else { Some(beta) });
            // y becomes `previous` (the next precondition overwrites all of `preconditioned`).
            std::mem::swap(&mut w.previous, &mut w.preconditioned);
            // C d on all points: its projection on A updates r, all of it tracks C p.
            steering_product(op, low, &w.direction, &mut w.applied_direction, &mut w.scratch);
            let (applied_sum, curvature) = masked_sum_and_dot(&w.direction, &w.applied_direction, &w.mask_bits);
            let mean = applied_sum / count as f64;
            if !(curvature > 0.0) {
                break;
            }
            let alpha = rho / curvature;
            // One pass over plain slices: p, C p and r move, off the set r stays zero; max|r| too.
            let (direction, applied) = (&w.direction[..], &w.applied_direction[..]);
            let pur = [&mut p[..], &mut w.displacement[..], &mut w.residual[..]];
            residual_norm = cg_update(pur, direction, applied, &w.mask_bits, alpha, mean);
            rho_before = rho;
            iterations += 1;
        }
        self.coarse_is_last = coarse.is_some();
        self.coarse = coarse;
        iterations
    }
}

/// The gap for displacement `u` = C p, with the rigid approach that makes it zero-mean on `mask`,
/// and the next trial set in `mask` (points with p <= 0 leave, penetrating points join); returns
/// whether the set changed.
fn update_set(z: &[f64], p: &[f64], mask: &mut [bool], gap: &mut [f64], u: &[f64]) -> usize {
    let count = mask.iter().filter(|&&m| m).count();
    let approach = -gap_and_masked_sum(gap, u, z, mask) / count as f64;
    shift_gap_and_update(gap, p, mask, approach)
}
