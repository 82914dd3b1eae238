//! A real block-circulant operator on an ny x nx grid (row-major, rows along x), applied by real
//! 2-D FFTs: real transforms along the rows, complex transforms along the columns. Any sizes (not
//! only powers of two); plans are built once and shared by threads.
//!
//! Multipliers (the operator's eigenvalues, real because the kernels are even in x and in y) are
//! stored column-major in the half spectrum: index `qx * ny + qy`, qx = 0..=nx/2, qy = 0..ny.

use std::sync::Arc;

use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};

/// Grids of at least this many points transform their rows and columns in parallel (rayon):
/// each row and column is transformed by the same sequential code whichever thread runs it, so
/// results are bitwise the same whatever the thread count.
const PARALLEL_MIN: usize = 1 << 15;

#[derive(Clone)]
pub struct Circulant2 {
    ny: usize,
    nx: usize,
    /// Distance between columns in the transposed buffer: ny plus a little padding, so that a
    /// power-of-two ny does not map every column to the same cache sets during the transposes.
    stride: usize,
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
    /// The same transposed: (nx/2 + 1) columns of ny, `stride` apart.
    columns: Vec<Complex<f64>>,
    row_scratch: Vec<Complex<f64>>,
    column_scratch: Vec<Complex<f64>>,
    /// 2-D FFT pairs applied with this scratch (a cost counter, as the line solver's).
    pairs: u64,
}

impl Circulant2Scratch {
    /// 2-D FFT pairs (circulant products) applied so far with this scratch.
    pub fn pairs(&self) -> u64 {
        self.pairs
    }
}

