//! The elastic compliance operator: surface displacement (m) from element pressures, for E* = 1,
//! applied by FFT, plus the approximate inverse that preconditions the contact solver.

use crate::kernel::{finite_coefficients, periodic_coefficients, periodic_spectrum, Circulant, CirculantScratch, KernelKind};

/// A symmetric compliance operator on N elements with an FFT preconditioner.
pub trait Compliance: Sync {
    type Scratch: Send;
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    fn scratch(&self) -> Self::Scratch;
    /// FFT pairs (circulant products) applied so far with `scratch`, a cost counter; the finite
    /// model's products of size 2N count as one each.
    fn fft_pairs(scratch: &Self::Scratch) -> u64;
    /// out = C * pressure (displacement up to the rigid constant).
    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut Self::Scratch);
    /// out ~ C^-1 * gap on zero-mean input: the inverse of the periodic kernel (|k| E* / 2 like).
    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut Self::Scratch);
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
pub struct PeriodicCompliance {
    circulant: Circulant,
    spectrum: Vec<f64>,
    inverse_spectrum: Vec<f64>,
    /// Real-space coefficients, built only when a dense solve asks for them.
    coefficients: std::sync::OnceLock<Vec<f64>>,
    dx: f64,
    kind: KernelKind,
}

impl PeriodicCompliance {
    pub fn new(n: usize, dx: f64, kind: KernelKind) -> Self {
        let spectrum = periodic_spectrum(n, dx, kind);
        let inverse_spectrum = spectrum.iter().map(|&l| if l > 0.0 { 1.0 / l } else { 0.0 }).collect();
        Self { circulant: Circulant::new(n), spectrum, inverse_spectrum, coefficients: std::sync::OnceLock::new(), dx, kind }
    }

    /// Eigenvalues lambda_q, q = 0..=N/2 (m per unit pressure / E*).
    pub fn spectrum(&self) -> &[f64] {
        &self.spectrum
    }

    /// The coefficient for element offset d = i - j, -N < d < N: C[i][j] = kernel_at(i - j). The
    /// coarse space of the CG solver sums it over pairs of intervals.
    pub fn kernel_at(&self, offset: isize) -> f64 {
        let n = self.circulant.len() as isize;
        self.coefficients()[offset.rem_euclid(n) as usize]
    }

    fn coefficients(&self) -> &[f64] {
        self.coefficients.get_or_init(|| match self.kind {
            KernelKind::Element => periodic_coefficients(self.circulant.len(), self.dx),
            KernelKind::Spectral => {
                // Real-space column of the sampled spectral kernel: one inverse transform of lambda.
                let n = self.circulant.len();
                let mut unit = vec![0.0; n];
                unit[0] = 1.0;
                let mut column = vec![0.0; n];
                let mut scratch = self.circulant.scratch();
                self.circulant.apply(&self.spectrum, &unit, &mut column, &mut scratch);
                column
            }
        })
    }
}

impl Compliance for PeriodicCompliance {
    type Scratch = CirculantScratch;

    fn len(&self) -> usize {
        self.circulant.len()
    }

    fn scratch(&self) -> CirculantScratch {
        self.circulant.scratch()
    }

    fn fft_pairs(scratch: &CirculantScratch) -> u64 {
        scratch.pairs()
    }

    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut CirculantScratch) {
        self.circulant.apply(&self.spectrum, pressure, out, scratch);
    }

    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut CirculantScratch) {
        self.circulant.apply(&self.inverse_spectrum, gap, out, scratch);
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

/// The finite (non-periodic) model: a Toeplitz operator applied as a circulant of twice the size
/// (linear, not circular, convolution).
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
    padded: Vec<f64>,
    padded_out: Vec<f64>,
    periodic: CirculantScratch,
}

impl FiniteCompliance {
    pub fn new(n: usize, dx: f64) -> Self {
        let coefficients = finite_coefficients(n, dx);
        let size = 2 * n;
        let mut column = vec![0.0; size];
        column[..n].copy_from_slice(&coefficients);
        for m in 1..n {
            column[size - m] = coefficients[m];
        }
        let embedded = Circulant::new(size);
        let embedded_spectrum = embedded.spectrum_of(&column);
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
        FiniteScratch {
            embedded: self.embedded.scratch(),
            padded: vec![0.0; 2 * self.n],
            padded_out: vec![0.0; 2 * self.n],
            periodic: self.periodic.scratch(),
        }
    }

    fn fft_pairs(scratch: &FiniteScratch) -> u64 {
        scratch.embedded.pairs() + scratch.periodic.pairs()
    }

    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut FiniteScratch) {
        scratch.padded[..self.n].copy_from_slice(pressure);
        scratch.padded[self.n..].fill(0.0);
        self.embedded.apply(&self.embedded_spectrum, &scratch.padded, &mut scratch.padded_out, &mut scratch.embedded);
        out.copy_from_slice(&scratch.padded_out[..self.n]);
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
