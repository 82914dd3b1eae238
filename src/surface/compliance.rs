//! The compliance operators of a surface (E* = 1), for the line solvers' CG and dense paths: the
//! periodic model (block circulant, real 2-D FFTs on the grid) and the finite model (zero-padded
//! linear convolution on a grid of twice the size each way). Element (iy, ix) is index iy nx + ix.

use std::sync::OnceLock;

use super::fft::{Circulant2, Circulant2Scratch};
use super::kernel::{finite_embedded_spectrum, periodic_spectrum, rectangle_displacement, Grid};
use crate::compliance::Compliance;
use crate::kernel::KernelKind;

/// The periodic model on the grid.
pub struct SurfacePeriodic {
    grid: Grid,
    circulant: Circulant2,
    /// The same products in single precision ([`Compliance::precondition_low`]).
    low: Circulant2<f32>,
    spectrum: Vec<f64>,
    inverse_spectrum: Vec<f64>,
    /// Real-space coefficients C[(iy - jy) mod ny][(ix - jx) mod nx], built on first use (dense
    /// solve, column updates) by one inverse transform of the spectrum.
    coefficients: OnceLock<Vec<f64>>,
}

impl SurfacePeriodic {
    pub fn new(grid: Grid, kind: KernelKind) -> Self {
        let spectrum = periodic_spectrum(&grid, kind);
        let inverse_spectrum = spectrum.iter().map(|&l| if l > 0.0 { 1.0 / l } else { 0.0 }).collect();
        Self {
            grid,
            circulant: Circulant2::<f64>::new(grid.ny, grid.nx),
            low: Circulant2::<f32>::new(grid.ny, grid.nx),
            spectrum,
            inverse_spectrum,
            coefficients: OnceLock::new(),
        }
    }

    /// Eigenvalues in the half-spectrum layout (index qx ny + qy), m per unit pressure / E*.
    pub fn spectrum(&self) -> &[f64] {
        &self.spectrum
    }

    /// Real-space coefficients, row-major ny x nx: the displacement of unit pressure on element
    /// (0, 0) at every element, up to the rigid constant (the zero mode is 0).
    pub fn coefficients(&self) -> &[f64] {
        self.coefficients.get_or_init(|| {
            let mut unit = vec![0.0; self.grid.len()];
            unit[0] = 1.0;
            let mut column = vec![0.0; self.grid.len()];
            self.circulant.apply(&self.spectrum, &unit, &mut column, &mut self.circulant.scratch());
            column
        })
    }
}

/// Scratch of one thread for [`SurfacePeriodic`]: double- and single-precision products.
pub struct SurfacePeriodicScratch {
    full: Circulant2Scratch,
    low: Circulant2Scratch<f32>,
}

impl SurfacePeriodicScratch {
    /// Single-precision 2-D FFT pairs applied so far (included in [`Compliance::fft_pairs`]).
    pub fn low_pairs(&self) -> u64 {
        self.low.pairs()
    }
}

impl Compliance for SurfacePeriodic {
    type Scratch = SurfacePeriodicScratch;
    const LOW_PRECISION_DISPLACEMENT: bool = true;
    const STEERS_LOW_AT_TIGHT_TOL: bool = true;

    fn len(&self) -> usize {
        self.grid.len()
    }

    fn scratch(&self) -> SurfacePeriodicScratch {
        SurfacePeriodicScratch { full: self.circulant.scratch(), low: self.low.scratch() }
    }

    fn fft_pairs(scratch: &SurfacePeriodicScratch) -> u64 {
        scratch.full.pairs() + scratch.low.pairs()
    }

    fn displacement(&self, pressure: &[f64], out: &mut [f64], scratch: &mut SurfacePeriodicScratch) {
        self.circulant.apply(&self.spectrum, pressure, out, &mut scratch.full);
    }

    fn precondition(&self, gap: &[f64], out: &mut [f64], scratch: &mut SurfacePeriodicScratch) {
        self.circulant.apply(&self.inverse_spectrum, gap, out, &mut scratch.full);
    }

    fn precondition_low(&self, gap: &[f64], out: &mut [f64], scratch: &mut SurfacePeriodicScratch) {
        self.low.apply(&self.inverse_spectrum, gap, out, &mut scratch.low);
    }

    fn displacement_low(&self, pressure: &[f64], out: &mut [f64], scratch: &mut SurfacePeriodicScratch) {
        self.low.apply(&self.spectrum, pressure, out, &mut scratch.low);
    }

    fn dense_entry(&self, i: usize, j: usize) -> f64 {
        let (ny, nx) = (self.grid.ny, self.grid.nx);
        let dy = (i / nx + ny - j / nx) % ny;
        let dx = (i % nx + nx - j % nx) % nx;
        self.coefficients()[dy * nx + dx]
    }

