//! Criterion benchmarks of the surface (areal) contact core.
//!
//! * `surface_kernel_build/N`: `SurfaceSolver::new` with the element kernel (Love's coefficients,
//!   Ewald periodisation, FFT plans) on an N x N grid.
//! * `surface_solve/{spectral,element}/N`: one CG solve (tol 1e-8) of the self-affine
//!   surface (Hurst 0.8, 1 <= |q| < N/4, rms slope 0.1, side 1, E* = 1, P = 0.01: about 20 %
//!   contact) on a prebuilt solver. Each size is timed once first, with its iterations printed.
//!
//! * FFT floor (printed first, before criterion; issue 18's report for the areal solver): at 128^2
//!   to 1024^2 (512^2 and below with `-- --quick`), tol 1e-10 and 1e-8, spectral kernel, one
//!   thread, cold start: iterations, time per solve, 2-D FFT pairs applied (the workspace counter),
//!   the time of one operator product (`Circulant2::apply`), of one plain 2-D real FFT pair of
//!   the same grid (realfft on the rows, a transpose, rustfft batched on contiguous columns and
//!   back) and of one 1-D realfft pair of the same N (`benches/fft_floor.rs`'s floor), then
//!   `op / 1-D`, `op / 2-D` and `solve / 1-D`, the solve's time in 1-D pairs: beside
//!   `pairs/solve`, the rest of it is the solver's vector work outside the transforms. Each repetition of a case is
//!   followed by the pair timings, and the ratios are medians of per-repetition ratios (the
//!   machine is shared); times are the thread's CPU time where Linux reports it.
//!
//! Run: `cargo bench --bench surface` (`-- --floor` for the floor table alone). Threads: rayon's
//! default (RAYON_NUM_THREADS=1 for one).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, BenchmarkId, Criterion, SamplingMode};
use realfft::num_complex::Complex;
use realfft::RealFftPlanner;
use roadtex::surface::fft::Circulant2;
use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{Grid, SurfaceSolver, SurfaceWorkspace};
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

/// Mean time (s) of one 1-D realfft forward plus inverse pair of n points over `reps`.
fn line_pair(n: usize, reps: usize) -> f64 {
    let mut planner = RealFftPlanner::<f64>::new();
    let (forward, inverse) = (planner.plan_fft_forward(n), planner.plan_fft_inverse(n));
    let mut real: Vec<f64> = (0..n).map(|i| (i % 17) as f64).collect();
    let mut spectrum = forward.make_output_vec();
    let mut scratch = vec![Complex::default(); forward.get_scratch_len().max(inverse.get_scratch_len())];
    let origin = Instant::now();
    let start = clock(origin);
    for _ in 0..reps {
        forward.process_with_scratch(&mut real, &mut spectrum, &mut scratch).expect("sizes");
        spectrum[0].im = 0.0;
        spectrum[n / 2].im = 0.0;
        inverse.process_with_scratch(&mut spectrum, &mut real, &mut scratch).expect("sizes");
        black_box(&real);
    }
    (clock(origin) - start) / reps as f64
}

/// Mean time (s) of one operator product (`Circulant2::apply`) on an n x n grid over `reps`.
fn operator_pair(n: usize, reps: usize) -> f64 {
    let circulant = Circulant2::new(n, n);
    let multiplier = vec![1.0; circulant.spectrum_len()];
    let input: Vec<f64> = (0..n * n).map(|i| (i % 17) as f64).collect();
    let mut out = vec![0.0; n * n];
    let mut scratch = circulant.scratch();
    let origin = Instant::now();
    let start = clock(origin);
    for _ in 0..reps {
        circulant.apply(&multiplier, &input, &mut out, &mut scratch);
        black_box(&out);
    }
    (clock(origin) - start) / reps as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The FFT-floor table (see the module docs), on one thread.
fn floor(sizes: &[usize]) {
    let rubber = Material::new(0.75, 0.5).expect("E* = 1");
    println!(
        "{:<18} {:>6} {:>10} {:>11} {:>12} {:>10} {:>10} {:>10} {:>9} {:>9} {:>11} {:>9}",
        "case",
        "tol",
        "iterations",
        "pairs/solve",
        "time/solve",
        "operator",
        "1-D pair",
        "2-D pair",
        "op / 1-D",
        "op / 2-D",
        "solve / 1-D",
        "residual"
    );
    for &n in sizes {
        let heights = self_affine_surface(n, 1.0, 0.8, 0.1, 1);
        let plain = PlainPair::new(n);
        let reps = (20_000_000 / (n * n)).clamp(3, 400);
        let repeats = if n >= 1024 { 3 } else { 5 };
        for tol in [1e-10, 1e-8] {
            let options = SolverOptions { kernel: KernelKind::Spectral, tol, max_iterations: 20_000, ..Default::default() };
            let solver = SurfaceSolver::new(grid(n), options).expect("solver");
            let (mut times, mut operators, mut lines, mut plains) = (vec![], vec![], vec![], vec![]);
            let (mut solve_ratios, mut op_ratios, mut plain_ratios) = (vec![], vec![], vec![]);
            let mut last = None;
            for _ in 0..repeats {
                let mut workspace = SurfaceWorkspace::default();
                let origin = Instant::now();
                let start = clock(origin);
                let solution = solver.solve_from(&mut workspace, &heights, rubber, 0.01, None).expect("solve");
                let time = clock(origin) - start;
                let (operator, line, pair) = (operator_pair(n, reps), line_pair(n * n, reps), plain.time(reps));
                times.push(time);
                operators.push(operator);
                lines.push(line);
                plains.push(pair);
                solve_ratios.push(time / line);
                op_ratios.push(operator / line);
                plain_ratios.push(operator / pair);
                last = Some((solution, workspace.fft_pairs()));
            }
            let (solution, pairs) = last.expect("one repetition");
            let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
            println!(
                "{:<18} {:>6.0e} {:>10} {:>11} {:>10.3} s {:>7.2} ms {:>7.2} ms {:>7.2} ms {:>9.2} {:>9.2} {:>11.0} {:>9.1e}",
                format!("self-affine {n}^2"),
                tol,
                solution.iterations,
                pairs,
                best(&times),
                best(&operators) * 1e3,
                best(&lines) * 1e3,
                best(&plains) * 1e3,
                median(op_ratios),
                median(plain_ratios),
                median(solve_ratios),
                solution.residual
            );
        }
    }
}

criterion_group!(benches, kernel_build, solve);

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let sizes: &[usize] = if args.iter().any(|a| a == "--quick") { &[128, 256, 512] } else { &[128, 256, 512, 1024] };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("one thread");
    one.install(|| floor(sizes));
    if args.iter().any(|a| a == "--floor") {
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
