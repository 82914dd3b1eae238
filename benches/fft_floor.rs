//! How close the contact solve is to its FFT floor (issue 18).
//!
//! An FFT-based solve cannot cost less than one kernel application, a real FFT pair, per
//! iteration. For each case this prints the iterations per solve, the time per solve, the time of
//! one realfft forward plus inverse pair of the same N and their ratio, "FFT pairs per solve";
//! beside it the pairs the solve really applied (counted in its workspace), so the rest of the
//! ratio is work outside the transforms. One thread; times are the thread's CPU time where Linux
//! reports it (/proc/thread-self/schedstat), wall-clock time elsewhere. Each repetition of a case is followed by an
//! FFT-pair timing, and the ratio printed is the median of the per-repetition ratios (the machine
//! is shared: ratios of times taken together are what count); the times printed are the best, and
//! `best/best` is their ratio.
//!
//! * `road`: 64 road-like segments of N = 1,000 (0.5 m at 0.5 mm, self-affine, seeds 0..64), each
//!   under E = 1, 2, 5, 10 MPa (nu 0.5, P = 0.2 MPa) in that order, warm-started from the last
//!   (its pressure shifted for the stiffer rubber, `continuation::next_modulus_guess`, as the job does),
//!   tol 1e-6 (the bulk job's unit of work). Targets: at most 40 pairs per solve.
//! * `self-affine 2^16` (and 2^20 with `--large`): Hurst 0.8, rms slope 0.1, L = 1, E* = 1,
//!   P = 0.0105, cutoff 0.25, seed 1, tol 1e-8, cold start. Targets: 150 and 600 pairs.
//!
//! Cold self-affine solves of 2^14 points or more start from the nested guess
//! (`solver::nested`): "iterations" and "pairs applied" are the finest level's, "incl coarse" adds
//! the coarser levels' pairs weighted N_level / N (the time per solve includes them).
//!
//! Run: `cargo bench --bench fft_floor` (add `-- --large` for 2^20, about a minute or more;
//! `-- --only road|16|20|road20|model` for one case (`road20`: a 52 m road-like profile at 0.05 mm;
//! `model`: the road case's segments on a model grid k = 8 times finer, `--refine k` for another k),
//! with `--profile` to leave out the FFT-pair timings, e.g. under `perf record`; `--baseline`
//! runs the solver's own loops in their baseline (SSE2) copies, not the AVX2 ones chosen at run
//! time; `--sizes 16,18,20` and `--seeds 0,1,2` for self-affine cases of those sizes and seeds;
//! `--cold` adds each self-affine case without the nested guess, in the same run).

use std::hint::black_box;
use std::time::Instant;

use realfft::RealFftPlanner;
use roadtex::continuation::next_modulus_guess;
use roadtex::solver::{ContactSolution, ContactSolver, Material, SolverOptions, Workspace};
use roadtex::synthetic::self_affine;

const HURST: f64 = 0.8;
const RMS_SLOPE: f64 = 0.1;
const CUTOFF: f64 = 0.25;

/// A clock for this thread: its CPU time (s) from /proc/thread-self/schedstat where Linux has it,
/// so that time spent descheduled on a shared machine is not counted; else wall-clock time.
struct Clock(Instant);

impl Clock {
    fn start() -> (Self, f64) {
        (Clock(Instant::now()), Self::cpu().unwrap_or(0.0))
    }

    fn cpu() -> Option<f64> {
        let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
        Some(text.split_whitespace().next()?.parse::<f64>().ok()? * 1e-9)
    }

    fn elapsed(&self, cpu_start: f64) -> f64 {
        match Self::cpu() {
            Some(now) => now - cpu_start,
            None => self.0.elapsed().as_secs_f64(),
        }
    }
}

/// Times forward plus inverse real FFT pairs of size n.
struct PairTimer {
    n: usize,
    forward: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    inverse: std::sync::Arc<dyn realfft::ComplexToReal<f64>>,
}

impl PairTimer {
    fn new(n: usize) -> Self {
        let mut planner = RealFftPlanner::<f64>::new();
        Self { n, forward: planner.plan_fft_forward(n), inverse: planner.plan_fft_inverse(n) }
    }

