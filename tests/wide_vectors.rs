//! The solver's own loops run in AVX2 copies where the CPU has AVX2 and in baseline x86-64
//! copies elsewhere (`solver::wide`): the same code, so both must give the same bits. Each test
//! runs both paths in one process and compares every bit of the results; one also checks the
//! answer against the dense direct solve.

use std::sync::Mutex;

use roadtex::solver::{set_wide_vectors, wide_vectors, ContactSolution, ContactSolver, Material, Method, Workspace};
use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{solve_surfaces, Grid};
use roadtex::synthetic::self_affine;
use roadtex::{KernelKind, SolverOptions};

/// The switch is process-wide: the tests of this file take turns with it.
static SWITCH: Mutex<()> = Mutex::new(());

/// `run` with the AVX2 copies (where the CPU has them), then with the baseline ones.
fn both_paths<T>(run: impl Fn() -> T) -> (T, T) {
    let _turn = SWITCH.lock().unwrap_or_else(|e| e.into_inner());
    set_wide_vectors(true);
    #[cfg(target_arch = "x86_64")]
    assert_eq!(wide_vectors(), std::arch::is_x86_feature_detected!("avx2"));
    let wide = run();
    set_wide_vectors(false);
    assert!(!wide_vectors());
    let baseline = run();
    set_wide_vectors(true);
    (wide, baseline)
}

fn bits(solutions: &[ContactSolution]) -> Vec<(Vec<u64>, Vec<u64>, usize, u64)> {
    let to_bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    solutions.iter().map(|s| (to_bits(&s.pressure), to_bits(&s.envelope), s.iterations, s.residual.to_bits())).collect()
}

/// Road segments under four moduli, each warm-started from the last (the bulk job's unit of
/// work), for each kernel and model.
#[test]
fn road_segments_give_the_same_bits_on_both_paths() {
    let (n, dx) = (1000usize, 5e-4);
    let profiles: Vec<Vec<f64>> = (0..3).map(|seed| self_affine(n, n as f64 * dx, 0.8, 0.1, 0.25, seed)).collect();
    let cases = [(true, KernelKind::Element), (true, KernelKind::Spectral), (false, KernelKind::Element)];
    for (periodic, kernel) in cases {
        let options = SolverOptions { periodic, kernel, tol: 1e-8, ..Default::default() };
        let solver = ContactSolver::new(n, dx, options).unwrap();
        let solve_all = || {
            let mut workspace = Workspace::default();
            let mut out = Vec::new();
            for heights in &profiles {
                let mut previous: Option<Vec<f64>> = None;
                for e in [1e6, 2e6, 5e6, 1e7] {
                    let sol = solver.solve_from(&mut workspace, heights, Material::new(e, 0.5).unwrap(), 2e5, previous.as_deref()).unwrap();
                    assert!(sol.converged && sol.residual <= 1e-8);
                    previous = Some(sol.pressure.clone());
                    out.push(sol);
                }
            }
            out
        };
        let (wide, baseline) = both_paths(solve_all);
        assert_eq!(bits(&wide), bits(&baseline), "periodic={periodic} {kernel:?}");
        if periodic && kernel == KernelKind::Element {
            // And the answer itself, against the dense active-set solve of the same discrete model.
            let direct = ContactSolver::new(n, dx, SolverOptions { method: Method::Direct, tol: 1e-12, ..options }).unwrap();
            let exact = direct.solve(&profiles[0], Material::new(1e6, 0.5).unwrap(), 2e5).unwrap();
            let worst = wide[0].pressure.iter().zip(&exact.pressure).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
            assert!(worst / 2e5 < 1e-4, "max |p - p_direct| / P = {worst:e}");
        }
    }
}

/// A longer profile whose many islands are grouped in the coarse space, and a surface (the
/// areal solver shares the vector passes).
#[test]
fn grouped_coarse_spaces_and_surfaces_give_the_same_bits_on_both_paths() {
    let n = 1 << 15;
    let heights = self_affine(n, 1.0, 0.8, 0.1, 0.25, 1);
    let solver = ContactSolver::new(n, 1.0 / n as f64, SolverOptions { tol: 1e-8, ..Default::default() }).unwrap();
    let (wide, baseline) = both_paths(|| vec![solver.solve(&heights, Material::new(0.75, 0.5).unwrap(), 0.0105).unwrap()]);
    assert!(wide[0].converged && wide[0].residual <= 1e-8);
    assert_eq!(bits(&wide), bits(&baseline));

    let side = 96;
    let grid = Grid { ny: side, nx: side, dx: 1.0 / side as f64, dy: 1.0 / side as f64 };
    let tiles = self_affine_surface(side, 1.0, 0.8, 0.1, 4);
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    let (wide, baseline) = both_paths(|| solve_surfaces(&tiles, grid, &[0.75], 0.5, 0.01, options, Some(1), false).unwrap());
    assert!(wide[0].converged && wide[0].residual <= 1e-8);
    assert_eq!(wide, baseline);
    assert_eq!(
        wide[0].pressure.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        baseline[0].pressure.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
}
