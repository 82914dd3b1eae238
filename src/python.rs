//! The pyo3 binding: thin wrappers that convert arrays, release the GIL around the numerical work,
//! and raise the classes of `roadtex.errors` (python/roadtex/errors.py) through `to_py_err`. Every
//! function's body runs in `guarded`, so a panic in the core (in `py.detach`, on a rayon thread)
//! reaches Python as `roadtex.errors.InternalError`, never as pyo3's PanicException.

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};

use numpy::ndarray::{Array2, Array3, Array4};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArray4, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4};
use pyo3::prelude::*;
use pyo3::types::PyType;

use crate::batch::{fork_safe, solve_many as solve_many_core, solve_many_from, Segments};
use crate::clapp::{clapp as clapp_core, ClappOptions};
use crate::envelope::von_meier as von_meier_core;
use crate::error::{invalid, ContactError, Result};
use crate::kernel::{fast_len, finite_coefficients, periodic_coefficients, periodic_spectrum, KernelKind};
use crate::reference::{FlatPunch, Westergaard};
use crate::solver::{ContactSolver, Material, Method, SolverOptions};
use crate::surface::{solve_surface as solve_surface_core, solve_surfaces, solve_surfaces_from, Grid};
use crate::synthetic::self_affine;

/// How a call into the core failed.
enum Failure {
    Core(ContactError),
    /// A panic, with its message: a bug.
    Panic(String),
}

impl From<ContactError> for Failure {
    fn from(err: ContactError) -> Self {
        Failure::Core(err)
    }
}

/// The one mapping from a failure to the Python exception raised: a class of `roadtex.errors`,
/// looked up by name (that module imports nothing from roadtex, so this cannot recurse).
fn to_py_err(py: Python<'_>, failure: impl Into<Failure>) -> PyErr {
    let (class, message) = match failure.into() {
        Failure::Core(ContactError::InvalidInput(message)) => ("InvalidInputError", message),
        Failure::Core(err @ ContactError::DirectSolverFailed(_)) => ("SolverError", err.to_string()),
        Failure::Core(err @ ContactError::ClappFailed(_)) => ("ClappError", err.to_string()),
        Failure::Panic(message) => ("InternalError", message),
    };
    let class = py.import("roadtex.errors").and_then(|errors| Ok(errors.getattr(class)?.cast_into::<PyType>()?));
    match class {
        Ok(class) => PyErr::from_type(class, message),
        // roadtex.errors itself is broken: raise that (an ImportError or AttributeError).
        Err(lookup_failed) => lookup_failed,
    }
}

/// Runs the body of a #[pyfunction], its numerical work included, catching any panic: a panic
/// becomes roadtex.errors.InternalError with the panic's message.
fn guarded<T>(py: Python<'_>, body: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|payload| Err(to_py_err(py, Failure::Panic(panic_message(&*payload)))))
}

/// The message of a panic (`panic!` gives a `&str` or a `String` payload).
fn panic_message(payload: &(dyn Any + Send)) -> String {
    match (payload.downcast_ref::<&str>(), payload.downcast_ref::<String>()) {
        (Some(message), _) => (*message).to_owned(),
        (None, Some(message)) => message.clone(),
        (None, None) => "the Rust core panicked (no message)".to_owned(),
    }
}

fn parse_kernel(kernel: &str) -> Result<KernelKind> {
    match kernel {
        "element" => Ok(KernelKind::Element),
        "spectral" => Ok(KernelKind::Spectral),
        other => invalid(format!("kernel must be 'element' or 'spectral', got {other:?}")),
    }
}

fn parse_method(method: &str) -> Result<Method> {
    match method {
        "cg" => Ok(Method::ConjugateGradient),
        "direct" => Ok(Method::Direct),
        other => invalid(format!("method must be 'cg' or 'direct', got {other:?}")),
    }
}

fn options(periodic: bool, kernel: &str, method: &str, tol: f64, max_iterations: usize) -> Result<SolverOptions> {
    let options = SolverOptions { periodic, kernel: parse_kernel(kernel)?, method: parse_method(method)?, tol, max_iterations };
    options.validate()?;
    Ok(options)
}

type Solved<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, usize, f64, bool);

