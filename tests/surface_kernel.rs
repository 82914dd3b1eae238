//! The surface kernel: Love's closed form, the exactness of the Ewald periodisation, and plane
//! strain for pressures uniform across the road.

use std::f64::consts::PI;

use roadtex::kernel::{periodic_spectrum as line_spectrum, KernelKind};
use roadtex::surface::fft::Circulant2;
use roadtex::surface::kernel::{default_alpha, element_spectrum, periodic_spectrum, rectangle_displacement, Grid};

fn max_rel(a: &[f64], b: &[f64], scale: f64) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

#[test]
fn centre_of_a_square_matches_love() {
    // Uniform pressure on a square of side d: w(0) = 4 d ln(1 + sqrt 2) / (pi E*) (Love 1929).
    let d = 2e-3;
    let exact = 4.0 * d * (1.0 + 2f64.sqrt()).ln() / PI;
    assert!((rectangle_displacement(0.0, 0.0, d, d) - exact).abs() < 1e-15 * exact);
    // The corner of a rectangle a x b: (1/pi)(a asinh(b/a) + b asinh(a/b)); the centre is four corners.
    let (dx, dy) = (1e-3, 3e-3);
    let corner = |a: f64, b: f64| (a * (b / a).asinh() + b * (a / b).asinh()) / PI;
    let centre = 4.0 * corner(dx / 2.0, dy / 2.0);
    assert!((rectangle_displacement(0.0, 0.0, dx, dy) - centre).abs() < 1e-15 * centre);
}

#[test]
fn closed_form_and_far_quadrature_agree_and_tend_to_a_point_load() {
    let (dx, dy) = (1e-3, 2.5e-3);
    // Just inside and outside the switch to quadrature (6 cells of the larger spacing).
    for &(x, y) in &[(0.0, 5.99 * dy), (0.0, 6.01 * dy), (5.99 * dy, 0.0), (6.01 * dy, 0.0), (4.3 * dy, 4.3 * dy)] {
        let w = rectangle_displacement(x, y, dx, dy);
        // The independent reference: Love's closed form at (x, y) by inclusion-exclusion of the
        // antiderivative G(u, v) = u ln(v + r) + v ln(u + r) of 1/r over the rectangle, in whatever
        // branch (closed form or far quadrature) the kernel itself takes at that point.
        let g = |u: f64, v: f64| {
            let r = u.hypot(v);
            u * (v + r).ln() + v * (u + r).ln()
        };
        let (x1, x2, y1, y2) = (-dx / 2.0 - x, dx / 2.0 - x, -dy / 2.0 - y, dy / 2.0 - y);
        let parts = (g(x2, y2) - g(x1, y2) - g(x2, y1) + g(x1, y1)) / PI;
        assert!((w - parts).abs() < 5e-12 * w, "({x}, {y}): {w} vs {parts}");
    }
    let r = 400.0 * dy;
    let point = dx * dy / (PI * r);
    assert!((rectangle_displacement(r, 0.0, dx, dy) / point - 1.0).abs() < 1e-5);
}

#[test]
fn periodisation_does_not_depend_on_the_split() {
    // Two Ewald parameters move work between the real-space and the Fourier sums: the sums are
    // exact only if the spectra agree to rounding.
    for &(ny, nx, dx, dy) in &[(16usize, 16usize, 1e-3, 1e-3), (12, 20, 0.5e-3, 1.5e-3), (9, 7, 2e-3, 0.4e-3), (64, 48, 1e-4, 1e-4)] {
        let grid = Grid { ny, nx, dx, dy };
        let alpha = default_alpha(&grid);
        let a = element_spectrum(&grid, alpha);
        let b = element_spectrum(&grid, 0.6 * alpha);
        let c = element_spectrum(&grid, 1.4 * alpha);
        let scale = a.iter().fold(0.0f64, |m, &x| m.max(x));
        assert!(max_rel(&a, &b, scale) < 2e-14, "{ny}x{nx}: {}", max_rel(&a, &b, scale));
        assert!(max_rel(&a, &c, scale) < 2e-14, "{ny}x{nx}: {}", max_rel(&a, &c, scale));
    }
}

#[test]
fn uniform_across_the_road_is_the_line_kernel() {
    // Mode qy = 0 of the surface kernel is the plane-strain element kernel (Clausen/trigamma).
    for &(ny, nx, dx, dy) in &[(8usize, 64usize, 1e-3, 1e-3), (5, 100, 0.2e-3, 1e-3), (32, 33, 1e-3, 0.1e-3)] {
        let grid = Grid { ny, nx, dx, dy };
        let surface = periodic_spectrum(&grid, KernelKind::Element);
        let line = line_spectrum(nx, dx, KernelKind::Element);
        let row: Vec<f64> = (0..=nx / 2).map(|qx| surface[qx * ny]).collect();
        assert!(max_rel(&row, &line, line[1]) < 1e-13, "{ny}x{nx}: {}", max_rel(&row, &line, line[1]));
        let spectral = periodic_spectrum(&grid, KernelKind::Spectral);
        let row: Vec<f64> = (0..=nx / 2).map(|qx| spectral[qx * ny]).collect();
        assert!(max_rel(&row, &line_spectrum(nx, dx, KernelKind::Spectral), line[1]) < 1e-15);
    }
}

#[test]
fn periodic_sum_tends_to_the_half_space_far_from_the_images() {
    // On a large period the periodic coefficients differ from Love's by a smooth image field: its
    // second difference at the centre is O(d^2 / L^3), far below the element's own.
    let (n, d) = (256usize, 1e-3);
    let grid = Grid { ny: n, nx: n, dx: d, dy: d };
    let op = roadtex::surface::compliance::SurfacePeriodic::new(grid, KernelKind::Element);
    let c = op.coefficients();
    for &(a, b) in &[(1usize, 0usize), (2, 1), (5, 3)] {
        let periodic = c[b * n + a] - c[0];
        let free = rectangle_displacement(a as f64 * d, b as f64 * d, d, d) - rectangle_displacement(0.0, 0.0, d, d);
        assert!((periodic - free).abs() < 1e-3 * free.abs(), "({a},{b}): {periodic} vs {free}");
    }
}

#[test]
fn circulant_product_matches_a_direct_convolution() {
    let (ny, nx) = (6usize, 10usize);
    let circ = Circulant2::<f64>::new(ny, nx);
    let column: Vec<f64> = (0..ny * nx)
        .map(|k| {
            let (y, x) = ((k / nx).min(ny - k / nx), (k % nx).min(nx - k % nx));
            1.0 / (1.0 + (x * x + 2 * y * y) as f64)
        })
        .collect();
    let spectrum = circ.spectrum_of(&column);
    let input: Vec<f64> = (0..ny * nx).map(|k| ((k * 37 % 11) as f64 - 5.0) * 0.1).collect();
    let mut out = vec![0.0; ny * nx];
    circ.apply(&spectrum, &input, &mut out, &mut circ.scratch());
    for (i, &got) in out.iter().enumerate() {
        let mut direct = 0.0;
        for (j, &x) in input.iter().enumerate() {
            let (dy, dx) = ((i / nx + ny - j / nx) % ny, (i % nx + nx - j % nx) % nx);
            direct += column[dy * nx + dx] * x;
        }
        assert!((got - direct).abs() < 1e-14, "{i}");
    }
}
