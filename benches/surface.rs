//! Criterion benchmarks of the surface (areal) contact core.
//!
//! * `surface_kernel_build/N`: `SurfaceSolver::new` with the element kernel (Love's coefficients,
//!   Ewald periodisation, FFT plans) on an N x N grid.
//! * `surface_solve/{spectral,element}/N`: one CG solve (tol 1e-8) of the self-affine
//!   surface (Hurst 0.8, 1 <= |q| < N/4, rms slope 0.1, side 1, E* = 1, P = 0.01: about 20 %
//!   contact) on a prebuilt solver. Each size is timed once first, with its iterations printed.
//!
//! Run: `cargo bench --bench surface`. Threads: rayon's default (RAYON_NUM_THREADS=1 for one).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};
use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{Grid, SurfaceSolver};
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

criterion_group!(benches, kernel_build, solve);
criterion_main!(benches);
