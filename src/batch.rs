//! Many segments, many moduli: one kernel and one set of FFT plans for all, the (segment, modulus)
//! problems solved in parallel with rayon. Every problem is solved by the same sequential code as a
//! one-by-one call, so results are bitwise identical whatever the thread count.

use rayon::prelude::*;

use crate::coarse_start::CoarseStart;
use crate::continuation::next_modulus_guess;
use crate::error::{invalid, ContactError, Result};
use crate::solver::{validate_problem, ContactSolution, ContactSolver, Material, Method, SolverOptions, Workspace};

/// Segments of equal length N, stored row after row.
#[derive(Clone, Copy, Debug)]
pub struct Segments<'a> {
    pub heights: &'a [f64],
    pub len: usize,
}

impl Segments<'_> {
    pub fn count(&self) -> usize {
        self.heights.len() / self.len
    }

    pub fn row(&self, i: usize) -> &[f64] {
        &self.heights[i * self.len..(i + 1) * self.len]
    }
}

/// Names the problem an error came from.
fn in_problem(error: ContactError, segment: usize, material: Material) -> ContactError {
    match error {
        ContactError::InvalidInput(message) => {
            ContactError::InvalidInput(format!("segment {segment}, youngs_modulus {:e}: {message}", material.youngs_modulus))
        }
        other => other,
    }
}

/// The checks every batch makes at the door, the moduli as materials, and the one solver (kernel,
/// FFT plans) all the problems share.
fn prepare(
    segments: Segments<'_>,
    dx: f64,
    youngs_moduli: &[f64],
    poisson: f64,
    mean_pressure: f64,
    options: SolverOptions,
) -> Result<(Vec<Material>, ContactSolver)> {
    if segments.len == 0 || segments.heights.is_empty() {
        return invalid("segments is empty: give a 2-D array with one profile per row");
    }
    if segments.heights.len() % segments.len != 0 {
        return invalid("segments must hold whole rows of equal length");
    }
    if youngs_moduli.is_empty() {
        return invalid("youngs_modulus is empty: give one or more moduli in pascals");
    }
    let materials: Vec<Material> = youngs_moduli.iter().map(|&e| Material::new(e, poisson)).collect::<Result<_>>()?;
    for s in 0..segments.count() {
        validate_problem(segments.row(s), dx, mean_pressure).map_err(|e| ContactError::InvalidInput(format!("segment {s}: {e}")))?;
    }
    Ok((materials, ContactSolver::new(segments.len, dx, options)?))
}

/// Solves every (segment, modulus) pair; results are ordered segment-major: index
/// `segment * moduli.len() + modulus`. `threads = None` uses rayon's global pool.
///
/// With `warm_start`, each segment's moduli are solved in the order given, each CG solve starting
/// from the previous modulus's converged solution (see [`ContactSolver::solve_from`]; shifted
/// down to a smaller contact set for a stiffer rubber, [`next_modulus_guess`]): fewer sweeps, results within the tolerance of cold solves and still bitwise the same whatever the
/// thread count. Without it every result is bitwise that of a one-by-one solve.
///
/// With `coarse_start = Some(k)` (k >= 2), the segments are model grids k times finer than the
/// data (every k-th point a reading): each segment's first modulus (every modulus without
/// `warm_start`) starts from the data grid's answer, the readings solved first and their pressure
/// prolonged ([`crate::coarse_start`]). Results meet the tolerance by the same test and are
/// bitwise the same whatever the thread count.
#[allow(clippy::too_many_arguments)]
pub fn solve_many(
    segments: Segments<'_>,
    dx: f64,
    youngs_moduli: &[f64],
    poisson: f64,
    mean_pressure: f64,
    options: SolverOptions,
    threads: Option<usize>,
    warm_start: bool,
    coarse_start: Option<usize>,
) -> Result<Vec<ContactSolution>> {
    let (materials, solver) = prepare(segments, dx, youngs_moduli, poisson, mean_pressure, options)?;
    // The direct method ignores initial pressures: no coarse level to solve for it.
    let coarse = match coarse_start {
        Some(k) if options.method == Method::ConjugateGradient => CoarseStart::new(segments.len, dx, k, options)?,
        Some(0) => return invalid("coarse_start must be a whole number of at least 1 (the model grid's refinement k)"),
        _ => None,
    };
    let jobs = segments.count() * materials.len();
    // The initial pressure of a solve without a previous modulus to start from: the data grid's
    // answer prolonged, or None (cold).
    let first_guess = |workspaces: &mut (Workspace, Workspace), s: usize, material: Material| -> Result<Option<Vec<f64>>> {
        let Some(coarse) = coarse.as_ref() else { return Ok(None) };
        let solution =
            coarse.solve(&mut workspaces.1, segments.row(s), material, mean_pressure, None).map_err(|e| in_problem(e, s, material))?;
        Ok(Some(coarse.prolong(&solution.pressure)))
    };
    let run = || {
        if warm_start {
            // One job per segment, its moduli in the order given, each started from the last.
            let per_segment = (0..segments.count())
                .into_par_iter()
                .map_init(Default::default, |workspaces: &mut (Workspace, Workspace), s| {
                    let mut chain: Vec<ContactSolution> = Vec::with_capacity(materials.len());
                    for (m, &material) in materials.iter().enumerate() {
                        let guess = match chain.last() {
                            Some(last) if last.converged => Some(next_modulus_guess(&last.pressure, materials[m - 1], material)),
                            _ => first_guess(workspaces, s, material)?,
                        };
                        let solution = solver.solve_from(&mut workspaces.0, segments.row(s), material, mean_pressure, guess.as_deref());
                        chain.push(solution.map_err(|e| in_problem(e, s, material))?);
                    }
                    Ok(chain)
                })
                .collect::<Result<Vec<_>>>()?;
            return Ok(per_segment.into_iter().flatten().collect());
        }
        (0..jobs)
            .into_par_iter()
            // One workspace per rayon work item, reused across its jobs: results never depend on it.
            .map_init(Default::default, |workspaces: &mut (Workspace, Workspace), job| {
                let (s, m) = (job / materials.len(), job % materials.len());
                let guess = first_guess(workspaces, s, materials[m])?;
                solver
                    .solve_from(&mut workspaces.0, segments.row(s), materials[m], mean_pressure, guess.as_deref())
                    .map_err(|e| in_problem(e, s, materials[m]))
            })
            .collect::<Result<Vec<_>>>()
    };
    in_pool(threads, run)
}

