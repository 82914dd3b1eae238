//! The surface solver: CG against the dense direct solve, the flat and stiff limits, and
//! determinism of the parallel batch.

mod common;

use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{solve_surface, solve_surfaces, solve_surfaces_from, Grid, SurfaceSolver, SurfaceWorkspace};
use roadtex::{KernelKind, Material, Method, SolverOptions};

fn rough(ny: usize, nx: usize, seed: u64) -> Vec<f64> {
    let mut rng = roadtex::synthetic::SplitMix64::new(seed);
    (0..ny * nx).map(|_| 1e-4 * (rng.next_f64() - 0.5)).collect()
}

#[test]
fn cg_matches_direct_on_small_rough_surfaces() {
    let rubber = Material::new(4e6, 0.5).unwrap();
    for &(ny, nx) in &[(8usize, 8usize), (10, 14), (16, 16)] {
        let grid = Grid { ny, nx, dx: 1e-3, dy: 0.7e-3 };
        let z = rough(ny, nx, (ny * nx) as u64);
        for &(periodic, kernel) in &[(true, KernelKind::Element), (true, KernelKind::Spectral), (false, KernelKind::Element)] {
            let cg = SolverOptions { periodic, kernel, tol: 1e-12, ..Default::default() };
            let direct = SolverOptions { method: Method::Direct, ..cg };
            let a = solve_surface(&z, grid, rubber, 2e5, cg).unwrap();
            let b = solve_surface(&z, grid, rubber, 2e5, direct).unwrap();
            assert!(a.converged && b.converged);
            let worst = a.pressure.iter().zip(&b.pressure).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
            assert!(worst < 1e-9 * 2e5, "{ny}x{nx} periodic={periodic} {kernel:?}: {worst}");
        }
    }
}

#[test]
fn flat_surface_and_stiff_rubber_limits() {
    let grid = Grid { ny: 8, nx: 12, dx: 1e-3, dy: 2e-3 };
    let flat = vec![0.05; grid.len()];
    let sol = solve_surface(&flat, grid, Material::new(2.5e6, 0.5).unwrap(), 2e5, SolverOptions::default()).unwrap();
    assert!(sol.pressure.iter().all(|&p| (p - 2e5).abs() < 1e-9 * 2e5));
    let z = rough(8, 12, 3);
    let top = (0..z.len()).max_by(|&i, &j| z[i].total_cmp(&z[j])).unwrap();
    let sol = solve_surface(&z, grid, Material::new(1e13, 0.5).unwrap(), 2e5, SolverOptions::default()).unwrap();
    assert_eq!(sol.pressure.iter().filter(|&&p| p > 0.0).count(), 1);
    assert!((sol.pressure[top] / (2e5 * z.len() as f64) - 1.0).abs() < 1e-12);
}

#[test]
fn batch_is_bitwise_identical_whatever_the_thread_count() {
    let grid = Grid { ny: 64, nx: 64, dx: 1.0 / 64.0, dy: 1.0 / 64.0 };
    let tiles: Vec<f64> = (0..3).flat_map(|s| self_affine_surface(64, 1.0, 0.8, 0.1, s)).collect();
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    let moduli = [0.75, 1.5];
    let one = solve_surfaces(&tiles, grid, &moduli, 0.5, 0.01, options, Some(1), false).unwrap();
    let two = solve_surfaces(&tiles, grid, &moduli, 0.5, 0.01, options, Some(2), false).unwrap();
    assert_eq!(one, two);
    assert!(one.iter().all(|s| s.converged));
    let fraction = one[0].pressure.iter().filter(|&&p| p > 0.0).count() as f64 / grid.len() as f64;
    assert!((0.1..0.35).contains(&fraction), "{fraction}");
}

