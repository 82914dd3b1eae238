//! The nested (coarse-to-fine) initial guess of cold surface solves (`SurfaceSolver`, 2 x 2 blocks
//! via `solver::nested`): the answer meets the same stopping rule and is as close to the dense
//! direct solve (the independent check, no FFT) as a cold start's; the levels are really taken,
//! odd sides are kept, warm starts keep their guess; the same bits on one and two threads.

use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{Grid, SurfaceSolver, SurfaceWorkspace, NESTED_MIN_POINTS};
use roadtex::{KernelKind, Material, Method, SolverOptions};

fn max_relative_difference(a: &[f64], b: &[f64], scale: f64) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

/// The first `ny` rows of a periodic 64 x 64 self-affine surface (side 1 m, rms slope 0.1).
fn surface(ny: usize, seed: u64) -> Vec<f64> {
    self_affine_surface(64, 1.0, 0.8, 0.1, seed)[..ny * 64].to_vec()
}

// E = 0.75 and nu = 0.5: E* = 1; P = 0.01 touches about 20 % of these surfaces.
const P: f64 = 0.01;

fn rubber() -> Material {
    Material::new(0.75, 0.5).unwrap()
}

#[test]
fn nested_solves_agree_with_the_dense_direct_solve_as_cold_ones_do() {
    let cases = [(true, KernelKind::Element), (true, KernelKind::Spectral), (false, KernelKind::Element)];
    // 64 x 64: three levels (down to 8 x 8, solved cold); 45 x 64: the odd side kept, four levels.
    for (ny, seed, levels) in [(64usize, 3u64, 3usize), (45, 4, 4)] {
        let grid = Grid { ny, nx: 64, dx: 1.0 / 64.0, dy: 1.0 / 64.0 };
        let heights = surface(ny, seed);
        for (periodic, kernel) in cases {
            let direct_options = SolverOptions { periodic, kernel, method: Method::Direct, tol: 1e-12, ..Default::default() };
            let direct = SurfaceSolver::new(grid, direct_options).unwrap().solve(&heights, rubber(), P).unwrap();
            assert!(direct.converged);
            let fraction = direct.pressure.iter().filter(|&&p| p > 0.0).count() as f64 / grid.len() as f64;
            assert!((0.05..0.6).contains(&fraction), "contact fraction {fraction}");
            for (tol, bound) in [(1e-12, 1e-8), (1e-8, 1e-4)] {
                let options = SolverOptions { periodic, kernel, tol, ..Default::default() };
                let nested = SurfaceSolver::new(grid, options).unwrap().with_nested_min_points(256);
                let cold = SurfaceSolver::new(grid, options).unwrap().with_nested_min_points(usize::MAX);
                let mut workspace = SurfaceWorkspace::default();
                let a = nested.solve_from(&mut workspace, &heights, rubber(), P, None).unwrap();
                assert_eq!(workspace.nested_levels(), levels, "{ny} x 64: levels");
                // The coarser levels' pairs are counted, weighted by their share of the points.
                assert!(workspace.fft_pairs_equivalent() > workspace.fft_pairs() as f64);
                let b = cold.solve_from(&mut workspace, &heights, rubber(), P, None).unwrap();
                assert_eq!(workspace.nested_levels(), 0);
                assert!(a.converged && a.residual <= tol && b.converged && b.residual <= tol);
                let (da, db) =
                    (max_relative_difference(&a.pressure, &direct.pressure, P), max_relative_difference(&b.pressure, &direct.pressure, P));
                let label = format!("{ny} x 64 periodic={periodic} {kernel:?} tol={tol:e}: max|dp|/P nested {da:e}, cold {db:e}");
                println!("{label}; iterations nested {} cold {}", a.iterations, b.iterations);
                assert!(da <= bound && db <= bound, "{label}");
                assert!(da <= 10.0 * db.max(bound / 100.0), "{label}");
                // The coarser levels leave the fine one less to do.
                assert!(a.iterations < b.iterations, "{label}: iterations nested {} cold {}", a.iterations, b.iterations);
            }
        }
    }
}

