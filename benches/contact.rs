//! Criterion benchmarks of the numerical core.
//!
//! * `kernel_build/N`: `PeriodicCompliance::new` (element spectrum via trigamma + FFT plans).
//! * `solve_self_affine/N`: one preconditioned-CG contact solve (tol 1e-8) of a self-affine profile
//!   (hurst 0.8, rms slope 0.1, L = 1, E* = 1, mean pressure 0.0105, cutoff 0.25) on a prebuilt
//!   `ContactSolver`: the solve alone, not the kernel build.
//! * `westergaard/4096`: the wavy surface at P = 0.3 p*, tol 1e-10, prebuilt solver.
//! * `batch_1000/threads`: the bulk job's unit of work, `batch::solve_many` on 64 road segments of
//!   N = 1,000 (self-affine, 0.5 m at 0.5 mm, seeds 0..64) x 4 moduli (1, 2, 5, 10 MPa), P = 0.2 MPa,
//!   tol 1e-6, on 1 and 2 threads; criterion reports time per batch of 256 solves (and
//!   throughput in solves per second).
//!
//! N runs over 2^10, 2^12, ..., 2^20. Before the solve group every size is timed once (one cold
//! solve, printed with its iterations and residual, and the `ContactSolver::new` set-up time, which
//! is more than `kernel_build`: it also builds the real-space kernel and its pair sums for the
//! coarse space); sizes whose single solve takes longer than `SOLVE_BUDGET` are left out of the
//! solve group with a note, so that `cargo bench --bench contact` stays within a few minutes on
//! two cores. Larger sizes are still timed once (their single-solve line is printed) unless a
//! single solve has already taken longer than `CALIBRATION_CAP`.
//!
//! Run: `cargo bench --bench contact`; one group: `cargo bench --bench contact -- kernel_build`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Throughput;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};
use roadtex::batch::{solve_many, Segments};
use roadtex::compliance::PeriodicCompliance;
use roadtex::reference::Westergaard;
use roadtex::solver::{ContactSolver, Material, SolverOptions};
use roadtex::synthetic::self_affine;
use roadtex::KernelKind;

/// log2 N of the benchmarked sizes.
const LOG2_SIZES: [u32; 6] = [10, 12, 14, 16, 18, 20];
/// A size whose single solve takes longer than this is not benchmarked (its single solve is still
/// printed).
const SOLVE_BUDGET: Duration = Duration::from_secs(2);
/// Once a single solve takes longer than this, larger sizes are not even timed once.
const CALIBRATION_CAP: Duration = Duration::from_secs(5);

// The self-affine case, in E* = 1 units.
const LENGTH: f64 = 1.0;
const HURST: f64 = 0.8;
const RMS_SLOPE: f64 = 0.1;
const CUTOFF: f64 = 0.25;
const SEED: u64 = 1;
const MEAN_PRESSURE: f64 = 0.0105;

/// E = 0.75, nu = 0.5: E* = E / (1 - nu^2) = 1.
fn unit_rubber() -> Material {
    Material::new(0.75, 0.5).expect("valid material")
}

/// Sample counts and times from the cost of one run: 30 samples where a run is cheap, criterion's
/// minimum (10, flat sampling, so about max(3 s, 10 runs)) where it is not.
fn configure(group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>, one_run: Duration) {
    group.warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    if one_run < Duration::from_millis(5) {
        group.sampling_mode(SamplingMode::Auto).sample_size(30);
    } else {
        group.sampling_mode(SamplingMode::Flat).sample_size(10);
    }
}

fn kernel_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("kernel_build");
    for log2_n in LOG2_SIZES {
        let n = 1usize << log2_n;
        let dx = LENGTH / n as f64;
        // Kernel builds cost about 0.25 us per element.
        configure(&mut group, Duration::from_nanos(250 * n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| PeriodicCompliance::new(black_box(n), black_box(dx), KernelKind::Element))
        });
    }
    group.finish();
}

