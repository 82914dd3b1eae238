//! Geometric envelopes of a profile that stand in for the elastic contact model.
//!
//! von Meier et al.: the rubber sags into cavities as parabolas of bounded curvature. For heights
//! z on a grid dx, the envelope e is the lowest sequence with e >= z and
//! (e[i-1] - 2 e[i] + e[i+1]) / dx^2 <= 2 d* at every interior point.
//!
//! The published algorithm raises points until nothing changes; in floating point it never quite
//! stops. It need not iterate: with c = 2 d* dx^2 and g_i = e_i - c i^2 / 2 the constraint reads
//! "g is concave", so the least envelope is the least concave majorant (the upper convex hull) of
//! z_i - c i^2 / 2, plus c i^2 / 2. One monotone-chain pass computes the hull in O(N). Between
//! two hull vertices a < b the envelope is the chord lowered by a parabola,
//! e_i = z_a + t (z_b - z_a) + (c / 2)(i - a)(i - b),  t = (i - a) / (b - a),
//! written in differences so that no term of size c N^2 is ever formed.

use crate::error::{invalid, Result};

/// The von Meier envelope (m) of `heights` (m) sampled at `dx` (m) with curvature limit `d_star`
/// (1/m; the seed's 0.054 1/mm is 54 1/m). Exact to rounding; touches the profile at both ends of
/// every parabolic arc and at both ends of the profile.
pub fn von_meier(heights: &[f64], dx: f64, d_star: f64) -> Result<Vec<f64>> {
    if heights.len() < 3 {
        return invalid(format!("heights has {} points: the envelope needs at least 3", heights.len()));
    }
    if let Some(i) = heights.iter().position(|z| !z.is_finite()) {
        return invalid(format!("heights contains a non-finite value ({}) at index {i}", heights[i]));
    }
    if !(dx.is_finite() && dx > 0.0) {
        return invalid(format!("dx must be a positive finite number of metres, got {dx}"));
    }
    if !(d_star.is_finite() && d_star >= 0.0) {
        return invalid(format!("d_star must be a non-negative finite curvature in 1/m, got {d_star}"));
    }
    let half_c = d_star * dx * dx;
    // Height at i of the arc through vertices a and b.
    let arc = |a: usize, b: usize, i: usize| {
        let t = (i - a) as f64 / (b - a) as f64;
        heights[a] + t * (heights[b] - heights[a]) + half_c * (i as f64 - a as f64) * (i as f64 - b as f64)
    };
    let mut hull: Vec<usize> = Vec::with_capacity(64);
    for k in 0..heights.len() {
        while hull.len() >= 2 {
            let (h1, h2) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            if heights[h2] <= arc(h1, k, h2) {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(k);
    }
    let mut envelope = heights.to_vec();
    for pair in hull.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        for (i, e) in envelope.iter_mut().enumerate().take(b).skip(a + 1) {
            // max(): the arc is >= z by construction; rounding must not let it dip below.
            *e = arc(a, b, i).max(heights[i]);
        }
    }
    Ok(envelope)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::SplitMix64;

    /// The published rule, iterated to convergence: raise each point to the lowest value the
    /// curvature limit allows given its neighbours.
    fn plain_sweep(z: &[f64], dx: f64, d_star: f64) -> Vec<f64> {
        let c = 2.0 * d_star * dx * dx;
        let mut e = z.to_vec();
        for _ in 0..2_000_000 {
            let mut change = 0.0_f64;
            for i in 1..e.len() - 1 {
                let needed = 0.5 * (e[i - 1] + e[i + 1] - c);
                if needed > e[i] {
                    change = change.max(needed - e[i]);
                    e[i] = needed;
                }
            }
            if change < 1e-16 {
                break;
            }
        }
        e
    }

    fn random_profile(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = SplitMix64::new(seed);
        (0..n).map(|_| 1e-3 * (rng.next_f64() - 0.5)).collect()
    }

    #[test]
    fn envelope_is_the_least_admissible_one() {
        for seed in 0..20 {
            let n = 40 + seed as usize;
            let z = random_profile(n, seed);
            let (dx, d_star) = (1e-3, 200.0);
            let e = von_meier(&z, dx, d_star).unwrap();
            let c = 2.0 * d_star * dx * dx;
            for i in 1..n - 1 {
                assert!(e[i - 1] - 2.0 * e[i] + e[i + 1] <= c * (1.0 + 1e-9) + 1e-18, "curvature at {i}");
            }
            assert!(e.iter().zip(&z).all(|(a, b)| a >= b));
            let sweep = plain_sweep(&z, dx, d_star);
            let diff = e.iter().zip(&sweep).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(diff < 1e-12, "seed {seed}: differs from the converged sweep by {diff:e}");
        }
    }

    #[test]
    fn arcs_touch_the_profile_at_both_ends() {
        let z = random_profile(500, 99);
        let e = von_meier(&z, 5e-4, 54.0).unwrap();
        let mut i = 0;
        while i < z.len() {
            if e[i] > z[i] {
                let start = i;
                while i < z.len() && e[i] > z[i] {
                    i += 1;
                }
                assert!(start > 0 && i < z.len(), "an arc reaches the end of the profile");
                assert_eq!(e[start - 1], z[start - 1]);
                assert_eq!(e[i], z[i]);
            }
            i += 1;
        }
    }

    #[test]
    fn a_valley_fills_with_one_parabola() {
        // A V-shaped valley between two crests, curvature limit low enough to bridge it.
        let n = 101;
        let dx = 1e-3;
        let z: Vec<f64> = (0..n).map(|i| -1e-3 * (1.0 - ((i as f64 - 50.0) / 50.0).abs())).collect();
        let e = von_meier(&z, dx, 0.1).unwrap();
        let mid = 0.0 + 0.1 * dx * dx * (50.0) * (-50.0);
        assert!((e[50] - mid).abs() < 1e-15);
    }
}
