//! The contact solver's vector kernels: projections and reductions over the contact set.
//!
//! The reductions keep four partial sums (or maxima) in a fixed order: they vectorise, where one
//! running sum is a chain of dependent additions (at N = 1,000 eight such passes cost as much as
//! two FFT pairs), and they are deterministic, whatever the thread count.
//!
//! Vectors of [`PARALLEL_MIN`] points or more (large surfaces, very long profiles) are processed
//! in parallel (rayon) in blocks of [`BLOCK`] points fixed by N alone: each block by the
//! sequential code, the block results combined in block order. A result therefore depends on N,
//! never on the thread count or on which thread ran a block. Below it the passes stay sequential:
//! splitting costs more than it saves there.

use rayon::prelude::*;

use super::residual;
use super::wide::wide_fn;

/// x where `m`, else 0.0: the same value as `if m { x } else { 0.0 }`, bit for bit. Written as an
/// AND, but LLVM still turns the bool's sign-extension back into a branch per point (seen in the
/// AVX2 build of `masked_sum_and_dot_seq`): the inner iterations below the parallel size use stored
/// 64-bit masks instead ([`super::cg`]'s `mask_bits`); these bool passes serve the parallel path
/// and the sweeps.
#[inline(always)]
fn keep(x: f64, m: bool) -> f64 {
    f64::from_bits(x.to_bits() & (m as u64).wrapping_neg())
}

/// The set as 64-bit masks (all ones on it, 0 off it), for the inner iterations' passes: an AND
/// with a stored mask stays branch-free, where LLVM turns a mask of bools back into a branch per
/// point, mispredicted at every ragged contact edge. The values are the same, bit for bit.
pub(crate) fn fill_mask_bits(mask: &[bool], bits: &mut Vec<u64>) {
    bits.clear();
    bits.extend(mask.iter().map(|&m| (m as u64).wrapping_neg()));
}

/// x on the set (`bits` all ones), else 0.0.
#[inline(always)]
pub(crate) fn keep_bits(x: f64, bits: u64) -> f64 {
    f64::from_bits(x.to_bits() & bits)
}

/// Vectors at least this long are processed in parallel blocks.
pub(crate) const PARALLEL_MIN: usize = 1 << 17;
/// Points per block of a parallel pass (a multiple of 4, so blocks keep the four-sum pattern).
pub(crate) const BLOCK: usize = 1 << 14;

/// Whether a pass over `n` points runs in parallel blocks.
pub(crate) fn parallel(n: usize) -> bool {
    n >= PARALLEL_MIN
}

/// Sum of `values` in order (block partial sums combined deterministically).
fn in_order(values: Vec<f64>) -> f64 {
    values.into_iter().fold(0.0, |total, x| total + x)
}

/// Pairs of block partial sums combined in order.
fn pairs_in_order(values: Vec<(f64, f64)>) -> (f64, f64) {
    values.into_iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y))
}

pub(crate) fn masked_sum(v: &[f64], mask: &[bool]) -> f64 {
    let n = v.len().min(mask.len());
    if !parallel(n) {
        return masked_sum_seq(v, mask);
    }
    in_order(v[..n].par_chunks(BLOCK).zip(mask[..n].par_chunks(BLOCK)).map(|(v, m)| masked_sum_seq(v, m)).collect())
}

pub(crate) fn sum4(v: &[f64]) -> f64 {
    if !parallel(v.len()) {
        return sum4_seq(v);
    }
    in_order(v.par_chunks(BLOCK).map(sum4_seq).collect())
}

pub(crate) fn max_abs(v: &[f64]) -> f64 {
    if !parallel(v.len()) {
        return max_abs_seq(v);
    }
    v.par_chunks(BLOCK).map(max_abs_seq).collect::<Vec<_>>().into_iter().fold(0.0, f64::max)
}

/// Dot product with four interleaved partial sums (vectorises; fixed order, so deterministic).
pub(crate) fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if !parallel(n) {
        return dot4_seq(a, b);
    }
    in_order(a[..n].par_chunks(BLOCK).zip(b[..n].par_chunks(BLOCK)).map(|(a, b)| dot4_seq(a, b)).collect())
}

