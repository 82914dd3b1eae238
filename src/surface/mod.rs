//! Areal contact: a rigid road surface z[iy, ix] (rows across the road, spacing dy; columns along
//! it, spacing dx) pressed into an elastic half-space (Boussinesq) under a prescribed mean
//! pressure, periodic in both directions (or finite). The discrete problem is the line model's
//! with the surface kernel ([`kernel`]), solved by the same solvers (`crate::solver::cg`, without
//! the 1-D island deflation, and `crate::solver::direct`), with the same stopping rule and
//! residual ([`crate::solver::residual`]).

pub mod compliance;
pub mod fft;
pub mod kernel;
pub mod synthetic;

use rayon::prelude::*;

use self::compliance::{SurfaceFinite, SurfaceFiniteScratch, SurfacePeriodic};
use self::fft::Circulant2Scratch;
pub use self::kernel::Grid;
use crate::compliance::Compliance;
use crate::continuation::next_modulus_guess;
use crate::error::{invalid, ContactError, Result};
use crate::solver::{
    cg, check_magnitude, check_solution, check_strain, direct, ContactSolution, Material, Method, SolverOptions, MAGNITUDE_LIMIT,
    MAX_DIRECT_ELEMENTS,
};

/// Bound-constrained CG steps before the active-set sweeps on a cold start, by N: 10 up to
/// 2^14 points, 12 at 2^16, 16 at 2^18 (512^2), 20 at 2^20 (1024^2), 24 at 2^22. The surface
/// sweeps run without the line solver's island deflation, so each sweep needs more iterations at
/// larger N and a better start pays more. On the self-affine surfaces (seeds 1 to 3, tol
/// 1e-10) 20 steps instead of 10 cut the FFT pairs of a 1024^2 solve from 172/163/162 to
/// 145/154/149; at 512^2 16 steps gave 113 to 117 pairs against 118/119/119, and from 128^2 to
/// 256^2 the count moved by at most 3 either way.
fn warm_up_steps(n: usize) -> usize {
    let bits = (usize::BITS - n.leading_zeros()) as usize;
    (2 * bits).saturating_sub(22).clamp(10, 30)
}

/// Fewest elements a surface may have along each direction.
pub const MIN_SIDE: usize = 4;

/// Checks the grid: sizes and spacings (m).
pub fn validate_grid(grid: &Grid) -> Result<()> {
    if grid.ny < MIN_SIDE || grid.nx < MIN_SIDE || grid.len() < crate::solver::MIN_ELEMENTS {
        return invalid(format!(
            "heights has shape ({}, {}): a surface needs at least {MIN_SIDE} points each way and 8 in all",
            grid.ny, grid.nx
        ));
    }
    for (name, d) in [("dx", grid.dx), ("dy", grid.dy)] {
        if !(d.is_finite() && d > 0.0) {
            return invalid(format!("{name} must be a positive finite number of metres, got {d}"));
        }
        check_magnitude(name, d, "m")?;
    }
    Ok(())
}

/// Checks one surface (row-major ny x nx heights, m) and its load (Pa).
pub fn validate_surface(grid: &Grid, heights: &[f64], mean_pressure: f64) -> Result<()> {
    validate_grid(grid)?;
    if heights.len() != grid.len() {
        return invalid(format!("heights has {} points, the grid ({}, {}) has {}", heights.len(), grid.ny, grid.nx, grid.len()));
    }
    if let Some(i) = heights.iter().position(|z| !z.is_finite()) {
        return invalid(format!(
            "heights contains a non-finite value ({}) at row {}, column {}; interpolate drop-outs first",
            heights[i],
            i / grid.nx,
            i % grid.nx
        ));
    }
    if !(mean_pressure.is_finite() && mean_pressure > 0.0) {
        return invalid(format!("mean_pressure must be a positive finite number of pascals, got {mean_pressure}"));
    }
    check_magnitude("mean_pressure", mean_pressure, "Pa")?;
    let largest = heights.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    if largest > MAGNITUDE_LIMIT {
        return invalid(format!("heights reach {largest:e} m, beyond the {MAGNITUDE_LIMIT:e} the solver handles: check the units (m)"));
    }
    Ok(())
}

enum Model {
    Periodic(SurfacePeriodic),
    Finite(SurfaceFinite),
}

/// Work vectors of one thread for [`SurfaceSolver::solve_in`]; results never depend on them.
#[derive(Default)]
pub struct SurfaceWorkspace {
    inner: Inner,
}

