//! Areal contact: a rigid road surface z[iy, ix] (rows across the road, spacing dy; columns along
//! it, spacing dx) pressed into an elastic half-space (Boussinesq) under a prescribed mean
//! pressure, periodic in both directions (or finite). The discrete problem is the line model's
//! with the surface kernel ([`kernel`]), solved by the same solvers (`crate::solver::cg`, without
//! the 1-D island deflation, and `crate::solver::direct`), with the same stopping rule and
//! residual ([`crate::solver::residual`]). Cold solves of [`NESTED_MIN_POINTS`] points or more
//! start from the nested (coarse-to-fine) guess of `crate::solver::nested`; cold and warm starts
//! take a few bound-constrained CG steps before the active-set sweeps.

pub mod compliance;
pub mod fft;
pub mod kernel;
pub mod synthetic;

use rayon::prelude::*;

use self::compliance::{SurfaceFinite, SurfaceFiniteScratch, SurfacePeriodic, SurfacePeriodicScratch};
pub use self::kernel::Grid;
use crate::compliance::Compliance;
use crate::continuation::next_modulus_guess;
use crate::error::{invalid, ContactError, Result};
use crate::solver::nested::{self, Blocks};
use crate::solver::{
    cg, check_magnitude, check_solution, check_strain, direct, ContactSolution, Material, Method, Outcome, SolverOptions, MAGNITUDE_LIMIT,
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

/// Cold CG solves of at least this many points (64^2; and every coarser level down to a quarter
/// of it) start from the nested guess (`crate::solver::nested`); the coarsest level is solved cold.
/// Measured on the self-affine benchmark surfaces (`benches/surface.rs`, tol 1e-8, seed 1, pairs
/// per solve with the coarser levels' weighted by their points): at 512^2 nesting down to 32^2
/// took 76 against 83 down to 64^2 and 84 down to 128^2 (90 cold), and going below 32^2 gained
/// nothing; at 64^2 (seeds 0-2) it took 36.5 to 42 against 47 cold.
pub const NESTED_MIN_POINTS: usize = 1 << 12;

/// The tolerance of the coarser levels of a nested surface solve (when the requested one is
/// looser, that one). At 512^2 (1024^2), 1e-3 left 76 (116) pairs per solve, 1e-4 83 (122) and
/// 1e-6 87: the fine level took about as many iterations whatever the guess's accuracy.
pub const NESTED_TOL: f64 = 1e-3;

/// Bound-constrained CG steps from a nested guess before the sweeps: its contact set, prolonged
/// over 2 x 2 blocks, is ragged at the edges, which these steps trim more cheaply than the sweeps.
/// At 512^2 (coarser levels at tol 1e-3): 2 steps 86 pairs per solve, 6 82, 10 76, 15 83.
const NESTED_GUESS_STEPS: usize = 10;

/// Bound-constrained CG steps from a warm start (the last modulus's pressure, shifted by
/// `continuation::next_modulus_guess`) before the sweeps. From such a guess the bounded CG
/// usually converges within them, and more cheaply than the sweeps, which run here without the
/// line solver's island deflation: 8 tiles x 3 moduli (`benches/surface.rs`, job-like case, tol
/// 1e-6), 256^2 60 -> 50 pairs per solve with 40 steps (55 with 10), 512^2 86 -> 67 (75).
pub const WARM_START_STEPS: usize = 40;

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

/// Work vectors of one thread for [`SurfaceSolver::solve_from`]; results never depend on them.
#[derive(Default)]
pub struct SurfaceWorkspace {
    inner: Inner,
    /// The workspace of the next coarser level of a nested solve.
    coarser: Option<Box<SurfaceWorkspace>>,
    /// Levels below this one the last solve in this workspace went through (0: none).
    levels: usize,
}

impl SurfaceWorkspace {
    /// 2-D FFT pairs (operator applications) applied with this workspace so far, all solves
    /// together, the coarser levels' not included: the cost counter of `benches/surface.rs`.
    pub fn fft_pairs(&self) -> u64 {
        match &self.inner {
            Inner::Empty => 0,
            Inner::Periodic(w) => SurfacePeriodic::fft_pairs(w.scratch()),
            Inner::Finite(w) => SurfaceFinite::fft_pairs(w.scratch()),
        }
    }

    /// Of [`SurfaceWorkspace::fft_pairs`], those applied in single precision (the preconditioner;
    /// for the periodic model also the rough sweeps' and loose tolerances' C d: `crate::solver::cg`).
    pub fn low_precision_pairs(&self) -> u64 {
        match &self.inner {
            Inner::Empty => 0,
            Inner::Periodic(w) => w.scratch().low_pairs(),
            Inner::Finite(w) => w.scratch().low_pairs(),
        }
    }

    /// Points of the grid this workspace's vectors were last sized for (0: none yet).
    fn len(&self) -> usize {
        match &self.inner {
            Inner::Empty => 0,
            Inner::Periodic(w) => w.len(),
            Inner::Finite(w) => w.len(),
        }
    }

    /// [`SurfaceWorkspace::fft_pairs`] plus those of the coarser levels of nested solves, each
    /// counted as its share of a pair of this grid (points of the level over points of this one).
    pub fn fft_pairs_equivalent(&self) -> f64 {
        let top = self.len().max(1) as f64;
        let mut total = self.fft_pairs() as f64;
        let mut level = self.coarser.as_deref();
        while let Some(w) = level {
            total += w.fft_pairs() as f64 * w.len() as f64 / top;
            level = w.coarser.as_deref();
        }
        total
    }

    /// The coarser levels the last solve in this workspace started from (0: a cold or warm start
    /// without nesting).
    pub fn nested_levels(&self) -> usize {
        self.levels
    }
}

#[derive(Default)]
enum Inner {
    #[default]
    Empty,
    Periodic(cg::Work<SurfacePeriodicScratch>),
    Finite(cg::Work<SurfaceFiniteScratch>),
}

/// The solver for one grid and model: the kernel (built once) and FFT plans, shared by every
/// surface, modulus and thread.
pub struct SurfaceSolver {
    grid: Grid,
    options: SolverOptions,
    model: Model,
    /// Cold CG solves of at least this many points start from the nested guess.
    nested_min: usize,
    /// The solver of the next coarser level (2 x 2 blocks, or 1 x 2 / 2 x 1 with an odd side, at
    /// the tolerance [`NESTED_TOL`]), built on first use.
    coarser: std::sync::OnceLock<Box<SurfaceSolver>>,
    /// Bound-constrained CG steps from a warm start before the sweeps.
    warm_steps: usize,
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
        Ok(Self { grid, options, model, nested_min: NESTED_MIN_POINTS, coarser: std::sync::OnceLock::new(), warm_steps: WARM_START_STEPS })
    }

    /// The same solver with nested initial guesses for cold CG solves of at least `min_points`
    /// points (default [`NESTED_MIN_POINTS`]; `usize::MAX` never nests).
    pub fn with_nested_min_points(mut self, min_points: usize) -> Self {
        self.nested_min = min_points;
        self.coarser = std::sync::OnceLock::new();
        self
    }

    /// The same solver with `steps` bound-constrained CG steps from a warm start before the sweeps
    /// (default [`WARM_START_STEPS`]; 0: the sweeps start on the guess's contact set).
    pub fn with_warm_start_steps(mut self, steps: usize) -> Self {
        self.warm_steps = steps;
        self
    }

    /// The solver of the next coarser level and how the grid is coarsened to it, when a cold
    /// solve nests.
    fn coarser(&self) -> Option<(&SurfaceSolver, Blocks)> {
        let Grid { ny, nx, dx, dy } = self.grid;
        if self.options.method != Method::ConjugateGradient || self.grid.len() < self.nested_min {
            return None;
        }
        let blocks = Blocks::grid(ny, nx, MIN_SIDE)?;
        let level = self.coarser.get_or_init(|| {
            let (cy, cx) = blocks.coarse_shape();
            let grid = Grid { ny: cy, nx: cx, dx: dx * blocks.fx as f64, dy: dy * blocks.fy as f64 };
            let options = SolverOptions { tol: self.options.tol.max(NESTED_TOL), ..self.options };
            let solver = SurfaceSolver::new(grid, options).expect("a valid solver on the coarser grid");
            Box::new(solver.with_nested_min_points(self.nested_min))
        });
        Some((level, blocks))
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
    /// e.g. the solution under another modulus) when given; ignored by the direct method. A cold
    /// CG solve of at least [`NESTED_MIN_POINTS`] points starts from the nested guess (the 2 x 2
    /// block-averaged surface solved first, see `crate::solver::nested`).
    pub fn solve_from(
        &self,
        workspace: &mut SurfaceWorkspace,
        heights: &[f64],
        material: Material,
        mean_pressure: f64,
        initial_pressure: Option<&[f64]>,
    ) -> Result<ContactSolution> {
        validate_surface(&self.grid, heights, mean_pressure)?;
        let e_star = material.plane_strain_modulus();
        let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let z: Vec<f64> = heights.iter().map(|&h| h - top).collect();
        let strain = mean_pressure / e_star;
        let Grid { ny, nx, dx, dy } = self.grid;
        check_strain(strain, (nx as f64 * dx).max(ny as f64 * dy))?;
        let scale = self.height_scale(&z, strain);
        workspace.levels = 0;
        let outcome = match (self.options.method, &self.model) {
            (Method::ConjugateGradient, _) => match initial_pressure {
                Some(q) => {
                    let initial: Vec<f64> = q.iter().map(|&x| x / e_star).collect();
                    self.solve_cg(workspace, &z, strain, scale, Some(&initial), self.warm_steps)
                }
                None => {
                    let guess = self.nested_guess(workspace, &z, strain);
                    self.solve_cg(workspace, &z, strain, scale, guess.as_deref(), NESTED_GUESS_STEPS)
                }
            },
            (Method::Direct, Model::Periodic(op)) => direct::solve(op, &z, strain, scale, self.options.tol)?,
            (Method::Direct, Model::Finite(op)) => direct::solve(op, &z, strain, scale, self.options.tol)?,
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

    /// The residual's height scale (m) of heights `z` relative to their top: peak-to-valley, or
    /// P sqrt(Lx Ly) / E* for a flat surface.
    fn height_scale(&self, z: &[f64], strain: f64) -> f64 {
        let Grid { ny, nx, dx, dy } = self.grid;
        let range = -z.iter().copied().fold(f64::INFINITY, f64::min);
        let (lx, ly) = (nx as f64 * dx, ny as f64 * dy);
        let load_scale = strain * (lx * ly).sqrt();
        if range > 1e-9 * load_scale {
            range
        } else {
            load_scale
        }
    }

    /// The CG solve of heights `z` (m, relative to the top) under mean strain P / E*, to this
    /// solver's tolerance, from `initial` (pressure / E*) when given (with `guess_steps`
    /// bound-constrained steps from it first), in `workspace`.
    fn solve_cg(
        &self,
        workspace: &mut SurfaceWorkspace,
        z: &[f64],
        strain: f64,
        scale: f64,
        initial: Option<&[f64]>,
        guess_steps: usize,
    ) -> Outcome {
        let n = self.grid.len();
        let problem = cg::Problem {
            z,
            mean_strain: strain,
            scale,
            tol: self.options.tol,
            max_iterations: self.options.max_iterations,
            warm_up: Some(warm_up_steps(n)),
            guess_steps,
        };
        match &self.model {
            Model::Periodic(op) => {
                if !matches!(&workspace.inner, Inner::Periodic(w) if w.len() == n) {
                    workspace.inner = Inner::Periodic(cg::Work::new(op));
                }
                let Inner::Periodic(work) = &mut workspace.inner else { unreachable!() };
                cg::solve(op, None, &problem, initial, work)
            }
            Model::Finite(op) => {
                if !matches!(&workspace.inner, Inner::Finite(w) if w.len() == n) {
                    workspace.inner = Inner::Finite(cg::Work::new(op));
                }
                let Inner::Finite(work) = &mut workspace.inner else { unreachable!() };
                cg::solve(op, None, &problem, initial, work)
            }
        }
    }

    /// The nested initial guess (pressure / E*) for a cold solve of `z` (m, relative to the top)
    /// under mean strain P / E*: the coarser level's solution (itself started from the levels
    /// below it) prolonged to this grid; None when this level does not nest.
    fn nested_guess(&self, workspace: &mut SurfaceWorkspace, z: &[f64], strain: f64) -> Option<Vec<f64>> {
        let (coarser, blocks) = self.coarser()?;
        let z_coarse = nested::restrict(z, blocks);
        let scale = coarser.height_scale(&z_coarse, strain);
        let below = workspace.coarser.get_or_insert_with(Default::default);
        below.levels = 0;
        let guess = coarser.nested_guess(below, &z_coarse, strain);
        let outcome = coarser.solve_cg(below, &z_coarse, strain, scale, guess.as_deref(), NESTED_GUESS_STEPS);
        workspace.levels = 1 + below.levels;
        Some(nested::prolong(&outcome.pressure, blocks))
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
    let start = if warm_start { Start::Chained } else { Start::Nested };
    solve_tiles(tiles, grid, youngs_moduli, poisson, mean_pressure, options, threads, start)
}

/// How each problem of a batch starts.
#[derive(Clone, Copy)]
enum Start<'a> {
    /// Every (tile, modulus) from its own nested start, in parallel.
    Nested,
    /// Each tile's moduli in order, each from the previous one's answer.
    Chained,
    /// Every (tile, modulus) from its own pressure (Pa, tile-major, each ny x nx), in parallel.
    Given(&'a [f64]),
}

/// [`solve_surfaces`]' and [`solve_surfaces_from`]'s body.
#[allow(clippy::too_many_arguments)]
fn solve_tiles(
    tiles: &[f64],
    grid: Grid,
    youngs_moduli: &[f64],
    poisson: f64,
    mean_pressure: f64,
    options: SolverOptions,
    threads: Option<usize>,
    start: Start<'_>,
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
    let initial = match start {
        Start::Given(initial) => {
            let problems = format!("{count} tiles x {} moduli x {} points", materials.len(), grid.len());
            crate::batch::check_initial_pressure(initial, count * materials.len() * grid.len(), &problems)?;
            Some(initial)
        }
        Start::Nested | Start::Chained => None,
    };
    for t in 0..count {
        validate_surface(&grid, tile(t), mean_pressure).map_err(|e| ContactError::InvalidInput(format!("tile {t}: {e}")))?;
    }
    let solver = SurfaceSolver::new(grid, options)?;
    let named = |e: ContactError, t: usize, m: &Material| match e {
        ContactError::InvalidInput(msg) => ContactError::InvalidInput(format!("tile {t}, youngs_modulus {:e}: {msg}", m.youngs_modulus)),
        other => other,
    };
    let run = || -> Result<Vec<ContactSolution>> {
        if matches!(start, Start::Chained) {
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
                let guess = initial.map(|all| &all[job * grid.len()..(job + 1) * grid.len()]);
                solver.solve_from(workspace, tile(t), *m, mean_pressure, guess).map_err(|e| named(e, t, m))
            })
            .collect()
    };
    crate::batch::in_pool(threads, run)
}

/// [`solve_surfaces`] without the chain, each (tile, modulus) problem started from its own
/// pressure in `initial` (Pa, tile-major like the results: `tile * moduli.len() + modulus`, each
/// row-major ny x nx), e.g. an answer at a looser tolerance carried on to a tighter one.
#[allow(clippy::too_many_arguments)]
pub fn solve_surfaces_from(
    tiles: &[f64],
    grid: Grid,
    youngs_moduli: &[f64],
    poisson: f64,
    mean_pressure: f64,
    options: SolverOptions,
    threads: Option<usize>,
    initial: &[f64],
) -> Result<Vec<ContactSolution>> {
    solve_tiles(tiles, grid, youngs_moduli, poisson, mean_pressure, options, threads, Start::Given(initial))
}
