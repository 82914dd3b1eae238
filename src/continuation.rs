//! Warm starts across moduli: the initial pressure for the next rubber of a chain.
//!
//! The bulk job solves each segment (or tile) under several moduli in turn, each solve starting
//! from the previous one's pressure (`warm_start`). Under the same mean pressure a stiffer rubber
//! indents less, so its contact set is smaller. Handed the previous pressure as it is, the solver
//! starts on the old, larger set and its active-set sweeps release the surplus edge points over
//! several sweeps. [`next_modulus_guess`] instead lowers the previous pressure by a constant and
//! clips it at zero: in strain units (p / E*) it is the previous field shifted down to the new,
//! smaller mean strain. The lowest pressures, at the contact edges, leave first, as they do in a
//! Hertzian contact whose width shrinks as E grows.
//!
//! On 64 road-like segments (0.5 m at 0.5 mm, E = 1, 2, 5, 10 MPa in that order, tol 1e-6) the
//! shifted guess took 35.5 FFT pairs per solve against 41.5 for the previous pressure as it is
//! (43.7 cold); a partial shift, or a larger one, gained less (see `benches/fft_floor.rs`).
//! For a softer rubber (a growing set) the previous pressure is returned as it is.

use crate::solver::Material;

/// The initial pressure (Pa, one per point) for solving a profile under `next` after it was
/// solved under `previous` at the same mean pressure, `previous_pressure` being that solution.
///
/// When `next` is stiffer (larger E*), returns `max(p - c, 0) * E*_next / E*_previous` with the
/// constant c >= 0 (Pa) that keeps the mean pressure: the strain field p / E* shifted down to the
/// new mean strain. Otherwise returns `previous_pressure` unchanged. Deterministic: the same
/// input gives the same bits.
pub fn next_modulus_guess(previous_pressure: &[f64], previous: Material, next: Material) -> Vec<f64> {
    let ratio = previous.plane_strain_modulus() / next.plane_strain_modulus();
    let n = previous_pressure.len() as f64;
    let mean = previous_pressure.iter().sum::<f64>() / n;
    if !(ratio < 1.0 && mean > 0.0 && mean.is_finite()) {
        return previous_pressure.to_vec();
    }
    let shift = mean_preserving_shift(previous_pressure, ratio * mean);
    let clipped: Vec<f64> = previous_pressure.iter().map(|&p| (p - shift).max(0.0)).collect();
    let clipped_mean = clipped.iter().sum::<f64>() / n;
    if clipped_mean.is_nan() || clipped_mean <= 0.0 {
        return previous_pressure.to_vec();
    }
    // Scaled back to the mean pressure exactly (E*_next / E*_previous up to the shift's rounding).
    let scale = mean / clipped_mean;
    clipped.into_iter().map(|p| p * scale).collect()
}

/// The c >= 0 with mean(max(p - c, 0)) = `target` (0 < target <= mean(p)), by Newton's method:
/// f(c) = sum(max(p - c, 0)) - N target is convex, decreasing and piecewise linear, so from c = 0
/// the iterates rise monotonically to the root and reach it in a few steps (each one passes the
/// breakpoints between it and the next kink).
fn mean_preserving_shift(pressure: &[f64], target: f64) -> f64 {
    let wanted = target * pressure.len() as f64;
    let mut shift = 0.0f64;
    for _ in 0..64 {
        let (mut sum, mut above) = (0.0f64, 0usize);
        for &p in pressure {
            if p > shift {
                sum += p - shift;
                above += 1;
            }
        }
        let excess = sum - wanted;
        if above == 0 || excess <= 1e-12 * wanted {
            break;
        }
        let next = shift + excess / above as f64;
        if next <= shift {
            break;
        }
        shift = next;
    }
    shift
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rubber(e: f64) -> Material {
        Material::new(e, 0.5).unwrap()
    }

    /// A Hertzian line-contact pressure p0 sqrt(1 - x^2 / a^2) on N points of a 1 m period.
    fn hertz(n: usize, half_width: f64, peak: f64) -> Vec<f64> {
        (0..n)
            .map(|i| {
                let x = (i as f64 + 0.5) / n as f64 - 0.5;
                peak * (1.0 - (x / half_width).powi(2)).max(0.0).sqrt()
            })
            .collect()
    }

    #[test]
    fn a_stiffer_rubber_gets_the_same_mean_on_a_smaller_set() {
        let previous = hertz(2000, 0.2, 3e5);
        let mean = previous.iter().sum::<f64>() / 2000.0;
        let guess = next_modulus_guess(&previous, rubber(1e6), rubber(4e6));
        let guess_mean = guess.iter().sum::<f64>() / 2000.0;
        assert!((guess_mean / mean - 1.0).abs() < 1e-12, "mean {guess_mean} against {mean}");
        assert!(guess.iter().all(|&p| p >= 0.0));
        // Contact only where there was contact, and strictly less of it.
        assert!(guess.iter().zip(&previous).all(|(&g, &p)| g == 0.0 || p > 0.0));
        let count = |v: &[f64]| v.iter().filter(|&&p| p > 0.0).count();
        assert!(count(&guess) < count(&previous), "{} against {}", count(&guess), count(&previous));
    }

    #[test]
    fn the_shift_lowers_the_strain_field_by_a_constant() {
        // In strain units the guess is (p_prev / E*_prev - s)+ for one s: where the guess is
        // positive, p_prev / E*_prev - p_guess / E*_next is the same everywhere.
        let previous = hertz(1000, 0.3, 2e5);
        let (soft, stiff) = (rubber(2e6), rubber(5e6));
        let guess = next_modulus_guess(&previous, soft, stiff);
        let drops: Vec<f64> = previous
            .iter()
            .zip(&guess)
            .filter(|(_, &g)| g > 0.0)
            .map(|(&p, &g)| p / soft.plane_strain_modulus() - g / stiff.plane_strain_modulus())
            .collect();
        let (low, high) = drops.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &d| (l.min(d), h.max(d)));
        assert!(low > 0.0, "the field must go down, lowest drop {low}");
        assert!(high - low <= 1e-9 * high, "drops range from {low} to {high}");
    }

    #[test]
    fn a_softer_rubber_or_the_same_one_keeps_the_previous_pressure() {
        let previous = hertz(500, 0.25, 1e5);
        assert_eq!(next_modulus_guess(&previous, rubber(5e6), rubber(2e6)), previous);
        assert_eq!(next_modulus_guess(&previous, rubber(5e6), rubber(5e6)), previous);
    }

    #[test]
    fn full_contact_stays_full_for_a_small_step_and_loses_its_lows_for_a_large_one() {
        // 1.5e5 to 2.5e5 Pa, mean 2e5: 1.5 times stiffer lowers the strain field by less than its
        // lowest value (no point leaves); 10 times stiffer by more (the lowest points leave).
        let previous: Vec<f64> = (0..400).map(|i| 2e5 + 5e4 * (i as f64 * 0.05).sin()).collect();
        let mean = previous.iter().sum::<f64>() / 400.0;
        for (stiffer, any_leave) in [(1.5e6, false), (1e7, true)] {
            let guess = next_modulus_guess(&previous, rubber(1e6), rubber(stiffer));
            assert!((guess.iter().sum::<f64>() / 400.0 / mean - 1.0).abs() < 1e-12);
            assert_eq!(guess.contains(&0.0), any_leave, "E = {stiffer}");
        }
    }
}
