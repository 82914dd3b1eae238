//! The elastic compliance operator: surface displacement (m) from element pressures, for E* = 1,
//! applied by FFT, plus the approximate inverse that preconditions the contact solver.

use crate::kernel::{
    circular_product_len, fast_len, finite_coefficients, periodic_coefficients, periodic_spectrum, Circulant, CirculantScratch, KernelKind,
};

/// A symmetric compliance operator on N elements with an FFT preconditioner.
pub trait Compliance: Sync {
    type Scratch: Send;
    /// Whether [`Compliance::displacement_low`] is a low-precision product (not the double one):
    /// only then do loose tolerances steer with it (`crate::solver::cg`).
    const LOW_PRECISION_DISPLACEMENT: bool = false;
    /// Whether solves at tolerances below the solver's low-precision bound still steer in low
    /// precision where it only costs iterations (every preconditioner application, the rough
    /// sweeps' products): the areal operator's do (its transforms are most of a solve; 1 to 3
    /// iterations more at most); the line operator's do not, so that its tight solves (the pilots'
    /// references) are those of double precision: in single precision a stiff rubber's two contact
    /// points stopped at the tolerance, 4e-8 P off the dense solve at tol 1e-12, against 2e-11.
    const STEERS_LOW_AT_TIGHT_TOL: bool = false;
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    fn scratch(&self) -> Self::Scratch;
    /// FFT pairs (circulant products) applied so far with `scratch`, a cost counter; a product
    /// embedded in a larger size (the finite model's, a periodic N with a large prime factor)
    /// counts as one.
    fn fft_pairs(scratch: &Self::Scratch) -> u64;
    /// out = C * pressure (displacement up to the rigid constant).
    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut Self::Scratch);
    /// out ~ C^-1 * gap on zero-mean input: the inverse of the periodic kernel (|k| E* / 2 like).
    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut Self::Scratch);
    /// [`Compliance::precondition`] in low precision where the operator has one (single-precision
    /// transforms, about 1e-7 relative rounding: the preconditioner only steers the iteration, so
    /// its rounding moves the iteration count, never the converged answer's check), else the same.
    fn precondition_low(&self, gap: &[f64], out: &mut [f64], scratch: &mut Self::Scratch) {
        self.precondition(gap, out, scratch);
    }
    /// [`Compliance::displacement`] in low precision where the operator has one (see
    /// [`Compliance::precondition_low`]), else the same: for the products that steer the rough
    /// sweeps and loose tolerances, whose inner stops are far above its rounding (their final
    /// tests stand on [`Compliance::displacement`]).
    fn displacement_low(&self, pressure: &[f64], out: &mut [f64], scratch: &mut Self::Scratch) {
        self.displacement(pressure, out, scratch);
    }
    /// The dense matrix entry C[i][j] (m per unit pressure / E*): the displacement at element i of
    /// unit pressure on element j. Used by the dense solver.
    fn dense_entry(&self, i: usize, j: usize) -> f64;

    /// out += weight * (column j of C): the displacement of pressure `weight` on element j alone.
    fn add_column(&self, j: usize, weight: f64, out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o += weight * self.dense_entry(i, j);
        }
    }
}

/// The periodic (INRETS) model: a circulant operator.
///
/// Applied by FFTs of size N, or, when N has a large prime factor (a prime N = 13,337 in a 0.5 m
/// CAPTIF segment), as a linear convolution on the 5-smooth size `circular_product_len(N)`: the
/// same products to rounding, 1.7-10 times faster per product.
pub struct PeriodicCompliance {
    n: usize,
    /// Size N, or the larger 5-smooth size that embeds the circular product.
    circulant: Circulant,
    /// The same products in single precision ([`Compliance::precondition_low`]).
    low: Circulant<f32>,
    spectrum: Vec<f64>,
    /// What `circulant` multiplies by for C and for the preconditioner: the N/2 + 1 eigenvalues,
    /// or the embedded kernels' spectra.
    kernel_multiplier: Vec<f64>,
    preconditioner_multiplier: Vec<f64>,
    /// Real-space coefficients, built only when a dense solve or an embedding asks for them.
    coefficients: std::sync::OnceLock<Vec<f64>>,
    dx: f64,
    kind: KernelKind,
}

impl PeriodicCompliance {
    pub fn new(n: usize, dx: f64, kind: KernelKind) -> Self {
        let spectrum = periodic_spectrum(n, dx, kind);
        let inverse_spectrum: Vec<f64> = spectrum.iter().map(|&l| if l > 0.0 { 1.0 / l } else { 0.0 }).collect();
        let size = circular_product_len(n);
        let mut this = Self {
            n,
            circulant: Circulant::new(size),
            low: Circulant::new(size),
            kernel_multiplier: Vec::new(),
            preconditioner_multiplier: Vec::new(),
            spectrum,
            coefficients: std::sync::OnceLock::new(),
            dx,
            kind,
        };
        if size == n {
            this.kernel_multiplier = this.spectrum.clone();
            this.preconditioner_multiplier = inverse_spectrum;
        } else {
            // Real-space columns from transforms of size N, once per operator.
            let preconditioner_column = Circulant::new(n).column_of(&inverse_spectrum);
            this.kernel_multiplier = this.circulant.embedded_spectrum(this.coefficients());
            this.preconditioner_multiplier = this.circulant.embedded_spectrum(&preconditioner_column);
        }
        this
    }

    /// Eigenvalues lambda_q, q = 0..=N/2 (m per unit pressure / E*).
    pub fn spectrum(&self) -> &[f64] {
        &self.spectrum
    }

