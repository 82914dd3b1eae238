//! The coarse matrix's Cholesky factor and solves (for [`super::deflation`]).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch, LltRegularization};
use faer::{MatMut, Par};

use super::reduce::dot4;
use super::wide::wide_fn;

/// Below this dimension E is factored here (a right-looking Cholesky of contiguous axpys, 5 to 7 %
/// of a road-segment solve faster than row-by-row dot products); above it by faer, whose blocked
/// factorisation wins from there on but costs more than the whole O(dim^3 / 6)
/// work for the coarse spaces of N = 1,000 segments (at most 62 vectors).
const SMALL_FACTOR: usize = 128;

/// The lower Cholesky factor of the symmetric `e` (row-major, dim x dim) in place of it, row-major;
/// the strict upper triangle is unspecified (only the lower one is read, by [`cholesky_solve`]).
/// None if `e` is not numerically positive definite.
pub(crate) fn cholesky(mut e: Vec<f64>, dim: usize) -> Option<Vec<f64>> {
    if dim >= SMALL_FACTOR {
        // In place, sequentially: E is symmetric (to rounding), so its row-major storage read
        // column-major is E again, and faer factors the lower triangle of that view (E's upper
        // triangle as stored, as `MatRef::llt` did on the same view) (no copy of the matrix: at the 250 to
        // 1,024 vectors of the model grids' and long profiles' spaces a copy is a fresh
        // allocation of 0.5 to 8 MB, whose page faults cost more than the factorisation's
        // arithmetic). The same arithmetic as `MatRef::llt`, which copies first.
        let mut scratch = MemBuffer::new(cholesky_in_place_scratch::<f64>(dim, Par::Seq, Default::default()));
        let view = MatMut::from_column_major_slice_mut(&mut e, dim, dim);
        cholesky_in_place(view, LltRegularization::default(), Par::Seq, MemStack::new(&mut scratch), Default::default()).ok()?;
        // L(a, b), a > b, sits at b * dim + a (column-major): move it to a * dim + b (row-major),
        // by cache blocks (entry by entry, one of each pair strides the whole matrix).
        pairs_above_diagonal(dim, |b, a| e.swap(a * dim + b, b * dim + a));
        return Some(e);
    }
    small_cholesky(e, dim)
}

/// Calls `f(i, j)` for every pair i < j < n, in square blocks of 32 x 32 (so that a transposition
/// or a mirror through it touches a few cache lines at a time, not a column of the whole matrix).
pub(crate) fn pairs_above_diagonal(n: usize, mut f: impl FnMut(usize, usize)) {
    const BLOCK: usize = 32;
    for i0 in (0..n).step_by(BLOCK) {
        for j0 in (i0..n).step_by(BLOCK) {
            for i in i0..(i0 + BLOCK).min(n) {
                for j in j0.max(i + 1)..(j0 + BLOCK).min(n) {
                    f(i, j);
                }
            }
        }
    }
}

wide_fn! {
/// [`cholesky`] below [`SMALL_FACTOR`].
fn small_cholesky(e: Vec<f64>, dim: usize) -> Option<Vec<f64>> {
    let mut e = e;
    // Right-looking: after each pivot, the trailing rows take the outer-product update as
    // contiguous axpys against a copy of the pivot's column (no short reductions: they vectorise).
    let mut column = vec![0.0; dim];
    for k in 0..dim {
        let pivot = e[k * dim + k];
        if !pivot.is_finite() || pivot <= 0.0 {
            return None;
        }
        let d = pivot.sqrt();
        e[k * dim + k] = d;
        // One division per pivot, not per entry (a division's latency dominated this loop).
        let inverse = 1.0 / d;
        for i in k + 1..dim {
            e[i * dim + k] *= inverse;
            column[i] = e[i * dim + k];
        }
        for i in k + 1..dim {
            let lik = column[i];
            let row = &mut e[i * dim + k + 1..i * dim + i + 1];
            for (a, &l) in row.iter_mut().zip(&column[k + 1..=i]) {
                *a -= lik * l;
            }
        }
    }
    Some(e)
}
}

wide_fn! {
/// y <- (L L^T)^-1 y.
pub(crate) fn cholesky_solve(l: &[f64], n: usize, y: &mut [f64]) {
    for i in 0..n {
        let row = &l[i * n..i * n + i + 1];
        y[i] = (y[i] - dot4(&row[..i], &y[..i])) / row[i];
    }
    for i in (0..n).rev() {
        let row = &l[i * n..i * n + i + 1];
        let xi = y[i] / row[i];
        y[i] = xi;
        for (yj, &lij) in y[..i].iter_mut().zip(&row[..i]) {
            *yj -= lij * xi;
        }
    }
}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_cholesky_factors_and_refuses_indefinite_matrices() {
        for dim in [1usize, 2, 5, 37, 127, 128, 200] {
            // A well-conditioned SPD matrix: a diagonal plus a smooth kernel.
            let e: Vec<f64> = (0..dim * dim)
                .map(|k| (k / dim, k % dim))
                .map(|(a, b)| 1.0 / (1.0 + (a as f64 - b as f64).abs()) + (a == b) as u8 as f64)
                .collect();
            let l = cholesky(e.clone(), dim).expect("positive definite");
            for a in 0..dim {
                for b in 0..=a {
                    let llt: f64 = (0..=b).map(|k| l[a * dim + k] * l[b * dim + k]).sum();
                    assert!((llt - e[a * dim + b]).abs() < 1e-12, "dim={dim} ({a}, {b})");
                }
            }
            let mut y: Vec<f64> = (0..dim).map(|k| (k as f64).sin()).collect();
            let rhs = y.clone();
            cholesky_solve(&l, dim, &mut y);
            for a in 0..dim {
                let ey: f64 = (0..dim).map(|b| e[a * dim + b] * y[b]).sum();
                assert!((ey - rhs[a]).abs() < 1e-10, "dim={dim} row {a}");
            }
        }
        assert!(cholesky(vec![1.0, 2.0, 2.0, 1.0], 2).is_none());
    }

    #[test]
    fn the_in_place_factor_is_bitwise_faers_llt_of_the_same_view() {
        for dim in [128usize, 131, 200, 253, 300] {
            // entries a little asymmetric in their last bits, as the coarse matrix's assembly leaves them
            let e: Vec<f64> = (0..dim * dim)
                .map(|k| (k / dim, k % dim))
                .map(|(a, b)| 1.0 / (1.0 + (a as f64 - b as f64).abs()) + (a == b) as u8 as f64 + if a < b { 1e-17 } else { 0.0 })
                .collect();
            let llt = faer::MatRef::from_column_major_slice(&e, dim, dim).llt(faer::Side::Lower).expect("positive definite");
            let l = llt.L();
            let ours = cholesky(e.clone(), dim).expect("positive definite");
            for a in 0..dim {
                for b in 0..=a {
                    assert_eq!(ours[a * dim + b].to_bits(), l[(a, b)].to_bits(), "dim={dim} ({a}, {b})");
                }
            }
        }
    }
}
