//! Influence coefficients of the elastic half-space (Boussinesq) for piecewise-constant pressure on
//! an ny x nx grid of dx x dy rectangles, displacement taken at the rectangle centres, for a unit
//! modulus E* = 1 (the solvers work with pressure / E*, so one kernel serves every modulus).
//!
//! A point force F displaces the surface by F / (pi E* r). Uniform unit pressure on the rectangle
//! |x| <= a, |y| <= b (a = dx/2, b = dy/2) gives Love's (1929) closed form
//!
//!   w(x, y) = (1/pi) [f(X, Y)] over X = x - a..x + a, Y = y - b..y + b,
//!   f(X, Y) = X asinh(Y / |X|) + Y asinh(X / |Y|),
//!
//! evaluated as written near the element and, beyond six cells, as a Gauss-Legendre quadrature of
//! 1 / r over the rectangle (smooth there, and free of the four-term cancellation).
//!
//! **Periodic model.** The image sum of w over the periods (m Lx, n Ly) diverges (w ~ dx dy /
//! (pi r)); only its mean, the zero mode (a rigid shift that load control fixes), is undefined.
//! The sum is split exactly, as Ewald does, with 1/r = erfc(alpha r)/r + erf(alpha r)/r:
//! - the short-range part, w minus the rectangle integral of erf(alpha r)/(pi r) (a smooth
//!   integrand: Gauss-Legendre to rounding), decays as erfc(alpha r) and is summed over every image
//!   within r = 6.5/alpha (the first term left out is below 1e-19 of the self coefficient);
//! - the long-range part is summed in Fourier space: the 2-D transform of erf(alpha r)/(pi r) is
//!   2 erfc(|k| / (2 alpha)) / |k|, times the rectangle's transform dx dy sinc(kx a) sinc(ky b),
//!   aliased over the grid's reciprocal lattice up to |K| = 13 alpha (erfc(6.5) ~ 4e-20).
//!
//! Both sums are therefore exact to rounding, and the result does not depend on alpha (a test
//! compares two alphas). For a pressure uniform along y only the l = 0 aliases survive (sinc(pi l)
//! = 0), so the first row of the spectrum is the line model's element spectrum: plane strain.

use std::f64::consts::PI;

use super::fft::Circulant2;
use crate::kernel::KernelKind;

/// The grid: ny rows (across the road, spacing dy) of nx elements (along the road, spacing dx).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub ny: usize,
    pub nx: usize,
    pub dx: f64,
    pub dy: f64,
}

impl Grid {
    pub fn len(&self) -> usize {
        self.ny * self.nx
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The wavenumbers (rad/m) of half-spectrum index (qx, qy), qy taken in (-ny/2, ny/2].
    fn wavenumbers(&self, qx: usize, qy: usize) -> (f64, f64) {
        let qy = if qy <= self.ny / 2 { qy as f64 } else { qy as f64 - self.ny as f64 };
        (2.0 * PI * qx as f64 / (self.nx as f64 * self.dx), 2.0 * PI * qy / (self.ny as f64 * self.dy))
    }
}

/// Love's displacement at (x, y) (m) of unit pressure on the dx x dy rectangle centred at the
/// origin, for E* = 1: the finite-model coefficient.
pub fn rectangle_displacement(x: f64, y: f64, dx: f64, dy: f64) -> f64 {
    let (a, b) = (0.5 * dx, 0.5 * dy);
    if x.hypot(y) >= FAR_CELLS * dx.max(dy) {
        return rectangle_quadrature(x, y, a, b, &gauss_legendre(8), |r| 1.0 / r) / PI;
    }
    let f = |xx: f64, yy: f64| {
        let t1 = if xx == 0.0 { 0.0 } else { xx * (yy / xx.abs()).asinh() };
        let t2 = if yy == 0.0 { 0.0 } else { yy * (xx / yy.abs()).asinh() };
        t1 + t2
    };
    (f(x + a, y + b) - f(x + a, y - b) - f(x - a, y + b) + f(x - a, y - b)) / PI
}

/// Beyond this many cells (the larger spacing) the rectangle integral is a quadrature.
const FAR_CELLS: f64 = 6.0;
/// erfc(CUTOFF) ~ 4e-20: where the Ewald sums are cut in real and in Fourier space.
const CUTOFF: f64 = 6.5;

/// Integral of g(|r - s|) over s in [-a, a] x [-b, b] by tensor Gauss-Legendre (nodes, weights).
fn rectangle_quadrature(x: f64, y: f64, a: f64, b: f64, rule: &[(f64, f64)], g: impl Fn(f64) -> f64) -> f64 {
    let mut total = 0.0;
    for &(tj, wj) in rule {
        let dy = y - b * tj;
        let mut row = 0.0;
        for &(ti, wi) in rule {
            row += wi * g((x - a * ti).hypot(dy));
        }
        total += wj * row;
    }
    total * a * b
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre recurrence).
pub(crate) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut t = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, t);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * t * p1 - (k - 1.0) * p0) / k);
                }
                derivative = n as f64 * (t * p1 - p0) / (t * t - 1.0);
                let step = p1 / derivative;
                t -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            (t, 2.0 / ((1.0 - t * t) * derivative * derivative))
        })
        .collect()
}

