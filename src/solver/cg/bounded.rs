//! The bound-constrained CG of the cold start's warm-up and of the safety net (split from
//! [`super`] by concern: the sweeps' deflated PCG stays there).

use super::precision::{steering_precondition, steering_product};
use super::{Context, MAX_COLUMN_UPDATES};
use crate::compliance::Compliance;
use crate::solver::reduce::{
    bounded_gap, dot, free_direction, free_set, mask_and_project, project_zero_sum, scale, step_and_count_negative, sum4,
};
use crate::solver::Outcome;

impl<Op: Compliance> Context<'_, Op> {
    /// Bound-constrained CG (Vollebregt 2014) with the FFT preconditioner from `p`: the free set is
    /// {p > 0} U {p = 0 and gap < 0}; pressures crossing zero are truncated and the iteration
    /// continues with a Polak-Ribiere direction instead of restarting.
    // `!(x > 0.0)` below is deliberate: it also stops on NaN. The free-set loop indexes four vectors in step.
    #[allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]
    pub(super) fn bounded_cg(&mut self, mut p: Vec<f64>, max_iterations: usize) -> Outcome {
        let (op, z, w) = (self.op, self.z, &mut *self.w);
        let low_products = self.low_products;
        let n = z.len();
        let mut gap = vec![0.0; n];
        let mut free = vec![false; n];
        let mut rho_before = 0.0;
        let mut iterations = 0;
        // Whether w.displacement holds C p tracked through the updates (else a fresh product is due).
        let mut tracked = false;
        let mut clipped_at: Vec<(usize, f64)> = Vec::new();
        loop {
            let mut fresh = !tracked;
            if fresh {
                op.displacement(&p, &mut w.displacement, &mut w.scratch);
            }
            let mut res = bounded_gap(z, &p, &w.displacement, &mut gap, self.scale);
            if (res <= self.tol || iterations >= max_iterations) && !fresh {
                // The stopping test and what is returned stand on a fresh product.
                op.displacement(&p, &mut w.displacement, &mut w.scratch);
                res = bounded_gap(z, &p, &w.displacement, &mut gap, self.scale);
                fresh = true;
            }
            if res <= self.tol || iterations >= max_iterations {
                debug_assert!(fresh);
                return Outcome { pressure: p, gap, iterations, residual: res, converged: res <= self.tol };
            }
            let free_count = free_set(&mut free, &mut w.residual, &p, &gap);
            project_zero_sum(&mut w.residual, &free, free_count);
            steering_precondition(op, low_products, &w.residual, &mut w.preconditioned, &mut w.scratch);
            mask_and_project(&mut w.preconditioned, &free, free_count);
            let rho = dot(&w.residual, &w.preconditioned);
            if !(rho > 0.0) {
                // A breakdown: what is returned stands on a fresh product too (the tracked C p may
                // carry low-precision steps).
                if !fresh {
                    op.displacement(&p, &mut w.displacement, &mut w.scratch);
                    res = bounded_gap(z, &p, &w.displacement, &mut gap, self.scale);
                }
                return Outcome { pressure: p, gap, iterations, residual: res, converged: false };
            }
            // `direction` and `previous` are read only after this call wrote them (iterations > 0).
            let beta = if iterations == 0 { 0.0 } else { ((rho - dot(&w.residual, &w.previous)) / rho_before).max(0.0) };
            free_direction(&mut w.direction, &w.preconditioned, &free, beta, iterations == 0);
            project_zero_sum(&mut w.direction, &free, free_count);
            w.previous.copy_from_slice(&w.preconditioned);
            steering_product(op, low_products, &w.direction, &mut w.applied_direction, &mut w.scratch);
            let curvature = dot(&w.direction, &w.applied_direction);
            if !(curvature > 0.0) {
                // A breakdown: what is returned stands on a fresh product too (the tracked C p may
                // carry low-precision steps).
                if !fresh {
                    op.displacement(&p, &mut w.displacement, &mut w.scratch);
                    res = bounded_gap(z, &p, &w.displacement, &mut gap, self.scale);
                }
                return Outcome { pressure: p, gap, iterations, residual: res, converged: false };
            }
            let alpha = dot(&w.residual, &w.direction) / curvature;
            // C p follows p: + alpha C d, then a column per clipped point (a fresh product instead
            // when more than a few are clipped), then the load rescaling.
            clipped_at.clear();
            let clipped = step_and_count_negative(&mut p, &mut w.displacement, &w.direction, &w.applied_direction, alpha);
            if clipped > 0 {
                for (i, pi) in p.iter_mut().enumerate().filter(|(_, pi)| **pi < 0.0) {
                    if clipped <= MAX_COLUMN_UPDATES {
                        clipped_at.push((i, -*pi));
                    }
                    *pi = 0.0;
                }
            }
            let total = if clipped > 0 { sum4(&p) } else { 0.0 };
            tracked = clipped <= MAX_COLUMN_UPDATES;
            if tracked {
                for &(j, delta) in &clipped_at {
                    op.add_column(j, delta, &mut w.displacement);
                }
            }
            if clipped > 0 {
                let factor = self.target_sum / total;
                scale(&mut p, factor);
                scale(&mut w.displacement, factor);
            }
            rho_before = rho;
            iterations += 1;
        }
    }
}
