//! Special functions needed by the influence coefficients: the Clausen function Cl2 (the integral
//! of the periodic log kernel) and the trigamma function (the aliased sums of its spectrum).

use std::f64::consts::PI;

/// Terms of the Cl2 series near 0: zeta(2k) / (k (2k + 1)), k = 1..=40 (zeta(2k) - 1 < 1e-18
/// beyond 2k = 60, where four terms of the zeta series are exact to rounding).
fn clausen_series_coefficients() -> &'static [f64; 40] {
    static TABLE: std::sync::OnceLock<[f64; 40]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        const ZETA_EVEN: [f64; 8] = [
            1.644_934_066_848_226_4, // zeta(2)
            1.082_323_233_711_138_2, // zeta(4)
            1.017_343_061_984_449,   // zeta(6)
            1.004_077_356_197_944_3, // zeta(8)
            1.000_994_575_127_818_1, // zeta(10)
            1.000_246_086_553_308,   // zeta(12)
            1.000_061_248_135_058_7, // zeta(14)
            1.000_015_282_259_408_7, // zeta(16)
        ];
        let mut table = [0.0; 40];
        for (i, c) in table.iter_mut().enumerate() {
            let k = i + 1;
            let zeta = if k <= ZETA_EVEN.len() {
                ZETA_EVEN[k - 1]
            } else {
                let s = 2.0 * k as f64;
                1.0 + 2f64.powf(-s) + 3f64.powf(-s) + 4f64.powf(-s)
            };
            *c = zeta / ((k * (2 * k + 1)) as f64);
        }
        table
    })
}

/// Clausen function Cl2(theta) = -int_0^theta ln|2 sin(t/2)| dt, for any real theta.
///
/// Accurate to a few ulps of max|Cl2| ~ 1.0149: the series
/// Cl2(t) = t - t ln|t| + sum_k zeta(2k) / (k (2k+1)) * t (t / 2 pi)^(2k)
/// is used on |t| <= pi after reduction by periodicity and oddness.
pub fn clausen2(theta: f64) -> f64 {
    let two_pi = 2.0 * PI;
    let mut t = theta.rem_euclid(two_pi);
    if t > PI {
        t -= two_pi;
    }
    if t == 0.0 {
        return 0.0;
    }
    let sign = t.signum();
    let t = t.abs();
    let x2 = (t / two_pi) * (t / two_pi);
    let mut sum = 0.0;
    let mut power = x2;
    for &c in clausen_series_coefficients() {
        let term = c * power;
        sum += term;
        if term < 1e-18 * sum {
            break;
        }
        power *= x2;
    }
    sign * (t - t * t.ln() + t * sum)
}

/// Trigamma psi'(x) for x > 0, to about 1e-15 relative.
pub fn trigamma(mut x: f64) -> f64 {
    debug_assert!(x > 0.0);
    let mut acc = 0.0;
    // Shift up with psi'(x) = psi'(x + 1) + 1 / x^2 until the asymptotic series is exact to rounding.
    while x < 12.0 {
        acc += 1.0 / (x * x);
        x += 1.0;
    }
    let inv = 1.0 / x;
    let inv2 = inv * inv;
    // 1/x + 1/(2x^2) + sum B_2k / x^(2k+1)
    let series = inv2
        * (1.0 / 6.0 + inv2 * (-1.0 / 30.0 + inv2 * (1.0 / 42.0 + inv2 * (-1.0 / 30.0 + inv2 * (5.0 / 66.0 + inv2 * (-691.0 / 2730.0))))));
    acc + inv + 0.5 * inv2 + inv * series
}

/// f(u) = sum_{j >= 0} (-1)^j / (u + j)^2 for u in (0, 1], via trigamma.
pub fn alternating_inverse_squares(u: f64) -> f64 {
    0.25 * (trigamma(0.5 * u) - trigamma(0.5 * (u + 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clausen_known_values() {
        // Catalan's constant G = Cl2(pi/2); max of Cl2 at pi/3 is 1.0149416064096536.
        assert!((clausen2(PI / 2.0) - 0.915_965_594_177_219).abs() < 1e-15);
        assert!((clausen2(PI / 3.0) - 1.014_941_606_409_653_6).abs() < 1e-15);
        assert!(clausen2(PI).abs() < 1e-15);
        assert!((clausen2(-PI / 3.0) + 1.014_941_606_409_653_6).abs() < 1e-15);
        assert!((clausen2(2.0 * PI + 0.3) - clausen2(0.3)).abs() < 1e-14);
    }

    #[test]
    fn clausen_matches_quadrature() {
        // Independent check: Cl2(b) - Cl2(a) = -int_a^b ln(2 sin(t/2)) dt by Gauss-Legendre (smooth there).
        let (a, b) = (1.0_f64, 2.5_f64);
        let nodes = [
            (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
            (-0.538_469_310_105_683, 0.478_628_670_499_366_5),
            (0.0, 0.568_888_888_888_888_9),
            (0.538_469_310_105_683, 0.478_628_670_499_366_5),
            (0.906_179_845_938_664, 0.236_926_885_056_189_1),
        ];
        let pieces = 200;
        let h = (b - a) / pieces as f64;
        let mut integral = 0.0;
        for i in 0..pieces {
            let mid = a + (i as f64 + 0.5) * h;
            for (x, w) in nodes {
                let t: f64 = mid + 0.5 * h * x;
                integral += 0.5 * h * w * (2.0 * (0.5 * t).sin()).ln();
            }
        }
        assert!((clausen2(b) - clausen2(a) + integral).abs() < 1e-13);
    }

    #[test]
    fn trigamma_known_values() {
        assert!((trigamma(1.0) - PI * PI / 6.0).abs() < 1e-14);
        assert!((trigamma(0.5) - PI * PI / 2.0).abs() < 1e-14);
        // psi'(x) = 1/x^2 + zeta(2) - 2 zeta(3) x + 3 zeta(4) x^2 - ... near 0.
        let series = 1e6 + PI * PI / 6.0 - 2.0 * 1.202_056_903_159_594 * 1e-3 + 3.0 * 1.082_323_233_711_138 * 1e-6;
        assert!((trigamma(1e-3) - series).abs() < 1e-8);
    }

    #[test]
    fn alternating_sum_matches_direct_sum() {
        for &u in &[0.013, 0.25, 0.5, 0.77, 1.0] {
            // Pairwise-summed alternating series, accelerated by averaging the last two partial sums.
            let mut partial = 0.0;
            let mut previous = 0.0;
            for j in 0..200_000 {
                previous = partial;
                let s = if j % 2 == 0 { 1.0 } else { -1.0 };
                partial += s / ((u + j as f64) * (u + j as f64));
            }
            let direct = 0.5 * (partial + previous);
            assert!((alternating_inverse_squares(u) - direct).abs() < 1e-12 * direct.abs().max(1.0));
        }
    }
}
