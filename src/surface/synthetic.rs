//! Reproducible isotropic self-affine surfaces, the benchmark case of issue 16: |h(k)| proportional
//! to |k|^-(1 + H) for 1 <= |q| < N/4 (q in cycles per side), random phases, scaled to a given rms
//! slope (forward differences in x and y), periodic.

use std::f64::consts::PI;

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use crate::synthetic::SplitMix64;

/// An n x n periodic self-affine surface of side `length` (m), row-major, with Hurst exponent
/// `hurst` and rms slope `rms_slope`, from `seed`.
pub fn self_affine_surface(n: usize, length: f64, hurst: f64, rms_slope: f64, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    let mut heights = vec![0.0; n * n];
    let half = n as isize / 2;
    let upper = n as f64 / 4.0;
    // A sum of cosines with one random phase per wave vector pair (q, -q): real and periodic.
    let mut modes = Vec::new();
    for qy in -half..half {
        for qx in 0..half {
            if qx == 0 && qy <= 0 {
                continue;
            }
            let q = (qx as f64).hypot(qy as f64);
            if (1.0..upper).contains(&q) {
                modes.push((qx as f64, qy as f64, q.powf(-(1.0 + hurst)), 2.0 * PI * rng.next_f64()));
            }
        }
    }
    // Each mode as a conjugate pair of Fourier coefficients; one inverse 2-D transform sums them.
    let mut spectrum = vec![Complex::new(0.0, 0.0); n * n];
    for &(qx, qy, amplitude, phase) in &modes {
        let c = Complex::from_polar(0.5 * amplitude, phase);
        let at = |qx: f64, qy: f64| (qy as isize).rem_euclid(n as isize) as usize * n + (qx as isize).rem_euclid(n as isize) as usize;
        spectrum[at(qx, qy)] += c;
        spectrum[at(-qx, -qy)] += c.conj();
    }
    let fft = FftPlanner::<f64>::new().plan_fft_inverse(n);
    fft.process(&mut spectrum);
    let mut transposed: Vec<Complex<f64>> = (0..n * n).map(|k| spectrum[(k % n) * n + k / n]).collect();
    fft.process(&mut transposed);
    for (k, h) in heights.iter_mut().enumerate() {
        *h = transposed[(k % n) * n + k / n].re;
    }
    let dx = length / n as f64;
    let mut slope2 = 0.0;
    for iy in 0..n {
        for ix in 0..n {
            let h = heights[iy * n + ix];
            let gx = (heights[iy * n + (ix + 1) % n] - h) / dx;
            let gy = (heights[((iy + 1) % n) * n + ix] - h) / dx;
            slope2 += gx * gx + gy * gy;
        }
    }
    let factor = rms_slope / (slope2 / (n * n) as f64).sqrt();
    heights.iter_mut().for_each(|h| *h *= factor);
    heights
}
