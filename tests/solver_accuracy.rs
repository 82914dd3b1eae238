//! Accuracy of the contact solvers against closed-form and dense references (Rust side; the
//! Python suite in tests/python covers the public API).

mod common;

use roadtex::reference::Westergaard;
use roadtex::solver::{solve, Material, Method, SolverOptions};
use roadtex::synthetic::self_affine;

const RUBBER: fn() -> Material = || Material::new(2.5e6, 0.5).unwrap();

/// (L1 relative pressure error, contact half-width error in dx, iterations)
fn westergaard_case(n: usize, ratio: f64, tol: f64) -> (f64, f64, usize) {
    let e_star = RUBBER().plane_strain_modulus();
    let (wavelength, amplitude) = (0.02, 1e-4);
    let base = Westergaard { amplitude, wavelength, plane_strain_modulus: e_star, mean_pressure: 1.0 };
    let exact = Westergaard { mean_pressure: ratio * base.full_contact_pressure(), ..base };
    let dx = wavelength / n as f64;
    let x: Vec<f64> = (0..n).map(|i| i as f64 * dx).collect();
    let heights: Vec<f64> = x.iter().map(|&x| amplitude * (2.0 * std::f64::consts::PI * x / wavelength).cos()).collect();
    let sol = solve(&heights, dx, RUBBER(), exact.mean_pressure, SolverOptions { tol, ..Default::default() }).unwrap();
    assert!(sol.converged, "n={n} ratio={ratio} residual={}", sol.residual);
    let exact_p: Vec<f64> = x.iter().map(|&x| exact.element_pressure(x, dx)).collect();
    let err = sol.pressure.iter().zip(&exact_p).map(|(p, q)| (p - q).abs()).sum::<f64>() / exact_p.iter().sum::<f64>();
    let half_width = sol.pressure.iter().filter(|&&p| p > 0.0).count() as f64 * dx / 2.0;
    (err, (half_width - exact.contact_half_width()).abs() / dx, sol.iterations)
}

#[test]
fn westergaard_pressure_converges_to_the_exact_solution() {
    for ratio in [0.05, 0.3, 0.9, 1.5] {
        let (e1, w1, _) = westergaard_case(1024, ratio, 1e-11);
        let (e4, w4, it4) = westergaard_case(4096, ratio, 1e-10);
        let (e16, w16, _) = westergaard_case(16384, ratio, 1e-11);
        assert!(e4 <= 5e-5, "ratio {ratio}: L1 error {e4:e} at N = 4096");
        assert!(e16 < e4 && e4 < e1, "ratio {ratio}: errors {e1:e} {e4:e} {e16:e} do not fall with N");
        assert!(w1.max(w4).max(w16) <= 2.0, "ratio {ratio}: half-width off by {w1} {w4} {w16} dx");
        assert!(it4 <= 50, "ratio {ratio}: {it4} iterations at N = 4096, tol 1e-10");
    }
}

fn max_relative_difference(a: &[f64], b: &[f64], scale: f64) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

#[test]
fn cg_agrees_with_dense_direct_solve() {
    // 1,009 is a prime: the CG applies its kernel as a linear convolution of size 2,048
    // (kernel::circular_product_len); the dense solve sums the real-space coefficients.
    for periodic in [true, false] {
        for (n, seed) in [(256usize, 3u64), (1000, 4), (1009, 5)] {
            let length = 0.1;
            let heights = self_affine(n, length, 0.8, 0.2, 0.25, seed);
            for e in [1e6, 2.5e6, 1e7] {
                let rubber = Material::new(e, 0.5).unwrap();
                let cg = SolverOptions { periodic, tol: 1e-12, ..Default::default() };
                let direct = SolverOptions { method: Method::Direct, ..cg };
                let a = solve(&heights, length / n as f64, rubber, 2e5, cg).unwrap();
                let b = solve(&heights, length / n as f64, rubber, 2e5, direct).unwrap();
                assert!(a.converged && b.converged);
                let diff = max_relative_difference(&a.pressure, &b.pressure, 2e5);
                assert!(diff <= 1e-8, "periodic={periodic} n={n} E={e}: max |dp|/P = {diff:e}");
            }
        }
    }
}

