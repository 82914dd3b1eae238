//! Warm starts across moduli (`roadtex::continuation`): a chain of stiffer rubbers, each solve
//! started from the last one's pressure shifted down to the new mean strain, must land where the
//! dense direct solve lands (the independent check: no FFT, no warm start), and must need fewer
//! CG iterations than a chain started from the previous pressure as it is.

use roadtex::continuation::next_modulus_guess;
use roadtex::solver::{ContactSolver, Material, Method, SolverOptions, Workspace};
use roadtex::synthetic::self_affine;

const MODULI: [f64; 4] = [1e6, 2e6, 5e6, 1e7];
const MEAN_PRESSURE: f64 = 2e5;

/// Iterations of each modulus's solve, and the pressures, of one warm chain.
fn chain(solver: &ContactSolver, heights: &[f64], shifted: bool) -> (Vec<usize>, Vec<Vec<f64>>) {
    let rubbers: Vec<Material> = MODULI.iter().map(|&e| Material::new(e, 0.5).unwrap()).collect();
    let mut workspace = Workspace::default();
    let (mut iterations, mut pressures) = (Vec::new(), Vec::<Vec<f64>>::new());
    for (m, &rubber) in rubbers.iter().enumerate() {
        let guess = pressures.last().map(|p| if shifted { next_modulus_guess(p, rubbers[m - 1], rubber) } else { p.clone() });
        let solution = solver.solve_from(&mut workspace, heights, rubber, MEAN_PRESSURE, guess.as_deref()).unwrap();
        assert!(solution.converged, "E = {}", MODULI[m]);
        iterations.push(solution.iterations);
        pressures.push(solution.pressure);
    }
    (iterations, pressures)
}

#[test]
fn a_shifted_warm_chain_lands_on_the_dense_solution() {
    let (n, dx) = (512, 1e-3);
    let cg = ContactSolver::new(n, dx, SolverOptions { tol: 1e-10, ..Default::default() }).unwrap();
    let direct = ContactSolver::new(n, dx, SolverOptions { tol: 1e-10, method: Method::Direct, ..Default::default() }).unwrap();
    for seed in [2u64, 9] {
        let heights = self_affine(n, n as f64 * dx, 0.8, 0.2, 0.25, seed);
        let (_, pressures) = chain(&cg, &heights, true);
        for (&e, pressure) in MODULI.iter().zip(&pressures) {
            let exact = direct.solve(&heights, Material::new(e, 0.5).unwrap(), MEAN_PRESSURE).unwrap();
            let worst = pressure.iter().zip(&exact.pressure).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(worst / MEAN_PRESSURE < 1e-7, "seed {seed}, E = {e}: max |p - p_direct| / P = {worst:e}");
        }
    }
}

#[test]
fn the_shifted_guess_saves_iterations_on_road_segments() {
    // The bulk job's unit of work: 0.5 m at 0.5 mm, four moduli in rising order, tol 1e-6.
    let (n, dx) = (1000, 5e-4);
    let solver = ContactSolver::new(n, dx, SolverOptions { tol: 1e-6, ..Default::default() }).unwrap();
    let (mut plain, mut shifted) = (0, 0);
    for seed in 0..16u64 {
        let heights = self_affine(n, n as f64 * dx, 0.8, 0.1, 0.25, seed);
        // The first modulus starts cold in both chains: only the later ones can differ.
        plain += chain(&solver, &heights, false).0[1..].iter().sum::<usize>();
        shifted += chain(&solver, &heights, true).0[1..].iter().sum::<usize>();
    }
    assert!((shifted as f64) < 0.95 * plain as f64, "shifted {shifted} against plain {plain} iterations");
}

/// `batch::solve_many_from`: every (segment, modulus) problem from its own start (here the answer
/// of a neighbouring road: the profile smoothed) lands on the dense direct solution of its own
/// profile, bitwise the same on 1 and 3 threads; starts of the wrong size or sign are refused.
#[test]
fn every_problem_from_its_own_start_lands_on_the_dense_solution() {
    use roadtex::batch::{solve_many, solve_many_from, Segments};
    let (n, dx) = (512, 1e-3);
    let options = SolverOptions { tol: 1e-10, ..Default::default() };
    let rows: Vec<Vec<f64>> = [4u64, 7].iter().map(|&seed| self_affine(n, n as f64 * dx, 0.8, 0.2, 0.25, seed)).collect();
    let heights: Vec<f64> = rows.concat();
    // the neighbouring road: each profile averaged over three points (periodic)
    let smoothed: Vec<f64> = rows.iter().flat_map(|r| (0..n).map(move |i| (r[(i + n - 1) % n] + r[i] + r[(i + 1) % n]) / 3.0)).collect();
    let segments = Segments { heights: &heights, len: n };
    let neighbour =
        solve_many(Segments { heights: &smoothed, len: n }, dx, &MODULI, 0.5, MEAN_PRESSURE, options, Some(1), true, None).unwrap();
    let start: Vec<f64> = neighbour.iter().flat_map(|s| s.pressure.iter().copied()).collect();
    let one = solve_many_from(segments, dx, &MODULI, 0.5, MEAN_PRESSURE, options, Some(1), &start).unwrap();
    let three = solve_many_from(segments, dx, &MODULI, 0.5, MEAN_PRESSURE, options, Some(3), &start).unwrap();
    let direct = ContactSolver::new(n, dx, SolverOptions { tol: 1e-10, method: Method::Direct, ..Default::default() }).unwrap();
    for (job, (a, b)) in one.iter().zip(&three).enumerate() {
        assert_eq!(a.pressure, b.pressure, "problem {job}: thread count changed the result");
        let (s, m) = (job / MODULI.len(), job % MODULI.len());
        let exact = direct.solve(&rows[s], Material::new(MODULI[m], 0.5).unwrap(), MEAN_PRESSURE).unwrap();
        let worst = a.pressure.iter().zip(&exact.pressure).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(a.converged && worst / MEAN_PRESSURE < 1e-7, "problem {job}: max |p - p_direct| / P = {worst:e}");
    }
    let short = solve_many_from(segments, dx, &MODULI, 0.5, MEAN_PRESSURE, options, Some(1), &start[1..]);
    assert!(short.unwrap_err().to_string().contains("initial_pressure holds 4095 values, the problems need 4096"));
    let mut negative = start.clone();
    negative[5] = -1.0;
    let refused = solve_many_from(segments, dx, &MODULI, 0.5, MEAN_PRESSURE, options, Some(1), &negative);
    assert!(refused.unwrap_err().to_string().contains("value 5 is -1"));
}