/// [`solve_many`] with every (segment, modulus) problem started from its own initial pressure (Pa):
/// `initial` holds one row of `segments.len` values per problem, segment-major as the results
/// (row `segment * moduli.len() + modulus`), typically the answer of the same problems on a
/// neighbouring road (the same readings joined otherwise) or grid. Every result meets the
/// tolerance by the same test as a cold solve, and is bitwise the same whatever the thread count.
/// The direct method ignores initial pressures.
#[allow(clippy::too_many_arguments)]
pub fn solve_many_from(
    segments: Segments<'_>,
    dx: f64,
    youngs_moduli: &[f64],
    poisson: f64,
    mean_pressure: f64,
    options: SolverOptions,
    threads: Option<usize>,
    initial: &[f64],
) -> Result<Vec<ContactSolution>> {
    let (materials, solver) = prepare(segments, dx, youngs_moduli, poisson, mean_pressure, options)?;
    let jobs = segments.count() * materials.len();
    let problems = format!("{} segments x {} moduli x {} points", segments.count(), materials.len(), segments.len);
    check_initial_pressure(initial, jobs * segments.len, &problems)?;
    let run = || {
        (0..jobs)
            .into_par_iter()
            .map_init(Workspace::default, |workspace, job| {
                let (s, m) = (job / materials.len(), job % materials.len());
                let guess = &initial[job * segments.len..(job + 1) * segments.len];
                solver
                    .solve_from(workspace, segments.row(s), materials[m], mean_pressure, Some(guess))
                    .map_err(|e| in_problem(e, s, materials[m]))
            })
            .collect::<Result<Vec<_>>>()
    };
    in_pool(threads, run)
}

/// `initial` (the problems' starting pressures, Pa) holds `needed` values (`problems` says of what)
/// and every one is finite and >= 0.
pub(crate) fn check_initial_pressure(initial: &[f64], needed: usize, problems: &str) -> Result<()> {
    if initial.len() != needed {
        return invalid(format!("initial_pressure holds {} values, the problems need {needed} ({problems})", initial.len()));
    }
    if let Some(bad) = initial.iter().position(|p| !p.is_finite() || *p < 0.0) {
        return invalid(format!("initial_pressure must be finite and >= 0 (Pa), value {bad} is {}", initial[bad]));
    }
    Ok(())
}

/// The process that loaded the module (set by the Python binding's module init).
static LOADED_IN: std::sync::OnceLock<u32> = std::sync::OnceLock::new();

/// Records the loading process, so that a forked child can tell it is one (see [`fork_safe`]).
pub fn note_loading_process() {
    LOADED_IN.get_or_init(std::process::id);
}

/// Runs `run` on rayon's global pool, or, in a child forked after the module was loaded, on a
/// fresh pool of as many threads: fork copies the global pool's state but not its threads, so
/// work handed to it in the child waited forever (multiprocessing's default on Linux after a
/// warm-up call in the parent).
pub(crate) fn fork_safe<T: Send>(run: impl FnOnce() -> T + Send) -> T {
    let forked = LOADED_IN.get().is_some_and(|pid| *pid != std::process::id());
    if !forked {
        return run();
    }
    // a pool that cannot start (no threads left) is reported as the core's failure, never a hang
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .build()
        .expect("cannot start a thread pool in a process forked after roadtex was loaded");
    pool.install(run)
}

/// Runs `run` on rayon's global pool (`threads` None; a fresh one in a forked child, see
/// [`fork_safe`]) or on a pool of `threads` threads: the batch functions' `threads` argument.
pub(crate) fn in_pool<T: Send>(threads: Option<usize>, run: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    match threads {
        None => fork_safe(run),
        Some(0) => invalid("threads must be at least 1"),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| ContactError::InvalidInput(format!("cannot start {t} threads: {e}")))?
            .install(run),
    }
}
