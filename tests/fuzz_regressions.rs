//! Regression tests from fuzzing the core (`bash scripts/fuzz.sh`, targets in `fuzz/`).
//!
//! Each problem goes through the fuzz targets' own checker, `fuzz/src/check.rs` (included here):
//! finite values, p >= 0, mean(p) = P, envelope >= heights and == heights on contact, converged
//! only if residual <= tol, and, when converged, the contact conditions on the elastic surface
//! recomputed with a dense O(N^2) sum of the influence coefficients.
//!
//! A known bug, while open, is pinned as a test that asserts it is still there (the Rust analogue
//! of a strict xfail); when fixed, the test turns positive. None is open: F1 and F2 are fixed (the
//! core refuses magnitudes it cannot carry).
//!
//! To add a crash found by `cargo fuzz run <target>`: read its input with
//! `ROADTEX_FUZZ_SHOW=1 cargo +nightly fuzz run -s none <target> fuzz/artifacts/<target>/<file>`, which
//! prints the `Problem`, and write it here as a test calling `must_hold`.

#[path = "../fuzz/src/check.rs"]
mod check;

use check::{check_solution, solve, solve_and_check, Problem};
use roadtex::kernel::{periodic_coefficients, periodic_spectrum};
use roadtex::solver::{Method, SolverOptions};
use roadtex::{ContactError, KernelKind};

fn options(periodic: bool, kernel: KernelKind, method: Method, tol: f64, max_iterations: usize) -> SolverOptions {
    SolverOptions { periodic, kernel, method, tol, max_iterations }
}

fn cg(tol: f64) -> SolverOptions {
    options(true, KernelKind::Element, Method::ConjugateGradient, tol, 2000)
}

fn problem(heights: Vec<f64>, dx: f64, youngs_modulus: f64, mean_pressure: f64, options: SolverOptions) -> Problem {
    Problem { heights, dx, youngs_modulus, poisson: 0.5, mean_pressure, options }
}

/// The promise: an error, or a result that passes every check. Returns the solution, if any.
fn must_hold(p: &Problem) -> Option<roadtex::ContactSolution> {
    match solve_and_check(p) {
        Ok(solution) => solution,
        Err(broken) => panic!("{broken}\nproblem: {p:?}"),
    }
}

fn wavy(n: usize, amplitude: f64) -> Vec<f64> {
    (0..n).map(|i| amplitude * ((i as f64 * 0.7).cos() + 0.3 * (i as f64 * 2.1).sin())).collect()
}

// ------------------------------------------------------------------------------------------------
// F1 and F2: inputs of absurd magnitude, now refused with a clear error

fn refused(p: &Problem, what: &str) {
    match solve(p) {
        Err(ContactError::InvalidInput(message)) => assert!(message.contains(what), "{message}"),
        other => panic!("expected a refusal naming {what}, got {:?}", other.map(|s| s.converged)),
    }
}

/// F1, found by `contact_raw`: heights spanning 1e160 m made the CG sums overflow and the
/// pressure come back NaN flagged converged (residual 0). Now refused: heights beyond 1e40 m.
#[test]
fn f1_huge_height_span_is_refused() {
    let mut heights = vec![0.0; 64];
    heights[1] = -1e160;
    refused(&problem(heights, 1e-4, 2.5e6, 2e5, cg(1e-10)), "heights reach");
}

/// F1, second form: dx = 1e-300 m with E = 1 Pa, P = 1e-300 Pa gave zero pressure everywhere,
/// flagged converged. Now refused: dx outside 1e+-40 m.
#[test]
fn f1_tiny_magnitudes_are_refused() {
    refused(&problem(wavy(64, 1e-4), 1e-300, 1.0, 1e-300, cg(1e-8)), "dx");
}

/// F2: the same input to the dense direct solve failed with DirectSolverFailed; now refused.
#[test]
fn f2_direct_solve_on_tiny_magnitudes_is_refused() {
    let mut p = problem(wavy(64, 1e-4), 1e-300, 1.0, 1e-300, cg(1e-8));
    p.options.method = Method::Direct;
    refused(&p, "dx");
}

/// Each magnitude within range but their ratio beyond: P / E* = 1e80 is refused, not solved wrong.
#[test]
fn extreme_strain_is_refused() {
    refused(&problem(wavy(32, 1.0), 1.0, 1e-40, 1e40, cg(1e-8)), "mean_pressure / E*");
}

/// Up to 1e+-40 in every magnitude, every combination is solved correctly or, where P / E* or
/// P L / E* pass 1e+-60, refused: heights (|z| <= 1e40), dx, E and P at 1e-40, 1e-4, 1, 1e40.
#[test]
fn magnitudes_within_1e40_all_hold() {
    let levels = [1e-40, 1e-4, 1.0, 1e40];
    let mut solved = 0;
    for &scale in &levels {
        for &dx in &levels {
            for &e in &levels {
                for &pressure in &levels {
                    for method in [Method::ConjugateGradient, Method::Direct] {
                        // wavy peaks at 1.3 times its amplitude: keep |z| within 1e40.
                        let p = problem(wavy(32, scale / 1.3), dx, e, pressure, options(true, KernelKind::Element, method, 1e-8, 500));
                        // Refused (P / E* or P L / E* beyond 1e60) or solved and checked.
                        solved += must_hold(&p).is_some() as usize;
                    }
                }
            }
        }
    }
    assert!(solved > 300, "{solved} solved");
}