/// One contact problem. Returns (pressure Pa, envelope m, iterations, residual, converged).
#[pyfunction]
#[pyo3(signature = (heights, dx, youngs_modulus, poisson, mean_pressure, periodic, kernel, method, tol, max_iterations))]
#[allow(clippy::too_many_arguments)]
fn solve<'py>(
    py: Python<'py>,
    heights: PyReadonlyArray1<'py, f64>,
    dx: f64,
    youngs_modulus: f64,
    poisson: f64,
    mean_pressure: f64,
    periodic: bool,
    kernel: &str,
    method: &str,
    tol: f64,
    max_iterations: usize,
) -> PyResult<Solved<'py>> {
    guarded(py, || {
        let options = options(periodic, kernel, method, tol, max_iterations).map_err(|e| to_py_err(py, e))?;
        let material = Material::new(youngs_modulus, poisson).map_err(|e| to_py_err(py, e))?;
        let heights = heights.as_slice()?.to_vec();
        let solution = py
            .detach(|| {
                fork_safe(|| {
                    crate::solver::validate_problem(&heights, dx, mean_pressure)?;
                    ContactSolver::new(heights.len(), dx, options)?.solve(&heights, material, mean_pressure)
                })
            })
            .map_err(|e| to_py_err(py, e))?;
        Ok((
            solution.pressure.into_pyarray(py),
            solution.envelope.into_pyarray(py),
            solution.iterations,
            solution.residual,
            solution.converged,
        ))
    })
}

type SolvedMany<'py> = (
    Bound<'py, PyArray3<f64>>,
    Bound<'py, PyArray3<f64>>,
    Bound<'py, PyArray2<u64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<bool>>,
);

/// Every (segment, modulus) pair in parallel. Arrays are indexed [segment, modulus, ...].
#[pyfunction]
#[pyo3(signature = (segments, dx, youngs_moduli, poisson, mean_pressure, periodic, kernel, method, tol, max_iterations, threads=None, warm_start=false, coarse_start=None, initial_pressure=None))]
#[allow(clippy::too_many_arguments)]
fn solve_many<'py>(
    py: Python<'py>,
    segments: PyReadonlyArray2<'py, f64>,
    dx: f64,
    youngs_moduli: PyReadonlyArray1<'py, f64>,
    poisson: f64,
    mean_pressure: f64,
    periodic: bool,
    kernel: &str,
    method: &str,
    tol: f64,
    max_iterations: usize,
    threads: Option<usize>,
    warm_start: bool,
    coarse_start: Option<usize>,
    initial_pressure: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<SolvedMany<'py>> {
    guarded(py, || {
        let options = options(periodic, kernel, method, tol, max_iterations).map_err(|e| to_py_err(py, e))?;
        let view = segments.as_array();
        let (count, len) = view.dim();
        let heights: Vec<f64> = view.iter().copied().collect();
        let moduli = youngs_moduli.as_slice()?.to_vec();
        let m = moduli.len();
        let segments = Segments { heights: &heights, len };
        // Each problem from its own start (rows segment-major), or cold / chained / coarse-started.
        let initial: Option<Vec<f64>> = initial_pressure.map(|a| a.as_array().iter().copied().collect());
        let solutions = py
            .detach(|| match &initial {
                Some(initial) => solve_many_from(segments, dx, &moduli, poisson, mean_pressure, options, threads, initial),
                None => solve_many_core(segments, dx, &moduli, poisson, mean_pressure, options, threads, warm_start, coarse_start),
            })
            .map_err(|e| to_py_err(py, e))?;
        let mut pressure = Vec::with_capacity(count * m * len);
        let mut envelope = Vec::with_capacity(count * m * len);
        let (mut iterations, mut residual, mut converged) = (Vec::new(), Vec::new(), Vec::new());
        for s in solutions {
            pressure.extend_from_slice(&s.pressure);
            envelope.extend_from_slice(&s.envelope);
            iterations.push(s.iterations as u64);
            residual.push(s.residual);
            converged.push(s.converged);
        }
        let shape3 = (count, m, len);
        let as3 = |v: Vec<f64>| Array3::from_shape_vec(shape3, v).expect("one row per solution");
        Ok((
            as3(pressure).into_pyarray(py),
            as3(envelope).into_pyarray(py),
            Array2::from_shape_vec((count, m), iterations).expect("one per solution").into_pyarray(py),
            Array2::from_shape_vec((count, m), residual).expect("one per solution").into_pyarray(py),
            Array2::from_shape_vec((count, m), converged).expect("one per solution").into_pyarray(py),
        ))
    })
}

