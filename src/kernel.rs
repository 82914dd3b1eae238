//! Influence coefficients of the elastic half-space (plane strain) for piecewise-constant pressure
//! on N equal elements, displacement taken at element centres, and their fast application.
//!
//! Everything here is for a unit plane-strain modulus E* = 1: displacements scale as 1/E*, so one
//! kernel serves every modulus (the solvers work with pressure / E*).
//!
//! Periodic model. The point-force Green's function -2/(pi E*) ln|x| summed over the images x - nL
//! is, up to a constant, G(x) = -2/(pi E*) ln|2 sin(pi x / L)| = (2 / (pi E*)) sum_m cos(2 pi m x/L) / m.
//! Its integral over an element is a difference of Clausen functions, and the discrete spectrum of
//! the (circulant) coefficient matrix is an aliased sum that closes in trigamma functions:
//!
//!   lambda_q = L sin(pi u) / (pi^2 E* N) * (f(u) + f(1 - u)),  u = q / N,
//!   f(u) = sum_{j>=0} (-1)^j / (u + j)^2 = (psi'(u/2) - psi'((u+1)/2)) / 4,   lambda_0 = 0.
//!
//! Both are exact to rounding; no image sum is truncated. lambda_0 = 0 says that a uniform pressure
//! moves the surface rigidly: the mean mode is fixed by equilibrium, not by the kernel.

use std::f64::consts::PI;
use std::sync::Arc;

use realfft::num_complex::Complex;
use realfft::{ComplexToReal, FftNum, RealFftPlanner, RealToComplex};

use crate::special::{alternating_inverse_squares, clausen2};

/// Which discrete kernel represents the half-space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelKind {
    /// Exact influence coefficients of piecewise-constant pressure on elements (the INRETS model).
    Element,
    /// The continuous spectral kernel 2 / (E* |k|) sampled at the discrete wavenumbers.
    Spectral,
}

/// Periodic element influence coefficients C_n (m per unit pressure / E*), n = 0..N-1 circularly:
/// the displacement at the centre of element i due to unit pressure on element j is C_{(i-j) mod N}.
/// Built from Clausen functions in real space; used by the dense solver and to cross-check the
/// spectral construction.
pub fn periodic_coefficients(n: usize, dx: f64) -> Vec<f64> {
    let length = n as f64 * dx;
    let scale = length / (PI * PI);
    let step = 2.0 * PI / n as f64;
    // Cl2 at the element edges (m + 1/2) step, m = 0..=N/2; C is even, C_(N-m) = C_m, and
    // neighbouring coefficients share an edge, so N/2 + 2 evaluations give all of them.
    let edges: Vec<f64> = (0..=n / 2 + 1).map(|m| clausen2(step * (m as f64 - 0.5))).collect();
    let half: Vec<f64> = (0..=n / 2).map(|m| scale * (edges[m + 1] - edges[m])).collect();
    (0..n).map(|k| half[if k <= n / 2 { k } else { n - k }]).collect()
}

/// Eigenvalues lambda_q, q = 0..=N/2, of the periodic circulant kernel (m per unit pressure / E*).
pub fn periodic_spectrum(n: usize, dx: f64, kind: KernelKind) -> Vec<f64> {
    let length = n as f64 * dx;
    (0..=n / 2)
        .map(|q| {
            if q == 0 {
                return 0.0;
            }
            match kind {
                KernelKind::Element => {
                    let u = q as f64 / n as f64;
                    let aliased = alternating_inverse_squares(u) + alternating_inverse_squares(1.0 - u);
                    length * (PI * u).sin() / (PI * PI * n as f64) * aliased
                }
                KernelKind::Spectral => {
                    let k = 2.0 * PI * q as f64 / length;
                    2.0 / k
                }
            }
        })
        .collect()
}