/// Two sums over (a, b, c) by `pass`: at once below [`PARALLEL_MIN`], else per block, the block
/// results added in block order.
fn two_sums<C: Sync>(a: &[f64], b: &[f64], c: &[C], pass: impl Fn(&[f64], &[f64], &[C]) -> (f64, f64) + Sync) -> (f64, f64) {
    let n = a.len().min(b.len()).min(c.len());
    if !parallel(n) {
        return pass(a, b, c);
    }
    let blocks = a[..n].par_chunks(BLOCK).zip(b[..n].par_chunks(BLOCK)).zip(c[..n].par_chunks(BLOCK));
    pairs_in_order(blocks.map(|((a, b), c)| pass(a, b, c)).collect())
}

/// (a . b, a . c) in one pass, each with the four partial sums of [`dot4`] (the same results).
pub(crate) fn dot2(a: &[f64], b: &[f64], c: &[f64]) -> (f64, f64) {
    two_sums(a, b, c, dot2_seq)
}

/// (sum of b over the set, a . b) in one pass, the set as 64-bit masks ([`fill_mask_bits`]):
/// [`masked_sum`] and [`dot4`] with the same results.
pub(crate) fn masked_sum_and_dot(a: &[f64], b: &[f64], bits: &[u64]) -> (f64, f64) {
    debug_assert!(a.len() == bits.len() && b.len() == bits.len(), "masks of the set's size");
    two_sums(a, b, bits, masked_sum_and_dot_seq)
}

/// The CG update in one pass: p += alpha d, u += alpha a, r -= alpha (a - mean) on the set (64-bit
/// masks, [`fill_mask_bits`]; r stays as it is off it); returns max|r| afterwards (four running maxima,
/// as [`max_abs`]).
pub(crate) fn cg_update([p, u, r]: [&mut [f64]; 3], d: &[f64], a: &[f64], bits: &[u64], alpha: f64, mean: f64) -> f64 {
    debug_assert!([p.len(), u.len(), r.len(), d.len(), a.len()].iter().all(|&l| l == bits.len()), "masks of the set's size");
    let n = p.len().min(u.len()).min(r.len()).min(d.len()).min(a.len()).min(bits.len());
    if !parallel(n) {
        return cg_update_seq([p, u, r], d, a, bits, alpha, mean);
    }
    let outputs = p[..n].par_chunks_mut(BLOCK).zip(u[..n].par_chunks_mut(BLOCK)).zip(r[..n].par_chunks_mut(BLOCK));
    let inputs = d[..n].par_chunks(BLOCK).zip(a[..n].par_chunks(BLOCK)).zip(bits[..n].par_chunks(BLOCK));
    let worst: Vec<f64> = outputs.zip(inputs).map(|(((p, u), r), ((d, a), m))| cg_update_seq([p, u, r], d, a, m, alpha, mean)).collect();
    worst.into_iter().fold(0.0, f64::max)
}

/// v *= factor, elementwise (in parallel blocks for long vectors).
pub(crate) fn scale(v: &mut [f64], factor: f64) {
    if !parallel(v.len()) {
        scale_seq(v, factor);
        return;
    }
    v.par_chunks_mut(BLOCK).for_each(|v| scale_seq(v, factor));
}

wide_fn! {
fn scale_seq(v: &mut [f64], factor: f64) {
    v.iter_mut().for_each(|x| *x *= factor);
}
}

