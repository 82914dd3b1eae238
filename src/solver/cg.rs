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

use super::deflation::{runs, CoarseSpace, PairSums};
use super::{residual, Outcome};
use crate::compliance::Compliance;

/// Active-set sweeps before the bound-constrained CG takes over.
const MAX_SWEEPS: usize = 40;
/// Inner solves of early sweeps, while the set is still changing, stop after reducing the
/// residual by this factor: measured best among 0.3, 0.1, 0.02 and 0.005 for time to solution.
const ROUGH_REDUCTION: f64 = 0.1;
/// Most pairs of contact runs summed to assemble E (runs (runs + 1) / 2, about 4 ns a pair: up to
/// some 44,700 runs). Beyond, only the largest islands are deflated, and the sweeps then need many
/// more iterations: on a self-affine profile at N = 2^20 (some 30,000 runs once the set settles)
/// 142-154 iterations in 63-75 s within this budget, 3,072 iterations in 279 s when only 8,000
/// runs were assembled, over 300 s with 4,000 (the earlier budget).
const MAX_RUN_PAIRS: usize = 1_000_000_000;

/// Coarse-space dimension (runs of contact, grouped beyond it) for a set of `runs` runs at size N.
///
/// Rough sweeps refactor E every sweep, so they use a smaller space: 256 vectors up to N = 2^16,
/// N / 256 beyond, and never fewer than one per three runs (with fewer, iterations grow faster
/// with N: on self-affine profiles 65-75 iterations at 2^16 and 160-190 at 2^18, against 56-61
/// and 72-73 with one per three runs). Precise sweeps use 1,024 to 2,048. Both stay at or below
/// N / 16, where the coarse work would outweigh the FFTs, and at or below 2,048 (factoring E
/// costs dim^3 / 3).
fn coarse_dim(n: usize, runs: usize, rough: bool) -> usize {
    const MAX_DIM: usize = 2048;
    let wanted = if rough { (n / 256).clamp(256, MAX_DIM).max(runs / 3) } else { (n / 64).clamp(1024, MAX_DIM) };
    wanted.min((n / 16).max(32)).min(MAX_DIM)
}

/// Most points whose pressure is dropped from the set between sweeps for which C p is updated
/// column by column (O(N) each) instead of by a fresh FFT product.
const MAX_COLUMN_UPDATES: usize = 24;

/// Bound-constrained CG steps before the active-set sweeps, by N: more help at larger N, where
/// each sweep costs more (measured on self-affine profiles, N = 1,000 to 65,536).
fn warm_up_iterations(n: usize) -> usize {
    let log2 = (usize::BITS - n.leading_zeros()) as usize;
    (3 * log2).saturating_sub(26).clamp(4, 30)
}

/// Work vectors of one solve (all of length N). Every solve overwrites them before reading, so one
/// `Work` can serve any number of solves (of the same N) with bitwise the same results.
pub(crate) struct Work<S> {
    scratch: S,
    mask: Vec<bool>,
    coarse_rhs: Vec<f64>,
    /// The last solve's coarse space and the [`PairSums::id`] it was built from: a warm start
    /// begins on the previous solution's contact set, whose coarse space is then the same (E*
    /// is scaled out), bitwise, so reusing it changes no result.
    coarse: Option<(u64, CoarseSpace)>,
    displacement: Vec<f64>,
    residual: Vec<f64>,
    preconditioned: Vec<f64>,
    applied: Vec<f64>,
    direction: Vec<f64>,
    applied_direction: Vec<f64>,
    previous: Vec<f64>,
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
        }
    }

    pub fn len(&self) -> usize {
        self.mask.len()
    }
}

