//! Criterion benchmarks of the surface (areal) contact core.
//!
//! * `surface_kernel_build/N`: `SurfaceSolver::new` with the element kernel (Love's coefficients,
//!   Ewald periodisation, FFT plans) on an N x N grid.
//! * `surface_solve/{spectral,element}/N`: one CG solve (tol 1e-8) of the self-affine
//!   surface (Hurst 0.8, 1 <= |q| < N/4, rms slope 0.1, side 1, E* = 1, P = 0.01: about 20 %
//!   contact) on a prebuilt solver. Each size is timed once first, with its iterations printed.
//!
//! * FFT floor (printed first, before criterion; issue 18's report for the areal solver): the
//!   self-affine surface of seeds 0-2 at 128^2 to 1024^2 (512^2 and below with `-- --quick`;
//!   `--sizes`, `--seeds`, `--tol` (default 1e-8), `--element` for the element kernel, spectral by
//!   default), one thread, each solved cold and from the nested guess (`--nested-from P` points,
//!   default `NESTED_MIN_POINTS`) alternately in the same run: nested levels, iterations (finest
//!   level), 2-D FFT pairs applied (the workspace counter; "incl coarse" adds the coarser levels'
//!   pairs weighted by their share of the points), time per solve, the time of one plain 2-D real
//!   FFT pair of the same grid (realfft on the rows, a transpose, rustfft batched on contiguous
//!   columns and back) and their ratio `solve/pair`, the solve's time in pairs: beside the pairs
//!   applied, the rest of it is the solver's vector work outside the transforms. Each repetition
//!   is followed by the pair timing, the ratios are medians of per-repetition ratios (the machine
//!   is shared), times the best, in the thread's CPU time where Linux reports it.
//! * Job-like (`--job` for it alone, `--no-job` without it, `--job-sizes 256,512`, `--job-tol`): 8 tiles of n^2 at
//!   0.5 mm, E = 2, 5, 10 MPa in order, each tile's moduli warm-started from the last as
//!   `solve_surfaces` does (only the first is a cold solve), tol 1e-6: before this pass (neither
//!   the nested start nor bounded steps from a warm start), the nested start alone, and both.
//!
//! Run: `cargo bench --bench surface` (`-- --floor` for the tables alone). Threads: rayon's
//! default (RAYON_NUM_THREADS=1 for one).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, BenchmarkId, Criterion, SamplingMode};
use realfft::num_complex::Complex;
use realfft::RealFftPlanner;
use roadtex::continuation::next_modulus_guess;
use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{Grid, SurfaceSolver, SurfaceWorkspace, NESTED_MIN_POINTS};
use roadtex::{KernelKind, Material, SolverOptions};

const SIZES: [usize; 3] = [128, 256, 512];

fn grid(n: usize) -> Grid {
    Grid { ny: n, nx: n, dx: 1.0 / n as f64, dy: 1.0 / n as f64 }
}

fn kernel_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("surface_kernel_build");
    group.sample_size(10).measurement_time(Duration::from_secs(5));
    for n in SIZES {
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| SurfaceSolver::new(black_box(grid(n)), SolverOptions::default()).unwrap())
        });
    }
    group.finish();
}

fn solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("surface_solve");
    group.sample_size(10).measurement_time(Duration::from_secs(8)).sampling_mode(SamplingMode::Flat);
    // E = 0.75 with nu = 0.5 gives E* = 1.
    let rubber = Material::new(0.75, 0.5).unwrap();
    for (name, kernel) in [("spectral", KernelKind::Spectral), ("element", KernelKind::Element)] {
        for n in SIZES {
            let heights = self_affine_surface(n, 1.0, 0.8, 0.1, 1);
            let options = SolverOptions { kernel, tol: 1e-8, max_iterations: 5000, ..Default::default() };
            let solver = SurfaceSolver::new(grid(n), options).unwrap();
            let start = Instant::now();
            let once = solver.solve(&heights, rubber, 0.01).unwrap();
            let fraction = once.pressure.iter().filter(|&&p| p > 0.0).count() as f64 / (n * n) as f64;
            println!(
                "surface_solve/{name}/{n}: {} iterations, residual {:.2e}, contact {:.3}, {:.3} s once",
                once.iterations,
                once.residual,
                fraction,
                start.elapsed().as_secs_f64()
            );
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| solver.solve(black_box(&heights), rubber, 0.01).unwrap())
            });
        }
    }
    group.finish();
}

