//! Preconditioned constrained conjugate gradients for the load-controlled contact problem
//! (Polonsky-Keer family, with the FFT preconditioner restricted to the free set as in
//! Vollebregt's BCCG-FFT).
//!
//! Each iteration:
//! 1. s = C p; the rigid approach h makes the gap s + h - z zero-mean on the contact set {p > 0}.
//! 2. Stop when [`residual`](super::residual) <= tol (gap on contact, penetration off it).
//! 3. Free set F = {p > 0} U {p = 0 and gap < 0}: contact points and points that penetrate.
//!    Residual r = -gap on F, projected to zero sum on F (the load stays P).
//! 4. Preconditioned residual w = C^-1 r (FFT), restricted to F and projected to zero sum.
//! 5. Conjugate direction d = w + beta d_old, restarted (beta = 0) whenever F changes or a
//!    pressure was clipped at zero in the previous step.
//! 6. Exact line search on the quadratic energy, p += alpha d, clip p at 0, rescale to mean P.
//!
//! The preconditioner is exact for full contact (one step solves it); for partial contact it keeps
//! the iteration count nearly independent of N, where unpreconditioned Polonsky-Keer grows as N^1.1.

use super::{residual, Outcome};
use crate::compliance::Compliance;

/// Solves for pressure / E* with mean `mean_strain` on heights `z` (m). `scale` is the height scale
/// of the residual.
pub(crate) fn solve<Op: Compliance>(op: &Op, z: &[f64], mean_strain: f64, scale: f64, tol: f64, max_iterations: usize) -> Outcome {
    let n = z.len();
    let mut scratch = op.scratch();
    let target_sum = mean_strain * n as f64;

    let mut p = vec![mean_strain; n];
    let mut displacement = vec![0.0; n];
    let mut gap = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut d = vec![0.0; n];
    let mut cd = vec![0.0; n];
    let mut free = vec![false; n];
    let mut free_before = vec![false; n];

    let mut rho_before = 0.0;
    let mut restart = true;
    let mut iterations = 0;
    let mut res;
    loop {
        op.displacement(&p, &mut displacement, &mut scratch);
        let (sum, count) = p
            .iter()
            .zip(displacement.iter().zip(z))
            .filter(|(&pi, _)| pi > 0.0)
            .fold((0.0, 0usize), |(s, c), (_, (&u, &zi))| (s + (u - zi), c + 1));
        let approach = -sum / count as f64;
        for ((g, &u), &zi) in gap.iter_mut().zip(&displacement).zip(z) {
            *g = u + approach - zi;
        }
        res = residual(&p, &gap, scale);
        if res <= tol || iterations >= max_iterations {
            break;
        }

        let mut changed = false;
        let restart_added = (0..n).any(|i| p[i] == 0.0 && gap[i] < 0.0);
        let mut free_count = 0usize;
        for i in 0..n {
            let is_free = p[i] > 0.0 || gap[i] < 0.0;
            changed |= is_free != free_before[i];
            free[i] = is_free;
            free_count += is_free as usize;
            r[i] = if is_free { -gap[i] } else { 0.0 };
        }
        project_zero_sum(&mut r, &free, free_count);
        op.precondition(&r, &mut w, &mut scratch);
        for (wi, &f) in w.iter_mut().zip(&free) {
            if !f {
                *wi = 0.0;
            }
        }
        project_zero_sum(&mut w, &free, free_count);
        let rho = dot(&r, &w);
        if !(rho > 0.0) {
            // r is zero to rounding on the free set: nothing left to gain at this precision.
            break;
        }
        let variant = std::env::var("RT_VARIANT").unwrap_or_default();
        let do_restart = match variant.as_str() { "never" => iterations == 0, "added" => restart_added || iterations == 0, _ => restart || changed };
        if do_restart {
            d.copy_from_slice(&w);
        } else {
            let beta = rho / rho_before;
            for (di, &wi) in d.iter_mut().zip(&w) {
                *di = wi + beta * *di;
            }
        }
        op.displacement(&d, &mut cd, &mut scratch);
        let curvature = dot(&d, &cd);
        if !(curvature > 0.0) {
            break;
        }
        let alpha = rho / curvature;

        let mut clipped = false;
        let mut total = 0.0;
        for (pi, &di) in p.iter_mut().zip(&d) {
            *pi += alpha * di;
            if *pi < 0.0 {
                *pi = 0.0;
                clipped = true;
            }
            total += *pi;
        }
        if clipped {
            let factor = target_sum / total;
            p.iter_mut().for_each(|pi| *pi *= factor);
        }
        if std::env::var("RT_TRACE").is_ok() && iterations % 25 == 0 { let nc = p.iter().filter(|&&x| x > 0.0).count(); eprintln!("it={iterations} res={res:.3e} contact={nc} changed={changed} clipped={clipped} free={free_count}"); }
        restart = clipped;
        rho_before = rho;
        std::mem::swap(&mut free, &mut free_before);
        iterations += 1;
    }
    Outcome { pressure: p, gap, iterations, residual: res, converged: res <= tol }
}

