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

/// v zero off `mask`, then zero-sum on it ([`project_zero_sum`]): the zeroing and the sum in one pass.
pub(crate) fn mask_and_project(v: &mut [f64], mask: &[bool], count: usize) {
    let n = v.len().min(mask.len());
    let (v, mask) = (&mut v[..n], &mask[..n]);
    let mut acc = [0.0; 4];
    let mut v4 = v.chunks_exact_mut(4);
    let m4 = mask.chunks_exact(4);
    let tail_mask = m4.remainder();
    for (x, m) in (&mut v4).zip(m4) {
        for k in 0..4 {
            x[k] = if m[k] { x[k] } else { 0.0 };
            acc[k] += x[k];
        }
    }
    let mut tail = 0.0;
    for (x, &m) in v4.into_remainder().iter_mut().zip(tail_mask) {
        if !m {
            *x = 0.0;
        }
        tail += if m { *x } else { 0.0 };
    }
    if count == 0 {
        return;
    }
    let mean = ((acc[0] + acc[1]) + (acc[2] + acc[3]) + tail) / count as f64;
    for (x, &m) in v.iter_mut().zip(mask) {
        if m {
            *x -= mean;
        }
    }
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

/// (a . b, a . c) in one pass, each with the four partial sums of [`dot4`] (the same results).
pub(crate) fn dot2(a: &[f64], b: &[f64], c: &[f64]) -> (f64, f64) {
    let n = a.len().min(b.len()).min(c.len());
    let (a, b, c) = (&a[..n], &b[..n], &c[..n]);
    let (mut ab, mut ac) = ([0.0; 4], [0.0; 4]);
    let (a4, b4, c4) = (a.chunks_exact(4), b.chunks_exact(4), c.chunks_exact(4));
    let tail_ab: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    let tail_ac: f64 = a4.remainder().iter().zip(c4.remainder()).map(|(x, y)| x * y).sum();
    for ((x, y), z) in a4.zip(b4).zip(c4) {
        for k in 0..4 {
            ab[k] += x[k] * y[k];
            ac[k] += x[k] * z[k];
        }
    }
    ((ab[0] + ab[1]) + (ab[2] + ab[3]) + tail_ab, (ac[0] + ac[1]) + (ac[2] + ac[3]) + tail_ac)
}

/// (sum of b over `mask`, a . b) in one pass: [`masked_sum`] and [`dot4`] with the same results.
pub(crate) fn masked_sum_and_dot(a: &[f64], b: &[f64], mask: &[bool]) -> (f64, f64) {
    let n = a.len().min(b.len()).min(mask.len());
    let (a, b, mask) = (&a[..n], &b[..n], &mask[..n]);
    let (mut sum, mut ab) = ([0.0; 4], [0.0; 4]);
    let (a4, b4, m4) = (a.chunks_exact(4), b.chunks_exact(4), mask.chunks_exact(4));
    let tail_sum: f64 = b4.remainder().iter().zip(m4.remainder()).map(|(&x, &m)| if m { x } else { 0.0 }).sum();
    let tail_ab: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    for ((x, y), m) in a4.zip(b4).zip(m4) {
        for k in 0..4 {
            sum[k] += if m[k] { y[k] } else { 0.0 };
            ab[k] += x[k] * y[k];
        }
    }
    ((sum[0] + sum[1]) + (sum[2] + sum[3]) + tail_sum, (ab[0] + ab[1]) + (ab[2] + ab[3]) + tail_ab)
}

/// The CG update in one pass: p += alpha d, u += alpha a, r -= alpha (a - mean) on `mask` (r stays
/// as it is off it); returns max|r| afterwards (four running maxima, as [`max_abs`]).
pub(crate) fn cg_update([p, u, r]: [&mut [f64]; 3], d: &[f64], a: &[f64], mask: &[bool], alpha: f64, mean: f64) -> f64 {
    let n = p.len().min(u.len()).min(r.len()).min(d.len()).min(a.len()).min(mask.len());
    let (p, u, r, d, a, mask) = (&mut p[..n], &mut u[..n], &mut r[..n], &d[..n], &a[..n], &mask[..n]);
    let step = |pi: &mut f64, ui: &mut f64, ri: &mut f64, di: f64, ai: f64, m: bool| {
        *pi += alpha * di;
        *ui += alpha * ai;
        *ri -= if m { alpha * (ai - mean) } else { 0.0 };
        ri.abs()
    };
    let mut worst = [0.0f64; 4];
    let (mut p4, mut u4, mut r4) = (p.chunks_exact_mut(4), u.chunks_exact_mut(4), r.chunks_exact_mut(4));
    let (d4, a4, m4) = (d.chunks_exact(4), a.chunks_exact(4), mask.chunks_exact(4));
    let (dt, at, mt) = (d4.remainder(), a4.remainder(), m4.remainder());
    for ((((pc, uc), rc), (dc, ac)), mc) in (&mut p4).zip(&mut u4).zip(&mut r4).zip(d4.zip(a4)).zip(m4) {
        for k in 0..4 {
            worst[k] = worst[k].max(step(&mut pc[k], &mut uc[k], &mut rc[k], dc[k], ac[k], mc[k]));
        }
    }
    let mut tail = 0.0f64;
    let rest = p4.into_remainder().iter_mut().zip(u4.into_remainder().iter_mut()).zip(r4.into_remainder().iter_mut());
    for (((pi, ui), ri), ((&di, &ai), &m)) in rest.zip(dt.iter().zip(at).zip(mt)) {
        tail = tail.max(step(pi, ui, ri, di, ai, m));
    }
    worst[0].max(worst[1]).max(worst[2].max(worst[3])).max(tail)
}
