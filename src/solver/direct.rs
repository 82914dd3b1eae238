//! Dense direct solve of the same discrete contact problem, for small N: a primal-dual active-set
//! loop whose every step solves the contact-set equations exactly with a Cholesky factor (faer).
//!
//! On a trial contact set A, with p = 0 off A:  C_AA p_A + h 1 = z_A,  sum p_A = N P.
//! C_AA is only positive definite on zero-sum vectors (a uniform pressure moves the surface
//! rigidly), so the factor is taken of C_AA + c 1 1^T, which changes h but not p. The loop drops
//! points with p < 0, adds points that penetrate, and stops when A repeats.
//!
//! Independent of the CG path: it reads the real-space coefficients (Clausen functions), never the
//! FFT spectrum, and shares only the residual definition.

use faer::prelude::*;
use faer::{Mat, Side};

use super::{residual, Outcome};
use crate::compliance::Compliance;
use crate::error::{ContactError, Result};

const MAX_SWEEPS: usize = 500;

/// `converged` means both that the set settled and that the residual is within `tol`: a settled
/// set solved to rounding can still miss a very small tol on an ill-conditioned problem.
pub(crate) fn solve<Op: Compliance>(op: &Op, z: &[f64], mean_strain: f64, scale: f64, tol: f64) -> Result<Outcome> {
    let n = z.len();
    let target_sum = mean_strain * n as f64;
    let mut active: Vec<usize> = (0..n).collect();
    let mut pressure = vec![0.0; n];
    let mut gap = vec![0.0; n];
    for sweep in 1..=MAX_SWEEPS {
        let (p_active, approach) = solve_on_set(op, z, &active, target_sum)?;
        pressure.fill(0.0);
        for (&i, &pi) in active.iter().zip(&p_active) {
            pressure[i] = pi;
        }
        for i in 0..n {
            let u: f64 = active.iter().zip(&p_active).map(|(&j, &pj)| op.dense_entry(i, j) * pj).sum();
            gap[i] = u + approach - z[i];
        }
        // Tolerance for "penetrates": rounding of the dense products, not a modelling choice.
        let slack = 1e-13 * scale;
        let next: Vec<usize> = (0..n)
            .filter(|&i| {
                let was_active = active.binary_search(&i).is_ok();
                if was_active {
                    pressure[i] > 0.0
                } else {
                    gap[i] < -slack
                }
            })
            .collect();
        if next == active {
            let pressure_nonneg: Vec<f64> = pressure.iter().map(|&p| p.max(0.0)).collect();
            let res = residual(&pressure_nonneg, &gap, scale);
            return Ok(Outcome { pressure: pressure_nonneg, gap, iterations: sweep, residual: res, converged: res <= tol });
        }
        if next.is_empty() {
            return Err(ContactError::DirectSolverFailed("the trial contact set became empty".into()));
        }
        active = next;
    }
    Err(ContactError::DirectSolverFailed(format!("the active set did not settle in {MAX_SWEEPS} sweeps")))
}

/// Pressures on `active` (p elsewhere 0) and the approach h solving C_AA p + h = z_A, sum p = S.
fn solve_on_set<Op: Compliance>(op: &Op, z: &[f64], active: &[usize], target_sum: f64) -> Result<(Vec<f64>, f64)> {
    contact_set_solve(
        active.len(),
        |a, b| op.dense_entry(active[a], active[b]),
        |a| z[active[a]],
        |_| true,
        target_sum,
        op.dense_entry(0, 0).abs(),
    )
    .ok_or_else(|| ContactError::DirectSolverFailed("no positive-definite shift of the contact-set matrix was found".into()))
}

/// The dense solve on one contact set of m points, shared with Clapp's windows: pressures q and
/// the approach c0 with A q + c0 1 = z and the sum of q over the points `counted` selects equal to
/// S, for the m x m compliance A of the set (`entry`).
///
/// A log kernel is only positive definite on zero-sum vectors (a uniform pressure moves the
/// surface rigidly), so the factor is taken of M = A + s 1 1^T, s grown from `shift` until M
/// factors: with T = sum q, M q + (c0 - s T) 1 = z, so q = x - h y with x = M^-1 z, y = M^-1 1
/// and h = c0 - s T fixed by the load. One step of iterative refinement recovers the digits the
/// dense products lose at N ~ 1000. None when no shift makes M factor.
pub(crate) fn contact_set_solve(
    m: usize,
    entry: impl Fn(usize, usize) -> f64,
    z: impl Fn(usize) -> f64,
    counted: impl Fn(usize) -> bool,
    target_sum: f64,
    mut shift: f64,
) -> Option<(Vec<f64>, f64)> {
    for _ in 0..60 {
        let matrix = Mat::from_fn(m, m, |a, b| entry(a, b) + shift);
        let Ok(factor) = matrix.llt(Side::Lower) else {
            shift *= 4.0;
            continue;
        };
        let saddle = |rhs: &dyn Fn(usize) -> f64, sum: f64| {
            let x = factor.solve(Mat::from_fn(m, 2, |a, col| if col == 0 { rhs(a) } else { 1.0 }));
            let counted_sum = |col: usize| (0..m).filter(|&a| counted(a)).map(|a| x[(a, col)]).sum::<f64>();
            let h = (counted_sum(0) - sum) / counted_sum(1);
            let q: Vec<f64> = (0..m).map(|a| x[(a, 0)] - h * x[(a, 1)]).collect();
            let total: f64 = q.iter().sum();
            (q, h + shift * total)
        };
        let (mut q, mut approach) = saddle(&z, target_sum);
        let residual: Vec<f64> = (0..m).map(|a| z(a) - (0..m).map(|b| entry(a, b) * q[b]).sum::<f64>() - approach).collect();
        let (dq, dc) = saddle(&|a| residual[a], 0.0);
        q.iter_mut().zip(&dq).for_each(|(x, d)| *x += d);
        approach += dc;
        return Some((q, approach));
    }
    None
}