impl SurfaceWorkspace {
    /// 2-D FFT pairs (operator applications) applied with this workspace so far, all solves
    /// together: the cost counter of `benches/surface.rs`.
    pub fn fft_pairs(&self) -> u64 {
        match &self.inner {
            Inner::Empty => 0,
            Inner::Periodic(w) => SurfacePeriodic::fft_pairs(w.scratch()),
            Inner::Finite(w) => SurfaceFinite::fft_pairs(w.scratch()),
        }
    }
}

#[derive(Default)]
enum Inner {
    #[default]
    Empty,
    Periodic(cg::Work<Circulant2Scratch>),
    Finite(cg::Work<SurfaceFiniteScratch>),
}

/// The solver for one grid and model: the kernel (built once) and FFT plans, shared by every
/// surface, modulus and thread.
pub struct SurfaceSolver {
    grid: Grid,
    options: SolverOptions,
    model: Model,
}

impl SurfaceSolver {
    pub fn new(grid: Grid, options: SolverOptions) -> Result<Self> {
        options.validate()?;
        validate_grid(&grid)?;
        if options.method == Method::Direct && grid.len() > MAX_DIRECT_ELEMENTS {
            return invalid(format!(
                "method='direct' is a dense check limited to {MAX_DIRECT_ELEMENTS} points (O(N^3)); got {}: use method='cg'",
                grid.len()
            ));
        }
        let model = if options.periodic {
            Model::Periodic(SurfacePeriodic::new(grid, options.kernel))
        } else {
            Model::Finite(SurfaceFinite::new(grid))
        };
        Ok(Self { grid, options, model })
    }

    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The periodic operator (None for the finite model).
    pub fn periodic_operator(&self) -> Option<&SurfacePeriodic> {
        match &self.model {
            Model::Periodic(op) => Some(op),
            Model::Finite(_) => None,
        }
    }

    /// Solves one surface (heights in m, row-major ny x nx) for one rubber under mean pressure (Pa).
    pub fn solve(&self, heights: &[f64], material: Material, mean_pressure: f64) -> Result<ContactSolution> {
        self.solve_from(&mut SurfaceWorkspace::default(), heights, material, mean_pressure, None)
    }

    /// [`SurfaceSolver::solve`] with reusable work vectors, started from `initial_pressure` (Pa,
    /// e.g. the solution under another modulus) when given; ignored by the direct method.
    pub fn solve_from(
        &self,
        workspace: &mut SurfaceWorkspace,
        heights: &[f64],
        material: Material,
        mean_pressure: f64,
        initial_pressure: Option<&[f64]>,
    ) -> Result<ContactSolution> {
        validate_surface(&self.grid, heights, mean_pressure)?;
        let n = self.grid.len();
        match &self.model {
            Model::Periodic(op) => {
                if !matches!(&workspace.inner, Inner::Periodic(w) if w.len() == n) {
                    workspace.inner = Inner::Periodic(cg::Work::new(op));
                }
                let Inner::Periodic(work) = &mut workspace.inner else { unreachable!() };
                self.solve_with(op, work, heights, material, mean_pressure, initial_pressure)
            }
            Model::Finite(op) => {
                if !matches!(&workspace.inner, Inner::Finite(w) if w.len() == n) {
                    workspace.inner = Inner::Finite(cg::Work::new(op));
                }
                let Inner::Finite(work) = &mut workspace.inner else { unreachable!() };
                self.solve_with(op, work, heights, material, mean_pressure, initial_pressure)
            }
        }
    }

    fn solve_with<Op: Compliance>(
        &self,
        op: &Op,
        work: &mut cg::Work<Op::Scratch>,
        heights: &[f64],
        material: Material,
        mean_pressure: f64,
        initial_pressure: Option<&[f64]>,
    ) -> Result<ContactSolution> {
        let e_star = material.plane_strain_modulus();
        let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let z: Vec<f64> = heights.iter().map(|&h| h - top).collect();
        let strain = mean_pressure / e_star;
        let Grid { ny, nx, dx, dy } = self.grid;
        let (lx, ly) = (nx as f64 * dx, ny as f64 * dy);
        check_strain(strain, lx.max(ly))?;
        // The residual's height scale: peak-to-valley, or P sqrt(Lx Ly) / E* for a flat surface.
        let range = -z.iter().copied().fold(f64::INFINITY, f64::min);
        let load_scale = strain * (lx * ly).sqrt();
        let scale = if range > 1e-9 * load_scale { range } else { load_scale };
        let outcome = match self.options.method {
            Method::ConjugateGradient => {
                let initial: Option<Vec<f64>> = initial_pressure.map(|q| q.iter().map(|&x| x / e_star).collect());
                let problem = cg::Problem {
                    z: &z,
                    mean_strain: strain,
                    scale,
                    tol: self.options.tol,
                    max_iterations: self.options.max_iterations,
                    warm_up: Some(warm_up_steps(z.len())),
                };
                cg::solve(op, None, &problem, initial.as_deref(), work)
            }
            Method::Direct => direct::solve(op, &z, strain, scale, self.options.tol)?,
        };
        let pressure = outcome.pressure.iter().map(|&q| q * e_star).collect();
        let envelope =
            outcome.gap.iter().zip(heights).zip(&outcome.pressure).map(|((&g, &h), &q)| if q > 0.0 { h } else { h + g.max(0.0) }).collect();
        let solution = ContactSolution {
            pressure,
            envelope,
            iterations: outcome.iterations,
            residual: outcome.residual,
            converged: outcome.converged,
        };
        check_solution(&solution, mean_pressure)?;
        Ok(solution)
    }
}