/// Non-periodic (finite sample) element coefficients c_m, m = 0..N-1, for |i - j| = m: the
/// integral of -2/pi ln|x| over an element, up to the arbitrary constant of the 2-D half-space
/// (which the rigid approach absorbs).
pub fn finite_coefficients(n: usize, dx: f64) -> Vec<f64> {
    // -2/pi [ (x ln|x| - x) ] from (m - 1/2) dx to (m + 1/2) dx, written in dx units plus dx ln dx.
    let antiderivative = |s: f64| if s == 0.0 { 0.0 } else { s * s.abs().ln() - s };
    (0..n)
        .map(|m| {
            let m = m as f64;
            let in_units = if m < 8.0 {
                antiderivative(m + 0.5) - antiderivative(m - 0.5)
            } else {
                // Taylor series of the same difference about m, free of cancellation far away:
                // ln m - 1/(24 m^2) - 1/(320 m^4) - 1/(2688 m^6) - 1/(18432 m^8) - 1/(112640 m^10).
                let inv2 = 1.0 / (m * m);
                m.ln() - inv2 * (1.0 / 24.0 + inv2 * (1.0 / 320.0 + inv2 * (1.0 / 2688.0 + inv2 * (1.0 / 18432.0 + inv2 / 112640.0))))
            };
            -2.0 / PI * dx * (in_units + dx.ln())
        })
        .collect()
}

/// The smallest 5-smooth length (2^a 3^b 5^c) at or above `n`: realfft is fastest on such sizes.
///
/// A size with a large prime factor costs far more per point: N = 13,334 = 2 x 59 x 113 (a 0.5 m
/// segment at 0.0375 mm) some 17 times more than 2^16. Where a profile is resampled anyway, choose
/// N = fast_len(n) (13,500 for 13,334). Returns 1 for n <= 1; panics if the answer overflows usize.
pub fn fast_len(n: usize) -> usize {
    if n <= 1 {
        return 1;
    }
    let mut best = n.checked_next_power_of_two().expect("fast_len overflows usize");
    let mut p5 = 1usize;
    while p5 < best {
        let mut p35 = p5;
        while p35 < best {
            // The smallest power of two that lifts p35 to at least n.
            let factor = n.div_ceil(p35).next_power_of_two();
            if let Some(candidate) = p35.checked_mul(factor) {
                best = best.min(candidate);
            }
            match p35.checked_mul(3) {
                Some(next) => p35 = next,
                None => break,
            }
        }
        match p5.checked_mul(5) {
            Some(next) => p5 = next,
            None => break,
        }
    }
    best
}

/// Largest prime factor of a size that rustfft transforms with its own butterflies; a larger one
/// goes through Rader's or Bluestein's algorithm, several times slower per point.
const LARGEST_FAST_PRIME: usize = 31;

/// The FFT size that applies a circular product of size N: N itself, or, when N has a prime
/// factor above 31, the even 5-smooth size 2 fast_len(N) (>= 2N - 1), on which the circular
/// product is computed exactly as a linear convolution with the N-periodic kernel. Even, because
/// realfft halves only even sizes (an odd 5-smooth size such as 2,025 is no faster than a prime).
///
/// Measured (one realfft pair, one thread, 2026-11-23): N = 13,337 (a prime: a 0.5 m CAPTIF
/// segment) 442 us against 140 us for 27,000; 1,009: 21 against 5.3 us; 13,334 = 2 x 59 x 113:
/// 203 against 118 us; 99,991: 10.4 against 1.1 ms; 67: 0.9 against 0.3 us. With prime factors
/// up to 31 the direct size stays faster (1,001 = 7 x 11 x 13: 10 against 22 us; 7,000: 47
/// against 56 us). A rule on N alone, never a timing: the same N always takes the same arithmetic.
pub fn circular_product_len(n: usize) -> usize {
    if largest_prime_factor(n) > LARGEST_FAST_PRIME {
        2 * fast_len(n)
    } else {
        n
    }
}

/// The largest prime factor of n (1 for n <= 1).
fn largest_prime_factor(mut n: usize) -> usize {
    let mut largest = 1;
    let mut p = 2;
    while p * p <= n {
        while n % p == 0 {
            largest = p;
            n /= p;
        }
        p += 1;
    }
    if n > 1 {
        n
    } else {
        largest
    }
}

/// The precision a circulant's transforms run in: `f64`, or `f32` for the contact solver's
/// low-precision products (`crate::compliance::Compliance::precondition_low`, about 1e-7 relative
/// rounding against 1e-16): input, output and multipliers stay `f64`, converted as the transform's
/// buffer is filled and read.
pub trait FftReal: FftNum + Default + Into<f64> {
    fn of(x: f64) -> Self;
    /// `real` = `input`, then zeros.
    fn load(real: &mut [Self], input: &[f64]);
    /// `out` = the inverse transform of `spectrum`, through `real` when the precisions differ.
    fn inverse_into(
        plan: &dyn ComplexToReal<Self>,
        spectrum: &mut [Complex<Self>],
        out: &mut [f64],
        real: &mut [Self],
        scratch: &mut [Complex<Self>],
    );
}

