//! The contact solver's vector kernels: projections and reductions over the contact set.
//!
//! The reductions keep four partial sums (or maxima) in a fixed order: they vectorise, where one
//! running sum is a chain of dependent additions (at N = 1,000 eight such passes cost as much as
//! two FFT pairs), and they are deterministic, whatever the thread count.

use super::residual;

/// The bounded CG's gap for displacement `u` = C p (the approach that makes it zero-mean where
/// p > 0) into `gap`; returns the residual.
pub(crate) fn bounded_gap(z: &[f64], p: &[f64], u: &[f64], gap: &mut [f64], scale: f64) -> f64 {
    for ((g, &ui), &zi) in gap.iter_mut().zip(u).zip(z) {
        *g = ui - zi;
    }
    let (mut acc, mut count) = ([0.0; 4], 0usize);
    let (g4, p4) = (gap.chunks_exact(4), p.chunks_exact(4));
    let tail: f64 = g4.remainder().iter().zip(p4.remainder()).map(|(&g, &pi)| if pi > 0.0 { g } else { 0.0 }).sum();
    count += p4.remainder().iter().filter(|&&pi| pi > 0.0).count();
    for (g, pi) in g4.zip(p4) {
        for k in 0..4 {
            let on = pi[k] > 0.0;
            acc[k] += if on { g[k] } else { 0.0 };
            count += on as usize;
        }
    }
    let approach = -((acc[0] + acc[1]) + (acc[2] + acc[3]) + tail) / count as f64;
    gap.iter_mut().for_each(|g| *g += approach);
    residual(p, gap, scale)
}

pub(crate) fn project_zero_sum(v: &mut [f64], mask: &[bool], count: usize) {
    if count == 0 {
        return;
    }
    let mean = masked_sum(v, mask) / count as f64;
    for (x, &m) in v.iter_mut().zip(mask) {
        if m {
            *x -= mean;
        }
    }
}

pub(crate) fn mask_and_project(v: &mut [f64], mask: &[bool], count: usize) {
    for (x, &m) in v.iter_mut().zip(mask) {
        if !m {
            *x = 0.0;
        }
    }
    project_zero_sum(v, mask, count);
}

/// Sum of v over the points of `mask`.
pub(crate) fn masked_sum(v: &[f64], mask: &[bool]) -> f64 {
    let n = v.len().min(mask.len());
    let (v, mask) = (&v[..n], &mask[..n]);
    let mut acc = [0.0; 4];
    let (v4, m4) = (v.chunks_exact(4), mask.chunks_exact(4));
    let tail: f64 = v4.remainder().iter().zip(m4.remainder()).map(|(&x, &m)| if m { x } else { 0.0 }).sum();
    for (x, m) in v4.zip(m4) {
        for k in 0..4 {
            acc[k] += if m[k] { x[k] } else { 0.0 };
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

pub(crate) fn sum4(v: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let v4 = v.chunks_exact(4);
    let tail: f64 = v4.remainder().iter().sum();
    for x in v4 {
        for k in 0..4 {
            acc[k] += x[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    dot4(a, b)
}

pub(crate) fn max_abs(v: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let v4 = v.chunks_exact(4);
    let tail = v4.remainder().iter().fold(0.0f64, |m, &x| m.max(x.abs()));
    for x in v4 {
        for k in 0..4 {
            acc[k] = acc[k].max(x[k].abs());
        }
    }
    acc[0].max(acc[1]).max(acc[2].max(acc[3])).max(tail)
}

/// Dot product with four interleaved partial sums (vectorises; fixed order, so deterministic).
pub(crate) fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in a4.zip(b4) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