/// Solves one surface: builds a [`SurfaceSolver`] and calls it once.
pub fn solve_surface(
    heights: &[f64],
    grid: Grid,
    material: Material,
    mean_pressure: f64,
    options: SolverOptions,
) -> Result<ContactSolution> {
    validate_surface(&grid, heights, mean_pressure)?;
    SurfaceSolver::new(grid, options)?.solve(heights, material, mean_pressure)
}

/// Every (tile, modulus) pair of a stack of tiles (tile after tile, each row-major ny x nx), in
/// parallel on rayon; results tile-major (`tile * moduli.len() + modulus`). Each problem is solved
/// by the same sequential code, so results are bitwise identical whatever the thread count. With
/// `warm_start`, each tile's moduli are solved in order, each from the previous solution (shifted
/// down to a smaller contact set for a stiffer rubber: [`next_modulus_guess`]).
#[allow(clippy::too_many_arguments)]
pub fn solve_surfaces(
    tiles: &[f64],
    grid: Grid,
    youngs_moduli: &[f64],
    poisson: f64,
    mean_pressure: f64,
    options: SolverOptions,
    threads: Option<usize>,
    warm_start: bool,
) -> Result<Vec<ContactSolution>> {
    validate_grid(&grid)?;
    if tiles.is_empty() || tiles.len() % grid.len() != 0 {
        return invalid("tiles must hold one or more whole surfaces of the grid's shape");
    }
    if youngs_moduli.is_empty() {
        return invalid("youngs_modulus is empty: give one or more moduli in pascals");
    }
    let materials: Vec<Material> = youngs_moduli.iter().map(|&e| Material::new(e, poisson)).collect::<Result<_>>()?;
    let tile = |t: usize| &tiles[t * grid.len()..(t + 1) * grid.len()];
    let count = tiles.len() / grid.len();
    for t in 0..count {
        validate_surface(&grid, tile(t), mean_pressure).map_err(|e| ContactError::InvalidInput(format!("tile {t}: {e}")))?;
    }
    let solver = SurfaceSolver::new(grid, options)?;
    let named = |e: ContactError, t: usize, m: &Material| match e {
        ContactError::InvalidInput(msg) => ContactError::InvalidInput(format!("tile {t}, youngs_modulus {:e}: {msg}", m.youngs_modulus)),
        other => other,
    };
    let run = || -> Result<Vec<ContactSolution>> {
        if warm_start {
            let chains = (0..count)
                .into_par_iter()
                .map_init(SurfaceWorkspace::default, |workspace, t| {
                    let mut chain: Vec<ContactSolution> = Vec::with_capacity(materials.len());
                    for (m, material) in materials.iter().enumerate() {
                        let guess =
                            chain.last().filter(|c| c.converged).map(|c| next_modulus_guess(&c.pressure, materials[m - 1], *material));
                        let solution = solver.solve_from(workspace, tile(t), *material, mean_pressure, guess.as_deref());
                        chain.push(solution.map_err(|e| named(e, t, material))?);
                    }
                    Ok(chain)
                })
                .collect::<Result<Vec<_>>>()?;
            return Ok(chains.into_iter().flatten().collect());
        }
        (0..count * materials.len())
            .into_par_iter()
            .map_init(SurfaceWorkspace::default, |workspace, job| {
                let (t, m) = (job / materials.len(), &materials[job % materials.len()]);
                solver.solve_from(workspace, tile(t), *m, mean_pressure, None).map_err(|e| named(e, t, m))
            })
            .collect()
    };
    crate::batch::in_pool(threads, run)
}
