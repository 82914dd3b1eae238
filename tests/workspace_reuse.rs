//! A workspace carries work vectors and the last solve's coarse space from one solve to the next:
//! what it held must never change a result (Python's determinism tests check the same through
//! `contact_many`, across thread counts; this checks it directly, solve by solve).

use roadtex::solver::{ContactSolver, Material, SolverOptions, Workspace};
use roadtex::synthetic::self_affine;

#[test]
fn a_used_workspace_gives_the_bits_of_a_fresh_one() {
    let (n, dx) = (1000, 5e-4);
    let solver = ContactSolver::new(n, dx, SolverOptions { tol: 1e-8, ..Default::default() }).unwrap();
    let moduli = [1e6, 2e6, 5e6, 1e7];
    // Segment 2 repeats segment 0, so a coarse space kept from segment 0 matches segment 2's sets.
    let profiles: Vec<Vec<f64>> = [3u64, 8, 3, 21].iter().map(|&seed| self_affine(n, n as f64 * dx, 0.8, 0.2, 0.25, seed)).collect();
    let mut shared = Workspace::default();
    for heights in &profiles {
        let mut previous: Option<Vec<f64>> = None;
        for &e in &moduli {
            let rubber = Material::new(e, 0.5).unwrap();
            let reused = solver.solve_from(&mut shared, heights, rubber, 2e5, previous.as_deref()).unwrap();
            let fresh = solver.solve_from(&mut Workspace::default(), heights, rubber, 2e5, previous.as_deref()).unwrap();
            assert!(reused.converged && reused.residual <= 1e-8, "E = {e}: residual {}", reused.residual);
            assert_eq!(reused, fresh, "E = {e}: the used workspace changed the result");
            previous = Some(reused.pressure);
        }
    }
}

#[test]
fn a_workspace_moved_between_solvers_of_the_same_size_changes_nothing() {
    // Same N, another dx: the kernel sums differ, so nothing built for one solver may serve the other.
    let n = 1000;
    let heights = self_affine(n, 0.5, 0.8, 0.2, 0.25, 5);
    let rubber = Material::new(2.5e6, 0.5).unwrap();
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    let (a, b) = (ContactSolver::new(n, 5e-4, options).unwrap(), ContactSolver::new(n, 2.5e-4, options).unwrap());
    let mut shared = Workspace::default();
    let from_a = a.solve_from(&mut shared, &heights, rubber, 2e5, None).unwrap();
    let warm_b = b.solve_from(&mut shared, &heights, rubber, 2e5, Some(&from_a.pressure)).unwrap();
    let fresh_b = b.solve_from(&mut Workspace::default(), &heights, rubber, 2e5, Some(&from_a.pressure)).unwrap();
    assert_eq!(warm_b, fresh_b);
}