#[test]
fn preconditioned_iterations_grow_slowly_with_n() {
    // The benchmark case of the issue: Hurst 0.8, rms slope 0.1, L = 1, E* = 1, P = 0.0105.
    let rubber = Material::new(0.75, 0.5).unwrap();
    let mut counts = Vec::new();
    for n in [1usize << 10, 1 << 12, 1 << 14] {
        let heights = self_affine(n, 1.0, 0.8, 0.1, 0.25, 1);
        let sol = solve(&heights, 1.0 / n as f64, rubber, 0.0105, SolverOptions { tol: 1e-8, ..Default::default() }).unwrap();
        assert!(sol.converged);
        counts.push(sol.iterations as f64);
    }
    // Unpreconditioned Polonsky-Keer grows about as N^1.1 here (4x per 4x in N).
    let growth = (counts[2] / counts[0]).ln() / 16f64.ln();
    assert!(growth <= 0.5, "iterations {counts:?} grow as N^{growth:.2}");
    assert!(counts[2] <= 100.0, "iterations {counts:?}");
}

/// Loose tolerances (the bulk job's model grids) steer the line solver in single precision; tight
/// ones (the pilots' references) not at all; either way the answer meets tol on a double-precision
/// product computed here, independently of the solver's own check.
#[test]
fn single_precision_steers_loose_line_solves_and_never_tight_ones() {
    use roadtex::compliance::PeriodicCompliance;
    use roadtex::kernel::KernelKind;
    use roadtex::solver::{ContactSolver, Workspace};
    let (n, length) = (4000usize, 0.5);
    let dx = length / n as f64;
    let heights = self_affine(n, length, 0.8, 0.2, 0.25, 7);
    for tol in [1e-3, 1e-4, 1e-8] {
        let solver = ContactSolver::new(n, dx, SolverOptions { tol, ..Default::default() }).unwrap();
        let mut workspace = Workspace::default();
        let solution = solver.solve_in(&mut workspace, &heights, RUBBER(), 2e5).unwrap();
        assert!(solution.converged, "tol {tol}: residual {}", solution.residual);
        let (low, all) = (workspace.low_precision_pairs(), workspace.fft_pairs());
        if tol >= 1e-5 {
            assert!(low > 0 && low < all, "tol {tol}: {low} single-precision pairs of {all}");
        } else {
            assert_eq!(low, 0, "tol {tol}: {low} single-precision pairs of {all}");
        }
        let op = PeriodicCompliance::new(n, dx, KernelKind::Element);
        let residual = common::recomputed_residual(&op, &heights, &solution.pressure, RUBBER().plane_strain_modulus());
        assert!(residual <= tol, "tol {tol}: recomputed residual {residual:e} (solver: {:e})", solution.residual);
    }
}

/// A crowded line (more than 128 contact runs on at most 8,192 points, as cement concrete's model
/// grids are) solved at the loose tolerances that give it a smaller coarse space than one vector a
/// run (`cg::space_size::CROWDED_DIM`): the answer still meets tol on a product computed here.
#[test]
fn crowded_lines_meet_loose_tolerances_on_their_smaller_coarse_space() {
    use roadtex::compliance::PeriodicCompliance;
    use roadtex::kernel::KernelKind;
    use roadtex::solver::{ContactSolver, Workspace};
    let (n, length) = (4000usize, 0.5);
    let dx = length / n as f64;
    // 300 stones of 1.7 mm under a rough texture: one run of contact on nearly every stone.
    let texture = self_affine(n, length, 0.8, 0.05, 0.25, 11);
    let heights: Vec<f64> =
        (0..n).map(|i| 1e-4 * (2.0 * std::f64::consts::PI * 300.0 * i as f64 / n as f64).cos() + 0.2 * texture[i]).collect();
    for tol in [1e-3, 1e-4] {
        let solver = ContactSolver::new(n, dx, SolverOptions { tol, ..Default::default() }).unwrap();
        let solution = solver.solve_in(&mut Workspace::default(), &heights, RUBBER(), 2e5).unwrap();
        assert!(solution.converged, "tol {tol}: residual {}", solution.residual);
        let contact: Vec<bool> = solution.pressure.iter().map(|&p| p > 0.0).collect();
        let runs = (0..n).filter(|&i| contact[i] && !contact[(i + n - 1) % n]).count();
        assert!(runs > 128, "tol {tol}: {runs} runs of contact, not a crowded set");
        let op = PeriodicCompliance::new(n, dx, KernelKind::Element);
        let residual = common::recomputed_residual(&op, &heights, &solution.pressure, RUBBER().plane_strain_modulus());
        assert!(residual <= tol, "tol {tol}: recomputed residual {residual:e} (solver: {:e})", solution.residual);
    }
}