impl Circulant2 {
    pub fn new(ny: usize, nx: usize) -> Self {
        let mut real_planner = RealFftPlanner::<f64>::new();
        let mut planner = FftPlanner::<f64>::new();
        Self {
            ny,
            nx,
            stride: if ny >= 64 { ny + 2 } else { ny },
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

    fn parallel(&self) -> bool {
        self.nx * self.ny >= PARALLEL_MIN
    }

    pub fn scratch(&self) -> Circulant2Scratch {
        let row_len = self.row_forward.get_scratch_len().max(self.row_inverse.get_scratch_len());
        let column_len = self.column_forward.get_inplace_scratch_len().max(self.column_inverse.get_inplace_scratch_len());
        Circulant2Scratch {
            row: vec![0.0; self.nx],
            rows: vec![Complex::default(); self.spectrum_len()],
            columns: vec![Complex::default(); self.half_width() * self.stride],
            row_scratch: vec![Complex::default(); row_len],
            column_scratch: vec![Complex::default(); column_len],
            pairs: 0,
        }
    }

    /// Task sizes: rows per row task and columns per column task (one task when serial).
    fn tasks(&self) -> (usize, usize) {
        if self.parallel() {
            ((self.ny / 32).max(8), COLUMN_BLOCK)
        } else {
            (self.ny, self.half_width())
        }
    }

    /// Real transforms of the rows of `input` into `s.rows` (ny x h).
    fn rows_forward(&self, input: &[f64], s: &mut Circulant2Scratch) {
        let (nx, h) = (self.nx, self.half_width());
        let plan = &self.row_forward;
        let task = |input: &[f64], rows: &mut [Complex<f64>], row: &mut [f64], scratch: &mut [Complex<f64>]| {
            for (row_in, row_out) in input.chunks_exact(nx).zip(rows.chunks_exact_mut(h)) {
                row.copy_from_slice(row_in);
                plan.process_with_scratch(row, row_out, scratch).expect("buffer sizes are fixed by the plan");
            }
        };
        if self.parallel() {
            let per = self.tasks().0;
            input.par_chunks(per * nx).zip(s.rows.par_chunks_mut(per * h)).for_each(|(input, rows)| {
                task(input, rows, &mut vec![0.0; nx], &mut plan.make_scratch_vec());
            });
        } else {
            task(input, &mut s.rows, &mut s.row, &mut s.row_scratch);
        }
    }

    /// Column phase: for each block of columns of `s.rows`, gathers them into `s.columns`
    /// (`stride` apart), transforms them forward and, with a multiplier, multiplies and
    /// transforms back. Each column is processed whole by one task.
    fn columns(&self, multiplier: Option<&[f64]>, s: &mut Circulant2Scratch) {
        let (ny, h, stride) = (self.ny, self.half_width(), self.stride);
        let norm = 1.0 / (self.nx * ny) as f64;
        let rows = &s.rows;
        let task = |first: usize, block: &mut [Complex<f64>], scratch: &mut [Complex<f64>]| {
            let count = block.len() / stride;
            for r in 0..ny {
                for (k, &v) in rows[r * h + first..r * h + first + count].iter().enumerate() {
                    block[k * stride + r] = v;
                }
            }
            for (k, column) in block.chunks_exact_mut(stride).enumerate() {
                let column = &mut column[..ny];
                self.column_forward.process_with_scratch(column, scratch);
                if let Some(m) = multiplier {
                    for (c, &m) in column.iter_mut().zip(&m[(first + k) * ny..(first + k + 1) * ny]) {
                        *c *= m * norm;
                    }
                    self.column_inverse.process_with_scratch(column, scratch);
                }
            }
        };
        if self.parallel() {
            let per = self.tasks().1;
            let len = self.column_forward.get_inplace_scratch_len().max(self.column_inverse.get_inplace_scratch_len());
            s.columns.par_chunks_mut(per * stride).enumerate().for_each(|(b, block)| {
                task(b * per, block, &mut vec![Complex::default(); len]);
            });
        } else {
            task(0, &mut s.columns, &mut s.column_scratch);
        }
    }

    /// Gathers the rows back from `s.columns` and transforms them to real rows of `out`.
    fn rows_inverse(&self, s: &mut Circulant2Scratch, out: &mut [f64]) {
        let (nx, h, stride) = (self.nx, self.half_width(), self.stride);
        let plan = &self.row_inverse;
        let columns = &s.columns;
        let task = |first: usize, rows: &mut [Complex<f64>], out: &mut [f64], scratch: &mut [Complex<f64>]| {
            let count = out.len() / nx;
            for c in 0..h {
                for (k, &v) in columns[c * stride + first..c * stride + first + count].iter().enumerate() {
                    rows[k * h + c] = v;
                }
            }
            for (row_in, row_out) in rows.chunks_exact_mut(h).zip(out.chunks_exact_mut(nx)) {
                // The inverse real transform requires exactly real end bins; rounding must not trip it.
                row_in[0].im = 0.0;
                if nx % 2 == 0 {
                    row_in[h - 1].im = 0.0;
                }
                plan.process_with_scratch(row_in, row_out, scratch).expect("buffer sizes are fixed by the plan");
            }
        };
        if self.parallel() {
            let per = self.tasks().0;
            s.rows.par_chunks_mut(per * h).zip(out.par_chunks_mut(per * nx)).enumerate().for_each(|(b, (rows, out))| {
                task(b * per, rows, out, &mut plan.make_scratch_vec());
            });
        } else {
            task(0, &mut s.rows, out, &mut s.row_scratch);
        }
    }

    /// out = operator(multiplier) * input: multiplier holds the (nx/2 + 1) ny real eigenvalues.
    pub fn apply(&self, multiplier: &[f64], input: &[f64], out: &mut [f64], s: &mut Circulant2Scratch) {
        debug_assert_eq!(multiplier.len(), self.spectrum_len());
        debug_assert_eq!(input.len(), self.nx * self.ny);
        self.rows_forward(input, s);
        self.columns(Some(multiplier), s);
        self.rows_inverse(s, out);
        s.pairs += 1;
    }

    /// Eigenvalues of the block-circulant operator whose first column (the response to a unit
    /// load on element (0, 0), as an ny x nx grid) is `column`: real for an even kernel. Layout:
    /// index qx ny + qy.
    pub fn spectrum_of(&self, column: &[f64]) -> Vec<f64> {
        let mut s = self.scratch();
        self.rows_forward(column, &mut s);
        self.columns(None, &mut s);
        s.columns.chunks(self.stride).flat_map(|c| c[..self.ny].iter().map(|v| v.re)).collect()
    }
}

/// Columns per column task when parallel (16 complex values: four cache lines per row).
const COLUMN_BLOCK: usize = 16;