impl FftReal for f64 {
    fn of(x: f64) -> Self {
        x
    }
    fn load(real: &mut [f64], input: &[f64]) {
        real[..input.len()].copy_from_slice(input);
        real[input.len()..].fill(0.0);
    }
    fn inverse_into(
        plan: &dyn ComplexToReal<f64>,
        spectrum: &mut [Complex<f64>],
        out: &mut [f64],
        real: &mut [f64],
        scratch: &mut [Complex<f64>],
    ) {
        if out.len() == real.len() {
            plan.process_with_scratch(spectrum, out, scratch).expect("buffer sizes are fixed by the plan");
        } else {
            plan.process_with_scratch(spectrum, real, scratch).expect("buffer sizes are fixed by the plan");
            let kept = out.len();
            out.copy_from_slice(&real[..kept]);
        }
    }
}

impl FftReal for f32 {
    fn of(x: f64) -> Self {
        x as f32
    }
    fn load(real: &mut [f32], input: &[f64]) {
        for (r, &x) in real.iter_mut().zip(input) {
            *r = x as f32;
        }
        real[input.len()..].fill(0.0);
    }
    fn inverse_into(
        plan: &dyn ComplexToReal<f32>,
        spectrum: &mut [Complex<f32>],
        out: &mut [f64],
        real: &mut [f32],
        scratch: &mut [Complex<f32>],
    ) {
        plan.process_with_scratch(spectrum, real, scratch).expect("buffer sizes are fixed by the plan");
        for (o, &r) in out.iter_mut().zip(real.iter()) {
            *o = r.into();
        }
    }
}

/// A real circulant operator applied by real FFTs in precision `T`, with plans built once and
/// shared by threads. Sizes need not be powers of two.
#[derive(Clone)]
pub struct Circulant<T: FftReal = f64> {
    n: usize,
    forward: Arc<dyn RealToComplex<T>>,
    inverse: Arc<dyn ComplexToReal<T>>,
}

/// Scratch buffers of one thread for [`Circulant`] products.
pub struct CirculantScratch<T = f64> {
    real: Vec<T>,
    spectrum: Vec<Complex<T>>,
    forward_scratch: Vec<Complex<T>>,
    inverse_scratch: Vec<Complex<T>>,
    /// Products (FFT pairs) applied with this scratch: a cost counter for benchmarks.
    pairs: u64,
}

impl<T> CirculantScratch<T> {
    /// How many circulant products (one forward plus one inverse real FFT each) used this scratch.
    pub fn pairs(&self) -> u64 {
        self.pairs
    }
}

impl<T: FftReal> Circulant<T> {
    pub fn new(n: usize) -> Self {
        let mut planner = RealFftPlanner::<T>::new();
        Self { n, forward: planner.plan_fft_forward(n), inverse: planner.plan_fft_inverse(n) }
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    pub fn scratch(&self) -> CirculantScratch<T> {
        CirculantScratch {
            real: vec![T::default(); self.n],
            spectrum: self.forward.make_output_vec(),
            forward_scratch: self.forward.make_scratch_vec(),
            inverse_scratch: self.inverse.make_scratch_vec(),
            pairs: 0,
        }
    }

    /// out = circulant(multiplier) * input, where `multiplier` holds the N/2+1 real eigenvalues.
    ///
    /// `input` may be shorter than N (the rest is taken as zeros) and `out` may be shorter (the
    /// first out.len() values of the product): a linear convolution embedded in a larger circulant.
    pub fn apply(&self, multiplier: &[f64], input: &[f64], out: &mut [f64], scratch: &mut CirculantScratch<T>) {
        debug_assert!(input.len() <= self.n && out.len() <= self.n);
        debug_assert_eq!(multiplier.len(), self.n / 2 + 1);
        scratch.pairs += 1;
        T::load(&mut scratch.real, input);
        self.forward
            .process_with_scratch(&mut scratch.real, &mut scratch.spectrum, &mut scratch.forward_scratch)
            .expect("buffer sizes are fixed by the plan");
        let norm = 1.0 / self.n as f64;
        for (c, &m) in scratch.spectrum.iter_mut().zip(multiplier) {
            *c = *c * T::of(m * norm);
        }
        // The inverse real transform requires exactly real end bins; rounding must not trip it.
        scratch.spectrum[0].im = T::default();
        if self.n % 2 == 0 {
            scratch.spectrum[self.n / 2].im = T::default();
        }
        T::inverse_into(&*self.inverse, &mut scratch.spectrum, out, &mut scratch.real, &mut scratch.inverse_scratch);
    }
}

impl Circulant<f64> {
    /// The real-space first column of the circulant with eigenvalues `multiplier` (N/2+1 values).
    pub fn column_of(&self, multiplier: &[f64]) -> Vec<f64> {
        let mut unit = vec![0.0; self.n];
        unit[0] = 1.0;
        let mut column = vec![0.0; self.n];
        self.apply(multiplier, &unit, &mut column, &mut self.scratch());
        column
    }

