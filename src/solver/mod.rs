//! Tyre/road contact solvers for a rigid road profile pressed into an elastic half-space under a
//! prescribed mean pressure (load control).
//!
//! The discrete problem, with E* = E / (1 - nu^2), heights z (m), element pressures p (Pa) and the
//! compliance C (m/Pa, E* = 1 scaled by 1/E*):
//!
//!   s = C p / E* + h          (rubber surface, h the rigid approach)
//!   s >= z,  p >= 0,  p (s - z) = 0,  mean(p) = P.
//!
//! Two solvers: preconditioned constrained conjugate gradients ([`cg`]) for any N, and a dense
//! active-set solve with Cholesky factors ([`direct`]) for small N, the independent check.

pub mod cg;
mod deflation;
pub mod direct;
mod factor;
mod far_field;
pub mod nested;
mod reduce;
mod wide;

use crate::compliance::{Compliance, FiniteCompliance, FiniteScratch, PeriodicCompliance, PeriodicScratch};
use crate::error::{invalid, Result};
use crate::kernel::KernelKind;
use deflation::PairSums;
use far_field::Singular;
pub use wide::{set_wide_vectors, wide_vectors};

/// Fewest elements a profile may have: below this the discrete model says nothing useful.
pub const MIN_ELEMENTS: usize = 8;
/// Largest N accepted by the dense direct solver (its cost grows as N^3).
pub const MAX_DIRECT_ELEMENTS: usize = 8192;

/// The rubber: Young's modulus E (Pa) and Poisson ratio nu.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub youngs_modulus: f64,
    pub poisson: f64,
}

impl Material {
    pub fn new(youngs_modulus: f64, poisson: f64) -> Result<Self> {
        if !(youngs_modulus.is_finite() && youngs_modulus > 0.0) {
            return invalid(format!("youngs_modulus must be a positive finite number of pascals, got {youngs_modulus}"));
        }
        check_magnitude("youngs_modulus", youngs_modulus, "Pa")?;
        if !(poisson.is_finite() && poisson > -1.0 && poisson <= 0.5) {
            return invalid(format!("poisson must lie in (-1, 0.5], got {poisson}"));
        }
        Ok(Self { youngs_modulus, poisson })
    }

    /// E* = E / (1 - nu^2), the plane-strain modulus (Pa).
    pub fn plane_strain_modulus(&self) -> f64 {
        self.youngs_modulus / (1.0 - self.poisson * self.poisson)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Preconditioned constrained conjugate gradients on the FFT-applied kernel.
    ConjugateGradient,
    /// Dense active-set solve with Cholesky factors; N <= MAX_DIRECT_ELEMENTS.
    Direct,
}

/// How the problem is discretised and solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverOptions {
    /// Periodic (INRETS, default) or finite-sample model.
    pub periodic: bool,
    pub kernel: KernelKind,
    pub method: Method,
    /// Stop when the residual (see [`residual`]) is at most `tol`.
    pub tol: f64,
    pub max_iterations: usize,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self { periodic: true, kernel: KernelKind::Element, method: Method::ConjugateGradient, tol: 1e-10, max_iterations: 2000 }
    }
}

impl SolverOptions {
    pub fn validate(&self) -> Result<()> {
        if !(self.tol.is_finite() && self.tol > 0.0 && self.tol < 1.0) {
            return invalid(format!("tol must lie in (0, 1), got {}", self.tol));
        }
        if self.max_iterations == 0 {
            return invalid("max_iterations must be at least 1");
        }
        if !self.periodic && self.kernel == KernelKind::Spectral {
            return invalid("kernel='spectral' exists only for the periodic model (periodic=True)");
        }
        Ok(())
    }
}

/// The solution of one contact problem, in SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactSolution {
    /// Element pressures (Pa), >= 0, mean equal to the prescribed mean pressure.
    pub pressure: Vec<f64>,
    /// The rubber surface (m): >= heights, equal to them where in contact.
    pub envelope: Vec<f64>,
    /// Iterations the solver used (CG steps, or active-set sweeps for the direct solver).
    pub iterations: usize,
    /// The achieved residual, see [`residual`].
    pub residual: f64,
    pub converged: bool,
}

impl ContactSolution {
    pub fn in_contact(&self) -> impl Iterator<Item = bool> + '_ {
        self.pressure.iter().map(|&p| p > 0.0)
    }
}