fn solve_self_affine(c: &mut Criterion) {
    let rubber = unit_rubber();
    let options = SolverOptions { tol: 1e-8, max_iterations: 20_000, ..Default::default() };

    // Build every size's problem and time one solve; keep the sizes within the budget.
    let mut cases = Vec::new();
    for log2_n in LOG2_SIZES {
        let n = 1usize << log2_n;
        let dx = LENGTH / n as f64;
        let heights = self_affine(n, LENGTH, HURST, RMS_SLOPE, CUTOFF, SEED);
        let build_start = Instant::now();
        let solver = ContactSolver::new(n, dx, options).expect("solver");
        let build = build_start.elapsed();
        let start = Instant::now();
        let sol = solver.solve(&heights, rubber, MEAN_PRESSURE).expect("solve");
        let elapsed = start.elapsed();
        let contact = sol.pressure.iter().filter(|&&p| p > 0.0).count() as f64 / n as f64;
        eprintln!(
            "solve_self_affine N={n:>8}: single solve {:>9.3} ms, {} iterations, residual {:.2e}, converged {}, contact fraction {contact:.3}; ContactSolver::new {:.3} ms",
            elapsed.as_secs_f64() * 1e3,
            sol.iterations,
            sol.residual,
            sol.converged,
            build.as_secs_f64() * 1e3,
        );
        if !sol.converged {
            eprintln!("WARNING: N={n} did not converge to tol {:e} in {} iterations", options.tol, options.max_iterations);
        }
        if elapsed > SOLVE_BUDGET {
            eprintln!(
                "NOTE: a single solve at N={n} takes {:.2} s > {:.0} s: N={n} is not benchmarked (single solve above only)",
                elapsed.as_secs_f64(),
                SOLVE_BUDGET.as_secs_f64()
            );
            if elapsed > CALIBRATION_CAP {
                eprintln!(
                    "NOTE: {:.0} s > {:.0} s: sizes above N={n} are not timed at all",
                    elapsed.as_secs_f64(),
                    CALIBRATION_CAP.as_secs_f64()
                );
                break;
            }
            continue;
        }
        cases.push((n, heights, solver, elapsed));
    }

    let mut group = c.benchmark_group("solve_self_affine");
    for (n, heights, solver, one_run) in &cases {
        configure(&mut group, *one_run);
        group.bench_with_input(BenchmarkId::from_parameter(n), heights, |b, heights| {
            b.iter(|| solver.solve(black_box(heights), rubber, black_box(MEAN_PRESSURE)).expect("solve"))
        });
    }
    group.finish();
}

fn westergaard(c: &mut Criterion) {
    let n = 4096;
    let rubber = Material::new(2.5e6, 0.5).expect("valid material");
    let (wavelength, amplitude) = (0.02, 1e-4);
    let base = Westergaard { amplitude, wavelength, plane_strain_modulus: rubber.plane_strain_modulus(), mean_pressure: 1.0 };
    let exact = Westergaard { mean_pressure: 0.3 * base.full_contact_pressure(), ..base };
    let dx = wavelength / n as f64;
    let heights: Vec<f64> = (0..n).map(|i| amplitude * (2.0 * std::f64::consts::PI * i as f64 * dx / wavelength).cos()).collect();
    let solver = ContactSolver::new(n, dx, SolverOptions { tol: 1e-10, ..Default::default() }).expect("solver");

    let sol = solver.solve(&heights, rubber, exact.mean_pressure).expect("solve");
    let l1: f64 = sol.pressure.iter().enumerate().map(|(i, &p)| (p - exact.element_pressure(i as f64 * dx, dx)).abs()).sum::<f64>()
        / (exact.mean_pressure * n as f64);
    eprintln!(
        "westergaard N={n}: {} iterations, residual {:.2e}, converged {}, relative L1 pressure error {l1:.2e}",
        sol.iterations, sol.residual, sol.converged
    );

    let mut group = c.benchmark_group("westergaard");
    configure(&mut group, Duration::from_millis(5));
    group.bench_function(BenchmarkId::from_parameter(n), |b| {
        b.iter(|| solver.solve(black_box(&heights), rubber, black_box(exact.mean_pressure)).expect("solve"))
    });
    group.finish();
}

fn batch_1000(c: &mut Criterion) {
    let (n, segments, dx) = (1000usize, 64usize, 5e-4);
    let moduli = [1e6, 2e6, 5e6, 1e7];
    let heights: Vec<f64> = (0..segments as u64).flat_map(|seed| self_affine(n, n as f64 * dx, HURST, RMS_SLOPE, CUTOFF, seed)).collect();
    let options = SolverOptions { tol: 1e-6, ..Default::default() };
    let run = |threads: usize| {
        solve_many(Segments { heights: &heights, len: n }, dx, &moduli, 0.5, 2e5, options, Some(threads), false, None).expect("batch")
    };
    let sols = run(1);
    let iterations: usize = sols.iter().map(|s| s.iterations).sum();
    eprintln!(
        "batch_1000: {} solves, mean {:.2} iterations, all converged {}",
        sols.len(),
        iterations as f64 / sols.len() as f64,
        sols.iter().all(|s| s.converged)
    );
    let mut group = c.benchmark_group("batch_1000");
    group.throughput(Throughput::Elements((segments * moduli.len()) as u64));
    configure(&mut group, Duration::from_millis(100));
    for threads in [1usize, 2] {
        group.bench_with_input(BenchmarkId::from_parameter(threads), &threads, |b, &threads| b.iter(|| run(black_box(threads))));
    }
    group.finish();
}

criterion_group!(benches, kernel_build, solve_self_affine, westergaard, batch_1000);
criterion_main!(benches);