/// The bounded CG's gap for displacement `u` = C p (the approach that makes it zero-mean where
/// p > 0) into `gap`; returns the residual.
pub(crate) fn bounded_gap(z: &[f64], p: &[f64], u: &[f64], gap: &mut [f64], scale: f64) -> f64 {
    let n = z.len().min(p.len()).min(u.len()).min(gap.len());
    let (z, p, u, gap) = (&z[..n], &p[..n], &u[..n], &mut gap[..n]);
    let (sum, count) = if parallel(n) {
        let blocks = gap.par_chunks_mut(BLOCK).zip(u.par_chunks(BLOCK)).zip(z.par_chunks(BLOCK)).zip(p.par_chunks(BLOCK));
        let parts: Vec<(f64, usize)> = blocks.map(|(((g, u), z), p)| open_gap_seq(z, p, u, g)).collect();
        parts.into_iter().fold((0.0, 0), |(s, c), (x, k)| (s + x, c + k))
    } else {
        open_gap_seq(z, p, u, gap)
    };
    let approach = -sum / count as f64;
    if !parallel(n) {
        gap.iter_mut().for_each(|g| *g += approach);
        return residual(p, gap, scale);
    }
    // residual is a maximum over points: per block (scale 1, exact), then over blocks.
    let worst: Vec<f64> = gap
        .par_chunks_mut(BLOCK)
        .zip(p.par_chunks(BLOCK))
        .map(|(g, p)| {
            g.iter_mut().for_each(|g| *g += approach);
            residual(p, g, 1.0)
        })
        .collect();
    worst.into_iter().fold(0.0, f64::max) / scale
}

wide_fn! {
/// gap = u - z, and (the sum of the gap where p > 0, the number of such points).
fn open_gap_seq(z: &[f64], p: &[f64], u: &[f64], gap: &mut [f64]) -> (f64, usize) {
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
    ((acc[0] + acc[1]) + (acc[2] + acc[3]) + tail, count)
}
}

/// v -= mean on `mask` (in parallel blocks for long vectors).
pub(crate) fn subtract_on_mask(v: &mut [f64], mask: &[bool], mean: f64) {
    if parallel(v.len()) {
        v.par_chunks_mut(BLOCK).zip(mask.par_chunks(BLOCK)).for_each(|(v, m)| subtract_on_mask_seq(v, m, mean));
    } else {
        subtract_on_mask_seq(v, mask, mean);
    }
}

wide_fn! {
fn subtract_on_mask_seq(v: &mut [f64], mask: &[bool], mean: f64) {
    for (x, &m) in v.iter_mut().zip(mask) {
        // x - 0.0 is x, bit for bit (-0.0 included): the same as subtracting on the mask only.
        *x -= keep(mean, m);
    }
}
}

pub(crate) fn project_zero_sum(v: &mut [f64], mask: &[bool], count: usize) {
    if count == 0 {
        return;
    }
    let mean = masked_sum(v, mask) / count as f64;
    subtract_on_mask(v, mask, mean);
}

/// v zero off `mask`, then zero-sum on it ([`project_zero_sum`]): the zeroing and the sum in one pass.
pub(crate) fn mask_and_project(v: &mut [f64], mask: &[bool], count: usize) {
    let n = v.len().min(mask.len());
    let (v, mask) = (&mut v[..n], &mask[..n]);
    let sum = if parallel(n) {
        in_order(v.par_chunks_mut(BLOCK).zip(mask.par_chunks(BLOCK)).map(|(v, m)| mask_and_sum_seq(v, m)).collect())
    } else {
        mask_and_sum_seq(v, mask)
    };
    if count == 0 {
        return;
    }
    subtract_on_mask(v, mask, sum / count as f64);
}

/// r = z - u on `mask`, 0 off it; returns the sum of r (one pass, the four partial sums of
/// [`masked_sum`]; in parallel blocks for long vectors).
pub(crate) fn masked_difference(r: &mut [f64], z: &[f64], u: &[f64], mask: &[bool]) -> f64 {
    let n = r.len().min(z.len()).min(u.len()).min(mask.len());
    let (r, z, u, mask) = (&mut r[..n], &z[..n], &u[..n], &mask[..n]);
    if !parallel(n) {
        return masked_difference_seq(r, z, u, mask);
    }
    let blocks = r.par_chunks_mut(BLOCK).zip(z.par_chunks(BLOCK)).zip(u.par_chunks(BLOCK)).zip(mask.par_chunks(BLOCK));
    in_order(blocks.map(|(((r, z), u), m)| masked_difference_seq(r, z, u, m)).collect())
}

