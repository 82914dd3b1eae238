//! Closed-form reference solutions, for tests and benchmarks. SI units throughout.

use std::f64::consts::PI;

/// Westergaard's wavy surface z = A cos(2 pi x / L) pressed by an elastic half-space of plane
/// strain modulus E* under mean pressure P (Johnson, Contact Mechanics, section 13.2).
#[derive(Clone, Copy, Debug)]
pub struct Westergaard {
    /// A (m)
    pub amplitude: f64,
    /// L (m)
    pub wavelength: f64,
    /// E* (Pa)
    pub plane_strain_modulus: f64,
    /// P (Pa)
    pub mean_pressure: f64,
}

impl Westergaard {
    /// p* = pi E* A / L: the mean pressure at which contact becomes complete (Pa).
    pub fn full_contact_pressure(&self) -> f64 {
        PI * self.plane_strain_modulus * self.amplitude / self.wavelength
    }

    /// Half-width a of the contact zone around each crest (m): sin^2(pi a / L) = P / p*.
    pub fn contact_half_width(&self) -> f64 {
        let ratio = self.mean_pressure / self.full_contact_pressure();
        if ratio >= 1.0 {
            self.wavelength / 2.0
        } else {
            self.wavelength / PI * ratio.sqrt().asin()
        }
    }

    fn centred(&self, x: f64) -> f64 {
        let l = self.wavelength;
        (x + 0.5 * l).rem_euclid(l) - 0.5 * l
    }

    /// Pressure at x (Pa).
    pub fn pressure(&self, x: f64) -> f64 {
        let x = self.centred(x);
        let (p, l) = (self.mean_pressure, self.wavelength);
        let p_star = self.full_contact_pressure();
        if p >= p_star {
            return p + p_star * (2.0 * PI * x / l).cos();
        }
        let sa = (PI * self.contact_half_width() / l).sin();
        let s = (PI * x / l).sin();
        if s.abs() >= sa {
            return 0.0;
        }
        2.0 * p / (sa * sa) * (PI * x / l).cos() * (sa * sa - s * s).sqrt()
    }

    /// Antiderivative of the pressure on (-L/2, L/2] (N/m), continuous there.
    fn load_up_to(&self, x: f64) -> f64 {
        let (p, l) = (self.mean_pressure, self.wavelength);
        let p_star = self.full_contact_pressure();
        if p >= p_star {
            return p * x + p_star * l / (2.0 * PI) * (2.0 * PI * x / l).sin();
        }
        let sa = (PI * self.contact_half_width() / l).sin();
        let v = (PI * x / l).sin().clamp(-sa, sa);
        let w = (v / sa).clamp(-1.0, 1.0);
        l / PI * p / (sa * sa) * (v * (sa * sa - v * v).max(0.0).sqrt() + sa * sa * w.asin())
    }

    /// Mean of the exact pressure over the element [x - dx/2, x + dx/2] (Pa): the quantity a
    /// piecewise-constant pressure approximates.
    pub fn element_pressure(&self, x: f64, dx: f64) -> f64 {
        let l = self.wavelength;
        let c = self.centred(x);
        let (a, b) = (c - 0.5 * dx, c + 0.5 * dx);
        // An element may straddle the period boundary at L/2: split it there.
        let load = |lo: f64, hi: f64| self.load_up_to(hi) - self.load_up_to(lo);
        let total = if b > 0.5 * l {
            load(a, 0.5 * l) + load(-0.5 * l, b - l)
        } else if a < -0.5 * l {
            load(a + l, 0.5 * l) + load(-0.5 * l, b)
        } else {
            load(a, b)
        };
        total / dx
    }
}

/// Rigid flat punch of width L pressed with mean pressure P into a half-space (no periodicity):
/// p(x) = P L / (pi sqrt(x (L - x))) on 0 < x < L. Also the finite model's flat profile.
#[derive(Clone, Copy, Debug)]
pub struct FlatPunch {
    /// L (m)
    pub width: f64,
    /// P (Pa)
    pub mean_pressure: f64,
}

impl FlatPunch {
    pub fn pressure(&self, x: f64) -> f64 {
        let l = self.width;
        if x <= 0.0 || x >= l {
            return 0.0;
        }
        self.mean_pressure * l / (PI * (x * (l - x)).sqrt())
    }

    /// Mean of the exact pressure over [x - dx/2, x + dx/2] clipped to the punch (Pa).
    pub fn element_pressure(&self, x: f64, dx: f64) -> f64 {
        let l = self.width;
        let cumulative = |s: f64| 2.0 * (s.clamp(0.0, l) / l).sqrt().asin();
        self.mean_pressure * l / PI * (cumulative(x + 0.5 * dx) - cumulative(x - 0.5 * dx)) / dx
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn westergaard_carries_the_load() {
        for ratio in [0.05, 0.3, 0.9, 1.5] {
            let w = Westergaard { amplitude: 1e-4, wavelength: 0.01, plane_strain_modulus: 3e6, mean_pressure: 0.0 };
            let w = Westergaard { mean_pressure: ratio * w.full_contact_pressure(), ..w };
            let n = 1000;
            let dx = w.wavelength / n as f64;
            let mean: f64 = (0..n).map(|i| w.element_pressure((i as f64 + 0.5) * dx, dx)).sum::<f64>() / n as f64;
            assert!((mean / w.mean_pressure - 1.0).abs() < 1e-12, "ratio {ratio}: {mean}");
            // Fine midpoint sums of the point pressure agree with the element averages.
            let fine: f64 = (0..200).map(|k| w.pressure(0.3 * dx + (k as f64 + 0.5) * dx / 200.0)).sum::<f64>() / 200.0;
            assert!((fine - w.element_pressure(0.8 * dx, dx)).abs() < 1e-6 * w.mean_pressure);
        }
    }

    #[test]
    fn flat_punch_carries_the_load() {
        let f = FlatPunch { width: 0.5, mean_pressure: 2e5 };
        let n = 777;
        let dx = f.width / n as f64;
        let mean: f64 = (0..n).map(|i| f.element_pressure((i as f64 + 0.5) * dx, dx)).sum::<f64>() / n as f64;
        // The end elements integrate a 1/sqrt singularity: an ulp of position costs 1e-8 of load.
        assert!((mean / f.mean_pressure - 1.0).abs() < 1e-7, "{mean}");
    }
}
