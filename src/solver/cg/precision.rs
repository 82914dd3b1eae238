//! Which products may run in low precision (split from [`super`] by concern): the ones that only
//! steer the iteration.

use crate::compliance::Compliance;

/// Tolerances at or above this solve every product that steers the iteration (the inner CG's
/// C d, the bounded CG's of the warm-up and the safety net) in low precision
/// ([`Compliance::displacement_low`], single-precision transforms where the operator has them:
/// [`Compliance::LOW_PRECISION_DISPLACEMENT`], about 1e-7 of the product's size); tighter ones only
/// the rough sweeps', and only where [`Compliance::STEERS_LOW_AT_TIGHT_TOL`]. Every stopping test
/// stands on a fresh double-precision product, and a precise sweep that misses tol on a settled
/// set is solved again in double precision.
pub(super) const LOW_PRECISION_TOL: f64 = 1e-5;

/// C x into `out` for a product that steers the iteration (no stopping test stands on it): in low
/// precision when `low`.
pub(super) fn steering_product<Op: Compliance>(op: &Op, low: bool, x: &[f64], out: &mut [f64], scratch: &mut Op::Scratch) {
    if low {
        op.displacement_low(x, out, scratch);
    } else {
        op.displacement(x, out, scratch);
    }
}

/// M r into `out` (the preconditioner steers every iteration, no stopping test stands on it): in
/// low precision when `low`, and at every tolerance where the operator says so
/// ([`Compliance::STEERS_LOW_AT_TIGHT_TOL`]).
pub(super) fn steering_precondition<Op: Compliance>(op: &Op, low: bool, r: &[f64], out: &mut [f64], scratch: &mut Op::Scratch) {
    if low || Op::STEERS_LOW_AT_TIGHT_TOL {
        op.precondition_low(r, out, scratch);
    } else {
        op.precondition(r, out, scratch);
    }
}