    fn add_column(&self, j: usize, weight: f64, out: &mut [f64]) {
        let (ny, nx) = (self.grid.ny, self.grid.nx);
        let c = self.coefficients();
        let (jy, jx) = (j / nx, j % nx);
        for (iy, row) in out.chunks_exact_mut(nx).enumerate() {
            let c_row = &c[((iy + ny - jy) % ny) * nx..][..nx];
            // Columns ix >= jx read offsets 0.., columns ix < jx the wrapped ones.
            let (head, tail) = row.split_at_mut(jx);
            for (o, &cv) in tail.iter_mut().zip(c_row) {
                *o += weight * cv;
            }
            for (o, &cv) in head.iter_mut().zip(&c_row[nx - jx..]) {
                *o += weight * cv;
            }
        }
    }
}

/// The finite (non-periodic) model: Love's coefficients without periodisation, applied as a linear
/// convolution, preconditioned by the periodic element kernel's inverse.
pub struct SurfaceFinite {
    grid: Grid,
    embedded: Circulant2,
    embedded_spectrum: Vec<f64>,
    periodic: SurfacePeriodic,
    coefficients: OnceLock<Vec<f64>>,
}

pub struct SurfaceFiniteScratch {
    embedded: Circulant2Scratch,
    padded: Vec<f64>,
    padded_out: Vec<f64>,
    periodic: SurfacePeriodicScratch,
}

impl SurfaceFiniteScratch {
    /// Single-precision 2-D FFT pairs applied so far (the preconditioner's; its C p is double).
    pub fn low_pairs(&self) -> u64 {
        self.periodic.low_pairs()
    }
}

impl SurfaceFinite {
    pub fn new(grid: Grid) -> Self {
        Self {
            grid,
            embedded: Circulant2::<f64>::new(2 * grid.ny, 2 * grid.nx),
            embedded_spectrum: finite_embedded_spectrum(&grid),
            periodic: SurfacePeriodic::new(grid, KernelKind::Element),
            coefficients: OnceLock::new(),
        }
    }

    /// Love's coefficients for offsets (|dy| < ny, |dx| < nx), row-major ny x nx (even in both).
    fn coefficients(&self) -> &[f64] {
        self.coefficients.get_or_init(|| {
            let Grid { ny, nx, dx, dy } = self.grid;
            (0..ny * nx).map(|k| rectangle_displacement((k % nx) as f64 * dx, (k / nx) as f64 * dy, dx, dy)).collect()
        })
    }
}

impl Compliance for SurfaceFinite {
    type Scratch = SurfaceFiniteScratch;
    const STEERS_LOW_AT_TIGHT_TOL: bool = true;

    fn fft_pairs(scratch: &SurfaceFiniteScratch) -> u64 {
        scratch.embedded.pairs() + SurfacePeriodic::fft_pairs(&scratch.periodic)
    }

    fn len(&self) -> usize {
        self.grid.len()
    }

    fn scratch(&self) -> SurfaceFiniteScratch {
        let padded = 4 * self.grid.len();
        SurfaceFiniteScratch {
            embedded: self.embedded.scratch(),
            padded: vec![0.0; padded],
            padded_out: vec![0.0; padded],
            periodic: self.periodic.scratch(),
        }
    }

    fn displacement(&self, pressure: &[f64], out: &mut [f64], s: &mut SurfaceFiniteScratch) {
        let nx = self.grid.nx;
        s.padded.fill(0.0);
        for (row_in, row_out) in pressure.chunks_exact(nx).zip(s.padded.chunks_exact_mut(2 * nx)) {
            row_out[..nx].copy_from_slice(row_in);
        }
        self.embedded.apply(&self.embedded_spectrum, &s.padded, &mut s.padded_out, &mut s.embedded);
        for (row_out, row_in) in out.chunks_exact_mut(nx).zip(s.padded_out.chunks_exact(2 * nx)) {
            row_out.copy_from_slice(&row_in[..nx]);
        }
    }

    fn precondition(&self, gap: &[f64], out: &mut [f64], s: &mut SurfaceFiniteScratch) {
        self.periodic.precondition(gap, out, &mut s.periodic);
    }

    fn precondition_low(&self, gap: &[f64], out: &mut [f64], s: &mut SurfaceFiniteScratch) {
        self.periodic.precondition_low(gap, out, &mut s.periodic);
    }

    fn dense_entry(&self, i: usize, j: usize) -> f64 {
        let nx = self.grid.nx;
        let dy = (i / nx).abs_diff(j / nx);
        let dx = (i % nx).abs_diff(j % nx);
        self.coefficients()[dy * nx + dx]
    }
}