fn project_zero_sum(v: &mut [f64], mask: &[bool], count: usize) {
    if count == 0 {
        return;
    }
    let mean = v.iter().zip(mask).filter(|(_, &m)| m).map(|(x, _)| x).sum::<f64>() / count as f64;
    for (x, &m) in v.iter_mut().zip(mask) {
        if m {
            *x -= mean;
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Experimental: primal-dual active set with PCG inner solves.
pub(crate) fn solve_active_set<Op: Compliance>(op: &Op, z: &[f64], mean_strain: f64, scale: f64, tol: f64, max_iterations: usize) -> Outcome {
    let n = z.len();
    let mut scratch = op.scratch();
    let target_sum = mean_strain * n as f64;
    let mut p = vec![mean_strain; n];
    let mut active = vec![true; n];
    let mut u = vec![0.0; n];
    let mut gap = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut d = vec![0.0; n];
    let mut cd = vec![0.0; n];
    let mut iterations = 0;
    let mut sweeps = 0;
    let mut res = f64::INFINITY;
    loop {
        sweeps += 1;
        let count = active.iter().filter(|&&a| a).count();
        // p on A rescaled to the load, zero elsewhere
        for i in 0..n { if !active[i] { p[i] = 0.0; } }
        let s: f64 = p.iter().sum();
        if s > 0.0 { p.iter_mut().for_each(|x| *x *= target_sum / s); } else { for i in 0..n { if active[i] { p[i] = target_sum / count as f64; } } }
        // PCG on fixed set
        let mut rho_before = 0.0;
        let mut first = true;
        let mut inner = 0;
        loop {
            op.displacement(&p, &mut u, &mut scratch);
            for i in 0..n { r[i] = if active[i] { z[i] - u[i] } else { 0.0 }; }
            project_zero_sum(&mut r, &active, count);
            let rmax = r.iter().fold(0.0f64, |m, &x| m.max(x.abs())) / scale;
            if rmax <= 0.1 * tol || inner >= 200 || iterations >= max_iterations { break; }
            op.precondition(&r, &mut w, &mut scratch);
            for i in 0..n { if !active[i] { w[i] = 0.0; } }
            project_zero_sum(&mut w, &active, count);
            let rho = dot(&r, &w);
            if first { d.copy_from_slice(&w); first = false; } else { let b = rho / rho_before; for i in 0..n { d[i] = w[i] + b * d[i]; } }
            op.displacement(&d, &mut cd, &mut scratch);
            let alpha = rho / dot(&d, &cd);
            for i in 0..n { p[i] += alpha * d[i]; }
            rho_before = rho;
            inner += 1;
            iterations += 1;
        }
        // gap
        let (sum, c) = (0..n).filter(|&i| active[i]).fold((0.0, 0usize), |(s, c), i| (s + u[i] - z[i], c + 1));
        let approach = -sum / c as f64;
        for i in 0..n { gap[i] = u[i] + approach - z[i]; }
        let pc: Vec<f64> = p.iter().map(|&x| x.max(0.0)).collect();
        res = residual(&pc, &gap, scale);
        let mut changed = 0;
        for i in 0..n {
            let next = if active[i] { p[i] > 0.0 } else { gap[i] < 0.0 };
            if next != active[i] { changed += 1; }
            active[i] = next;
        }
        if std::env::var("RT_TRACE").is_ok() { eprintln!("sweep={sweeps} inner={inner} changed={changed} res={res:.2e} count={count}"); }
        if changed == 0 || iterations >= max_iterations { break; }
    }
    let pc: Vec<f64> = p.iter().map(|&x| x.max(0.0)).collect();
    Outcome { pressure: pc, gap, iterations, residual: res, converged: res <= tol }
}
