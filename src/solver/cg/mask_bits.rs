//! The deflation's zeroing pass with the contact set as 64-bit masks (`reduce::fill_mask_bits`), for the
//! run-wise deflation of [`super::covering`]: sequential, as that deflation is used below the
//! parallel size only. The CG update and the curvature pass take the same masks at every size
//! ([`crate::solver::reduce`]).

#[cfg(test)]
use crate::solver::reduce::fill_mask_bits;
use crate::solver::reduce::keep_bits;
use crate::solver::wide::wide_fn;

wide_fn! {
/// `reduce::mask_and_project`'s zeroing and sum with the set as `reduce::fill_mask_bits` (the same results;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::reduce::{cg_update, dot4, mask_and_project, masked_sum, masked_sum_and_dot};

    /// The passes on 64-bit masks against the bool passes and plain loops, bit for bit, at every
    /// length around the 4-wide chunks.
    #[test]
    fn bit_mask_passes_match_the_bool_passes_bit_for_bit() {
        for n in 0..70usize {
            let mask: Vec<bool> = (0..n).map(|i| (i * 5 + i / 3) % 7 < 3).collect();
            let mut bits = Vec::new();
            fill_mask_bits(&mask, &mut bits);
            let a: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).cos() - 0.2).collect();
            let same = |x: f64, y: f64| x.to_bits() == y.to_bits();
            // As documented: masked_sum and dot4 in one pass.
            let (sum, dot) = masked_sum_and_dot(&a, &b, &bits);
            assert!(same(sum, masked_sum(&b, &mask)) && same(dot, dot4(&a, &b)), "n {n}: sum and dot");
            // Zeroing and sum: mask_and_project with count 0 zeroes and sums without projecting.
            let (mut v1, mut v2) = (a.clone(), a.clone());
            mask_and_project(&mut v1, &mask, 0);
            let sum = mask_and_sum_bits(&mut v2, &bits);
            assert!(v1.iter().zip(&v2).all(|(x, y)| same(*x, *y)), "n {n}: zeroing");
            let reference: f64 = v1.iter().sum();
            assert!((sum - reference).abs() <= 1e-12, "n {n}: sum {sum} vs {reference}");
            // The CG update against a plain loop (elementwise, so the same bits).
            let (alpha, mean) = (0.37, 0.01);
            let (mut p, mut u, mut r) = (a.clone(), b.clone(), a.iter().map(|x| x * 0.5).collect::<Vec<_>>());
            let (mut p1, mut u1, mut r1) = (p.clone(), u.clone(), r.clone());
            let worst = cg_update([&mut p, &mut u, &mut r], &b, &a, &bits, alpha, mean);
            for i in 0..n {
                p1[i] += alpha * b[i];
                u1[i] += alpha * a[i];
                if mask[i] {
                    r1[i] -= alpha * (a[i] - mean);
                }
            }
            let worst1 = r1.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(same(worst, worst1), "n {n}: worst residual");
            for (x, y) in [(&p, &p1), (&u, &u1), (&r, &r1)] {
                assert!(x.iter().zip(y).all(|(x, y)| same(*x, *y)), "n {n}: updates");
            }
        }
    }
}