wide_fn! {
fn masked_difference_seq(r: &mut [f64], z: &[f64], u: &[f64], mask: &[bool]) -> f64 {
    let mut acc = [0.0; 4];
    let mut r4 = r.chunks_exact_mut(4);
    let (z4, u4, m4) = (z.chunks_exact(4), u.chunks_exact(4), mask.chunks_exact(4));
    let (zt, ut, mt) = (z4.remainder(), u4.remainder(), m4.remainder());
    for (((x, z), u), m) in (&mut r4).zip(z4).zip(u4).zip(m4) {
        for k in 0..4 {
            x[k] = keep(z[k] - u[k], m[k]);
            acc[k] += x[k];
        }
    }
    let mut tail = 0.0;
    for (((x, &z), &u), &m) in r4.into_remainder().iter_mut().zip(zt).zip(ut).zip(mt) {
        *x = if m { z - u } else { 0.0 };
        tail += *x;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
}

/// gap = u - z, and its sum over `mask` (one pass, the four partial sums of [`masked_sum`]).
pub(crate) fn gap_and_masked_sum(gap: &mut [f64], u: &[f64], z: &[f64], mask: &[bool]) -> f64 {
    let n = gap.len().min(z.len()).min(u.len()).min(mask.len());
    let (gap, z, u, mask) = (&mut gap[..n], &z[..n], &u[..n], &mask[..n]);
    if !parallel(n) {
        return gap_and_masked_sum_seq(gap, u, z, mask);
    }
    let blocks = gap.par_chunks_mut(BLOCK).zip(u.par_chunks(BLOCK)).zip(z.par_chunks(BLOCK)).zip(mask.par_chunks(BLOCK));
    in_order(blocks.map(|(((g, u), z), m)| gap_and_masked_sum_seq(g, u, z, m)).collect())
}

wide_fn! {
fn gap_and_masked_sum_seq(gap: &mut [f64], u: &[f64], z: &[f64], mask: &[bool]) -> f64 {
    let mut acc = [0.0; 4];
    let mut g4 = gap.chunks_exact_mut(4);
    let (u4, z4, m4) = (u.chunks_exact(4), z.chunks_exact(4), mask.chunks_exact(4));
    let (ut, zt, mt) = (u4.remainder(), z4.remainder(), m4.remainder());
    for (((g, u), z), m) in (&mut g4).zip(u4).zip(z4).zip(m4) {
        for k in 0..4 {
            g[k] = u[k] - z[k];
            acc[k] += keep(g[k], m[k]);
        }
    }
    let mut tail = 0.0;
    for (((g, &u), &z), &m) in g4.into_remainder().iter_mut().zip(ut).zip(zt).zip(mt) {
        *g = u - z;
        tail += if m { *g } else { 0.0 };
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
}

/// gap += approach, then the next trial set in `mask` (points with p <= 0 leave, points with
/// gap < 0 join); returns how many points changed (one pass).
pub(crate) fn shift_gap_and_update(gap: &mut [f64], p: &[f64], mask: &mut [bool], approach: f64) -> usize {
    let n = gap.len().min(p.len()).min(mask.len());
    let (gap, p, mask) = (&mut gap[..n], &p[..n], &mut mask[..n]);
    if !parallel(n) {
        return shift_gap_and_update_seq(gap, p, mask, approach);
    }
    let blocks = gap.par_chunks_mut(BLOCK).zip(p.par_chunks(BLOCK)).zip(mask.par_chunks_mut(BLOCK));
    blocks.map(|((g, p), m)| shift_gap_and_update_seq(g, p, m, approach)).sum()
}

wide_fn! {
fn shift_gap_and_update_seq(gap: &mut [f64], p: &[f64], mask: &mut [bool], approach: f64) -> usize {
    let mut changed = 0usize;
    for ((g, &pi), m) in gap.iter_mut().zip(p).zip(mask.iter_mut()) {
        *g += approach;
        // if *m { pi > 0.0 } else { *g < 0.0 }, without a branch.
        let next = (*m & (pi > 0.0)) | (!*m & (*g < 0.0));
        changed += (next != *m) as usize;
        *m = next;
    }
    changed
}
}

wide_fn! {
/// v zero off `mask`; returns the sum of v (over the mask).
fn mask_and_sum_seq(v: &mut [f64], mask: &[bool]) -> f64 {
    let mut acc = [0.0; 4];
    let mut v4 = v.chunks_exact_mut(4);
    let m4 = mask.chunks_exact(4);
    let tail_mask = m4.remainder();
    for (x, m) in (&mut v4).zip(m4) {
        for k in 0..4 {
            x[k] = keep(x[k], m[k]);
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
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
}

wide_fn! {
fn masked_sum_seq(v: &[f64], mask: &[bool]) -> f64 {
    let n = v.len().min(mask.len());
    let (v, mask) = (&v[..n], &mask[..n]);
    let mut acc = [0.0; 4];
    let (v4, m4) = (v.chunks_exact(4), mask.chunks_exact(4));
    let tail: f64 = v4.remainder().iter().zip(m4.remainder()).map(|(&x, &m)| if m { x } else { 0.0 }).sum();
    for (x, m) in v4.zip(m4) {
        for k in 0..4 {
            acc[k] += keep(x[k], m[k]);
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
}

wide_fn! {
fn sum4_seq(v: &[f64]) -> f64 {
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
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    dot4(a, b)
}

wide_fn! {
fn max_abs_seq(v: &[f64]) -> f64 {
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
}

wide_fn! {
fn dot4_seq(a: &[f64], b: &[f64]) -> f64 {
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
}

wide_fn! {
fn dot2_seq(a: &[f64], b: &[f64], c: &[f64]) -> (f64, f64) {
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
}

wide_fn! {
fn masked_sum_and_dot_seq(a: &[f64], b: &[f64], bits: &[u64]) -> (f64, f64) {
    let n = a.len().min(b.len()).min(bits.len());
    let (a, b, bits) = (&a[..n], &b[..n], &bits[..n]);
    let (mut sum, mut ab) = ([0.0; 4], [0.0; 4]);
    let (a4, b4, m4) = (a.chunks_exact(4), b.chunks_exact(4), bits.chunks_exact(4));
    let tail_sum: f64 = b4.remainder().iter().zip(m4.remainder()).map(|(&x, &m)| keep_bits(x, m)).sum();
    let tail_ab: f64 = a4.remainder().iter().zip(b4.remainder()).map(|(x, y)| x * y).sum();
    for ((x, y), m) in a4.zip(b4).zip(m4) {
        for k in 0..4 {
            sum[k] += keep_bits(y[k], m[k]);
            ab[k] += x[k] * y[k];
        }
    }
    ((sum[0] + sum[1]) + (sum[2] + sum[3]) + tail_sum, (ab[0] + ab[1]) + (ab[2] + ab[3]) + tail_ab)
}
}

wide_fn! {
fn cg_update_seq(pur: [&mut [f64]; 3], d: &[f64], a: &[f64], bits: &[u64], alpha: f64, mean: f64) -> f64 {
    let [p, u, r] = pur;
    let n = p.len().min(u.len()).min(r.len()).min(d.len()).min(a.len()).min(bits.len());
    let (p, u, r, d, a, bits) = (&mut p[..n], &mut u[..n], &mut r[..n], &d[..n], &a[..n], &bits[..n]);
    let step = |pi: &mut f64, ui: &mut f64, ri: &mut f64, di: f64, ai: f64, m: u64| {
        *pi += alpha * di;
        *ui += alpha * ai;
        *ri -= keep_bits(alpha * (ai - mean), m);
        ri.abs()
    };
    let mut worst = [0.0f64; 4];
    let (mut p4, mut u4, mut r4) = (p.chunks_exact_mut(4), u.chunks_exact_mut(4), r.chunks_exact_mut(4));
    let (d4, a4, m4) = (d.chunks_exact(4), a.chunks_exact(4), bits.chunks_exact(4));
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
}

/// d = y + beta d (`beta` None: d = y + 0.0, the last solve's d ignored), in parallel blocks for
/// long vectors (elementwise: the same result whatever the split).
pub(crate) fn new_direction(direction: &mut [f64], preconditioned: &[f64], beta: Option<f64>) {
    if parallel(direction.len()) {
        direction.par_chunks_mut(BLOCK).zip(preconditioned.par_chunks(BLOCK)).for_each(|(d, y)| new_direction_seq(d, y, beta));
    } else {
        new_direction_seq(direction, preconditioned, beta);
    }
}

wide_fn! {
fn new_direction_seq(d: &mut [f64], y: &[f64], beta: Option<f64>) {
    match beta {
        None => d.iter_mut().zip(y).for_each(|(d, &y)| *d = y + 0.0),
        Some(beta) => d.iter_mut().zip(y).for_each(|(d, &y)| *d = y + beta * *d),
    }
}
}

/// The bounded CG's free set {p > 0} U {gap < 0} into `free`, the residual -gap on it (0 off it)
/// into `residual`; returns the free set's size.
pub(crate) fn free_set(free: &mut [bool], residual: &mut [f64], p: &[f64], gap: &[f64]) -> usize {
    let task = |free: &mut [bool], residual: &mut [f64], p: &[f64], gap: &[f64]| {
        let mut count = 0;
        for (((f, r), &pi), &g) in free.iter_mut().zip(residual.iter_mut()).zip(p).zip(gap) {
            *f = pi > 0.0 || g < 0.0;
            count += *f as usize;
            *r = if *f { -g } else { 0.0 };
        }
        count
    };
    if !parallel(p.len()) {
        return task(free, residual, p, gap);
    }
    let blocks = free.par_chunks_mut(BLOCK).zip(residual.par_chunks_mut(BLOCK)).zip(p.par_chunks(BLOCK)).zip(gap.par_chunks(BLOCK));
    blocks.map(|(((f, r), p), g)| task(f, r, p, g)).sum()
}

/// The bounded CG's direction: y + beta d on the free set (d taken as 0 on the `first` step), 0 off it.
pub(crate) fn free_direction(direction: &mut [f64], preconditioned: &[f64], free: &[bool], beta: f64, first: bool) {
    let task = |direction: &mut [f64], preconditioned: &[f64], free: &[bool]| {
        for ((d, &y), &f) in direction.iter_mut().zip(preconditioned).zip(free) {
            let previous = if first { 0.0 } else { *d };
            *d = if f { y + beta * previous } else { 0.0 };
        }
    };
    if parallel(direction.len()) {
        let blocks = direction.par_chunks_mut(BLOCK).zip(preconditioned.par_chunks(BLOCK)).zip(free.par_chunks(BLOCK));
        blocks.for_each(|((d, y), f)| task(d, y, f));
    } else {
        task(direction, preconditioned, free);
    }
}

/// p += alpha d and u += alpha C d; returns how many pressures turned negative.
pub(crate) fn step_and_count_negative(p: &mut [f64], u: &mut [f64], d: &[f64], applied: &[f64], alpha: f64) -> usize {
    let task = |p: &mut [f64], u: &mut [f64], d: &[f64], a: &[f64]| {
        let mut negative = 0usize;
        for ((pi, ui), (&d, &a)) in p.iter_mut().zip(u.iter_mut()).zip(d.iter().zip(a)) {
            *pi += alpha * d;
            *ui += alpha * a;
            negative += (*pi < 0.0) as usize;
        }
        negative
    };
    if !parallel(p.len()) {
        return task(p, u, d, applied);
    }
    let blocks = p.par_chunks_mut(BLOCK).zip(u.par_chunks_mut(BLOCK)).zip(d.par_chunks(BLOCK)).zip(applied.par_chunks(BLOCK));
    blocks.map(|(((p, u), d), a)| task(p, u, d, a)).sum()
}