    /// Time of one pair (s), a copy of the input, the forward and the inverse transform (what one
    /// `Circulant::apply` does, less its spectrum multiply): the median mean over `batches` batches
    /// of about 0.2 s each (the CPU clock may tick in steps of a few ms).
    fn time(&self, batches: usize) -> f64 {
        let n = self.n;
        let input: Vec<f64> = (0..n).map(|i| (i % 17) as f64).collect();
        let mut real = vec![0.0; n];
        let mut out = vec![0.0; n];
        let mut spectrum = self.forward.make_output_vec();
        let mut fs = self.forward.make_scratch_vec();
        let mut is = self.inverse.make_scratch_vec();
        let reps = (50_000_000 / n).max(20);
        let mut means = Vec::with_capacity(batches);
        for _ in 0..batches {
            let (clock, start) = Clock::start();
            for r in 0..reps {
                // A copy of the input (realfft's forward transform overwrites it), as the solver's
                // products make; an integer-modulo fill here cost some 20 % of the pair at 2^16.
                real.copy_from_slice(&input);
                real[r % n] += 1.0;
                self.forward.process_with_scratch(&mut real, &mut spectrum, &mut fs).expect("sizes");
                spectrum[0].im = 0.0;
                if n % 2 == 0 {
                    spectrum[n / 2].im = 0.0;
                }
                self.inverse.process_with_scratch(&mut spectrum, &mut out, &mut is).expect("sizes");
                black_box(&out);
            }
            means.push(clock.elapsed(start) / reps as f64);
        }
        means.sort_by(f64::total_cmp);
        means[means.len() / 2]
    }
}

struct Measured {
    name: String,
    n: usize,
    solves: usize,
    iterations: f64,
    pairs_applied: f64,
    /// Pairs applied at N plus those of the coarser levels of nested solves, weighted N_level / N.
    pairs_equivalent: f64,
    /// Best time per solve and best FFT-pair time (s).
    time: f64,
    pair: f64,
    /// Median over the repetitions of (time per solve) / (FFT-pair time measured right after it).
    ratio: f64,
    /// Best time per solve over best FFT-pair time.
    best_ratio: f64,
    worst_residual: f64,
    converged: bool,
}

/// Runs `run` (which solves `solves` problems and returns them with the FFT pairs its
/// workspaces applied) `repeats` times, each
/// followed by an FFT-pair timing of the same N, so that every ratio compares two times taken
/// under the same machine load.
fn measure(name: &str, n: usize, solves: usize, repeats: usize, mut run: impl FnMut() -> (Vec<ContactSolution>, u64, f64)) -> Measured {
    let timer = PairTimer::new(n);
    // `--profile`: the solves only, no FFT-pair timings between them (for `perf record`).
    let profile = std::env::args().any(|a| a == "--profile");
    let (mut best, mut best_pair, mut ratios) = (f64::INFINITY, f64::INFINITY, Vec::new());
    let mut last = (Vec::new(), 0, 0.0);
    for _ in 0..repeats {
        let (clock, start) = Clock::start();
        let (sols, pairs, equivalent) = run();
        let per_solve = clock.elapsed(start) / solves as f64;
        let pair = if profile { f64::NAN } else { timer.time(5) };
        ratios.push(per_solve / pair);
        best = best.min(per_solve);
        best_pair = best_pair.min(pair);
        last = (sols, pairs, equivalent);
    }
    ratios.sort_by(f64::total_cmp);
    let (sols, pairs, equivalent) = last;
    assert_eq!(sols.len(), solves);
    Measured {
        name: name.to_string(),
        n,
        solves,
        iterations: sols.iter().map(|s| s.iterations).sum::<usize>() as f64 / solves as f64,
        pairs_applied: pairs as f64 / solves as f64,
        pairs_equivalent: equivalent / solves as f64,
        time: best,
        pair: best_pair,
        ratio: ratios[ratios.len() / 2],
        best_ratio: best / best_pair,
        worst_residual: sols.iter().map(|s| s.residual).fold(0.0, f64::max),
        converged: sols.iter().all(|s| s.converged),
    }
}

fn road(repeats: usize) -> Measured {
    let (n, segments, dx) = (1000usize, 64u64, 5e-4);
    let moduli = [1e6, 2e6, 5e6, 1e7];
    let profiles: Vec<Vec<f64>> = (0..segments).map(|seed| self_affine(n, n as f64 * dx, HURST, RMS_SLOPE, CUTOFF, seed)).collect();
    let solver = ContactSolver::new(n, dx, SolverOptions { tol: 1e-6, ..Default::default() }).expect("solver");
    let rubbers: Vec<Material> = moduli.iter().map(|&e| Material::new(e, 0.5).expect("material")).collect();
    // Four passes over the segments per repetition: about 0.4 s, long against the CPU clock's step.
    let passes = 4;
    measure("road N=1000 x4 E warm", n, passes * profiles.len() * moduli.len(), repeats, || {
        warm_moduli(&solver, std::iter::repeat(&profiles).take(passes).flatten(), &rubbers)
    })
}