type SolvedSurface<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>, usize, f64, bool);

/// One surface (heights [iy, ix] in m). Returns (pressure Pa, envelope m, iterations, residual, converged).
#[pyfunction]
#[pyo3(signature = (heights, dx, dy, youngs_modulus, poisson, mean_pressure, periodic, kernel, method, tol, max_iterations))]
#[allow(clippy::too_many_arguments)]
fn solve_surface<'py>(
    py: Python<'py>,
    heights: PyReadonlyArray2<'py, f64>,
    dx: f64,
    dy: f64,
    youngs_modulus: f64,
    poisson: f64,
    mean_pressure: f64,
    periodic: bool,
    kernel: &str,
    method: &str,
    tol: f64,
    max_iterations: usize,
) -> PyResult<SolvedSurface<'py>> {
    guarded(py, || {
        let options = options(periodic, kernel, method, tol, max_iterations).map_err(|e| to_py_err(py, e))?;
        let material = Material::new(youngs_modulus, poisson).map_err(|e| to_py_err(py, e))?;
        let view = heights.as_array();
        let (ny, nx) = view.dim();
        let heights: Vec<f64> = view.iter().copied().collect();
        let grid = Grid { ny, nx, dx, dy };
        let solution = py
            .detach(|| fork_safe(|| solve_surface_core(&heights, grid, material, mean_pressure, options)))
            .map_err(|e| to_py_err(py, e))?;
        let as2 = |v: Vec<f64>| Array2::from_shape_vec((ny, nx), v).expect("one value per element").into_pyarray(py);
        Ok((as2(solution.pressure), as2(solution.envelope), solution.iterations, solution.residual, solution.converged))
    })
}

type SolvedSurfaces<'py> = (
    Bound<'py, PyArray4<f64>>,
    Bound<'py, PyArray4<f64>>,
    Bound<'py, PyArray2<u64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<bool>>,
);

/// Every (tile, modulus) pair in parallel. Arrays are indexed [tile, modulus, ...].
#[pyfunction]
#[pyo3(signature = (tiles, dx, dy, youngs_moduli, poisson, mean_pressure, periodic, kernel, method, tol, max_iterations, threads=None, warm_start=false, initial_pressure=None))]
#[allow(clippy::too_many_arguments)]
fn solve_surface_many<'py>(
    py: Python<'py>,
    tiles: PyReadonlyArray3<'py, f64>,
    dx: f64,
    dy: f64,
    youngs_moduli: PyReadonlyArray1<'py, f64>,
    poisson: f64,
    mean_pressure: f64,
    periodic: bool,
    kernel: &str,
    method: &str,
    tol: f64,
    max_iterations: usize,
    threads: Option<usize>,
    warm_start: bool,
    initial_pressure: Option<PyReadonlyArray4<'py, f64>>,
) -> PyResult<SolvedSurfaces<'py>> {
    guarded(py, || {
        let options = options(periodic, kernel, method, tol, max_iterations).map_err(|e| to_py_err(py, e))?;
        let view = tiles.as_array();
        let (count, ny, nx) = view.dim();
        let heights: Vec<f64> = view.iter().copied().collect();
        let moduli = youngs_moduli.as_slice()?.to_vec();
        let m = moduli.len();
        let grid = Grid { ny, nx, dx, dy };
        let initial: Option<Vec<f64>> = initial_pressure.map(|a| a.as_array().iter().copied().collect());
        let solutions = py
            .detach(|| match &initial {
                Some(initial) => solve_surfaces_from(&heights, grid, &moduli, poisson, mean_pressure, options, threads, initial),
                None => solve_surfaces(&heights, grid, &moduli, poisson, mean_pressure, options, threads, warm_start),
            })
            .map_err(|e| to_py_err(py, e))?;
        let mut pressure = Vec::with_capacity(count * m * ny * nx);
        let mut envelope = Vec::with_capacity(count * m * ny * nx);
        let (mut iterations, mut residual, mut converged) = (Vec::new(), Vec::new(), Vec::new());
        for s in solutions {
            pressure.extend_from_slice(&s.pressure);
            envelope.extend_from_slice(&s.envelope);
            iterations.push(s.iterations as u64);
            residual.push(s.residual);
            converged.push(s.converged);
        }
        let as4 = |v: Vec<f64>| Array4::from_shape_vec((count, m, ny, nx), v).expect("one surface per solution").into_pyarray(py);
        Ok((
            as4(pressure),
            as4(envelope),
            Array2::from_shape_vec((count, m), iterations).expect("one per solution").into_pyarray(py),
            Array2::from_shape_vec((count, m), residual).expect("one per solution").into_pyarray(py),
            Array2::from_shape_vec((count, m), converged).expect("one per solution").into_pyarray(py),
        ))
    })
}