#[test]
fn odd_sides_are_kept_and_warm_starts_keep_their_guess() {
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    // (rows, columns, threshold, levels): 2 x 2 blocks while both sides are even; an odd side is
    // kept; two odd sides or a grid below the threshold stop; 12 x 16 -> 6 x 8 -> 6 x 4 (6 would
    // fall below 4 points).
    let cases =
        [(32usize, 32usize, 256usize, 2usize), (33, 32, 256, 3), (32, 33, 256, 3), (33, 35, 64, 0), (12, 16, 16, 2), (32, 32, 2048, 0)];
    for (ny, nx, threshold, levels) in cases {
        let grid = Grid { ny, nx, dx: 1e-3, dy: 1.5e-3 };
        let heights: Vec<f64> =
            self_affine_surface(36, 0.036, 0.8, 0.1, 5).chunks(36).take(ny).flat_map(|row| row[..nx].to_vec()).collect();
        let solver = SurfaceSolver::new(grid, options).unwrap().with_nested_min_points(threshold);
        let mut workspace = SurfaceWorkspace::default();
        let cold = solver.solve_from(&mut workspace, &heights, Material::new(2.5e6, 0.5).unwrap(), 2e5, None).unwrap();
        assert!(cold.converged && cold.residual <= 1e-8, "{ny} x {nx}");
        assert_eq!(workspace.nested_levels(), levels, "{ny} x {nx}, threshold {threshold}");
        let stiffer = Material::new(5e6, 0.5).unwrap();
        let warm = solver.solve_from(&mut workspace, &heights, stiffer, 2e5, Some(&cold.pressure)).unwrap();
        assert!(warm.converged && warm.residual <= 1e-8);
        assert_eq!(workspace.nested_levels(), 0, "{ny} x {nx}: a warm start");
    }
}

#[test]
fn nested_surface_solves_give_the_same_bits_on_one_and_two_threads() {
    // 384^2 points: the transforms and the vector passes run on rayon, and the default threshold
    // nests 384^2 -> 192^2 -> 96^2 -> 48^2 (below NESTED_MIN_POINTS, solved cold).
    let n = 384;
    let grid = Grid { ny: n, nx: n, dx: 1.0 / n as f64, dy: 1.0 / n as f64 };
    let heights = self_affine_surface(n, 1.0, 0.8, 0.1, 2);
    let solver = SurfaceSolver::new(grid, SolverOptions { tol: 1e-8, ..Default::default() }).unwrap();
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut workspace = SurfaceWorkspace::default();
            let solution = solver.solve_from(&mut workspace, &heights, rubber(), P, None).unwrap();
            (solution, workspace.nested_levels(), workspace.fft_pairs())
        })
    };
    let (one, two) = (on(1), on(2));
    let (mut side, mut levels) = (n, 0);
    while side * side >= NESTED_MIN_POINTS {
        (side, levels) = (side / 2, levels + 1);
    }
    assert!(levels >= 2);
    assert_eq!(one.1, levels);
    assert_eq!(one, two);
    assert!(one.0.converged && one.0.residual <= 1e-8);
}

#[test]
fn warm_starts_with_bounded_steps_agree_with_the_dense_direct_solve() {
    // The job's chain: a softer rubber, then a stiffer one from its shifted pressure; with the
    // default bounded steps from the guess and with none (the sweeps straight from it).
    use roadtex::continuation::next_modulus_guess;
    let grid = Grid { ny: 48, nx: 64, dx: 1.0 / 64.0, dy: 1.0 / 64.0 };
    let heights = surface(48, 6);
    let (soft, stiff) = (Material::new(0.75, 0.5).unwrap(), Material::new(2.0, 0.5).unwrap());
    for periodic in [true, false] {
        let direct_options = SolverOptions { periodic, method: Method::Direct, tol: 1e-12, ..Default::default() };
        let direct = SurfaceSolver::new(grid, direct_options).unwrap().solve(&heights, stiff, P).unwrap();
        let options = SolverOptions { periodic, tol: 1e-12, ..Default::default() };
        for steps in [roadtex::surface::WARM_START_STEPS, 0] {
            let solver = SurfaceSolver::new(grid, options).unwrap().with_warm_start_steps(steps);
            let mut workspace = SurfaceWorkspace::default();
            let first = solver.solve_from(&mut workspace, &heights, soft, P, None).unwrap();
            let guess = next_modulus_guess(&first.pressure, soft, stiff);
            let warm = solver.solve_from(&mut workspace, &heights, stiff, P, Some(&guess)).unwrap();
            assert!(warm.converged && warm.residual <= 1e-12);
            let d = max_relative_difference(&warm.pressure, &direct.pressure, P);
            println!("periodic={periodic} steps={steps}: max|dp|/P {d:e}, {} iterations", warm.iterations);
            assert!(d <= 1e-8, "periodic={periodic} steps={steps}: max|dp|/P {d:e}");
        }
    }
}