    /// The coefficient for element offset d = i - j, -N < d < N: C[i][j] = kernel_at(i - j). The
    /// coarse space of the CG solver sums it over pairs of intervals.
    pub fn kernel_at(&self, offset: isize) -> f64 {
        self.coefficients()[offset.rem_euclid(self.n as isize) as usize]
    }

    fn coefficients(&self) -> &[f64] {
        self.coefficients.get_or_init(|| match self.kind {
            KernelKind::Element => periodic_coefficients(self.n, self.dx),
            // The real-space column of the sampled spectral kernel: one inverse transform of lambda.
            KernelKind::Spectral => Circulant::new(self.n).column_of(&self.spectrum),
        })
    }
}

/// Scratch of one thread for [`PeriodicCompliance`]: double- and single-precision products.
pub struct PeriodicScratch {
    full: CirculantScratch,
    low: CirculantScratch<f32>,
}

impl PeriodicScratch {
    /// Single-precision FFT pairs applied so far (included in [`Compliance::fft_pairs`]).
    pub fn low_pairs(&self) -> u64 {
        self.low.pairs()
    }
}

impl Compliance for PeriodicCompliance {
    type Scratch = PeriodicScratch;
    const LOW_PRECISION_DISPLACEMENT: bool = true;

    fn len(&self) -> usize {
        self.n
    }

    fn scratch(&self) -> PeriodicScratch {
        PeriodicScratch { full: self.circulant.scratch(), low: self.low.scratch() }
    }

    fn fft_pairs(scratch: &PeriodicScratch) -> u64 {
        scratch.full.pairs() + scratch.low.pairs()
    }

    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut PeriodicScratch) {
        self.circulant.apply(&self.kernel_multiplier, pressure, out, &mut scratch.full);
    }

    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut PeriodicScratch) {
        self.circulant.apply(&self.preconditioner_multiplier, gap, out, &mut scratch.full);
    }

    fn precondition_low(&self, gap: &[f64], out: &mut [f64], scratch: &mut PeriodicScratch) {
        self.low.apply(&self.preconditioner_multiplier, gap, out, &mut scratch.low);
    }

    fn displacement_low(&self, pressure: &[f64], out: &mut [f64], scratch: &mut PeriodicScratch) {
        self.low.apply(&self.kernel_multiplier, pressure, out, &mut scratch.low);
    }

    fn dense_entry(&self, i: usize, j: usize) -> f64 {
        self.kernel_at(i as isize - j as isize)
    }

    fn add_column(&self, j: usize, weight: f64, out: &mut [f64]) {
        // C[i][j] = c[(i - j) mod N].
        let c = self.coefficients();
        let n = c.len();
        let (head, tail) = out.split_at_mut(j);
        for (o, &cv) in tail.iter_mut().zip(&c[..n - j]) {
            *o += weight * cv;
        }
        for (o, &cv) in head.iter_mut().zip(&c[n - j..]) {
            *o += weight * cv;
        }
    }
}

/// The finite (non-periodic) model: a Toeplitz operator applied as a circulant of the 5-smooth
/// size fast_len(2N - 1) (linear, not circular, convolution).
pub struct FiniteCompliance {
    n: usize,
    coefficients: Vec<f64>,
    embedded: Circulant,
    embedded_spectrum: Vec<f64>,
    /// The periodic kernel's inverse on N points: a good approximate inverse away from the ends.
    periodic: PeriodicCompliance,
}

pub struct FiniteScratch {
    embedded: CirculantScratch,
    periodic: PeriodicScratch,
}

impl FiniteCompliance {
    pub fn new(n: usize, dx: f64) -> Self {
        let coefficients = finite_coefficients(n, dx);
        let embedded = Circulant::new(fast_len(2 * n - 1));
        let embedded_spectrum = embedded.embedded_spectrum(&coefficients);
        Self { n, coefficients, embedded, embedded_spectrum, periodic: PeriodicCompliance::new(n, dx, KernelKind::Element) }
    }

    /// The coefficient for element offset d = i - j, -N < d < N: C[i][j] = kernel_at(i - j).
    pub fn kernel_at(&self, offset: isize) -> f64 {
        self.coefficients[offset.unsigned_abs()]
    }
}

impl Compliance for FiniteCompliance {
    type Scratch = FiniteScratch;

    fn len(&self) -> usize {
        self.n
    }

    fn scratch(&self) -> FiniteScratch {
        FiniteScratch { embedded: self.embedded.scratch(), periodic: self.periodic.scratch() }
    }

    fn fft_pairs(scratch: &FiniteScratch) -> u64 {
        scratch.embedded.pairs() + PeriodicCompliance::fft_pairs(&scratch.periodic)
    }

    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut FiniteScratch) {
        self.embedded.apply(&self.embedded_spectrum, pressure, out, &mut scratch.embedded);
    }

    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut FiniteScratch) {
        self.periodic.precondition(gap, out, &mut scratch.periodic);
    }

    fn dense_entry(&self, i: usize, j: usize) -> f64 {
        self.kernel_at(i as isize - j as isize)
    }

    fn add_column(&self, j: usize, weight: f64, out: &mut [f64]) {
        // C[i][j] = c[|i - j|].
        let c = &self.coefficients;
        let (head, tail) = out.split_at_mut(j);
        for (o, &cv) in tail.iter_mut().zip(c) {
            *o += weight * cv;
        }
        for (o, &cv) in head.iter_mut().rev().zip(&c[1..]) {
            *o += weight * cv;
        }
    }
}