/// Solves for pressure / E* with mean `mean_strain` on heights `z` (m). `scale` is the height
/// scale of the residual.
pub(crate) fn solve<Op: Compliance>(
    op: &Op,
    pair_sums: &PairSums,
    z: &[f64],
    mean_strain: f64,
    scale: f64,
    tol: f64,
    max_iterations: usize,
    initial: Option<&[f64]>,
    work: &mut Work<Op::Scratch>,
) -> Outcome {
    let n = z.len();
    assert_eq!(work.len(), n, "work vectors of the wrong size");
    let target_sum = mean_strain * n as f64;
    let mut mask = std::mem::take(&mut work.mask);
    let mut gap = vec![0.0; n];
    let mut coarse: Option<CoarseSpace> = work.coarse.take().filter(|(id, _)| *id == pair_sums.id()).map(|(_, c)| c);
    let (mut p, warm) = match initial.filter(|q| q.len() == n && q.iter().any(|&x| x > 0.0)) {
        // A neighbouring solution (the same profile under another modulus): its contact set is
        // close to this one, so the sweeps start from it with its pressure scaled to this load.
        Some(q) => {
            let total: f64 = q.iter().map(|&x| x.max(0.0)).sum();
            let p: Vec<f64> = q.iter().map(|&x| x.max(0.0) * target_sum / total).collect();
            for i in 0..n {
                mask[i] = p[i] > 0.0;
            }
            (p, 0)
        }
        None => {
            // A few bound-constrained CG steps from full contact shed most of the points that are
            // not in contact far more cheaply than active-set sweeps would.
            let warm_budget = warm_up_iterations(n).min(max_iterations);
            let start = bounded_cg(op, z, vec![mean_strain; n], target_sum, scale, tol, warm_budget, work);
            if start.converged {
                work.mask = mask;
                return start;
            }
            for i in 0..n {
                mask[i] = start.pressure[i] > 0.0 || start.gap[i] < 0.0;
            }
            (start.pressure, start.iterations)
        }
    };
    let max_iterations = max_iterations - warm;
    let outcome = sweeps(op, pair_sums, z, &mut p, &mut mask, &mut gap, &mut coarse, target_sum, scale, tol, max_iterations, work);
    work.mask = mask;
    work.coarse = coarse.map(|c| (pair_sums.id(), c));
    match outcome {
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
            let fallback = bounded_cg(op, z, p, target_sum, scale, tol, budget, work);
            Outcome { iterations: iterations + fallback.iterations, ..fallback }
        }
    }
}

/// The active-set sweeps: Ok((iterations, residual)) when converged, Err(iterations) when they did
/// not settle.
#[allow(clippy::too_many_arguments)]
fn sweeps<Op: Compliance>(
    op: &Op,
    pair_sums: &PairSums,
    z: &[f64],
    p: &mut [f64],
    mask: &mut [bool],
    gap: &mut [f64],
    coarse: &mut Option<CoarseSpace>,
    target_sum: f64,
    scale: f64,
    tol: f64,
    max_iterations: usize,
    work: &mut Work<Op::Scratch>,
) -> std::result::Result<(usize, f64), usize> {
    let n = z.len();
    let mut iterations = 0usize;
    let mut rough = true;
    let mut deflate = true;
    // Whether work.displacement holds C p for the current p (tracked, not a fresh product).
    let mut known = false;
    let mut leaving: Vec<(usize, f64)> = Vec::new();
    for _sweep in 0..MAX_SWEEPS {
        let budget = max_iterations.saturating_sub(iterations);
        if budget == 0 {
            break;
        }
        let inner_tol = 0.25 * tol * scale;
        // A precise solve starts from a fresh product, so that its stopping test is honest.
        let it_sweep = solve_on_set(op, pair_sums, z, p, mask, coarse, inner_tol, rough, deflate, known && rough, budget, work);
        iterations += it_sweep;

        // Set update from the tracked C p; a set that looks settled is checked on a fresh one.
        let mut changed = update_set(z, p, mask, gap, &work.displacement);
        if !changed {
            op.displacement(p, &mut work.displacement, &mut work.scratch);
            changed = update_set(z, p, mask, gap, &work.displacement);
        }
        if !changed {
            let res = residual(p, gap, scale);
            if res <= tol {
                return Ok((iterations, res));
            }
            known = true;
            if !rough {
                // A precise solve on a settled set missed tol. The coarse matrix is assembled from
                // prefix sums whose rounding can cap the attainable accuracy: retry without it.
                if !deflate {
                    break;
                }
                deflate = false;
            }
            rough = false;
            continue;
        }
        if !mask.iter().any(|&m| m) {
            break;
        }
        // New trial set: keep the pressures of points that stay, start new points at zero.
        leaving.clear();
        for i in 0..n {
            let next = if mask[i] { p[i].max(0.0) } else { 0.0 };
            if next != p[i] {
                leaving.push((i, next - p[i]));
            }
            p[i] = next;
        }
        let total: f64 = p.iter().sum();
        if total > 0.0 {
            let factor = target_sum / total;
            p.iter_mut().for_each(|x| *x *= factor);
            known = leaving.len() <= MAX_COLUMN_UPDATES;
            if known {
                for &(j, delta) in &leaving {
                    op.add_column(j, delta, &mut work.displacement);
                }
                work.displacement.iter_mut().for_each(|u| *u *= factor);
            }
        } else {
            let count = mask.iter().filter(|&&m| m).count() as f64;
            (0..n).filter(|&i| mask[i]).for_each(|i| p[i] = target_sum / count);
            known = false;
        }
    }
    Err(iterations)
}