#[test]
fn batch_from_given_pressures_carries_a_looser_answer_on_and_checks_its_start() {
    let grid = Grid { ny: 64, nx: 64, dx: 1.0 / 64.0, dy: 1.0 / 64.0 };
    let tiles: Vec<f64> = (0..2).flat_map(|s| self_affine_surface(64, 1.0, 0.8, 0.1, s)).collect();
    let moduli = [0.75, 1.5];
    let loose = SolverOptions { tol: 1e-3, ..Default::default() };
    let tight = SolverOptions { tol: 1e-8, ..Default::default() };
    let first = solve_surfaces(&tiles, grid, &moduli, 0.5, 0.01, loose, Some(1), true).unwrap();
    let start: Vec<f64> = first.iter().flat_map(|s| s.pressure.iter().copied()).collect();
    let nested = solve_surfaces(&tiles, grid, &moduli, 0.5, 0.01, tight, Some(1), false).unwrap();
    let one = solve_surfaces_from(&tiles, grid, &moduli, 0.5, 0.01, tight, Some(1), &start).unwrap();
    let two = solve_surfaces_from(&tiles, grid, &moduli, 0.5, 0.01, tight, Some(2), &start).unwrap();
    assert_eq!(one, two);
    assert!(one.iter().all(|s| s.converged && s.residual <= 1e-8));
    let iterations = |v: &[roadtex::ContactSolution]| v.iter().map(|s| s.iterations).sum::<usize>();
    assert!(iterations(&one) < iterations(&nested), "{} against {}", iterations(&one), iterations(&nested));
    // a converged start is kept as it is
    let again: Vec<f64> = one.iter().flat_map(|s| s.pressure.iter().copied()).collect();
    let kept = solve_surfaces_from(&tiles, grid, &moduli, 0.5, 0.01, tight, Some(1), &again).unwrap();
    assert!(kept.iter().all(|s| s.iterations == 0));
    let short = solve_surfaces_from(&tiles, grid, &moduli, 0.5, 0.01, tight, None, &start[1..]);
    assert!(format!("{}", short.unwrap_err()).contains("initial_pressure holds"));
    let mut negative = start.clone();
    negative[7] = -1.0;
    let refused = solve_surfaces_from(&tiles, grid, &moduli, 0.5, 0.01, tight, None, &negative);
    assert!(format!("{}", refused.unwrap_err()).contains("value 7 is -1"));
}

#[test]
fn workspace_counts_the_transform_pairs_of_its_solves() {
    // Each CG iteration applies the preconditioner and C d (two 2-D FFT pairs), so a solve applies
    // at least two pairs per iteration; the counter adds up over the solves of one workspace.
    let grid = Grid { ny: 32, nx: 48, dx: 1e-3, dy: 1e-3 };
    let solver = SurfaceSolver::new(grid, SolverOptions { tol: 1e-10, ..Default::default() }).unwrap();
    let rubber = Material::new(4e6, 0.5).unwrap();
    let mut workspace = SurfaceWorkspace::default();
    assert_eq!(workspace.fft_pairs(), 0);
    let z = rough(32, 48, 11);
    let first = solver.solve_from(&mut workspace, &z, rubber, 2e5, None).unwrap();
    let after_one = workspace.fft_pairs();
    assert!(first.converged && first.iterations > 0);
    assert!(after_one >= 2 * first.iterations as u64, "{after_one} pairs for {} iterations", first.iterations);
    let second = solver.solve_from(&mut workspace, &z, rubber, 2e5, None).unwrap();
    assert_eq!(second, first);
    assert_eq!(workspace.fft_pairs(), 2 * after_one);
}

/// [`common::recomputed_residual`] with the solver's periodic operator.
fn recomputed_residual(solver: &SurfaceSolver, z: &[f64], pressure: &[f64], e_star: f64) -> f64 {
    common::recomputed_residual(solver.periodic_operator().unwrap(), z, pressure, e_star)
}

#[test]
fn single_precision_steers_the_iteration_and_double_precision_checks_it() {
    // Loose tolerances take every steering product in single precision, tight ones the
    // preconditioner's and the rough sweeps' only; either way the returned solution meets tol on a
    // double-precision product computed here, independently of the solver's own check.
    let grid = Grid { ny: 64, nx: 64, dx: 1e-3, dy: 1e-3 };
    let z: Vec<f64> = self_affine_surface(64, 0.064, 0.8, 0.1, 4).iter().map(|h| 0.01 * h).collect();
    let rubber = Material::new(4e6, 0.5).unwrap();
    let mut low_shares = Vec::new();
    for tol in [1e-4, 1e-8] {
        let solver = SurfaceSolver::new(grid, SolverOptions { tol, ..Default::default() }).unwrap();
        let mut workspace = SurfaceWorkspace::default();
        let solution = solver.solve_from(&mut workspace, &z, rubber, 2e5, None).unwrap();
        assert!(solution.converged);
        let (low, all) = (workspace.low_precision_pairs(), workspace.fft_pairs());
        assert!(low > 0 && low < all, "tol {tol}: {low} single-precision pairs of {all}");
        low_shares.push(low as f64 / all as f64);
        let residual = recomputed_residual(&solver, &z, &solution.pressure, rubber.plane_strain_modulus());
        assert!(residual <= tol, "tol {tol}: recomputed residual {residual:e} (solver: {:e})", solution.residual);
    }
    assert!(low_shares[0] > low_shares[1], "single-precision shares {low_shares:?}");
}