wide::wide_fn! {
/// Convergence measure shared by all solvers, dimensionless:
///
///   residual = max( max_{p > 0} |s - z|,  max_{p = 0} max(0, z - s) ) / height_scale
///
/// i.e. the worst gap left open on the contact set and the worst penetration off it, relative to
/// the profile's peak-to-valley height (or to P L / E* for a flat profile). Load balance is exact
/// by construction in every solver and is not part of the measure.
pub fn residual(pressure: &[f64], gap: &[f64], height_scale: f64) -> f64 {
    let violation = |p: f64, g: f64| if p > 0.0 { g.abs() } else { (-g).max(0.0) };
    let n = pressure.len().min(gap.len());
    let (p4, g4) = (pressure[..n].chunks_exact(4), gap[..n].chunks_exact(4));
    let tail = p4.remainder().iter().zip(g4.remainder()).fold(0.0_f64, |worst, (&p, &g)| worst.max(violation(p, g)));
    // Four running maxima (the same result, in a form that vectorises).
    let mut worst = [0.0_f64; 4];
    for (p, g) in p4.zip(g4) {
        for k in 0..4 {
            worst[k] = worst[k].max(violation(p[k], g[k]));
        }
    }
    worst[0].max(worst[1]).max(worst[2].max(worst[3])).max(tail) / height_scale
}
}

/// The height scale that makes [`residual`] dimensionless (m).
pub fn height_scale(heights: &[f64], mean_pressure_over_modulus: f64, dx: f64) -> f64 {
    let (lo, hi) = heights.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &z| (lo.min(z), hi.max(z)));
    let load_scale = mean_pressure_over_modulus * dx * heights.len() as f64;
    let range = hi - lo;
    if range > 1e-9 * load_scale {
        range
    } else {
        load_scale
    }
}

/// Checks one profile and its load; the messages name the argument at fault.
pub fn validate_problem(heights: &[f64], dx: f64, mean_pressure: f64) -> Result<()> {
    if heights.is_empty() {
        return invalid("heights is empty: a profile needs at least 8 points");
    }
    if heights.len() < MIN_ELEMENTS {
        return invalid(format!("heights has {} points: a profile needs at least {MIN_ELEMENTS}", heights.len()));
    }
    if let Some(i) = heights.iter().position(|z| !z.is_finite()) {
        return invalid(format!("heights contains a non-finite value ({}) at index {i}; interpolate drop-outs first", heights[i]));
    }
    if !(dx.is_finite() && dx > 0.0) {
        return invalid(format!("dx must be a positive finite number of metres, got {dx}"));
    }
    if !(mean_pressure.is_finite() && mean_pressure > 0.0) {
        return invalid(format!("mean_pressure must be a positive finite number of pascals, got {mean_pressure}"));
    }
    check_magnitude("dx", dx, "m")?;
    check_magnitude("mean_pressure", mean_pressure, "Pa")?;
    let largest = heights.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    if largest > MAGNITUDE_LIMIT {
        return invalid(format!(
            "heights reach {largest:e} m, beyond the {MAGNITUDE_LIMIT:e} the solver handles in double precision: check the units (m)"
        ));
    }
    Ok(())
}

/// Magnitudes (SI) within which every input combination is solved correctly in double precision
/// (heights, dx, E and P each from 1e-40 to 1e40, tests/fuzz_regressions.rs). Beyond, sums of
/// squares overflow or pressures underflow (fuzz findings F1, F2): such input is refused. Roads
/// are some 30 orders of magnitude inside.
pub const MAGNITUDE_LIMIT: f64 = 1e40;
/// The same for the magnitudes the solver forms: P / E* and P L / E*.
const DERIVED_LIMIT: f64 = 1e60;

/// The solver's own scales, the strain P / E* and the displacement it makes over the sample
/// length (m), must stay well inside double precision too (fuzz findings F1, F2 lay beyond 1e+-100).
pub(crate) fn check_strain(strain: f64, sample_length: f64) -> Result<()> {
    let displacement_scale = strain * sample_length;
    if !(DERIVED_LIMIT.recip()..=DERIVED_LIMIT).contains(&strain) || !(DERIVED_LIMIT.recip()..=DERIVED_LIMIT).contains(&displacement_scale)
    {
        return invalid(format!(
            "mean_pressure / E* = {strain:e} (over the sample {displacement_scale:e} m) is beyond what double precision carries \
             through the solve: check the units of mean_pressure and youngs_modulus (Pa) and dx (m)"
        ));
    }
    Ok(())
}