/// The gap for displacement `u` = C p, with the rigid approach that makes it zero-mean on `mask`,
/// and the next trial set in `mask` (points with p <= 0 leave, penetrating points join); returns
/// whether the set changed.
fn update_set(z: &[f64], p: &[f64], mask: &mut [bool], gap: &mut [f64], u: &[f64]) -> bool {
    let n = z.len();
    let (sum, count) = (0..n).filter(|&i| mask[i]).fold((0.0, 0usize), |(s, c), i| (s + u[i] - z[i], c + 1));
    let approach = -sum / count as f64;
    for i in 0..n {
        gap[i] = u[i] + approach - z[i];
    }
    let mut changed = false;
    for i in 0..n {
        let next = if mask[i] { p[i] > 0.0 } else { gap[i] < 0.0 };
        changed |= next != mask[i];
        mask[i] = next;
    }
    changed
}

/// Deflated PCG on the fixed set `mask`: C_AA p_A + h = z_A with sum p_A unchanged. Stops at
/// max|gap| <= `abs_tol` on the set (or, when `rough`, after a fixed reduction). Returns the
/// iterations used; p may turn negative on the set (the outer sweep deals with that).
#[allow(clippy::too_many_arguments)]
fn solve_on_set<Op: Compliance>(
    op: &Op,
    pair_sums: &PairSums,
    z: &[f64],
    p: &mut [f64],
    mask: &[bool],
    cache: &mut Option<CoarseSpace>,
    abs_tol: f64,
    rough: bool,
    deflate: bool,
    displacement_known: bool,
    max_iterations: usize,
    w: &mut Work<Op::Scratch>,
) -> usize {
    let count = mask.iter().filter(|&&m| m).count();
    if count <= 1 {
        // One element carries the whole load: nothing to solve.
        return 0;
    }
    let islands = if deflate { runs(mask) } else { Vec::new() };
    if islands.len() >= 2 {
        let n = mask.len();
        let dim = coarse_dim(n, islands.len(), rough);
        // The same set as the last sweep (a rough sweep that changed nothing, then the precise
        // one): the same coarse space.
        if !cache.as_ref().is_some_and(|c| c.is_same(&islands, dim)) {
            let unit = if CoarseSpace::needs_displacement_of_set(islands.len(), dim, MAX_RUN_PAIRS) {
                for (u, &m) in w.preconditioned.iter_mut().zip(mask) {
                    *u = if m { 1.0 } else { 0.0 };
                }
                op.displacement(&w.preconditioned, &mut w.applied, &mut w.scratch);
                Some(&w.applied[..])
            } else {
                None
            };
            *cache = CoarseSpace::new(pair_sums, islands, mask, unit, dim, MAX_RUN_PAIRS);
        }
    } else {
        *cache = None;
    }
    let coarse = cache.as_ref();
    // r = projected (z - C p) on A: the gap the approach cannot close (C p fresh, or as tracked).
    let update_residual = |p: &[f64], w: &mut Work<Op::Scratch>, fresh: bool| {
        if fresh {
            op.displacement(p, &mut w.displacement, &mut w.scratch);
        }
        for i in 0..p.len() {
            w.residual[i] = if mask[i] { z[i] - w.displacement[i] } else { 0.0 };
        }
        project_zero_sum(&mut w.residual, mask, count);
    };
    update_residual(p, w, !displacement_known);
    // A-DEF2 start: the coarse solve puts the right load on every island at once.
    if let Some(coarse) = coarse {
        let mut q = std::mem::take(&mut w.coarse_rhs);
        coarse.restrict(&w.residual, 0.0, &mut q);
        coarse.solve(&mut q);
        coarse.add_prolonged(&q, 1.0, mask, p);
        w.coarse_rhs = q;
        update_residual(p, w, true);
    }
    let start_norm = max_abs(&w.residual);
    let stop = if rough { abs_tol.max(ROUGH_REDUCTION * start_norm) } else { abs_tol };

    let mut rho_before = 0.0;
    let mut iterations = 0;
    while max_abs(&w.residual) > stop && iterations < max_iterations {
        // y = M r on A, zero-sum.
        op.precondition(&w.residual, &mut w.preconditioned, &mut w.scratch);
        mask_and_project(&mut w.preconditioned, mask, count);
        // P^T y = y - Z E^-1 Z^T C y.
        if let Some(coarse) = coarse {
            op.displacement(&w.preconditioned, &mut w.applied, &mut w.scratch);
            let total: f64 = (0..p.len()).filter(|&i| mask[i]).map(|i| w.applied[i]).sum();
            let mut q = std::mem::take(&mut w.coarse_rhs);
            coarse.restrict(&w.applied, total, &mut q);
            coarse.solve(&mut q);
            coarse.add_prolonged(&q, -1.0, mask, &mut w.preconditioned);
            w.coarse_rhs = q;
        }
        let rho = dot(&w.residual, &w.preconditioned);
        if !(rho > 0.0) {
            break;
        }
        // Polak-Ribiere (flexible) beta: equal to Fletcher-Reeves in exact arithmetic, and robust
        // when the coarse solve makes the preconditioner slightly inexact.
        let beta = if iterations == 0 { 0.0 } else { ((rho - dot(&w.residual, &w.previous)) / rho_before).max(0.0) };
        if iterations == 0 {
            // Not beta * d: d holds the last solve's direction (`+ 0.0` as y + 0 * d would give).
            for (d, &y) in w.direction.iter_mut().zip(&w.preconditioned) {
                *d = y + 0.0;
            }
        } else {
            for (d, &y) in w.direction.iter_mut().zip(&w.preconditioned) {
                *d = y + beta * *d;
            }
        }
        w.previous.copy_from_slice(&w.preconditioned);
        // C d on all points: its projection on A updates r, all of it tracks C p.
        op.displacement(&w.direction, &mut w.applied_direction, &mut w.scratch);
        let mean = (0..p.len()).filter(|&i| mask[i]).map(|i| w.applied_direction[i]).sum::<f64>() / count as f64;
        let curvature = dot(&w.direction, &w.applied_direction);
        if !(curvature > 0.0) {
            break;
        }
        let alpha = rho / curvature;
        for i in 0..p.len() {
            p[i] += alpha * w.direction[i];
            w.displacement[i] += alpha * w.applied_direction[i];
            if mask[i] {
                w.residual[i] -= alpha * (w.applied_direction[i] - mean);
            }
        }
        rho_before = rho;
        iterations += 1;
    }
    iterations
}

