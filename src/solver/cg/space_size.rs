//! How many vectors a line's coarse space gets: [`space_dim`].

/// The coarse space's dimension for a set of `runs` runs of contact on a line of `n` points solved
/// at `tol`: [`coarse_dim`], at most [`CROWDED_DIM`] for a crowded set at a loose tol.
pub(super) fn space_dim(n: usize, runs: usize, tol: f64) -> usize {
    let dim = coarse_dim(n, runs);
    if n <= CROWDED_MAX_N && runs > CROWDED_RUNS && tol >= CROWDED_MIN_TOL {
        dim.min(CROWDED_DIM)
    } else {
        dim
    }
}

/// Coarse-space dimension (runs of contact, grouped beyond it) for a set of `runs` runs at size N.
///
/// 256 vectors up to N = 2^16, N / 256 beyond, never fewer than one per three runs (with fewer,
/// 65-75 iterations at 2^16 and 160-190 at 2^18 on self-affine profiles, against 56-61 and
/// 72-73), at most N / 16 and 512 below N = 2^19, 1,024 from there (E is factored again, dim^3 / 3,
/// by every sweep that moves the set, and after a nested start most move a few points only; issue
/// 18 fourth pass, pairs-equivalent: 2^18 cap 2,048 1,040-1,180, 1,024 510-730, 512 470-800; 2^20
/// nested, 2,048 894-946, 1,024 713-754, 512 957-973). Rough and precise sweeps share it, so a
/// precise sweep on a set left unchanged reuses the space: a larger precise space (1,024 to 2,048)
/// saved at most one iteration for a fresh assembly and factorisation (8-10 % at 2^16).
fn coarse_dim(n: usize, runs: usize) -> usize {
    const LARGE_DIM_N: usize = 1 << 19;
    let max_dim = if n >= LARGE_DIM_N { 1024 } else { 512 };
    (n / 256).clamp(256, max_dim).max(runs / 3).min((n / 16).max(32)).min(max_dim)
}

/// A set of more than CROWDED_RUNS runs on a line of at most CROWDED_MAX_N points solved at a tol
/// of CROWDED_MIN_TOL or looser gets a space of at most CROWDED_DIM vectors (equal counts of runs
/// per group). Such a space is refactored (dim^3 / 3) by every sweep that moves the set, and at a
/// loose tol a solve is a few inner iterations (N log N each), so the factor of one vector per run
/// was up to half of a model-grid solve on cement concrete (137 to 279 runs on 4,000 points).
/// Measured (issue 39, 2026-12-03, one thread, four moduli chained from the data grid's answer, 0.5 m
/// segments, medians of 5 to 9 alternated calls in one process): cement concrete at 0.5 mm, tol
/// 1e-3, k = 4 / 5 / 6 / 8 / 10 / 12 took 0.65-0.71 / 0.68-0.74 / 0.70 / 0.79 / 0.91 / 0.96 of
/// the time (iterations 5.3 -> 9.5 at k = 4), tol 1e-4 at k = 5 0.79, at 1 mm (k = 6, 8) 0.83 to 0.98;
/// CAPTIF averaged to 0.0625 / 0.075 / 0.1 mm (8,000 / 6,667 / 5,000 points, cold, 120 to 182 runs)
/// 0.78 / 0.88 / 0.72. Where the iterations cost more it does not pay: CAPTIF at 0.0556 mm (8,993
/// points, an FFT of factors 17 and 23) 1.23, as measured (13,337) 1.11; at tol 1e-6 (the pilots'
/// ladders) cement concrete at k = 8 and 16 0.93 and 1.17. Dense asphalt (at most 110 runs settled,
/// more in early sweeps) 6.4 against 5.9 iterations at k = 4 for 1.01 to 1.05 of the time, within
/// the calls' noise; 64 and 48 vectors, or 100 and 160 runs as the bound, did about as well.
const CROWDED_RUNS: usize = 128;
const CROWDED_DIM: usize = 64;
const CROWDED_MAX_N: usize = 1 << 13;
const CROWDED_MIN_TOL: f64 = 1e-4;