pub(crate) fn check_magnitude(name: &str, value: f64, unit: &str) -> Result<()> {
    if !(1.0 / MAGNITUDE_LIMIT..=MAGNITUDE_LIMIT).contains(&value) {
        return invalid(format!(
            "{name} = {value:e} {unit} is outside the {:e} to {MAGNITUDE_LIMIT:e} {unit} the solver handles in double precision: check the units",
            1.0 / MAGNITUDE_LIMIT
        ));
    }
    Ok(())
}

/// A last guard: a solution must be finite and carry the load. Inside the accepted magnitudes this
/// always holds; it is checked so that no rounding accident can ever come back flagged converged.
pub(crate) fn check_solution(solution: &ContactSolution, mean_pressure: f64) -> Result<()> {
    let n = solution.pressure.len() as f64;
    let balance = solution.pressure.iter().sum::<f64>() / (n * mean_pressure) - 1.0;
    let finite = solution.pressure.iter().chain(&solution.envelope).all(|v| v.is_finite()) && solution.residual.is_finite();
    if finite && balance.abs() <= 1e-9 {
        return Ok(());
    }
    invalid(format!(
        "the solve lost double precision (NaN, or a pressure that does not carry the load: balance error {balance:e}); check the units (m, Pa)"
    ))
}

/// The solver for one (N, dx, model): builds the kernel and FFT plans once, then solves any number
/// of profiles of that size, for any modulus, from any thread.
pub struct ContactSolver {
    n: usize,
    dx: f64,
    options: SolverOptions,
    model: Model,
    /// Interval sums of the kernel for the CG solver's coarse space (None for the direct solver).
    pair_sums: Option<PairSums>,
    /// Cold CG solves of at least this many points start from the nested guess ([`nested`]).
    nested_min: usize,
    /// The solver of the next coarser level (N / 2, dx * 2, the tolerance [`nested::NESTED_TOL`]),
    /// built on first use.
    coarser: std::sync::OnceLock<Box<ContactSolver>>,
}

enum Model {
    Periodic(PeriodicCompliance),
    Finite(FiniteCompliance),
}

/// Work vectors and FFT scratch of one thread for [`ContactSolver::solve_in`]: reusing one across
/// solves saves their allocation. Results do not depend on what a workspace held before.
#[derive(Default)]
pub struct Workspace {
    inner: WorkspaceInner,
    /// The workspace of the next coarser level of a nested solve.
    coarser: Option<Box<Workspace>>,
    /// Levels below this one the last solve in this workspace went through (0: none).
    levels: usize,
}

impl Workspace {
    /// FFT pairs (circulant products, one forward and one inverse real FFT each) the solves in
    /// this workspace have applied since it was (re)allocated: the cost counter of the benchmarks.
    pub fn fft_pairs(&self) -> u64 {
        match &self.inner {
            WorkspaceInner::Empty => 0,
            WorkspaceInner::Periodic(w) => PeriodicCompliance::fft_pairs(w.scratch()),
            WorkspaceInner::Finite(w) => FiniteCompliance::fft_pairs(w.scratch()),
        }
    }

    /// Of [`Workspace::fft_pairs`], those applied in single precision: the steering products of
    /// tolerances at or above `cg`'s low-precision bound (1e-5) with the periodic model; none
    /// below it, nor with the finite model.
    pub fn low_precision_pairs(&self) -> u64 {
        match &self.inner {
            WorkspaceInner::Periodic(w) => w.scratch().low_pairs(),
            WorkspaceInner::Empty | WorkspaceInner::Finite(_) => 0,
        }
    }

    /// [`Workspace::fft_pairs`] plus those of the coarser levels of nested solves, each counted as
    /// its share of a pair of this size (N_level / N): what the benchmarks compare with the floor.
    pub fn fft_pairs_equivalent(&self) -> f64 {
        let mut total = self.fft_pairs() as f64;
        let (mut level, mut weight) = (self.coarser.as_deref(), 1.0);
        while let Some(w) = level {
            weight *= 0.5;
            total += weight * w.fft_pairs() as f64;
            level = w.coarser.as_deref();
        }
        total
    }

    /// The coarser levels the last solve in this workspace started from (0: a cold or warm start
    /// without nesting, see [`nested`]).
    pub fn nested_levels(&self) -> usize {
        self.levels
    }
}

#[derive(Default)]
enum WorkspaceInner {
    #[default]
    Empty,
    Periodic(cg::Work<PeriodicScratch>),
    Finite(cg::Work<FiniteScratch>),
}