/// Bound-constrained CG (Vollebregt 2014) with the FFT preconditioner: the free set is
/// {p > 0} U {p = 0 and gap < 0}; pressures crossing zero are truncated and the iteration
/// continues with a Polak-Ribiere direction instead of restarting.
#[allow(clippy::too_many_arguments)]
fn bounded_cg<Op: Compliance>(
    op: &Op,
    z: &[f64],
    mut p: Vec<f64>,
    target_sum: f64,
    scale: f64,
    tol: f64,
    max_iterations: usize,
    w: &mut Work<Op::Scratch>,
) -> Outcome {
    let n = z.len();
    let mut gap = vec![0.0; n];
    let mut free = vec![false; n];
    let mut rho_before = 0.0;
    let mut iterations = 0;
    loop {
        op.displacement(&p, &mut w.displacement, &mut w.scratch);
        let (sum, count) = (0..n).filter(|&i| p[i] > 0.0).fold((0.0, 0usize), |(s, c), i| (s + w.displacement[i] - z[i], c + 1));
        let approach = -sum / count as f64;
        for i in 0..n {
            gap[i] = w.displacement[i] + approach - z[i];
        }
        let res = residual(&p, &gap, scale);
        if res <= tol || iterations >= max_iterations {
            return Outcome { pressure: p, gap, iterations, residual: res, converged: res <= tol };
        }
        let mut free_count = 0;
        for i in 0..n {
            free[i] = p[i] > 0.0 || gap[i] < 0.0;
            free_count += free[i] as usize;
            w.residual[i] = if free[i] { -gap[i] } else { 0.0 };
        }
        project_zero_sum(&mut w.residual, &free, free_count);
        op.precondition(&w.residual, &mut w.preconditioned, &mut w.scratch);
        mask_and_project(&mut w.preconditioned, &free, free_count);
        let rho = dot(&w.residual, &w.preconditioned);
        if !(rho > 0.0) {
            return Outcome { pressure: p, gap, iterations, residual: res, converged: false };
        }
        let beta = if iterations == 0 { 0.0 } else { ((rho - dot(&w.residual, &w.previous)) / rho_before).max(0.0) };
        for i in 0..n {
            let previous = if iterations == 0 { 0.0 } else { w.direction[i] };
            w.direction[i] = if free[i] { w.preconditioned[i] + beta * previous } else { 0.0 };
        }
        project_zero_sum(&mut w.direction, &free, free_count);
        w.previous.copy_from_slice(&w.preconditioned);
        op.displacement(&w.direction, &mut w.applied_direction, &mut w.scratch);
        let curvature = dot(&w.direction, &w.applied_direction);
        if !(curvature > 0.0) {
            return Outcome { pressure: p, gap, iterations, residual: res, converged: false };
        }
        let alpha = dot(&w.residual, &w.direction) / curvature;
        let mut clipped = false;
        let mut total = 0.0;
        for (pi, &di) in p.iter_mut().zip(&w.direction) {
            *pi += alpha * di;
            if *pi < 0.0 {
                *pi = 0.0;
                clipped = true;
            }
            total += *pi;
        }
        if clipped {
            p.iter_mut().for_each(|pi| *pi *= target_sum / total);
        }
        rho_before = rho;
        iterations += 1;
    }
}

fn project_zero_sum(v: &mut [f64], mask: &[bool], count: usize) {
    if count == 0 {
        return;
    }
    let mean = v.iter().zip(mask).filter(|(_, &m)| m).map(|(x, _)| x).sum::<f64>() / count as f64;
    for (x, &m) in v.iter_mut().zip(mask) {
        if m {
            *x -= mean;
        }
    }
}

fn mask_and_project(v: &mut [f64], mask: &[bool], count: usize) {
    for (x, &m) in v.iter_mut().zip(mask) {
        if !m {
            *x = 0.0;
        }
    }
    project_zero_sum(v, mask, count);
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, &x| m.max(x.abs()))
}