/// Every profile under every rubber in turn, one workspace, each modulus started as the bulk job
/// does (batch::solve_many): the last pressure shifted for a stiffer rubber. The solutions and the
/// FFT pairs the workspace applied (and their equivalent with coarser levels).
fn warm_moduli<'a>(
    solver: &ContactSolver,
    profiles: impl Iterator<Item = &'a Vec<f64>>,
    rubbers: &[Material],
) -> (Vec<ContactSolution>, u64, f64) {
    let mut workspace = Workspace::default();
    let mut out = Vec::new();
    for heights in profiles {
        let mut previous: Option<Vec<f64>> = None;
        for (m, &rubber) in rubbers.iter().enumerate() {
            let guess = previous.as_deref().map(|p| next_modulus_guess(p, rubbers[m - 1], rubber));
            let sol = solver.solve_from(&mut workspace, heights, rubber, 2e5, guess.as_deref()).expect("solve");
            previous = sol.converged.then(|| sol.pressure.clone());
            out.push(sol);
        }
    }
    (out, workspace.fft_pairs(), workspace.fft_pairs_equivalent())
}

/// `--only model` (issue 39): the bulk job's default unit of work on the model grid, the road case's
/// segments joined linearly to a grid `k` times finer (`--refine k`, default 8: N = 8,000), every
/// modulus warm-started from the last as the job does, at the pilot's usual tol 1e-4.
fn model_grid_road(refine: usize, repeats: usize) -> Measured {
    let (n, segments, dx) = (1000usize, 16u64, 5e-4);
    let moduli = [1e6, 2e6, 5e6, 1e7];
    let fine = n * refine;
    let profiles: Vec<Vec<f64>> = (0..segments)
        .map(|seed| {
            let data = self_affine(n, n as f64 * dx, HURST, RMS_SLOPE, CUTOFF, seed);
            (0..fine)
                .map(|i| {
                    let (j, t) = (i / refine, (i % refine) as f64 / refine as f64);
                    data[j] + (data[(j + 1) % n] - data[j]) * t
                })
                .collect()
        })
        .collect();
    let solver = ContactSolver::new(fine, dx / refine as f64, SolverOptions { tol: 1e-4, ..Default::default() }).expect("solver");
    let rubbers: Vec<Material> = moduli.iter().map(|&e| Material::new(e, 0.5).expect("material")).collect();
    measure(&format!("road k={refine} x4 E warm 1e-4"), fine, profiles.len() * moduli.len(), repeats, || {
        warm_moduli(&solver, profiles.iter(), &rubbers)
    })
}

fn self_affine_case(log2_n: u32, repeats: usize, seed: u64, cold: bool) -> Measured {
    let n = 1usize << log2_n;
    let heights = self_affine(n, 1.0, HURST, RMS_SLOPE, CUTOFF, seed);
    let mut solver =
        ContactSolver::new(n, 1.0 / n as f64, SolverOptions { tol: 1e-8, max_iterations: 20_000, ..Default::default() }).expect("solver");
    if cold {
        solver = solver.with_nested_min_elements(usize::MAX);
    }
    let rubber = Material::new(0.75, 0.5).expect("E* = 1");
    // Below 2^18 two solves per repetition (a fresh workspace each), so that it lasts about 0.4 s.
    let solves = if log2_n < 18 { 2 } else { 1 };
    let name = format!("self-affine 2^{log2_n} s{seed}{}", if cold { " cold" } else { "" });
    measure(&name, n, solves, repeats, || {
        let (mut sols, mut pairs, mut equivalent) = (Vec::new(), 0, 0.0);
        for _ in 0..solves {
            let mut workspace = Workspace::default();
            sols.push(solver.solve_in(&mut workspace, &heights, rubber, 0.0105).expect("solve"));
            pairs += workspace.fft_pairs();
            equivalent += workspace.fft_pairs_equivalent();
        }
        (sols, pairs, equivalent)
    })
}

