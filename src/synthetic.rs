//! Reproducible synthetic profiles for tests, benchmarks and the demo.

use std::f64::consts::PI;

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

/// SplitMix64: tiny, fast and reproducible on every platform; statistics quality is ample here.
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// A periodic self-affine profile of N points over length L (m): Fourier amplitudes
/// |h_k| proportional to k^-(hurst + 1/2) for 1 <= k < N * cutoff_fraction, random phases, scaled
/// so that the rms of the finite-difference slope is `rms_slope`. Mean zero.
pub fn self_affine(n: usize, length: f64, hurst: f64, rms_slope: f64, cutoff_fraction: f64, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    let mut planner = RealFftPlanner::<f64>::new();
    let inverse = planner.plan_fft_inverse(n);
    let mut spectrum = inverse.make_input_vec();
    spectrum.iter_mut().for_each(|c| *c = Complex::new(0.0, 0.0));
    let cutoff = ((n as f64 * cutoff_fraction).ceil() as usize).min(n / 2 + 1);
    for (k, c) in spectrum.iter_mut().enumerate().take(cutoff).skip(1) {
        let amplitude = (k as f64).powf(-(hurst + 0.5));
        let phase = 2.0 * PI * rng.next_f64();
        *c = Complex::from_polar(amplitude, phase);
    }
    if n % 2 == 0 {
        spectrum[n / 2].im = 0.0;
    }
    let mut heights = inverse.make_output_vec();
    // `spectrum` has zero imaginary part at bin 0 by construction.
    let _ = inverse.process(&mut spectrum, &mut heights);
    let dx = length / n as f64;
    let slope_ms: f64 = (0..n).map(|i| ((heights[(i + 1) % n] - heights[i]) / dx).powi(2)).sum::<f64>() / n as f64;
    let factor = if slope_ms > 0.0 { rms_slope / slope_ms.sqrt() } else { 0.0 };
    heights.iter_mut().for_each(|h| *h *= factor);
    heights
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn self_affine_has_requested_slope_and_is_reproducible() {
        let a = self_affine(1024, 1.0, 0.8, 0.1, 0.25, 7);
        let b = self_affine(1024, 1.0, 0.8, 0.1, 0.25, 7);
        let c = self_affine(1024, 1.0, 0.8, 0.1, 0.25, 8);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let dx = 1.0 / 1024.0;
        let rms = ((0..1024).map(|i| ((a[(i + 1) % 1024] - a[i]) / dx).powi(2)).sum::<f64>() / 1024.0).sqrt();
        assert!((rms - 0.1).abs() < 1e-12);
        assert!(a.iter().sum::<f64>().abs() < 1e-12);
    }
}