/// The short-range Ewald part at (x, y): Love's displacement minus the rectangle integral of
/// erf(alpha r) / (pi r) (16 x 16 points, `rule`); beyond FAR_CELLS, directly the integral of
/// erfc(alpha r) / (pi r) (8 x 8 points, `far_rule`: the integrand is smooth there and below
/// 1e-6 of the self coefficient, so its quadrature error stays below 1e-16 of it).
fn short_range(x: f64, y: f64, grid: &Grid, alpha: f64, rule: &[(f64, f64)], far_rule: &[(f64, f64)]) -> f64 {
    let (a, b) = (0.5 * grid.dx, 0.5 * grid.dy);
    if x.hypot(y) >= FAR_CELLS * grid.dx.max(grid.dy) {
        return rectangle_quadrature(x, y, a, b, far_rule, |r| libm::erfc(alpha * r) / r) / PI;
    }
    let smooth = |r: f64| if r == 0.0 { 2.0 * alpha / PI.sqrt() } else { libm::erf(alpha * r) / r };
    rectangle_displacement(x, y, grid.dx, grid.dy) - rectangle_quadrature(x, y, a, b, rule, smooth) / PI
}

/// The Ewald splitting parameter (1/m) used by [`periodic_spectrum`].
pub fn default_alpha(grid: &Grid) -> f64 {
    0.5 / grid.dx.max(grid.dy)
}

/// Eigenvalues (m per unit pressure / E*) of the periodic kernel in the half-spectrum layout of
/// [`Circulant2`] (index qx * ny + qy); the zero mode is 0.
pub fn periodic_spectrum(grid: &Grid, kind: KernelKind) -> Vec<f64> {
    match kind {
        KernelKind::Element => element_spectrum(grid, default_alpha(grid)),
        KernelKind::Spectral => {
            let mut spectrum = vec![0.0; (grid.nx / 2 + 1) * grid.ny];
            for qx in 0..=grid.nx / 2 {
                for qy in 0..grid.ny {
                    let (kx, ky) = grid.wavenumbers(qx, qy);
                    let k = kx.hypot(ky);
                    spectrum[qx * grid.ny + qy] = if k > 0.0 { 2.0 / k } else { 0.0 };
                }
            }
            spectrum
        }
    }
}

/// The element spectrum by the Ewald split with parameter `alpha` (1/m); see the module notes.
pub fn element_spectrum(grid: &Grid, alpha: f64) -> Vec<f64> {
    let Grid { ny, nx, dx, dy } = *grid;
    // Short range: every image within the cut-off, folded onto the grid, then transformed.
    let (rule, far_rule) = (gauss_legendre(16), gauss_legendre(8));
    let radius = CUTOFF / alpha;
    let (reach_x, reach_y) = ((radius / dx).ceil() as i64, (radius / dy).ceil() as i64);
    let mut column = vec![0.0; nx * ny];
    for b in -reach_y..=reach_y {
        for a in -reach_x..=reach_x {
            let (x, y) = (a as f64 * dx, b as f64 * dy);
            if x.hypot(y) > radius {
                continue;
            }
            let index = b.rem_euclid(ny as i64) as usize * nx + a.rem_euclid(nx as i64) as usize;
            column[index] += short_range(x, y, grid, alpha, &rule, &far_rule);
        }
    }
    let mut spectrum = Circulant2::<f64>::new(ny, nx).spectrum_of(&column);
    // Long range: aliases K = k + (2 pi j / dx, 2 pi l / dy) with |K| < 2 alpha CUTOFF.
    let k_max = 2.0 * alpha * CUTOFF;
    let (gx, gy) = (2.0 * PI / dx, 2.0 * PI / dy);
    let (jmax, lmax) = ((k_max / gx).ceil() as i64 + 1, (k_max / gy).ceil() as i64 + 1);
    let sinc = |t: f64| if t == 0.0 { 1.0 } else { t.sin() / t };
    // The aliases of each wavenumber along x and along y with |K| below the cut, and their sinc
    // factors: only these pairs can pass |K| < k_max.
    let aliases = |k: f64, g: f64, reach: i64, d: f64| -> Vec<(f64, f64)> {
        (-reach..=reach).map(|j| k + j as f64 * g).filter(|big| big.abs() < k_max).map(|big| (big, sinc(0.5 * big * d))).collect()
    };
    let along_x: Vec<Vec<(f64, f64)>> = (0..=nx / 2).map(|qx| aliases(grid.wavenumbers(qx, 0).0, gx, jmax, dx)).collect();
    let along_y: Vec<Vec<(f64, f64)>> = (0..ny).map(|qy| aliases(grid.wavenumbers(0, qy).1, gy, lmax, dy)).collect();
    for (qx, x_terms) in along_x.iter().enumerate() {
        for (qy, y_terms) in along_y.iter().enumerate() {
            let slot = qx * ny + qy;
            if qx == 0 && qy == 0 {
                spectrum[slot] = 0.0;
                continue;
            }
            let mut long = 0.0;
            for &(big_kx, sx) in x_terms {
                for &(big_ky, sy) in y_terms {
                    let k = big_kx.hypot(big_ky);
                    if k < k_max {
                        long += 2.0 * libm::erfc(k / (2.0 * alpha)) / k * sx * sy;
                    }
                }
            }
            spectrum[slot] += long;
        }
    }
    spectrum
}

/// The finite-model kernel embedded in a (2 ny) x (2 nx) circulant for linear convolution: its
/// eigenvalues in the layout of `Circulant2::<f64>::new(2 ny, 2 nx)`.
pub fn finite_embedded_spectrum(grid: &Grid) -> Vec<f64> {
    let Grid { ny, nx, dx, dy } = *grid;
    let (my, mx) = (2 * ny, 2 * nx);
    let mut column = vec![0.0; my * mx];
    for b in 0..ny {
        for a in 0..nx {
            let w = rectangle_displacement(a as f64 * dx, b as f64 * dy, dx, dy);
            // Even in x and in y: the four mirror images share one value.
            for &row in &[b, (my - b) % my] {
                for &col in &[a, (mx - a) % mx] {
                    column[row * mx + col] = w;
                }
            }
        }
    }
    Circulant2::<f64>::new(my, mx).spectrum_of(&column)
}