/// `--only road20`: a road-like profile at N = 2^20 (README "Performance"): 52.4 m at 0.05 mm,
/// texture down to 3.2 mm (cutoff N / 64), Hurst 0.8, rms slope 0.1, E = 2.5 MPa (nu 0.5),
/// P = 0.2 MPa, tol 1e-8, cold start, seed 0.
fn road_like_2_20(cold: bool) -> Measured {
    let (n, dx) = (1usize << 20, 5e-5);
    let heights = self_affine(n, n as f64 * dx, HURST, RMS_SLOPE, 1.0 / 64.0, 0);
    let mut solver = ContactSolver::new(n, dx, SolverOptions { tol: 1e-8, max_iterations: 20_000, ..Default::default() }).expect("solver");
    if cold {
        solver = solver.with_nested_min_elements(usize::MAX);
    }
    let rubber = Material::new(2.5e6, 0.5).expect("material");
    measure(&format!("road-like 2^20{}", if cold { " cold" } else { "" }), n, 1, 2, || {
        let mut workspace = Workspace::default();
        let sol = solver.solve_in(&mut workspace, &heights, rubber, 2e5).expect("solve");
        (vec![sol], workspace.fft_pairs(), workspace.fft_pairs_equivalent())
    })
}

fn main() {
    // One thread: the solver's vector passes go parallel above 2^17 points (`solver::reduce`), and
    // this thread's CPU clock would not see work done on others.
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("one thread");
    one.install(run);
}

fn run() {
    let args: Vec<String> = std::env::args().collect();
    if args.iter().any(|a| a == "--baseline") {
        roadtex::solver::set_wide_vectors(false);
    }
    let large = args.iter().any(|a| a == "--large");
    // `--only road` / `--only 16` / `--only 20` runs one case (for profiling).
    let only = args.iter().position(|a| a == "--only").and_then(|i| args.get(i + 1)).map(String::as_str);
    let wanted = |name: &str| only.map_or(true, |o| o == name);
    let mut cases = Vec::new();
    if wanted("road") && !args.iter().any(|a| a == "--sizes") {
        cases.push(road(7));
    }
    // `--seeds 0,1,2` (default 1), `--cold` adds each self-affine case without the nested guess
    // (the same run), `--sizes 16,18` any sizes (2^k; default 16, and 20 with --large).
    let list = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .map(|v| v.split(',').map(|x| x.parse::<u64>().expect("a number")).collect::<Vec<_>>())
    };
    let seeds = list("--seeds").unwrap_or_else(|| vec![1]);
    let cold = args.iter().any(|a| a == "--cold");
    let mut sizes: Vec<u32> = Vec::new();
    if let Some(s) = list("--sizes") {
        sizes.extend(s.iter().map(|&k| k as u32));
    } else {
        if wanted("16") {
            sizes.push(16);
        }
        if large || only == Some("20") {
            sizes.push(20);
        }
    }
    if only == Some("model") {
        let refine = args.iter().position(|a| a == "--refine").and_then(|i| args.get(i + 1)).map_or(8, |v| v.parse().expect("k"));
        cases.push(model_grid_road(refine, 5));
    }
    if only == Some("road20") {
        if cold {
            cases.push(road_like_2_20(true));
        }
        cases.push(road_like_2_20(false));
    }
    for &log2_n in &sizes {
        let repeats = if log2_n >= 20 {
            2
        } else if log2_n >= 18 {
            3
        } else {
            7
        };
        for &seed in &seeds {
            if cold {
                cases.push(self_affine_case(log2_n, repeats, seed, true));
            }
            cases.push(self_affine_case(log2_n, repeats, seed, false));
        }
    }
    println!("solver vector loops: {}", if roadtex::solver::wide_vectors() { "AVX2 (chosen at run time)" } else { "baseline x86-64" });
    println!(
        "{:<28} {:>8} {:>7} {:>10} {:>12} {:>10} {:>12} {:>10} {:>13} {:>11} {:>9}",
        "case",
        "N",
        "solves",
        "iterations",
        "time/solve",
        "FFT pair",
        "pairs/solve",
        "best/best",
        "pairs applied",
        "incl coarse",
        "residual"
    );
    for m in &cases {
        println!(
            "{:<28} {:>8} {:>7} {:>10.1} {:>9.3} ms {:>7.2} us {:>12.0} {:>10.0} {:>13.1} {:>11.1} {:>9.1e}{}",
            m.name,
            m.n,
            m.solves,
            m.iterations,
            m.time * 1e3,
            m.pair * 1e6,
            m.ratio,
            m.best_ratio,
            m.pairs_applied,
            m.pairs_equivalent,
            m.worst_residual,
            if m.converged { "" } else { "  NOT CONVERGED" }
        );
    }
}
