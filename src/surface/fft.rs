//! A real block-circulant operator on an ny x nx grid (row-major, rows along x), applied by real
//! 2-D FFTs: the rows two at a time by one complex transform (row a as the real part, row b as the
//! imaginary part; their half spectra separated by Hermitian symmetry), then the columns of the
//! half spectrum in blocks that are gathered, transformed, multiplied, transformed back and
//! scattered in place, then the rows two at a time back. Any sizes (not only powers of two); plans
//! are built once and shared by threads.
//!
//! Why not a real transform per row into a transposed copy and back (0.5.1): the 1024^2
//! self-affine solve (tol 1e-8, 45 iterations, kernel build included), runs alternated with the
//! 0.5.1 build, took about a tenth less (medians of 3 to 5 runs, one and two threads; on a shared
//! machine whose speed drifts by a fifth: benches/HISTORY-0.5.md). Each product now streams
//! the grid three times (rows, column blocks in place, rows) and holds one spectrum, not two:
//! in the solver, between the vector passes, that is what counts; alone, in a loop that keeps
//! everything in cache, the two ways take about as long (11-12 ms a pair at 1024^2).
//!
//! Multipliers (the operator's eigenvalues, real because the kernels are even in x and in y) are
//! stored column-major in the half spectrum: index `qx * ny + qy`, qx = 0..=nx/2, qy = 0..ny.

use std::sync::Arc;

use rayon::prelude::*;
use realfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use crate::kernel::FftReal;

/// Grids of at least this many points transform their rows and columns in parallel (rayon):
/// each row pair and column block is transformed by the same sequential code whichever thread
/// runs it, so results are bitwise the same whatever the thread count.
const PARALLEL_MIN: usize = 1 << 15;

/// The precision the transforms run in: `f64`, or `f32` for the contact solver's low-precision
/// products (`crate::compliance::Compliance::precondition_low`): input, output and multipliers
/// stay `f64`, converted as the rows are packed and unpacked.
pub trait Real: FftReal {
    /// Runs `task` with this thread's task buffers of this precision.
    #[doc(hidden)]
    fn with_thread_buffers<R>(task: impl FnOnce(&mut TaskBuffers<Self>) -> R) -> R;
}

thread_local! {
    static BUFFERS_F64: std::cell::RefCell<TaskBuffers<f64>> = const { std::cell::RefCell::new(TaskBuffers::EMPTY) };
    static BUFFERS_F32: std::cell::RefCell<TaskBuffers<f32>> = const { std::cell::RefCell::new(TaskBuffers::EMPTY) };
}

impl Real for f64 {
    fn with_thread_buffers<R>(task: impl FnOnce(&mut TaskBuffers<Self>) -> R) -> R {
        BUFFERS_F64.with(|cell| task(&mut cell.borrow_mut()))
    }
}

impl Real for f32 {
    fn with_thread_buffers<R>(task: impl FnOnce(&mut TaskBuffers<Self>) -> R) -> R {
        BUFFERS_F32.with(|cell| task(&mut cell.borrow_mut()))
    }
}

#[derive(Clone)]
pub struct Circulant2<T: Real = f64> {
    ny: usize,
    nx: usize,
    /// Distance between columns in a gathered block: ny plus a little padding, so that a
    /// power-of-two ny does not map every column to the same cache sets.
    stride: usize,
    row_forward: Arc<dyn Fft<T>>,
    row_inverse: Arc<dyn Fft<T>>,
    column_forward: Arc<dyn Fft<T>>,
    column_inverse: Arc<dyn Fft<T>>,
    /// In-place scratch every plan can work with (the largest of theirs).
    fft_scratch_len: usize,
}

/// Scratch buffers of one thread for [`Circulant2`] products.
pub struct Circulant2Scratch<T: Real = f64> {
    /// Row spectra, row-major: ny x (nx/2 + 1).
    rows: Vec<Complex<T>>,
    /// The serial products' task buffers (empty for a grid transformed in parallel, whose tasks
    /// hold their own).
    buffers: TaskBuffers<T>,
    /// 2-D FFT pairs applied with this scratch (a cost counter, as the line solver's).
    pairs: u64,
}

impl<T: Real> Circulant2Scratch<T> {
    /// 2-D FFT pairs (circulant products) applied so far with this scratch.
    pub fn pairs(&self) -> u64 {
        self.pairs
    }
}