impl ContactSolver {
    pub fn new(n: usize, dx: f64, options: SolverOptions) -> Result<Self> {
        options.validate()?;
        if n < MIN_ELEMENTS {
            return invalid(format!("a profile needs at least {MIN_ELEMENTS} points, got {n}"));
        }
        if !(dx.is_finite() && dx > 0.0) {
            return invalid(format!("dx must be a positive finite number of metres, got {dx}"));
        }
        if options.method == Method::Direct && n > MAX_DIRECT_ELEMENTS {
            return invalid(format!(
                "method='direct' is a dense check limited to {MAX_DIRECT_ELEMENTS} points (O(N^3)); got {n}: use method='cg'"
            ));
        }
        let model = if options.periodic {
            Model::Periodic(PeriodicCompliance::new(n, dx, options.kernel))
        } else {
            Model::Finite(FiniteCompliance::new(n, dx))
        };
        // The CG solver's coarse space takes its matrix from these sums and its products from the
        // model's operator: both must come from the same kernel (cg::solve relies on it).
        // The far field of the coarse matrix needs a kernel smooth between integers: the element
        // kernels are (logarithms, Clausen functions), the sampled spectral one is not (see
        // deflation's far_field).
        let pair_sums = (options.method == Method::ConjugateGradient).then(|| match &model {
            Model::Periodic(op) => {
                let far = (options.kernel == KernelKind::Element).then_some(Singular::Periodic);
                PairSums::new(n, |d| op.kernel_at(d), far)
            }
            Model::Finite(op) => PairSums::new(n, |d| op.kernel_at(d), Some(Singular::AtZero)),
        });
        Ok(Self { n, dx, options, model, pair_sums, nested_min: nested::NESTED_MIN_ELEMENTS, coarser: std::sync::OnceLock::new() })
    }

    /// The same solver with nested initial guesses for cold CG solves of at least `min_elements`
    /// points (default [`nested::NESTED_MIN_ELEMENTS`]; `usize::MAX` never nests).
    pub fn with_nested_min_elements(mut self, min_elements: usize) -> Self {
        self.nested_min = min_elements;
        self.coarser = std::sync::OnceLock::new();
        self
    }