    /// Eigenvalues of this circulant (of size M) when it applies the symmetric operator of size
    /// n whose first column is `column` (c_d = c_{-d}) as a linear convolution: M >= 2n - 1,
    /// c_d at d and M - d for 0 <= d < n, zeros between. For a Toeplitz `column` (c_|i-j|) the
    /// product is the Toeplitz product; for a periodic one (c_(N-d) = c_d) it is the circular one.
    pub fn embedded_spectrum(&self, column: &[f64]) -> Vec<f64> {
        let n = column.len();
        assert!(n >= 1 && self.n >= 2 * n - 1, "a circulant of size {} cannot embed a column of {n}", self.n);
        let mut extended = vec![0.0; self.n];
        extended[..n].copy_from_slice(column);
        for d in 1..n {
            extended[self.n - d] = column[d];
        }
        self.spectrum_of(&extended)
    }

    /// Eigenvalues of the circulant matrix whose first column is `column` (real, symmetric).
    pub fn spectrum_of(&self, column: &[f64]) -> Vec<f64> {
        let mut scratch = self.scratch();
        scratch.real.copy_from_slice(column);
        self.forward
            .process_with_scratch(&mut scratch.real, &mut scratch.spectrum, &mut scratch.forward_scratch)
            .expect("buffer sizes are fixed by the plan");
        scratch.spectrum.iter().map(|c| c.re).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clausen_coefficients_and_trigamma_spectrum_agree() {
        for &n in &[8usize, 9, 64, 1000, 4096, 7919] {
            let dx = 1e-3;
            let column = periodic_coefficients(n, dx);
            let from_real_space = Circulant::new(n).spectrum_of(&column);
            let closed_form = periodic_spectrum(n, dx, KernelKind::Element);
            let scale = closed_form[1];
            for q in 0..=n / 2 {
                let err = (from_real_space[q] - closed_form[q]).abs() / scale;
                assert!(err < 1e-11, "n={n} q={q} err={err}");
            }
        }
    }

    #[test]
    fn element_spectrum_tends_to_continuous_kernel_at_long_wavelengths() {
        let n = 4096;
        let dx = 1e-4;
        let element = periodic_spectrum(n, dx, KernelKind::Element);
        let spectral = periodic_spectrum(n, dx, KernelKind::Spectral);
        // Element averaging multiplies mode q by sinc(pi q / N) plus aliasing of order (q/N)^2.
        let rel = (element[1] - spectral[1]).abs() / spectral[1];
        assert!(rel < 1e-6, "rel={rel}");
        // At the Nyquist wavenumber the aliased sum closes: f(1/2) = 4 G (Catalan's constant).
        let catalan = 0.915_965_594_177_219;
        let nyquist = n as f64 * dx * 8.0 * catalan / (PI * PI * n as f64);
        assert!((element[n / 2] - nyquist).abs() < 1e-14 * nyquist);
    }

    #[test]
    fn fast_len_is_the_smallest_five_smooth_length() {
        // Independent check: strip the factors 2, 3, 5 and scan upwards.
        let smooth = |mut m: usize| {
            for p in [2, 3, 5] {
                while m % p == 0 {
                    m /= p;
                }
            }
            m == 1
        };
        for n in 0..5000usize {
            let expected = (n.max(1)..).find(|&m| smooth(m)).expect("5-smooth numbers are unbounded");
            assert_eq!(fast_len(n), expected, "n={n}");
        }
        assert_eq!(fast_len(13_334), 13_500);
        assert_eq!(fast_len(1 << 20), 1 << 20);
        assert_eq!(fast_len((1 << 20) + 1), 1_049_760); // 2^5 x 3^8 x 5
    }

    #[test]
    fn sizes_with_a_large_prime_factor_embed_in_a_five_smooth_size() {
        assert_eq!(circular_product_len(13_337), 27_000); // prime
        assert_eq!(circular_product_len(13_334), 27_000); // 2 x 59 x 113
        assert_eq!(circular_product_len(999), 2_000); // 27 x 37
        assert_eq!(circular_product_len(1_009), 2_048); // even: realfft halves only even sizes
        for direct in [1_000, 1_001, 1_331, 7_000, 13_500, 1 << 16, 31, 8] {
            assert_eq!(circular_product_len(direct), direct);
        }
        for n in [37usize, 1_009, 13_337] {
            assert!(circular_product_len(n) >= 2 * n - 1);
        }
    }

    /// Dense reference: out_i = sum_j column[(i - j) mod n] input_j (periodic) or column[|i - j|].
    fn dense_product(column: &[f64], input: &[f64], periodic: bool) -> Vec<f64> {
        let n = input.len();
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        let d = if periodic { (i + n - j) % n } else { i.abs_diff(j) };
                        column[d] * input[j]
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn embedded_products_equal_the_dense_circular_and_toeplitz_products() {
        for n in [37usize, 509, 1_009] {
            let input: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 1013.0 - 0.5).collect();
            // Periodic kernel: embedded when N has a prime factor above 31.
            let column = periodic_coefficients(n, 1e-3);
            let size = circular_product_len(n);
            assert!(size > n, "n={n}");
            let embedded = Circulant::new(size);
            let mut out = vec![0.0; n];
            embedded.apply(&embedded.embedded_spectrum(&column), &input, &mut out, &mut embedded.scratch());
            let expected = dense_product(&column, &input, true);
            let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = out.iter().zip(&expected).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
            assert!(err < 1e-13, "periodic n={n}: {err:e}");
            // Toeplitz kernel (the finite model) on the same size.
            let column = finite_coefficients(n, 1e-3);
            embedded.apply(&embedded.embedded_spectrum(&column), &input, &mut out, &mut embedded.scratch());
            let expected = dense_product(&column, &input, false);
            let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = out.iter().zip(&expected).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
            assert!(err < 1e-13, "toeplitz n={n}: {err:e}");
        }
    }

    /// The single-precision circulant (the solver's low-precision products) gives the double one's
    /// product to single precision, on a direct and an embedded (prime N) size, and really runs in
    /// single precision (not as close as double).
    #[test]
    fn single_precision_products_match_double_ones_to_single_precision() {
        for (n, size) in [(1_000usize, 1_000usize), (1_009, circular_product_len(1_009))] {
            let column = periodic_coefficients(n, 1e-3);
            let (full, low) = (Circulant::<f64>::new(size), Circulant::<f32>::new(size));
            let multiplier = if size == n { full.spectrum_of(&column) } else { full.embedded_spectrum(&column) };
            let input: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 1013.0).collect();
            let (mut exact, mut rounded) = (vec![0.0; n], vec![0.0; n]);
            full.apply(&multiplier, &input, &mut exact, &mut full.scratch());
            low.apply(&multiplier, &input, &mut rounded, &mut low.scratch());
            let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = exact.iter().zip(&rounded).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
            assert!(err < 1e-5 && err > 1e-12, "n={n}: {err:e}");
        }
    }

    #[test]
    fn finite_series_continues_exact_formula() {
        let dx = 0.37;
        let c = finite_coefficients(20, dx);
        let exact = |m: f64| {
            let a = |s: f64| s * s.abs().ln() - s;
            -2.0 / PI * dx * (a(m + 0.5) - a(m - 0.5) + dx.ln())
        };
        for (m, &cm) in c.iter().enumerate().skip(8) {
            assert!((cm - exact(m as f64)).abs() < 1e-13, "m={m}");
        }
    }
}
