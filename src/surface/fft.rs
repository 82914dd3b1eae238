//! A real block-circulant operator on an ny x nx grid (row-major, rows along x), applied by real
//! 2-D FFTs: real transforms along the rows, complex transforms along the columns. Any sizes (not
//! only powers of two); plans are built once and shared by threads.
//!
//! Multipliers (the operator's eigenvalues, real because the kernels are even in x and in y) are
//! stored column-major in the half spectrum: index `qx * ny + qy`, qx = 0..=nx/2, qy = 0..ny.

use std::sync::Arc;

use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};

#[derive(Clone)]
pub struct Circulant2 {
    ny: usize,
    nx: usize,
    row_forward: Arc<dyn RealToComplex<f64>>,
    row_inverse: Arc<dyn ComplexToReal<f64>>,
    column_forward: Arc<dyn Fft<f64>>,
    column_inverse: Arc<dyn Fft<f64>>,
}

/// Scratch buffers of one thread for [`Circulant2`] products.
pub struct Circulant2Scratch {
    row: Vec<f64>,
    /// Row spectra, row-major: ny x (nx/2 + 1).
    rows: Vec<Complex<f64>>,
    /// The same transposed: (nx/2 + 1) columns of ny.
    columns: Vec<Complex<f64>>,
    row_scratch: Vec<Complex<f64>>,
    column_scratch: Vec<Complex<f64>>,
}

impl Circulant2 {
    pub fn new(ny: usize, nx: usize) -> Self {
        let mut real_planner = RealFftPlanner::<f64>::new();
        let mut planner = FftPlanner::<f64>::new();
        Self {
            ny,
            nx,
            row_forward: real_planner.plan_fft_forward(nx),
            row_inverse: real_planner.plan_fft_inverse(nx),
            column_forward: planner.plan_fft_forward(ny),
            column_inverse: planner.plan_fft_inverse(ny),
        }
    }

    /// Columns of the half spectrum, nx/2 + 1.
    pub fn half_width(&self) -> usize {
        self.nx / 2 + 1
    }

    pub fn spectrum_len(&self) -> usize {
        self.half_width() * self.ny
    }

    pub fn scratch(&self) -> Circulant2Scratch {
        let row_len = self.row_forward.get_scratch_len().max(self.row_inverse.get_scratch_len());
        let column_len = self.column_forward.get_inplace_scratch_len().max(self.column_inverse.get_inplace_scratch_len());
        Circulant2Scratch {
            row: vec![0.0; self.nx],
            rows: vec![Complex::default(); self.spectrum_len()],
            columns: vec![Complex::default(); self.spectrum_len()],
            row_scratch: vec![Complex::default(); row_len],
            column_scratch: vec![Complex::default(); column_len],
        }
    }

    /// The 2-D DFT of `input` into `scratch.columns` (column-major half spectrum).
    fn forward(&self, input: &[f64], s: &mut Circulant2Scratch) {
        let (nx, ny, h) = (self.nx, self.ny, self.half_width());
        debug_assert_eq!(input.len(), nx * ny);
        for (row_in, row_out) in input.chunks_exact(nx).zip(s.rows.chunks_exact_mut(h)) {
            s.row.copy_from_slice(row_in);
            self.row_forward.process_with_scratch(&mut s.row, row_out, &mut s.row_scratch).expect("buffer sizes are fixed by the plan");
        }
        for iy in 0..ny {
            for qx in 0..h {
                s.columns[qx * ny + iy] = s.rows[iy * h + qx];
            }
        }
        self.column_forward.process_with_scratch(&mut s.columns, &mut s.column_scratch);
    }

    /// out = operator(multiplier) * input: multiplier holds the (nx/2 + 1) ny real eigenvalues.
    pub fn apply(&self, multiplier: &[f64], input: &[f64], out: &mut [f64], s: &mut Circulant2Scratch) {
        let (nx, ny, h) = (self.nx, self.ny, self.half_width());
        debug_assert_eq!(multiplier.len(), self.spectrum_len());
        self.forward(input, s);
        let norm = 1.0 / (nx * ny) as f64;
        for (c, &m) in s.columns.iter_mut().zip(multiplier) {
            *c *= m * norm;
        }
        self.column_inverse.process_with_scratch(&mut s.columns, &mut s.column_scratch);
        for iy in 0..ny {
            for qx in 0..h {
                s.rows[iy * h + qx] = s.columns[qx * ny + iy];
            }
        }
        for (row_in, row_out) in s.rows.chunks_exact_mut(h).zip(out.chunks_exact_mut(nx)) {
            // The inverse real transform requires exactly real end bins; rounding must not trip it.
            row_in[0].im = 0.0;
            if nx % 2 == 0 {
                row_in[h - 1].im = 0.0;
            }
            self.row_inverse.process_with_scratch(row_in, row_out, &mut s.row_scratch).expect("buffer sizes are fixed by the plan");
        }
    }

    /// Eigenvalues of the block-circulant operator whose first column (the response to a unit
    /// load on element (0, 0), as an ny x nx grid) is `column`: real for an even kernel.
    pub fn spectrum_of(&self, column: &[f64]) -> Vec<f64> {
        let mut s = self.scratch();
        self.forward(column, &mut s);
        s.columns.iter().map(|c| c.re).collect()
    }
}
