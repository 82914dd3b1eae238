//! Coarse starts for model-grid solves: each solve on a grid k times finer than the data starts
//! from the data grid's answer.
//!
//! The bulk job solves a segment of N data readings on a model grid of N k points (k = 4 to 12,
//! any whole number), every k-th model point being a reading exactly (`roadtex.models.grid`).
//! Started cold, the fine solve finds its contact set from full contact by bounded CG steps and
//! active-set sweeps, each sweep at N k points. The data grid's own problem (the readings alone,
//! N points, k times cheaper per iteration) has nearly the same contact set at the scale of the
//! readings: solved first, its pressure prolonged to the fine grid puts the sweeps next to the
//! answer. Unlike the nested start ([`crate::solver::nested`], halving, even sizes only, cold
//! solves of 2^14 points and more) this works for any k and any N divisible by k, and it is the
//! data grid's problem itself, not an average of the model's heights.
//!
//! The prolongation is linear between the coarse points (periodic, coarse point i on fine point
//! i k): it keeps p >= 0, and the mean pressure exactly in exact arithmetic (each coarse value
//! spreads over weights summing to k); the solver rescales its initial pressure to the load
//! anyway. The fine solve meets the requested tolerance by the solver's own test, as a cold one
//! does; its answer differs from the cold one's within that tolerance only.

use crate::error::{invalid, Result};
use crate::solver::{nested::NESTED_TOL, ContactSolution, ContactSolver, Material, SolverOptions, Workspace, MIN_ELEMENTS};

/// The tolerance of the data-grid solve that starts the fine one (the requested one when looser):
/// as for the nested start's coarser levels, the data grid's answer differs from the model
/// grid's by far more than 1e-4 of the profile height, so a tighter coarse solve buys nothing.
pub const COARSE_START_TOL: f64 = NESTED_TOL;

/// The data grid's solver for model-grid solves of `n` points refined `k` times (dx the model's
/// element size, m).
pub struct CoarseStart {
    k: usize,
    solver: ContactSolver,
}

impl CoarseStart {
    /// None when there is no coarser grid to start from (k = 1, or fewer than
    /// [`MIN_ELEMENTS`] data points): those solves start as they would without it. An N that is
    /// not a multiple of k is refused (the model grid is not the data's refined k times).
    pub fn new(n: usize, dx: f64, k: usize, options: SolverOptions) -> Result<Option<Self>> {
        if k == 0 {
            return invalid("coarse_start must be a whole number of at least 1 (the model grid's refinement k)");
        }
        if n % k != 0 {
            return invalid(format!(
                "coarse_start = {k}: segments of {n} points are not a grid {k} times finer than the data's (N must be a multiple of k)"
            ));
        }
        if k == 1 || n / k < MIN_ELEMENTS {
            return Ok(None);
        }
        let options = SolverOptions { tol: options.tol.max(COARSE_START_TOL), ..options };
        Ok(Some(Self { k, solver: ContactSolver::new(n / k, dx * k as f64, options)? }))
    }

    /// The refinement k.
    pub fn refinement(&self) -> usize {
        self.k
    }

    /// Solves the data grid's problem of the model heights `fine` (every k-th point), from
    /// `coarse_guess` (Pa, a data-grid pressure, e.g. the previous modulus's) when given.
    pub fn solve(
        &self,
        workspace: &mut Workspace,
        fine: &[f64],
        material: Material,
        mean_pressure: f64,
        coarse_guess: Option<&[f64]>,
    ) -> Result<ContactSolution> {
        let readings: Vec<f64> = fine.iter().step_by(self.k).copied().collect();
        self.solver.solve_from(workspace, &readings, material, mean_pressure, coarse_guess)
    }

    /// The data grid's pressure (Pa) on the model grid: [`prolong_linear`].
    pub fn prolong(&self, coarse_pressure: &[f64]) -> Vec<f64> {
        prolong_linear(coarse_pressure, self.k)
    }
}

/// A periodic grid's values on the grid `k` times finer, linear between them: fine point i k + j
/// (0 <= j < k) is (1 - j / k) c_i + (j / k) c_(i+1), the last interval wrapping to c_0. Keeps
/// c >= 0, and the mean (each c_i's weights sum to k).
pub fn prolong_linear(coarse: &[f64], k: usize) -> Vec<f64> {
    let n = coarse.len();
    let mut fine = Vec::with_capacity(n * k);
    for i in 0..n {
        let (a, b) = (coarse[i], coarse[(i + 1) % n]);
        fine.push(a);
        for j in 1..k {
            let t = j as f64 / k as f64;
            fine.push((1.0 - t) * a + t * b);
        }
    }
    fine
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_prolongation_keeps_the_points_the_mean_and_the_sign() {
        let coarse = [0.0, 3.0, 1.5, 0.0, 0.0, 6.0];
        for k in [2usize, 3, 5, 7] {
            let fine = prolong_linear(&coarse, k);
            assert_eq!(fine.len(), coarse.len() * k);
            assert!(fine.iter().step_by(k).zip(&coarse).all(|(f, c)| f == c), "k = {k}");
            assert!(fine.iter().all(|&p| p >= 0.0));
            let (mean_fine, mean_coarse) = (fine.iter().sum::<f64>() / fine.len() as f64, coarse.iter().sum::<f64>() / 6.0);
            assert!((mean_fine / mean_coarse - 1.0).abs() < 1e-14, "k = {k}: {mean_fine} against {mean_coarse}");
        }
        // The wrap: the last interval runs from the last value to the first.
        assert_eq!(prolong_linear(&[4.0, 0.0], 2), vec![4.0, 2.0, 0.0, 2.0]);
    }

    #[test]
    fn sizes_that_are_not_k_times_the_data_are_refused_and_k_1_has_no_coarse_level() {
        let options = SolverOptions { tol: 1e-6, ..Default::default() };
        assert!(CoarseStart::new(1000, 1e-4, 3, options).is_err());
        assert!(CoarseStart::new(1000, 1e-4, 0, options).is_err());
        assert!(CoarseStart::new(1000, 1e-4, 1, options).unwrap().is_none());
        assert!(CoarseStart::new(40, 1e-4, 8, options).unwrap().is_none());
        let start = CoarseStart::new(1200, 1e-4, 6, options).unwrap().unwrap();
        assert_eq!((start.refinement(), start.solver.len()), (6, 200));
    }
}
