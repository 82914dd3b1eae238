//! What every answer of the roadtex core must satisfy, checked independently of the solver.
//!
//! Shared by the fuzz targets (`fuzz/src/lib.rs`) and by the regression tests
//! (`tests/fuzz_regressions.rs`, which includes this file with `#[path]`). It uses only the public
//! API of the `roadtex` crate, so it keeps working while the solver's internals change.
//!
//! The contract (README, "What `tol` means"): a call either returns an error, or a solution with
//! finite values, p >= 0, mean(p) = P, envelope >= heights and == heights where p > 0, and
//! `converged` true only if `residual <= tol`. When it says converged, the pressure must really
//! solve the contact problem: the elastic surface u = C p / E* (C recomputed here from the
//! influence coefficients with a dense O(N^2) sum, no FFT) plus one rigid approach meets the
//! profile on the contact set and stays above it elsewhere, to the tolerance.

#![allow(dead_code)]
// A checker of numbers that may be NaN: every `!(a <= b)` here is meant to fail on NaN too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use roadtex::envelope::von_meier;
use roadtex::kernel::{finite_coefficients, periodic_coefficients, periodic_spectrum};
use roadtex::solver::{height_scale, validate_problem, ContactSolution, ContactSolver, Material, Method, SolverOptions};
use roadtex::{ContactError, KernelKind};

/// Largest N for which the dense independent check of a converged solution runs.
pub const DENSE_CHECK_MAX: usize = 1024;
/// Residual the dense direct solve is expected to reach when it reports convergence.
pub const DIRECT_RESIDUAL: f64 = 1e-9;

/// One contact problem, exactly as a caller of the Rust API would pose it.
#[derive(Clone, Debug)]
pub struct Problem {
    pub heights: Vec<f64>,
    pub dx: f64,
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub mean_pressure: f64,
    pub options: SolverOptions,
}

/// The public solve path of the Python binding and of `roadtex::solver::solve`.
pub fn solve(problem: &Problem) -> roadtex::Result<ContactSolution> {
    let material = Material::new(problem.youngs_modulus, problem.poisson)?;
    validate_problem(&problem.heights, problem.dx, problem.mean_pressure)?;
    ContactSolver::new(problem.heights.len(), problem.dx, problem.options)?.solve(&problem.heights, material, problem.mean_pressure)
}

/// Solves and checks; `Err` describes a broken promise (the fuzz targets panic on it).
pub fn solve_and_check(problem: &Problem) -> Result<Option<ContactSolution>, String> {
    match solve(problem) {
        Ok(solution) => match check_solution(problem, &solution) {
            Ok(()) => Ok(Some(solution)),
            Err(broken) => Err(format!(
                "{broken} (converged {}, residual {:e}, iterations {})",
                solution.converged, solution.residual, solution.iterations
            )),
        },
        Err(ContactError::InvalidInput(message)) => {
            if message.trim().is_empty() {
                Err("InvalidInput with an empty message".into())
            } else {
                Ok(None)
            }
        }
        // Documented as "never should on valid input".
        Err(other) => Err(format!("solver error on input it accepted: {other}")),
    }
}

/// Column of the circulant (periodic) or Toeplitz (finite) compliance for unit E*, built without
/// the solver's FFT path.
pub fn compliance_column(n: usize, dx: f64, options: &SolverOptions) -> Vec<f64> {
    if !options.periodic {
        return finite_coefficients(n, dx);
    }
    match options.kernel {
        KernelKind::Element => periodic_coefficients(n, dx),
        KernelKind::Spectral => {
            // Inverse real DFT of the eigenvalues lambda_q, q = 0..=N/2, summed directly.
            let lambda = periodic_spectrum(n, dx, KernelKind::Spectral);
            (0..n)
                .map(|k| {
                    let mut sum = lambda[0];
                    for (q, &l) in lambda.iter().enumerate().skip(1) {
                        let weight = if 2 * q == n { 1.0 } else { 2.0 };
                        let angle = 2.0 * std::f64::consts::PI * ((q * k) % n) as f64 / n as f64;
                        sum += weight * l * angle.cos();
                    }
                    sum / n as f64
                })
                .collect()
        }
    }
}

/// Checks the contract for one returned solution.
pub fn check_solution(problem: &Problem, s: &ContactSolution) -> Result<(), String> {
    let z = &problem.heights;
    let n = z.len();
    let p_mean = problem.mean_pressure;
    if s.pressure.len() != n || s.envelope.len() != n {
        return Err(format!("lengths {} / {} for N = {n}", s.pressure.len(), s.envelope.len()));
    }
    if let Some(i) = s.pressure.iter().position(|p| !p.is_finite()) {
        return Err(format!("pressure[{i}] = {} is not finite", s.pressure[i]));
    }
    if let Some(i) = s.envelope.iter().position(|e| !e.is_finite()) {
        return Err(format!("envelope[{i}] = {} is not finite", s.envelope[i]));
    }
    if s.residual.is_nan() || s.residual < 0.0 {
        return Err(format!("residual {} is not a non-negative number", s.residual));
    }
    if let Some(i) = s.pressure.iter().position(|&p| p < 0.0) {
        return Err(format!("pressure[{i}] = {} < 0", s.pressure[i]));
    }
    let total: f64 = s.pressure.iter().sum();
    let balance = total / (n as f64 * p_mean) - 1.0;
    if balance.abs() > 1e-9 {
        return Err(format!("load balance mean(p)/P - 1 = {balance:e}"));
    }
    for (i, ((&e, &p), &h)) in s.envelope.iter().zip(&s.pressure).zip(z).enumerate() {
        if e < h {
            return Err(format!("envelope[{i}] = {e} below heights {h}"));
        }
        if p > 0.0 && e != h {
            return Err(format!("envelope[{i}] != heights where p > 0"));
        }
    }
    let tol = problem.options.tol;
    // `converged` is documented as "residual <= tol" (for the dense direct solve, see
    // check_complementarity).
    if s.converged && problem.options.method == Method::ConjugateGradient && !(s.residual <= tol) {
        return Err(format!("converged with residual {} > tol {tol}", s.residual));
    }
    if !s.converged && s.residual <= tol && problem.options.method == Method::ConjugateGradient {
        // Not a wrong answer, but a solver that stops short of a met tolerance is worth knowing.
        return Err(format!("not converged although residual {} <= tol {tol}", s.residual));
    }
    if s.converged && n <= DENSE_CHECK_MAX {
        check_complementarity(problem, s)?;
    }
    Ok(())
}