/// The buffers of one task (a row chunk or a column block), or of a serial product.
pub struct TaskBuffers<T> {
    /// Two rows packed as one complex row (nx).
    pair: Vec<Complex<T>>,
    /// One block of columns, `stride` apart.
    block: Vec<Complex<T>>,
    fft_scratch: Vec<Complex<T>>,
}

impl<T> TaskBuffers<T> {
    const EMPTY: Self = TaskBuffers { pair: Vec::new(), block: Vec::new(), fft_scratch: Vec::new() };
}

impl<T: Real> Circulant2<T> {
    pub fn new(ny: usize, nx: usize) -> Self {
        let mut planner = FftPlanner::<T>::new();
        let plans =
            [planner.plan_fft_forward(nx), planner.plan_fft_inverse(nx), planner.plan_fft_forward(ny), planner.plan_fft_inverse(ny)];
        let fft_scratch_len = plans.iter().map(|plan| plan.get_inplace_scratch_len()).max().unwrap_or(0);
        let [row_forward, row_inverse, column_forward, column_inverse] = plans;
        Self {
            ny,
            nx,
            stride: if ny >= 64 { ny + 2 } else { ny },
            row_forward,
            row_inverse,
            column_forward,
            column_inverse,
            fft_scratch_len,
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

    /// Makes `b` large enough for this grid's tasks with `columns` columns a block (never
    /// smaller: a thread's buffers serve grids of any size in turn).
    fn fit(&self, b: &mut TaskBuffers<T>, columns: usize) {
        let zero = Complex::default();
        b.pair.resize(self.nx, zero);
        if b.block.len() < columns * self.stride {
            b.block.resize(columns * self.stride, zero);
        }
        if b.fft_scratch.len() < self.fft_scratch_len {
            b.fft_scratch.resize(self.fft_scratch_len, zero);
        }
    }

    /// Runs `task` with this thread's task buffers, fitted to this grid and `columns` columns a
    /// block: kept between products (a fresh set per rayon split zeroed some 8 MB a product at
    /// 1024^2). Their contents never reach a result: every entry is written before it is read.
    fn with_thread_buffers<R>(&self, columns: usize, task: impl FnOnce(&mut TaskBuffers<T>) -> R) -> R {
        T::with_thread_buffers(|b| {
            self.fit(b, columns);
            task(b)
        })
    }

    pub fn scratch(&self) -> Circulant2Scratch<T> {
        let mut buffers = TaskBuffers::EMPTY;
        if !self.parallel() {
            self.fit(&mut buffers, COLUMN_BLOCK);
        }
        Circulant2Scratch { rows: vec![Complex::default(); self.spectrum_len()], buffers, pairs: 0 }
    }

    /// Rows per row task when parallel: even, so that a row pair never straddles two tasks.
    fn rows_per_task(&self) -> usize {
        ((self.ny / 32).max(8) + 1) & !1
    }

    /// Half spectra of the rows of `input` into `rows` (ny x h), two rows per complex transform.
    fn rows_forward_task(&self, input: &[f64], rows: &mut [Complex<T>], b: &mut TaskBuffers<T>) {
        let (zero, half) = (T::zero(), T::of(0.5));
        let (nx, h) = (self.nx, self.half_width());
        for (rows_in, spectra) in input.chunks(2 * nx).zip(rows.chunks_mut(2 * h)) {
            let (a, second) = rows_in.split_at(nx);
            if second.is_empty() {
                for (z, &x) in b.pair.iter_mut().zip(a) {
                    *z = Complex::new(T::of(x), zero);
                }
            } else {
                for ((z, &x), &y) in b.pair.iter_mut().zip(a).zip(second) {
                    *z = Complex::new(T::of(x), T::of(y));
                }
            }
            self.row_forward.process_with_scratch(&mut b.pair, &mut b.fft_scratch);
            let z = &b.pair;
            let (spectrum_a, spectrum_b) = spectra.split_at_mut(h);
            // Z = A + i B with A, B Hermitian: A_k = (Z_k + conj Z_-k) / 2, B_k = (Z_k - conj Z_-k) / 2i.
            // Bin 0 pairs with itself, bin k >= 1 with nx - k.
            let mirrored = std::iter::once(z[0]).chain(z[nx - (h - 1)..].iter().rev().copied());
            if spectrum_b.is_empty() {
                for ((a, &zk), zm) in spectrum_a.iter_mut().zip(&z[..h]).zip(mirrored) {
                    *a = Complex::new(half * (zk.re + zm.re), half * (zk.im - zm.im));
                }
            } else {
                for (((a, b), &zk), zm) in spectrum_a.iter_mut().zip(spectrum_b.iter_mut()).zip(&z[..h]).zip(mirrored) {
                    *a = Complex::new(half * (zk.re + zm.re), half * (zk.im - zm.im));
                    *b = Complex::new(half * (zk.im + zm.im), half * (zm.re - zk.re));
                }
            }
        }
    }

    /// Real rows of `out` from the half spectra in `rows`, two rows per complex transform.
    fn rows_inverse_task(&self, rows: &mut [Complex<T>], out: &mut [f64], b: &mut TaskBuffers<T>) {
        let zero = T::zero();
        let (nx, h) = (self.nx, self.half_width());
        for (spectra, rows_out) in rows.chunks_mut(2 * h).zip(out.chunks_mut(2 * nx)) {
            let (spectrum_a, spectrum_b) = spectra.split_at_mut(h);
            // A real row's spectrum has real end bins; rounding must not leak into the other row.
            spectrum_a[0].im = zero;
            if !spectrum_b.is_empty() {
                spectrum_b[0].im = zero;
            }
            if nx % 2 == 0 {
                spectrum_a[h - 1].im = zero;
                if !spectrum_b.is_empty() {
                    spectrum_b[h - 1].im = zero;
                }
            }
            // Z = A + i B: bins 0..h from the half spectra, the rest by Hermitian symmetry
            // (A_k = conj A_(nx - k)).
            let (low, high) = b.pair.split_at_mut(h);
            let mirrored_a = spectrum_a[1..nx - h + 1].iter().rev();
            if spectrum_b.is_empty() {
                low.copy_from_slice(spectrum_a);
                for (z, a) in high.iter_mut().zip(mirrored_a) {
                    *z = a.conj();
                }
            } else {
                for ((z, a), bk) in low.iter_mut().zip(spectrum_a.iter()).zip(spectrum_b.iter()) {
                    *z = Complex::new(a.re - bk.im, a.im + bk.re);
                }
                let mirrored_b = spectrum_b[1..nx - h + 1].iter().rev();
                for ((z, a), bk) in high.iter_mut().zip(mirrored_a).zip(mirrored_b) {
                    // conj A + i conj B.
                    *z = Complex::new(a.re + bk.im, bk.re - a.im);
                }
            }
            self.row_inverse.process_with_scratch(&mut b.pair, &mut b.fft_scratch);
            let (first, second) = rows_out.split_at_mut(nx);
            if second.is_empty() {
                for (x, z) in first.iter_mut().zip(&b.pair) {
                    *x = z.re.into();
                }
            } else {
                for ((x, y), z) in first.iter_mut().zip(second.iter_mut()).zip(&b.pair) {
                    *x = z.re.into();
                    *y = z.im.into();
                }
            }
        }
    }

    /// Transforms the columns `first..first + count` of `rows` (ny x h) in place: gathered into
    /// `b.block`, forward, with a multiplier multiplied and transformed back, scattered back.
    ///
    /// # Safety
    /// `rows` points to the ny x h spectrum, alive for the call, whose columns `first..first +
    /// count` no other thread touches meanwhile.
    unsafe fn columns_task(&self, multiplier: Option<&[f64]>, rows: SharedRows<T>, first: usize, count: usize, b: &mut TaskBuffers<T>) {
        let (ny, h, stride) = (self.ny, self.half_width(), self.stride);
        assert!(first + count <= h && rows.1 == ny * h, "a column block outside the spectrum");
        let norm = 1.0 / (self.nx * ny) as f64;
        let block = &mut b.block[..count * stride];
        for r in 0..ny {
            // SAFETY: in bounds (asserted above), and these entries are this task's alone.
            let row = unsafe { std::slice::from_raw_parts(rows.0.add(r * h + first), count) };
            for (k, &v) in row.iter().enumerate() {
                block[k * stride + r] = v;
            }
        }
        for (k, column) in block.chunks_exact_mut(stride).enumerate() {
            let column = &mut column[..ny];
            self.column_forward.process_with_scratch(column, &mut b.fft_scratch);
            if let Some(m) = multiplier {
                for (c, &m) in column.iter_mut().zip(&m[(first + k) * ny..(first + k + 1) * ny]) {
                    *c = *c * T::of(m * norm);
                }
                self.column_inverse.process_with_scratch(column, &mut b.fft_scratch);
            }
        }
        for r in 0..ny {
            // SAFETY: as for the gather.
            let row = unsafe { std::slice::from_raw_parts_mut(rows.0.add(r * h + first), count) };
            for (k, v) in row.iter_mut().enumerate() {
                *v = block[k * stride + r];
            }
        }
    }

    fn rows_forward(&self, input: &[f64], s: &mut Circulant2Scratch<T>) {
        let (nx, h) = (self.nx, self.half_width());
        if self.parallel() {
            let per = self.rows_per_task();
            input
                .par_chunks(per * nx)
                .zip(s.rows.par_chunks_mut(per * h))
                .for_each(|(input, rows)| self.with_thread_buffers(0, |b| self.rows_forward_task(input, rows, b)));
        } else {
            self.rows_forward_task(input, &mut s.rows, &mut s.buffers);
        }
    }

    fn rows_inverse(&self, s: &mut Circulant2Scratch<T>, out: &mut [f64]) {
        let (nx, h) = (self.nx, self.half_width());
        if self.parallel() {
            let per = self.rows_per_task();
            s.rows
                .par_chunks_mut(per * h)
                .zip(out.par_chunks_mut(per * nx))
                .for_each(|(rows, out)| self.with_thread_buffers(0, |b| self.rows_inverse_task(rows, out, b)));
        } else {
            self.rows_inverse_task(&mut s.rows, out, &mut s.buffers);
        }
    }

    /// The column phase over the whole half spectrum in `s.rows`.
    fn columns(&self, multiplier: Option<&[f64]>, s: &mut Circulant2Scratch<T>) {
        let h = self.half_width();
        if self.parallel() {
            // Blocks of columns touch disjoint entries of every row: each task reaches the
            // spectrum through a raw pointer, its own columns only.
            let rows = SharedRows(s.rows.as_mut_ptr(), s.rows.len());
            (0..h.div_ceil(COLUMN_BLOCK)).into_par_iter().for_each(|block| {
                let first = block * COLUMN_BLOCK;
                let count = COLUMN_BLOCK.min(h - first);
                // SAFETY: `s.rows` outlives the loop and is not otherwise used in it; blocks are
                // disjoint.
                self.with_thread_buffers(COLUMN_BLOCK, |b| unsafe { self.columns_task(multiplier, rows, first, count, b) });
            });
        } else {
            let rows = SharedRows(s.rows.as_mut_ptr(), s.rows.len());
            for first in (0..h).step_by(COLUMN_BLOCK) {
                // SAFETY: one task at a time, `s.rows` not otherwise used meanwhile.
                unsafe { self.columns_task(multiplier, rows, first, COLUMN_BLOCK.min(h - first), &mut s.buffers) };
            }
        }
    }

    /// out = operator(multiplier) * input: multiplier holds the (nx/2 + 1) ny real eigenvalues.
    pub fn apply(&self, multiplier: &[f64], input: &[f64], out: &mut [f64], s: &mut Circulant2Scratch<T>) {
        assert_eq!(multiplier.len(), self.spectrum_len(), "a multiplier of the wrong size");
        assert_eq!(input.len(), self.nx * self.ny, "an input of the wrong size");
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
        let (ny, h) = (self.ny, self.half_width());
        (0..h).flat_map(|qx| (0..ny).map(move |qy| (qx, qy))).map(|(qx, qy)| s.rows[qy * h + qx].re.into()).collect()
    }
}

/// The row spectra shared by the column tasks (pointer, length), each of which reads and writes
/// its own columns only.
#[derive(Clone, Copy)]
struct SharedRows<T>(*mut Complex<T>, usize);

// SAFETY: see `Circulant2::columns`: tasks touch disjoint entries.
unsafe impl<T> Send for SharedRows<T> {}
unsafe impl<T> Sync for SharedRows<T> {}

/// Columns per column task when parallel (16 complex values: four cache lines per row).
const COLUMN_BLOCK: usize = 16;

#[cfg(test)]
mod tests {
    use super::*;

    /// An even stencil (symmetric in x and in y, so its eigenvalues are real), as offsets and
    /// weights, wrapped periodically on the grid.
    const STENCIL: [(isize, isize, f64); 9] =
        [(0, 0, 4.0), (0, 1, -1.25), (0, -1, -1.25), (1, 0, -0.75), (-1, 0, -0.75), (2, 3, 0.5), (-2, -3, 0.5), (2, -3, 0.5), (-2, 3, 0.5)];

    fn wrap(i: isize, n: usize) -> usize {
        i.rem_euclid(n as isize) as usize
    }

    /// The stencil's circular convolution with `input`, summed directly.
    fn direct(ny: usize, nx: usize, input: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; ny * nx];
        for r in 0..ny {
            for c in 0..nx {
                out[r * nx + c] =
                    STENCIL.iter().map(|&(dy, dx, w)| w * input[wrap(r as isize - dy, ny) * nx + wrap(c as isize - dx, nx)]).sum();
            }
        }
        out
    }

    /// The largest error of a product in precision `T` against the direct sum, relative to the
    /// product's largest value, on an ny x nx grid (one product: the pair counter says so).
    fn relative_error<T: Real>(ny: usize, nx: usize) -> f64 {
        let circulant = Circulant2::<T>::new(ny, nx);
        let mut column = vec![0.0; ny * nx];
        for &(dy, dx, w) in &STENCIL {
            column[wrap(dy, ny) * nx + wrap(dx, nx)] += w;
        }
        let multiplier = Circulant2::<f64>::new(ny, nx).spectrum_of(&column);
        let input: Vec<f64> = (0..ny * nx).map(|i| ((i * 7919 % 1009) as f64 / 1009.0 - 0.5) * (1.0 + (i % 13) as f64)).collect();
        let mut out = vec![0.0; ny * nx];
        let mut scratch = circulant.scratch();
        circulant.apply(&multiplier, &input, &mut out, &mut scratch);
        assert_eq!(scratch.pairs(), 1);
        let expected = direct(ny, nx, &input);
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        out.iter().zip(&expected).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())) / scale
    }

    #[test]
    fn products_match_a_direct_circular_convolution_for_odd_and_even_sizes() {
        // Small grids run serially, from 2^15 points in parallel (183^2, 257 x 130, 128 x 257;
        // 181^2 just below); odd ny leaves a lone last row
        // and odd nx a spectrum without a Nyquist bin.
        for (ny, nx) in [(4, 5), (5, 4), (7, 9), (8, 8), (9, 16), (181, 181), (183, 183), (130, 256), (257, 130), (128, 257)] {
            let error = relative_error::<f64>(ny, nx);
            assert!(error <= 1e-12, "{ny} x {nx}: off by {error:e} of the product");
        }
    }

    #[test]
    fn single_precision_products_match_the_direct_convolution_to_single_precision() {
        // The solver's low-precision products (preconditioner, rough sweeps, loose tolerances):
        // within 1e-5 of the product's size (single precision rounds at 6e-8; the transforms'
        // passes add up some of those), and not as close as double precision (the f32 path
        // really runs in f32).
        for (ny, nx) in [(7, 9), (8, 8), (181, 181), (183, 183), (257, 130)] {
            let error = relative_error::<f32>(ny, nx);
            assert!(error <= 1e-5 && error > 1e-12, "{ny} x {nx}: off by {error:e} of the product");
        }
    }

    #[test]
    fn products_are_bitwise_the_same_on_one_and_three_threads() {
        let (ny, nx) = (257, 130);
        let circulant = Circulant2::<f64>::new(ny, nx);
        let column: Vec<f64> = (0..ny * nx).map(|i| 1.0 / (1.0 + (i % 97) as f64)).collect();
        let input: Vec<f64> = (0..ny * nx).map(|i| ((i * 7919 % 1009) as f64).sin()).collect();
        // Single-precision products (their own thread-local buffers) alike.
        let low = Circulant2::<f32>::new(ny, nx);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let multiplier = circulant.spectrum_of(&column);
                let mut out = vec![0.0; ny * nx];
                circulant.apply(&multiplier, &input, &mut out, &mut circulant.scratch());
                let mut out_low = vec![0.0; ny * nx];
                low.apply(&multiplier, &input, &mut out_low, &mut low.scratch());
                (multiplier, out, out_low)
            })
        };
        let (one, three) = (run(1), run(3));
        assert!(one.0.iter().zip(&three.0).all(|(a, b)| a.to_bits() == b.to_bits()), "spectra differ");
        assert!(one.1.iter().zip(&three.1).all(|(a, b)| a.to_bits() == b.to_bits()), "products differ");
        assert!(one.2.iter().zip(&three.2).all(|(a, b)| a.to_bits() == b.to_bits()), "single-precision products differ");
    }
}
