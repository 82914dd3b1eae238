//! Accuracy of the periodic contact solver against closed-form and dense references.

use roadtex::reference::Westergaard;
use roadtex::solver::{solve, Material, Method, SolverOptions};
use roadtex::synthetic::self_affine;

fn westergaard_case(n: usize, ratio: f64, tol: f64) -> (f64, f64, usize, f64) {
    let rubber = Material::new(2.5e6, 0.5).unwrap();
    let e_star = rubber.plane_strain_modulus();
    let wavelength = 0.02;
    let amplitude = 1e-4;
    let base = Westergaard { amplitude, wavelength, plane_strain_modulus: e_star, mean_pressure: 1.0 };
    let exact = Westergaard { mean_pressure: ratio * base.full_contact_pressure(), ..base };
    let dx = wavelength / n as f64;
    let x: Vec<f64> = (0..n).map(|i| i as f64 * dx).collect();
    let heights: Vec<f64> = x.iter().map(|&x| amplitude * (2.0 * std::f64::consts::PI * x / wavelength).cos()).collect();
    let sol = solve(&heights, dx, rubber, exact.mean_pressure, SolverOptions { tol, ..Default::default() }).unwrap();
    assert!(sol.converged, "n={n} ratio={ratio} residual={}", sol.residual);
    let err: f64 = sol.pressure.iter().zip(&x).map(|(&p, &x)| (p - exact.element_pressure(x, dx)).abs()).sum::<f64>()
        / (exact.mean_pressure * n as f64);
    let half_width = sol.pressure.iter().filter(|&&p| p > 0.0).count() as f64 * dx / 2.0;
    let width_err = (half_width - exact.contact_half_width()).abs() / dx;
    (err, width_err, sol.iterations, sol.residual)
}

#[test]
fn westergaard_probe() {
    for &n in &[1024usize, 4096, 16384] {
        for &ratio in &[0.05, 0.3, 0.9, 1.5] {
            let (err, werr, it, res) = westergaard_case(n, ratio, 1e-10);
            println!("n={n} ratio={ratio} L1err={err:.3e} width_err={werr:.2}dx it={it} res={res:.2e}");
        }
    }
}

#[test]
fn self_affine_probe() {
    for &n in &[1usize << 10, 1 << 12, 1 << 14, 1 << 16] {
        let heights = self_affine(n, 1.0, 0.8, 0.1, 0.25, 1);
        let rubber = Material::new(0.75, 0.5).unwrap();
        let dx = 1.0 / n as f64;
        let t = std::time::Instant::now();
        let sol = solve(&heights, dx, rubber, 0.0105, SolverOptions { tol: 1e-8, max_iterations: 20000, ..Default::default() }).unwrap();
        let frac = sol.pressure.iter().filter(|&&p| p > 0.0).count() as f64 / n as f64;
        println!("n={n} it={} res={:.2e} conv={} frac={frac:.3} t={:.3}s", sol.iterations, sol.residual, sol.converged, t.elapsed().as_secs_f64());
        if n <= 1024 {
            let d = solve(&heights, dx, rubber, 0.0105, SolverOptions { method: Method::Direct, ..Default::default() }).unwrap();
            let diff = sol.pressure.iter().zip(&d.pressure).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / 0.0105;
            println!("   direct sweeps={} diff={diff:.2e}", d.iterations);
        }
    }
}