    /// The solver of the next coarser level, when a cold solve nests.
    fn coarser(&self) -> Option<&ContactSolver> {
        if self.options.method != Method::ConjugateGradient || !nested::nests(self.n, self.nested_min) {
            return None;
        }
        let level = self.coarser.get_or_init(|| {
            let options = SolverOptions { tol: self.options.tol.max(nested::NESTED_TOL), ..self.options };
            let solver = ContactSolver::new(self.n / 2, 2.0 * self.dx, options).expect("a valid solver at half the size");
            Box::new(solver.with_nested_min_elements(self.nested_min))
        });
        Some(level)
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    pub fn options(&self) -> &SolverOptions {
        &self.options
    }

    /// Solves one profile (heights in m) for one rubber under mean pressure (Pa).
    pub fn solve(&self, heights: &[f64], material: Material, mean_pressure: f64) -> Result<ContactSolution> {
        self.solve_in(&mut Workspace::default(), heights, material, mean_pressure)
    }

    /// [`ContactSolver::solve`] with the work vectors of `workspace` (allocated on first use and
    /// kept for the next call); the result is bitwise the same.
    pub fn solve_in(&self, workspace: &mut Workspace, heights: &[f64], material: Material, mean_pressure: f64) -> Result<ContactSolution> {
        self.solve_from(workspace, heights, material, mean_pressure, None)
    }

    /// [`ContactSolver::solve_in`] started from `initial_pressure` (Pa, one per point), typically
    /// the solution of the same profile under another modulus: the CG sweeps begin on its contact
    /// set. The result meets the same tolerance; it differs from a cold start only within it.
    /// Ignored by the direct method.
    pub fn solve_from(
        &self,
        workspace: &mut Workspace,
        heights: &[f64],
        material: Material,
        mean_pressure: f64,
        initial_pressure: Option<&[f64]>,
    ) -> Result<ContactSolution> {
        if heights.len() != self.n {
            return invalid(format!("heights has {} points, the solver was built for {}", heights.len(), self.n));
        }
        validate_problem(heights, self.dx, mean_pressure)?;
        let e_star = material.plane_strain_modulus();
        // Work in pressure / E* (a strain) and in heights relative to the highest point, so that
        // absolute offsets (a profile at 0.1 m) cost no digits.
        let top = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let z: Vec<f64> = heights.iter().map(|&h| h - top).collect();
        let strain = mean_pressure / e_star;
        check_strain(strain, self.dx * self.n as f64)?;
        let scale = height_scale(&z, strain, self.dx);
        workspace.levels = 0;
        let outcome = match (self.options.method, &self.model) {
            (Method::ConjugateGradient, _) => {
                // A warm start keeps its guess; a cold one starts from the coarser levels when N
                // is large enough (see [`nested`]).
                let initial: Option<Vec<f64>> = match initial_pressure {
                    Some(q) => Some(q.iter().map(|&x| x / e_star).collect()),
                    None => self.nested_guess(workspace, &z, strain),
                };
                self.solve_cg(workspace, &z, strain, scale, initial.as_deref())
            }
            (Method::Direct, Model::Periodic(op)) => direct::solve(op, &z, strain, scale, self.options.tol)?,
            (Method::Direct, Model::Finite(op)) => direct::solve(op, &z, strain, scale, self.options.tol)?,
        };
        let pressure = outcome.pressure.iter().map(|&q| q * e_star).collect();
        let envelope = outcome
            .gap
            .iter()
            .zip(heights)
            .zip(&outcome.pressure)
            // On contact the surface is the profile itself; the residual gap there is solver error.
            .map(|((&g, &h), &q)| if q > 0.0 { h } else { h + g.max(0.0) })
            .collect();
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

    /// The CG solve of heights `z` (m, relative to the top) under mean strain P / E*, to this
    /// solver's tolerance, from `initial` (pressure / E*) when given, in `workspace`.
    fn solve_cg(&self, workspace: &mut Workspace, z: &[f64], strain: f64, scale: f64, initial: Option<&[f64]>) -> Outcome {
        let pair_sums = Some(self.pair_sums.as_ref().expect("built for the CG method"));
        let problem = cg::Problem {
            z,
            mean_strain: strain,
            scale,
            tol: self.options.tol,
            max_iterations: self.options.max_iterations,
            warm_up: None,
            guess_steps: 0,
        };
        match &self.model {
            Model::Periodic(op) => {
                if !matches!(&workspace.inner, WorkspaceInner::Periodic(w) if w.len() == self.n) {
                    workspace.inner = WorkspaceInner::Periodic(cg::Work::new(op));
                }
                let WorkspaceInner::Periodic(work) = &mut workspace.inner else { unreachable!() };
                cg::solve(op, pair_sums, &problem, initial, work)
            }
            Model::Finite(op) => {
                if !matches!(&workspace.inner, WorkspaceInner::Finite(w) if w.len() == self.n) {
                    workspace.inner = WorkspaceInner::Finite(cg::Work::new(op));
                }
                let WorkspaceInner::Finite(work) = &mut workspace.inner else { unreachable!() };
                cg::solve(op, pair_sums, &problem, initial, work)
            }
        }
    }

    /// The nested initial guess (pressure / E*) for a cold solve of `z` (m, relative to the top)
    /// under mean strain P / E*: the coarser level's solution (itself started from the levels
    /// below it) prolonged to this one; None when this level does not nest.
    fn nested_guess(&self, workspace: &mut Workspace, z: &[f64], strain: f64) -> Option<Vec<f64>> {
        let coarser = self.coarser()?;
        let blocks = nested::Blocks::line(self.n);
        let z_coarse = nested::restrict(z, blocks);
        let scale = height_scale(&z_coarse, strain, coarser.dx);
        let below = workspace.coarser.get_or_insert_with(Default::default);
        below.levels = 0;
        let guess = coarser.nested_guess(below, &z_coarse, strain);
        let outcome = coarser.solve_cg(below, &z_coarse, strain, scale, guess.as_deref());
        workspace.levels = 1 + below.levels;
        Some(nested::prolong(&outcome.pressure, blocks))
    }
}

/// What a solver returns, in pressure / E* units and heights relative to the top.
pub(crate) struct Outcome {
    pub pressure: Vec<f64>,
    /// s - z: the gap between rubber surface and profile.
    pub gap: Vec<f64>,
    pub iterations: usize,
    pub residual: f64,
    pub converged: bool,
}

/// Solves one profile: builds a [`ContactSolver`] for it and calls it once.
pub fn solve(heights: &[f64], dx: f64, material: Material, mean_pressure: f64, options: SolverOptions) -> Result<ContactSolution> {
    validate_problem(heights, dx, mean_pressure)?;
    ContactSolver::new(heights.len(), dx, options)?.solve(heights, material, mean_pressure)
}