/// This thread's CPU time (s) where Linux reports it (time descheduled on a shared machine is not
/// counted), else wall-clock time since `origin`.
fn clock(origin: Instant) -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|t| t.split_whitespace().next()?.parse::<f64>().ok())
        .map_or_else(|| origin.elapsed().as_secs_f64(), |ns| ns * 1e-9)
}

/// One plain 2-D real FFT pair on an n x n grid, the floor of one operator product: realfft on
/// each row, a transpose to contiguous columns, rustfft forward and inverse on all columns at once,
/// the transpose back and the inverse realfft of each row.
struct PlainPair {
    n: usize,
    forward: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
    inverse: std::sync::Arc<dyn realfft::ComplexToReal<f64>>,
    column_forward: std::sync::Arc<dyn rustfft::Fft<f64>>,
    column_inverse: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

impl PlainPair {
    fn new(n: usize) -> Self {
        let mut real = RealFftPlanner::<f64>::new();
        let mut complex = rustfft::FftPlanner::<f64>::new();
        Self {
            n,
            forward: real.plan_fft_forward(n),
            inverse: real.plan_fft_inverse(n),
            column_forward: complex.plan_fft_forward(n),
            column_inverse: complex.plan_fft_inverse(n),
        }
    }

    /// Mean time (s) of one pair over `reps` pairs.
    fn time(&self, reps: usize) -> f64 {
        let (n, h) = (self.n, self.n / 2 + 1);
        let input: Vec<f64> = (0..n * n).map(|i| (i % 17) as f64).collect();
        let (mut row, mut out) = (vec![0.0; n], vec![0.0; n * n]);
        let mut rows = vec![Complex::default(); n * h];
        let mut columns = vec![Complex::default(); n * h];
        let scratch_len = [
            self.forward.get_scratch_len(),
            self.inverse.get_scratch_len(),
            self.column_forward.get_inplace_scratch_len(),
            self.column_inverse.get_inplace_scratch_len(),
        ];
        let mut scratch = vec![Complex::default(); scratch_len.into_iter().max().unwrap_or(0)];
        let origin = Instant::now();
        let start = clock(origin);
        for _ in 0..reps {
            for (x, spectrum) in input.chunks_exact(n).zip(rows.chunks_exact_mut(h)) {
                row.copy_from_slice(x);
                self.forward.process_with_scratch(&mut row, spectrum, &mut scratch).expect("sizes");
            }
            for (r, spectrum) in rows.chunks_exact(h).enumerate() {
                for (c, &v) in spectrum.iter().enumerate() {
                    columns[c * n + r] = v;
                }
            }
            self.column_forward.process_with_scratch(&mut columns, &mut scratch);
            self.column_inverse.process_with_scratch(&mut columns, &mut scratch);
            for (c, column) in columns.chunks_exact(n).enumerate() {
                for (r, &v) in column.iter().enumerate() {
                    rows[r * h + c] = v;
                }
            }
            for (spectrum, y) in rows.chunks_exact_mut(h).zip(out.chunks_exact_mut(n)) {
                spectrum[0].im = 0.0;
                spectrum[h - 1].im = 0.0;
                self.inverse.process_with_scratch(spectrum, y, &mut scratch).expect("sizes");
            }
            black_box(&out);
        }
        (clock(origin) - start) / reps as f64
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One case of the floor table: `repeats` solves of each variant (cold, nested), each repetition
/// followed by the pair timings; ratios are medians of per-repetition ratios.
struct Row {
    name: String,
    levels: usize,
    iterations: f64,
    pairs: f64,
    equivalent: f64,
    time: f64,
    plain: f64,
    ratio: f64,
    residual: f64,
    converged: bool,
}

impl Row {
    fn print(&self) {
        println!(
            "{:<34} {:>6} {:>10.1} {:>9.1} {:>11.1} {:>10.4} s {:>8.2} ms {:>11.0}  {:.1e}{}",
            self.name,
            self.levels,
            self.iterations,
            self.pairs,
            self.equivalent,
            self.time,
            self.plain * 1e3,
            self.ratio,
            self.residual,
            if self.converged { "" } else { "  NOT CONVERGED" }
        );
    }
}

fn header() {
    println!(
        "{:<34} {:>6} {:>10} {:>9} {:>11} {:>12} {:>11} {:>11}  residual",
        "case", "levels", "iterations", "pairs", "incl coarse", "time/solve", "2-D pair", "solve/pair"
    );
}

/// The workload of one variant: solves, 2-D pairs applied (fine level), pairs-equivalent (coarser
/// levels weighted by their points), nested levels of the last solve.
type Run<'a> = Box<dyn FnMut() -> (Vec<roadtex::ContactSolution>, f64, f64, usize) + 'a>;

/// Times the variants alternately, `repeats` times, each repetition followed by a plain 2-D pair.
fn compare(names: &[String], n: usize, mut runs: Vec<Run<'_>>, repeats: usize) -> Vec<Row> {
    let plain = PlainPair::new(n);
    let reps = (20_000_000 / (n * n)).clamp(3, 400);
    // One untimed round: plans and coarser levels' solvers are built on first use.
    for run in runs.iter_mut() {
        run();
    }
    let mut times = vec![Vec::new(); runs.len()];
    let mut ratios = vec![Vec::new(); runs.len()];
    let mut plains = Vec::new();
    let mut last = Vec::new();
    for _ in 0..repeats {
        last.clear();
        let mut these = Vec::new();
        for run in runs.iter_mut() {
            let origin = Instant::now();
            let start = clock(origin);
            let out = run();
            these.push(clock(origin) - start);
            last.push(out);
        }
        let pair = plain.time(reps);
        plains.push(pair);
        for (k, t) in these.into_iter().enumerate() {
            let solves = last[k].0.len() as f64;
            times[k].push(t / solves);
            ratios[k].push(t / solves / pair);
        }
    }
    let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    last.into_iter()
        .enumerate()
        .map(|(k, (sols, pairs, equivalent, levels))| {
            let solves = sols.len() as f64;
            Row {
                name: names[k].clone(),
                levels,
                iterations: sols.iter().map(|s| s.iterations as f64).sum::<f64>() / solves,
                pairs: pairs / solves,
                equivalent: equivalent / solves,
                time: best(&times[k]),
                plain: best(&plains),
                ratio: median(ratios[k].clone()),
                residual: sols.iter().map(|s| s.residual).fold(0.0, f64::max),
                converged: sols.iter().all(|s| s.converged),
            }
        })
        .collect()
}

/// Cold solves of `heights` (E* = 1, P = 0.01), each in a fresh workspace.
/// Small grids are solved several times per repetition (the CPU clock moves in scheduler ticks).
fn single<'a>(solver: &'a SurfaceSolver, heights: &'a [f64], rubber: Material) -> Run<'a> {
    let solves = (1_000_000 / heights.len()).max(1);
    Box::new(move || {
        let (mut out, mut pairs, mut equivalent, mut levels) = (Vec::new(), 0.0, 0.0, 0);
        for _ in 0..solves {
            let mut w = SurfaceWorkspace::default();
            out.push(solver.solve_from(&mut w, heights, rubber, 0.01, None).expect("solve"));
            (pairs, equivalent, levels) = (pairs + w.fft_pairs() as f64, equivalent + w.fft_pairs_equivalent(), w.nested_levels());
        }
        (out, pairs, equivalent, levels)
    })
}

/// Each tile under each rubber in order, warm-started from the last (shifted), in one workspace.
fn chain<'a>(solver: &'a SurfaceSolver, tiles: &'a [Vec<f64>], rubbers: &'a [Material]) -> Run<'a> {
    Box::new(move || {
        let mut w = SurfaceWorkspace::default();
        let mut out = Vec::new();
        let mut levels = 0;
        for tile in tiles {
            let mut previous: Option<Vec<f64>> = None;
            for (m, &rubber) in rubbers.iter().enumerate() {
                let guess = previous.as_deref().map(|p| next_modulus_guess(p, rubbers[m - 1], rubber));
                let solution = solver.solve_from(&mut w, tile, rubber, 2e5, guess.as_deref()).expect("solve");
                levels = levels.max(w.nested_levels());
                previous = solution.converged.then(|| solution.pressure.clone());
                out.push(solution);
            }
        }
        (out, w.fft_pairs() as f64, w.fft_pairs_equivalent(), levels)
    })
}

/// The FFT-floor table (see the module docs), on one thread: each size and seed cold and nested.
fn floor(sizes: &[usize], seeds: &[u64], tol: f64, kernel: KernelKind, nested_from: usize) {
    let rubber = Material::new(0.75, 0.5).expect("E* = 1");
    header();
    for &n in sizes {
        let options = SolverOptions { kernel, tol, max_iterations: 20_000, ..Default::default() };
        let cold = SurfaceSolver::new(grid(n), options).expect("solver").with_nested_min_points(usize::MAX);
        let nested = SurfaceSolver::new(grid(n), options).expect("solver").with_nested_min_points(nested_from);
        for &seed in seeds {
            let heights = self_affine_surface(n, 1.0, 0.8, 0.1, seed);
            let names = [format!("{n}^2 s{seed} {tol:.0e} cold"), format!("{n}^2 s{seed} {tol:.0e} nested")];
            let repeats = if n >= 1024 { 3 } else { 5 };
            for row in compare(&names, n, vec![single(&cold, &heights, rubber), single(&nested, &heights, rubber)], repeats) {
                row.print();
            }
        }
    }
}

/// The job-like case: 8 tiles of n^2 at 0.5 mm (self-affine, rms slope 0.1, seeds 0-7), each
/// under E = 2, 5, 10 MPa (nu 0.5, P = 0.2 MPa) in that order, warm-started from the last
/// (`continuation::next_modulus_guess`, as `solve_surfaces` does), tol 1e-6 (`--job-tol`): only the first
/// modulus of each tile is a cold solve.
fn job_like(n: usize, nested_from: usize, tol: f64) {
    let dx = 5e-4;
    let g = Grid { ny: n, nx: n, dx, dy: dx };
    let tiles: Vec<Vec<f64>> = (0..8).map(|seed| self_affine_surface(n, n as f64 * dx, 0.8, 0.1, seed)).collect();
    let rubbers: Vec<Material> = [2e6, 5e6, 1e7].iter().map(|&e| Material::new(e, 0.5).expect("material")).collect();
    let options = SolverOptions { tol, ..Default::default() };
    // Before this pass (no nested start, the sweeps straight from a warm start), the nested start
    // alone, and both (the solver's defaults).
    let before = SurfaceSolver::new(g, options).expect("solver").with_nested_min_points(usize::MAX).with_warm_start_steps(0);
    let nested = SurfaceSolver::new(g, options).expect("solver").with_nested_min_points(nested_from).with_warm_start_steps(0);
    let both = SurfaceSolver::new(g, options).expect("solver").with_nested_min_points(nested_from);
    let names =
        [format!("job {n}^2 {tol:.0e} before"), format!("job {n}^2 {tol:.0e} nested"), format!("job {n}^2 {tol:.0e} nested+warm steps")];
    let runs = vec![chain(&before, &tiles, &rubbers), chain(&nested, &tiles, &rubbers), chain(&both, &tiles, &rubbers)];
    for row in compare(&names, n, runs, 3) {
        row.print();
    }
}

criterion_group!(benches, kernel_build, solve);

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let value = |flag: &str| args.iter().position(|a| a == flag).and_then(|i| args.get(i + 1)).cloned();
    let list = |flag: &str| value(flag).map(|v| v.split(',').map(|x| x.parse::<usize>().expect("a number")).collect::<Vec<_>>());
    let quick = args.iter().any(|a| a == "--quick");
    let sizes = list("--sizes").unwrap_or_else(|| if quick { vec![128, 256, 512] } else { vec![128, 256, 512, 1024] });
    let seeds: Vec<u64> = list("--seeds").map_or_else(|| vec![0, 1, 2], |v| v.into_iter().map(|s| s as u64).collect());
    let tol = value("--tol").map_or(1e-8, |t| t.parse().expect("a tolerance"));
    // The threshold of the "nested" rows (points; default the solver's).
    let nested_from = value("--nested-from").map_or(NESTED_MIN_POINTS, |v| v.parse().expect("a number of points"));
    let job_tol = value("--job-tol").map_or(1e-6, |t| t.parse().expect("a tolerance"));
    let kernel = if args.iter().any(|a| a == "--element") { KernelKind::Element } else { KernelKind::Spectral };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("one thread");
    one.install(|| {
        if !args.iter().any(|a| a == "--job") {
            floor(&sizes, &seeds, tol, kernel, nested_from);
        }
        if !args.iter().any(|a| a == "--no-job") {
            for n in list("--job-sizes").unwrap_or_else(|| vec![256, 512]) {
                job_like(n, nested_from, job_tol);
            }
        }
    });
    if args.iter().any(|a| a == "--floor" || a == "--job") {
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