/// Influence coefficients for unit E* (m per Pa times Pa): periodic C_(i-j mod N) or finite c_|i-j|.
#[pyfunction]
fn influence_coefficients(py: Python<'_>, n: usize, dx: f64, periodic: bool) -> PyResult<Bound<'_, PyArray1<f64>>> {
    guarded(py, || {
        check_grid(n, dx).map_err(|e| to_py_err(py, e))?;
        Ok(if periodic { periodic_coefficients(n, dx) } else { finite_coefficients(n, dx) }.into_pyarray(py))
    })
}

fn check_grid(n: usize, dx: f64) -> Result<()> {
    if n < 2 {
        return invalid(format!("n must be at least 2, got {n}"));
    }
    if !(dx.is_finite() && dx > 0.0) {
        return invalid(format!("dx must be a positive finite number of metres, got {dx}"));
    }
    Ok(())
}

/// The smallest 5-smooth length (2^a 3^b 5^c points) at or above n, where realfft is fastest.
#[pyfunction]
fn fft_friendly_length(py: Python<'_>, n: usize) -> PyResult<usize> {
    guarded(py, || {
        if n > 1 << 40 {
            return Err(to_py_err(py, ContactError::InvalidInput(format!("n = {n} points is beyond any profile this solves"))));
        }
        Ok(fast_len(n))
    })
}

/// Eigenvalues lambda_q, q = 0..N/2, of the periodic kernel for unit E*.
#[pyfunction]
fn kernel_spectrum<'py>(py: Python<'py>, n: usize, dx: f64, kernel: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guarded(py, || {
        check_grid(n, dx).map_err(|e| to_py_err(py, e))?;
        Ok(periodic_spectrum(n, dx, parse_kernel(kernel).map_err(|e| to_py_err(py, e))?).into_pyarray(py))
    })
}

/// Element-averaged exact Westergaard pressure (Pa) at element centres x (m).
#[pyfunction]
fn westergaard_element_pressure<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    dx: f64,
    amplitude: f64,
    wavelength: f64,
    plane_strain_modulus: f64,
    mean_pressure: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guarded(py, || {
        let w = Westergaard { amplitude, wavelength, plane_strain_modulus, mean_pressure };
        Ok(x.as_slice()?.iter().map(|&x| w.element_pressure(x, dx)).collect::<Vec<_>>().into_pyarray(py))
    })
}

/// Westergaard contact half-width a (m).
#[pyfunction]
fn westergaard_contact_half_width(
    py: Python<'_>,
    amplitude: f64,
    wavelength: f64,
    plane_strain_modulus: f64,
    mean_pressure: f64,
) -> PyResult<f64> {
    guarded(py, || Ok(Westergaard { amplitude, wavelength, plane_strain_modulus, mean_pressure }.contact_half_width()))
}

/// Element-averaged exact flat-punch pressure (Pa) at element centres x (m) for a punch [0, width].
#[pyfunction]
fn flat_punch_element_pressure<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    dx: f64,
    width: f64,
    mean_pressure: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guarded(py, || {
        let f = FlatPunch { width, mean_pressure };
        Ok(x.as_slice()?.iter().map(|&x| f.element_pressure(x, dx)).collect::<Vec<_>>().into_pyarray(py))
    })
}