/// The pressure really solves the problem: u + h meets the profile on contact, stays above it
/// off contact, and the envelope is that surface (within the tolerance and rounding).
pub fn check_complementarity(problem: &Problem, s: &ContactSolution) -> Result<(), String> {
    let n = problem.heights.len();
    let top = problem.heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let z: Vec<f64> = problem.heights.iter().map(|&h| h - top).collect();
    let material = Material::new(problem.youngs_modulus, problem.poisson).map_err(|e| e.to_string())?;
    let e_star = material.plane_strain_modulus();
    let strain = problem.mean_pressure / e_star;
    let scale = height_scale(&z, strain, problem.dx);
    let column = compliance_column(n, problem.dx, &problem.options);
    let q: Vec<f64> = s.pressure.iter().map(|p| p / e_star).collect();
    let mut u = vec![0.0; n];
    let mut u_abs = 0.0_f64;
    for i in 0..n {
        let (mut sum, mut abs) = (0.0, 0.0);
        for j in 0..n {
            let c = if problem.options.periodic { column[(i + n - j) % n] } else { column[i.abs_diff(j)] };
            sum += c * q[j];
            abs += (c * q[j]).abs();
        }
        u[i] = sum;
        u_abs = u_abs.max(abs);
    }
    if problem.options.method == Method::Direct {
        // The dense solve ignores tol and stops when its active set settles, at a residual set by
        // rounding: large relative to the profile when C p / E* sums terms far larger than it.
        let floor = 1e-12 * u_abs / scale;
        let promised = problem.options.tol.max(DIRECT_RESIDUAL).max(floor);
        if !(s.residual <= promised) {
            return Err(format!("direct solve converged with residual {:e} > {promised:e}", s.residual));
        }
    }
    let on: Vec<usize> = (0..n).filter(|&i| s.pressure[i] > 0.0).collect();
    if on.is_empty() {
        return Err("converged with no element in contact".into());
    }
    let (lo, hi) = on.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &i| {
        let d = z[i] - u[i];
        (lo.min(d), hi.max(d))
    });
    let approach = 0.5 * (lo + hi);
    // Two tolerances (the solver's approach may differ from this one by one), plus the rounding
    // of two different evaluations of u, plus that of z itself.
    let z_abs = z.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    // The reported residual is what is checked (for CG it is <= tol when converged).
    let tol = problem.options.tol.max(s.residual);
    let slack = 2.0 * tol * scale + 1e-12 * u_abs + 4.0 * f64::EPSILON * (z_abs + top.abs());
    let open = 0.5 * (hi - lo);
    if open > slack {
        return Err(format!("gap on the contact set {open:e} > slack {slack:e} (tol {tol:e}, scale {scale:e})"));
    }
    for i in 0..n {
        let surface = u[i] + approach;
        if s.pressure[i] == 0.0 && z[i] - surface > slack {
            return Err(format!("penetration {:e} at {i} > slack {slack:e}", z[i] - surface));
        }
        let expected = surface.max(z[i]) + top;
        if (s.envelope[i] - expected).abs() > slack + 4.0 * f64::EPSILON * top.abs() {
            return Err(format!("envelope[{i}] = {} but the elastic surface is {expected}", s.envelope[i]));
        }
    }
    Ok(())
}

/// The von Meier envelope: an error, or e >= z with e == z at both ends and the curvature limit
/// met to rounding.
pub fn check_von_meier(heights: &[f64], dx: f64, d_star: f64) -> Result<(), String> {
    let e = match von_meier(heights, dx, d_star) {
        Ok(e) => e,
        Err(ContactError::InvalidInput(m)) if !m.trim().is_empty() => return Ok(()),
        Err(other) => return Err(format!("von_meier error: {other}")),
    };
    let n = heights.len();
    if e.len() != n {
        return Err(format!("envelope has {} points for {n}", e.len()));
    }
    for i in 0..n {
        if !(e[i] >= heights[i]) {
            return Err(format!("envelope[{i}] = {} below heights {}", e[i], heights[i]));
        }
    }
    if e[0] != heights[0] || e[n - 1] != heights[n - 1] {
        return Err("envelope leaves the profile at an end".into());
    }
    let c = 2.0 * d_star * dx * dx;
    let z_abs = heights.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if !(c.is_finite() && z_abs.is_finite() && (4.0 * z_abs).is_finite()) {
        return Ok(()); // second differences overflow: nothing checkable
    }
    let slack = 64.0 * f64::EPSILON * (z_abs + c * (n * n) as f64);
    for i in 1..n - 1 {
        let second = e[i - 1] - 2.0 * e[i] + e[i + 1];
        if second > c + slack {
            return Err(format!("curvature at {i}: {second:e} > 2 d* dx^2 = {c:e} (+{slack:e})"));
        }
    }
    Ok(())
}
