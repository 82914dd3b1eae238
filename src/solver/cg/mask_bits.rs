//! The inner iterations' masked passes with the contact set as 64-bit masks (split from
//! [`crate::solver::reduce`]; used for sets below its parallel size, sequentially).
//!
//! With the set as bools, `if m { x } else { 0.0 }` compiled to a branch per point (LLVM turns
//! even an AND with the bool's sign-extension back into one), mispredicted at every ragged contact
//! edge; an AND with a stored 64-bit mask stays branch-free. The values are the same, bit for bit.

use crate::solver::wide::wide_fn;

/// The set as 64-bit masks (all ones on it, 0 off it), for the inner iterations' passes below: an
/// AND on those vectorises, where LLVM turns a mask of bools back into a branch per point.
pub(crate) fn mask_bits(mask: &[bool], bits: &mut Vec<u64>) {
    bits.clear();
    bits.extend(mask.iter().map(|&m| (m as u64).wrapping_neg()));
}

#[inline(always)]
fn keep_bits(x: f64, bits: u64) -> f64 {
    f64::from_bits(x.to_bits() & bits)
}

wide_fn! {
/// `reduce::mask_and_project`'s zeroing and sum with the set as [`mask_bits`] (the same results;
/// sequential).
pub(crate) fn mask_and_sum_bits(v: &mut [f64], bits: &[u64]) -> f64 {
    debug_assert_eq!(v.len(), bits.len(), "masks of the set's size");
    let n = v.len().min(bits.len());
    let (v, bits) = (&mut v[..n], &bits[..n]);
    let mut acc = [0.0; 4];
    let mut v4 = v.chunks_exact_mut(4);
    let b4 = bits.chunks_exact(4);
    let tail_bits = b4.remainder();
    for (x, b) in (&mut v4).zip(b4) {
        for k in 0..4 {
            x[k] = keep_bits(x[k], b[k]);
            acc[k] += x[k];
        }
    }
    let mut tail = 0.0;
    for (x, &b) in v4.into_remainder().iter_mut().zip(tail_bits) {
        *x = keep_bits(*x, b);
        tail += *x;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}
}

wide_fn! {
/// [`masked_sum_and_dot`](crate::solver::reduce::masked_sum_and_dot) with the set as [`mask_bits`] (the same results; sequential).
pub(crate) fn masked_sum_and_dot_bits(a: &[f64], b: &[f64], bits: &[u64]) -> (f64, f64) {
    debug_assert!(a.len() == bits.len() && b.len() == bits.len(), "masks of the set's size");
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

/// [`cg_update`](crate::solver::reduce::cg_update) with the set as [`mask_bits`] (the same results; sequential).
pub(crate) fn cg_update_bits([p, u, r]: [&mut [f64]; 3], d: &[f64], a: &[f64], bits: &[u64], alpha: f64, mean: f64) -> f64 {
    debug_assert!([p.len(), u.len(), r.len(), d.len(), a.len()].iter().all(|&l| l == bits.len()), "masks of the set's size");
    let n = p.len().min(u.len()).min(r.len()).min(d.len()).min(a.len()).min(bits.len());
    cg_update_bits_seq([&mut p[..n], &mut u[..n], &mut r[..n]], &d[..n], &a[..n], &bits[..n], alpha, mean)
}

wide_fn! {
fn cg_update_bits_seq(pur: [&mut [f64]; 3], d: &[f64], a: &[f64], bits: &[u64], alpha: f64, mean: f64) -> f64 {
    let [p, u, r] = pur;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::reduce::{cg_update, mask_and_project, masked_sum_and_dot};

    /// The passes on 64-bit masks give the bool passes' values bit for bit, at every length
    /// around the 4-wide chunks.
    #[test]
    fn bit_mask_passes_match_the_bool_passes_bit_for_bit() {
        for n in 0..70usize {
            let mask: Vec<bool> = (0..n).map(|i| (i * 5 + i / 3) % 7 < 3).collect();
            let mut bits = Vec::new();
            mask_bits(&mask, &mut bits);
            let a: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).cos() - 0.2).collect();
            let same = |x: f64, y: f64| x.to_bits() == y.to_bits();
            let (s1, d1) = masked_sum_and_dot(&a, &b, &mask);
            let (s2, d2) = masked_sum_and_dot_bits(&a, &b, &bits);
            assert!(same(s1, s2) && same(d1, d2), "n {n}: sum and dot");
            // Zeroing and sum: mask_and_project with count 0 zeroes and sums without projecting.
            let (mut v1, mut v2) = (a.clone(), a.clone());
            mask_and_project(&mut v1, &mask, 0);
            let sum = mask_and_sum_bits(&mut v2, &bits);
            assert!(v1.iter().zip(&v2).all(|(x, y)| same(*x, *y)), "n {n}: zeroing");
            let reference: f64 = v1.iter().sum();
            assert!((sum - reference).abs() <= 1e-12, "n {n}: sum {sum} vs {reference}");
            let (mut p1, mut u1, mut r1) = (a.clone(), b.clone(), a.iter().map(|x| x * 0.5).collect::<Vec<_>>());
            let (mut p2, mut u2, mut r2) = (p1.clone(), u1.clone(), r1.clone());
            let w1 = cg_update([&mut p1, &mut u1, &mut r1], &b, &a, &mask, 0.37, 0.01);
            let w2 = cg_update_bits([&mut p2, &mut u2, &mut r2], &b, &a, &bits, 0.37, 0.01);
            assert!(same(w1, w2), "n {n}: worst residual");
            for (x, y) in [(&p1, &p2), (&u1, &u2), (&r1, &r2)] {
                assert!(x.iter().zip(y).all(|(x, y)| same(*x, *y)), "n {n}: updates");
            }
        }
    }
}
