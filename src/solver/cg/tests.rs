//! The low-precision steering products' safety net: a deliberately wrong low-precision C d may
//! cost iterations, never an answer that misses tol (every returned residual and gap stands on a
//! fresh double-precision product).

use std::sync::atomic::{AtomicU64, Ordering};

use super::{residual, solve, Problem, Work};
use crate::compliance::Compliance;
use crate::kernel::KernelKind;
use crate::surface::compliance::SurfacePeriodic;
use crate::surface::synthetic::self_affine_surface;
use crate::surface::Grid;

/// The periodic surface operator whose low-precision C d errs by 5 % of itself (far beyond single
/// precision's rounding): every inner stop of a loose tolerance rests on it.
struct SkewedLow {
    exact: SurfacePeriodic,
    low_calls: AtomicU64,
}

impl Compliance for SkewedLow {
    type Scratch = <SurfacePeriodic as Compliance>::Scratch;
    const LOW_PRECISION_DISPLACEMENT: bool = true;
    fn len(&self) -> usize {
        self.exact.len()
    }
    fn scratch(&self) -> Self::Scratch {
        self.exact.scratch()
    }
    fn fft_pairs(scratch: &Self::Scratch) -> u64 {
        SurfacePeriodic::fft_pairs(scratch)
    }
    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut Self::Scratch) {
        self.exact.displacement(pressure, out, scratch);
    }
    fn displacement_low(&self, pressure: &[f64], out: &mut [f64], scratch: &mut Self::Scratch) {
        self.low_calls.fetch_add(1, Ordering::Relaxed);
        self.exact.displacement(pressure, out, scratch);
        out.iter_mut().for_each(|u| *u *= 1.0 + 5e-2);
    }
    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut Self::Scratch) {
        self.exact.precondition(gap, out, scratch);
    }
    fn dense_entry(&self, i: usize, j: usize) -> f64 {
        self.exact.dense_entry(i, j)
    }
}

#[test]
fn a_skewed_low_precision_product_costs_iterations_not_the_answer() {
    let n = 64;
    let grid = Grid { ny: n, nx: n, dx: 1e-3, dy: 1e-3 };
    let heights: Vec<f64> = self_affine_surface(n, 0.064, 0.8, 0.1, 4);
    let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let z: Vec<f64> = heights.iter().map(|h| h - top).collect();
    let scale = -z.iter().copied().fold(f64::INFINITY, f64::min);
    let op = SkewedLow { exact: SurfacePeriodic::new(grid, KernelKind::Element), low_calls: AtomicU64::new(0) };
    let tol = 1e-4;
    let problem = Problem { z: &z, mean_strain: 2e5 / 5.33e6, scale, tol, max_iterations: 2_000, warm_up: Some(2), guess_steps: 0 };
    let outcome = solve(&op, None, &problem, None, &mut Work::new(&op));
    assert!(op.low_calls.load(Ordering::Relaxed) > 0, "the loose tolerance never steered in low precision");
    assert!(outcome.converged, "residual {:e} after {} iterations", outcome.residual, outcome.iterations);
    // The returned gap and residual are those of a fresh double-precision product.
    let p = &outcome.pressure;
    let mut u = vec![0.0; z.len()];
    op.exact.displacement(p, &mut u, &mut op.exact.scratch());
    let contact: Vec<usize> = (0..z.len()).filter(|&i| p[i] > 0.0).collect();
    let approach = -contact.iter().map(|&i| u[i] - z[i]).sum::<f64>() / contact.len() as f64;
    let gap: Vec<f64> = (0..z.len()).map(|i| u[i] - z[i] + approach).collect();
    let recomputed = residual(p, &gap, scale);
    assert!(recomputed <= tol, "recomputed residual {recomputed:e}, stated {:e}", outcome.residual);
}