/// Periodic self-affine profile (m), see `roadtex.synthetic.self_affine_profile`.
#[pyfunction]
fn self_affine_profile(
    py: Python<'_>,
    n: usize,
    length: f64,
    hurst: f64,
    rms_slope: f64,
    cutoff_fraction: f64,
    seed: u64,
) -> PyResult<Bound<'_, PyArray1<f64>>> {
    guarded(py, || {
        check_grid(n, length).map_err(|e| to_py_err(py, e))?;
        if !(hurst.is_finite() && rms_slope.is_finite() && rms_slope >= 0.0 && cutoff_fraction > 0.0 && cutoff_fraction <= 0.5) {
            let message = "hurst must be finite, rms_slope >= 0 and cutoff_fraction in (0, 0.5]";
            return Err(to_py_err(py, ContactError::InvalidInput(message.into())));
        }
        Ok(py.detach(|| self_affine(n, length, hurst, rms_slope, cutoff_fraction, seed)).into_pyarray(py))
    })
}

/// The von Meier envelope (m) of heights (m) at spacing dx (m) with curvature limit d_star (1/m).
#[pyfunction]
fn von_meier<'py>(py: Python<'py>, heights: PyReadonlyArray1<'py, f64>, dx: f64, d_star: f64) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guarded(py, || {
        let heights = heights.as_slice()?.to_vec();
        let envelope = py.detach(|| von_meier_core(&heights, dx, d_star)).map_err(|e| to_py_err(py, e))?;
        Ok(envelope.into_pyarray(py))
    })
}

type ClappSolved<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, usize, usize);

/// Clapp's model. Returns (pressure Pa, envelope m, number of sub-profiles, most active-set sweeps).
#[pyfunction]
#[pyo3(signature = (heights, dx, youngs_modulus, poisson, mean_pressure, sub_profile, overlap, wrap))]
#[allow(clippy::too_many_arguments)]
fn clapp<'py>(
    py: Python<'py>,
    heights: PyReadonlyArray1<'py, f64>,
    dx: f64,
    youngs_modulus: f64,
    poisson: f64,
    mean_pressure: f64,
    sub_profile: usize,
    overlap: usize,
    wrap: bool,
) -> PyResult<ClappSolved<'py>> {
    guarded(py, || {
        let material = Material::new(youngs_modulus, poisson).map_err(|e| to_py_err(py, e))?;
        let heights = heights.as_slice()?.to_vec();
        let options = ClappOptions { sub_profile, overlap, wrap };
        let solution =
            py.detach(|| fork_safe(|| clapp_core(&heights, dx, material, mean_pressure, options))).map_err(|e| to_py_err(py, e))?;
        Ok((solution.pressure.into_pyarray(py), solution.envelope.into_pyarray(py), solution.sub_profiles, solution.sweeps))
    })
}

/// Test hook: panics with `message` on a rayon thread inside `py.detach`, where the core's work
/// runs, so that tests can check a panic reaches Python as roadtex.errors.InternalError.
#[pyfunction]
#[pyo3(name = "_panic_for_tests")]
fn panic_for_tests(py: Python<'_>, message: String) -> PyResult<()> {
    guarded(py, || {
        // rayon::join from outside the pool runs on a pool thread: the panic crosses rayon as well.
        py.detach(|| rayon::join(|| (), || panic!("{message}")));
        Ok(())
    })
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::batch::note_loading_process();
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(solve_many, m)?)?;
    m.add_function(wrap_pyfunction!(solve_surface, m)?)?;
    m.add_function(wrap_pyfunction!(solve_surface_many, m)?)?;
    m.add_function(wrap_pyfunction!(influence_coefficients, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_spectrum, m)?)?;
    m.add_function(wrap_pyfunction!(fft_friendly_length, m)?)?;
    m.add_function(wrap_pyfunction!(westergaard_element_pressure, m)?)?;
    m.add_function(wrap_pyfunction!(westergaard_contact_half_width, m)?)?;
    m.add_function(wrap_pyfunction!(flat_punch_element_pressure, m)?)?;
    m.add_function(wrap_pyfunction!(self_affine_profile, m)?)?;
    m.add_function(wrap_pyfunction!(von_meier, m)?)?;
    m.add_function(wrap_pyfunction!(clapp, m)?)?;
    m.add_function(wrap_pyfunction!(panic_for_tests, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