// ------------------------------------------------------------------------------------------------
// what the shaped fuzz target met: honest non-convergence, flat profiles, spikes

/// Slow units of `contact_shaped`: a flat profile, finite model, P / E* = 1e4 (very soft rubber),
/// tol 1e-15, which double precision cannot reach. The solver must stop at max_iterations and
/// say so (converged false, residual > tol), with a valid pressure.
#[test]
fn unreachable_tolerance_is_reported_not_converged() {
    let mut p = problem(vec![-100.0; 1000], 10.0, 100.0, 1e6, cg(1e-15));
    p.options.periodic = false;
    p.options.max_iterations = 200;
    let solution = must_hold(&p).expect("accepted");
    assert!(!solution.converged && solution.residual > 1e-15 && solution.iterations <= 200);
}

/// Flat profiles on every model, kernel and method: uniform pressure (periodic) and converged.
#[test]
fn flat_profiles_hold_on_every_model() {
    for (periodic, kernel, method) in [
        (true, KernelKind::Element, Method::ConjugateGradient),
        (true, KernelKind::Spectral, Method::ConjugateGradient),
        (false, KernelKind::Element, Method::ConjugateGradient),
        (true, KernelKind::Element, Method::Direct),
        (false, KernelKind::Element, Method::Direct),
    ] {
        for n in [8, 9, 257] {
            let p = problem(vec![350.0; n], 5e-5, 2.5e6, 2e5, options(periodic, kernel, method, 1e-10, 2000));
            let s = must_hold(&p).expect("accepted");
            assert!(s.converged, "{periodic} {kernel:?} {method:?} n {n}");
            if periodic {
                assert!(s.pressure.iter().all(|&q| (q / 2e5 - 1.0).abs() <= 1e-12));
            }
        }
    }
}

/// One raised element on a flat profile, from soft to rigid rubber, both models and methods:
/// every answer holds; with rigid rubber the spike alone carries N P.
#[test]
fn single_spike_from_soft_to_rigid_rubber() {
    let n = 256;
    for e in [1e2, 1e4, 1e6, 1e8, 1e10, 1e13] {
        for method in [Method::ConjugateGradient, Method::Direct] {
            for periodic in [true, false] {
                let mut heights = vec![0.0; n];
                heights[77] = 1e-3;
                let p = problem(heights, 1e-4, e, 2e5, options(periodic, KernelKind::Element, method, 1e-10, 2000));
                let s = must_hold(&p).expect("accepted");
                if e >= 1e10 {
                    assert_eq!(s.pressure.iter().filter(|&&q| q > 0.0).count(), 1);
                    assert!((s.pressure[77] / (n as f64 * 2e5) - 1.0).abs() <= 1e-12);
                }
            }
        }
    }
}

/// Plateaus, steps and pores (the shaped target's blocks) with every tolerance from 1e-1 to
/// 1e-13, a few iteration caps, both models: an honest answer each time.
#[test]
fn blocks_at_every_tolerance() {
    let n = 300;
    let heights: Vec<f64> = (0..n)
        .map(|i| match i {
            0..=39 => 0.0,
            40..=99 => 2e-4,
            100 => -5e-3,
            101..=179 => 1e-4 * (i as f64 * 0.3).sin(),
            180..=189 => 3e-3,
            _ => -1e-4 * (i / 17) as f64,
        })
        .collect();
    for exponent in 1..=13 {
        for max_iterations in [1, 7, 2000] {
            for periodic in [true, false] {
                let opts = options(periodic, KernelKind::Element, Method::ConjugateGradient, 10f64.powi(-exponent), max_iterations);
                must_hold(&problem(heights.clone(), 5e-5, 2.5e6, 2e5, opts));
            }
        }
    }
}

// ------------------------------------------------------------------------------------------------
// the checker itself

/// The checker's inverse DFT (used to build the spectral kernel's column) gives back the real-space
/// element coefficients from the element spectrum, for even and odd N.
#[test]
fn checker_builds_kernel_columns_right() {
    for n in [8, 9, 64, 101] {
        let dx = 1e-4;
        let lambda = periodic_spectrum(n, dx, KernelKind::Element);
        let column = periodic_coefficients(n, dx);
        let scale = column.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (k, &c) in column.iter().enumerate() {
            let mut sum = lambda[0];
            for (q, &l) in lambda.iter().enumerate().skip(1) {
                let weight = if 2 * q == n { 1.0 } else { 2.0 };
                sum += weight * l * (2.0 * std::f64::consts::PI * ((q * k) % n) as f64 / n as f64).cos();
            }
            assert!((sum / n as f64 - c).abs() <= 1e-12 * scale, "n {n} k {k}");
        }
    }
}

/// The checker notices a wrong answer: moving 1e-6 of the load between two contact elements of a
/// converged solution breaks the contact conditions.
#[test]
fn checker_catches_a_slightly_wrong_pressure() {
    let p = problem(wavy(256, 1e-4), 1e-4, 2.5e6, 2e5, cg(1e-10));
    let mut s = must_hold(&p).expect("accepted");
    let on: Vec<usize> = (0..256).filter(|&i| s.pressure[i] > 0.0).collect();
    assert!(on.len() > 2);
    s.pressure[on[0]] += 1e-6 * 2e5;
    s.pressure[on[on.len() / 2]] -= 1e-6 * 2e5;
    assert!(check_solution(&p, &s).is_err());
}
