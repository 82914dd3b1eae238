//! The nested (coarse-to-fine) initial guess of large cold CG solves (`solver::nested`): the answer
//! meets the same stopping rule and is as close to the dense direct solve (the independent check,
//! no FFT) as a cold start's; the path is really taken, only for even N, never for a warm start;
//! and a warm start whose guess already meets tol returns at once.

use roadtex::solver::{nested, ContactSolver, Material, Method, SolverOptions, Workspace};
use roadtex::synthetic::self_affine;

fn max_relative_difference(a: &[f64], b: &[f64], scale: f64) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

#[test]
fn nested_solves_agree_with_the_dense_direct_solve_as_cold_ones_do() {
    let (length, pressure) = (0.1, 2e5);
    let rubber = Material::new(2.5e6, 0.5).unwrap();
    for periodic in [true, false] {
        for (n, seed) in [(2048usize, 3u64), (4096, 4)] {
            let heights = self_affine(n, length, 0.8, 0.2, 0.25, seed);
            let dx = length / n as f64;
            let direct = ContactSolver::new(n, dx, SolverOptions { periodic, method: Method::Direct, tol: 1e-12, ..Default::default() })
                .unwrap()
                .solve(&heights, rubber, pressure)
                .unwrap();
            assert!(direct.converged);
            for (tol, bound) in [(1e-12, 1e-8), (1e-8, 1e-4)] {
                let options = SolverOptions { periodic, tol, ..Default::default() };
                // Nested from 512 points on: n -> n/2 -> ... -> 256, solved cold.
                let nested = ContactSolver::new(n, dx, options).unwrap().with_nested_min_elements(512);
                let cold = ContactSolver::new(n, dx, options).unwrap().with_nested_min_elements(usize::MAX);
                let mut workspace = Workspace::default();
                let a = nested.solve_in(&mut workspace, &heights, rubber, pressure).unwrap();
                let levels = workspace.nested_levels();
                let b = cold.solve_in(&mut workspace, &heights, rubber, pressure).unwrap();
                assert_eq!(levels, (n / 512).trailing_zeros() as usize + 1, "n={n}: levels");
                assert_eq!(workspace.nested_levels(), 0);
                assert!(a.converged && a.residual <= tol && b.converged && b.residual <= tol);
                let (da, db) = (
                    max_relative_difference(&a.pressure, &direct.pressure, pressure),
                    max_relative_difference(&b.pressure, &direct.pressure, pressure),
                );
                let label = format!("periodic={periodic} n={n} tol={tol:e}: max|dp|/P nested {da:e}, cold {db:e}");
                println!("{label}; iterations nested {} cold {}", a.iterations, b.iterations);
                assert!(da <= bound && db <= bound, "{label}");
                // As close as a cold start: within the same bound, and not far from its error.
                assert!(da <= 10.0 * db.max(bound / 100.0), "{label}");
                // The coarse levels leave the fine one less to do.
                assert!(a.iterations < b.iterations, "{label}: iterations nested {} cold {}", a.iterations, b.iterations);
            }
        }
    }
}

#[test]
fn only_even_levels_are_halved_and_warm_starts_keep_their_guess() {
    let rubber = Material::new(2.5e6, 0.5).unwrap();
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    // 2,018 = 2 x 1,009: one level (1,009 is odd, solved cold); 1,009: none.
    for (n, levels) in [(2018usize, 1usize), (1009, 0), (2048, 3)] {
        let heights = self_affine(n, 0.1, 0.8, 0.2, 0.25, 7);
        let solver = ContactSolver::new(n, 0.1 / n as f64, options).unwrap().with_nested_min_elements(512);
        let mut workspace = Workspace::default();
        let cold = solver.solve_in(&mut workspace, &heights, rubber, 2e5).unwrap();
        assert!(cold.converged && cold.residual <= 1e-8);
        assert_eq!(workspace.nested_levels(), levels, "n={n}");
        // A warm start (the next modulus) starts from its guess, not from the coarser levels.
        let stiffer = Material::new(5e6, 0.5).unwrap();
        let warm = solver.solve_from(&mut workspace, &heights, stiffer, 2e5, Some(&cold.pressure)).unwrap();
        assert!(warm.converged && warm.residual <= 1e-8);
        assert_eq!(workspace.nested_levels(), 0, "n={n}");
    }
}

#[test]
fn a_guess_that_meets_tol_is_returned_without_iterations() {
    let n = 4096;
    let heights = self_affine(n, 0.1, 0.8, 0.2, 0.25, 11);
    let rubber = Material::new(2.5e6, 0.5).unwrap();
    let solver = ContactSolver::new(n, 0.1 / n as f64, SolverOptions { tol: 1e-8, ..Default::default() }).unwrap();
    let first = solver.solve(&heights, rubber, 2e5).unwrap();
    assert!(first.converged && first.iterations > 0);
    let mut workspace = Workspace::default();
    let again = solver.solve_from(&mut workspace, &heights, rubber, 2e5, Some(&first.pressure)).unwrap();
    assert!(again.converged && again.residual <= 1e-8);
    assert_eq!(again.iterations, 0);
    // One product to check the guess, no more.
    assert_eq!(workspace.fft_pairs(), 1);
    assert!(max_relative_difference(&again.pressure, &first.pressure, 2e5) <= 1e-12);
}

#[test]
fn nested_solves_give_the_same_bits_on_one_and_two_threads() {
    // 2^17 points: the vector passes run in parallel blocks (`solver::reduce`) and the solve nests
    // by default (down to half of nested::NESTED_MIN_ELEMENTS, solved cold).
    let n = 1 << 17;
    let heights = self_affine(n, 1.0, 0.8, 0.1, 0.25, 2);
    let rubber = Material::new(0.75, 0.5).unwrap();
    let solver = ContactSolver::new(n, 1.0 / n as f64, SolverOptions { tol: 1e-8, ..Default::default() }).unwrap();
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut workspace = Workspace::default();
            let solution = solver.solve_in(&mut workspace, &heights, rubber, 0.0105).unwrap();
            (solution, workspace.nested_levels())
        })
    };
    let (one, two) = (on(1), on(2));
    assert_eq!(one.1, (n / nested::NESTED_MIN_ELEMENTS).trailing_zeros() as usize + 1);
    assert_eq!(one, two);
    assert!(one.0.converged && one.0.residual <= 1e-8);
}
