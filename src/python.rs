//! The pyo3 binding: thin wrappers that convert arrays, release the GIL around the numerical work,
//! and map every core error to one Python exception type through `to_py_err`.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use crate::batch::{solve_many as solve_many_core, Segments};
use crate::clapp::{clapp as clapp_core, ClappOptions};
use crate::envelope::von_meier as von_meier_core;
use crate::error::ContactError;
use crate::kernel::{finite_coefficients, periodic_coefficients, periodic_spectrum, KernelKind};
use crate::reference::{FlatPunch, Westergaard};
use crate::solver::{ContactSolver, Material, Method, SolverOptions};
use crate::synthetic::self_affine;

fn to_py_err(err: ContactError) -> PyErr {
    match err {
        ContactError::InvalidInput(msg) => PyValueError::new_err(msg),
        other @ ContactError::DirectSolverFailed(_) => PyRuntimeError::new_err(other.to_string()),
    }
}

fn parse_kernel(kernel: &str) -> PyResult<KernelKind> {
    match kernel {
        "element" => Ok(KernelKind::Element),
        "spectral" => Ok(KernelKind::Spectral),
        other => Err(PyValueError::new_err(format!("kernel must be 'element' or 'spectral', got {other:?}"))),
    }
}

fn parse_method(method: &str) -> PyResult<Method> {
    match method {
        "cg" => Ok(Method::ConjugateGradient),
        "direct" => Ok(Method::Direct),
        other => Err(PyValueError::new_err(format!("method must be 'cg' or 'direct', got {other:?}"))),
    }
}

fn options(periodic: bool, kernel: &str, method: &str, tol: f64, max_iterations: usize) -> PyResult<SolverOptions> {
    let options = SolverOptions { periodic, kernel: parse_kernel(kernel)?, method: parse_method(method)?, tol, max_iterations };
    options.validate().map_err(to_py_err)?;
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
    let options = options(periodic, kernel, method, tol, max_iterations)?;
    let material = Material::new(youngs_modulus, poisson).map_err(to_py_err)?;
    let heights = heights.as_slice()?.to_vec();
    let solution = py
        .detach(|| {
            crate::solver::validate_problem(&heights, dx, mean_pressure)?;
            ContactSolver::new(heights.len(), dx, options)?.solve(&heights, material, mean_pressure)
        })
        .map_err(to_py_err)?;
    Ok((solution.pressure.into_pyarray(py), solution.envelope.into_pyarray(py), solution.iterations, solution.residual, solution.converged))
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
#[pyo3(signature = (segments, dx, youngs_moduli, poisson, mean_pressure, periodic, kernel, method, tol, max_iterations, threads=None, warm_start=false))]
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
) -> PyResult<SolvedMany<'py>> {
    let options = options(periodic, kernel, method, tol, max_iterations)?;
    let view = segments.as_array();
    let (count, len) = view.dim();
    let heights: Vec<f64> = view.iter().copied().collect();
    let moduli = youngs_moduli.as_slice()?.to_vec();
    let m = moduli.len();
    let solutions = py
        .detach(|| solve_many_core(Segments { heights: &heights, len }, dx, &moduli, poisson, mean_pressure, options, threads, warm_start))
        .map_err(to_py_err)?;
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
}

/// Influence coefficients for unit E* (m per Pa times Pa): periodic C_(i-j mod N) or finite c_|i-j|.
#[pyfunction]
fn influence_coefficients(py: Python<'_>, n: usize, dx: f64, periodic: bool) -> PyResult<Bound<'_, PyArray1<f64>>> {
    check_grid(n, dx)?;
    Ok(if periodic { periodic_coefficients(n, dx) } else { finite_coefficients(n, dx) }.into_pyarray(py))
}

fn check_grid(n: usize, dx: f64) -> PyResult<()> {
    if n < 2 {
        return Err(PyValueError::new_err(format!("n must be at least 2, got {n}")));
    }
    if !(dx.is_finite() && dx > 0.0) {
        return Err(PyValueError::new_err(format!("dx must be a positive finite number of metres, got {dx}")));
    }
    Ok(())
}

/// Eigenvalues lambda_q, q = 0..N/2, of the periodic kernel for unit E*.
#[pyfunction]
fn kernel_spectrum<'py>(py: Python<'py>, n: usize, dx: f64, kernel: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
    check_grid(n, dx)?;
    Ok(periodic_spectrum(n, dx, parse_kernel(kernel)?).into_pyarray(py))
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
    let w = Westergaard { amplitude, wavelength, plane_strain_modulus, mean_pressure };
    Ok(x.as_slice()?.iter().map(|&x| w.element_pressure(x, dx)).collect::<Vec<_>>().into_pyarray(py))
}

/// Westergaard contact half-width a (m).
#[pyfunction]
fn westergaard_contact_half_width(amplitude: f64, wavelength: f64, plane_strain_modulus: f64, mean_pressure: f64) -> f64 {
    Westergaard { amplitude, wavelength, plane_strain_modulus, mean_pressure }.contact_half_width()
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
    let f = FlatPunch { width, mean_pressure };
    Ok(x.as_slice()?.iter().map(|&x| f.element_pressure(x, dx)).collect::<Vec<_>>().into_pyarray(py))
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
    check_grid(n, length)?;
    if !(hurst.is_finite() && rms_slope.is_finite() && rms_slope >= 0.0 && cutoff_fraction > 0.0 && cutoff_fraction <= 0.5) {
        return Err(PyValueError::new_err("hurst must be finite, rms_slope >= 0 and cutoff_fraction in (0, 0.5]"));
    }
    Ok(py.detach(|| self_affine(n, length, hurst, rms_slope, cutoff_fraction, seed)).into_pyarray(py))
}

/// The von Meier envelope (m) of heights (m) at spacing dx (m) with curvature limit d_star (1/m).
#[pyfunction]
fn von_meier<'py>(py: Python<'py>, heights: PyReadonlyArray1<'py, f64>, dx: f64, d_star: f64) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let heights = heights.as_slice()?.to_vec();
    let envelope = py.detach(|| von_meier_core(&heights, dx, d_star)).map_err(to_py_err)?;
    Ok(envelope.into_pyarray(py))
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
    let material = Material::new(youngs_modulus, poisson).map_err(to_py_err)?;
    let heights = heights.as_slice()?.to_vec();
    let options = ClappOptions { sub_profile, overlap, wrap };
    let solution = py.detach(|| clapp_core(&heights, dx, material, mean_pressure, options)).map_err(to_py_err)?;
    Ok((solution.pressure.into_pyarray(py), solution.envelope.into_pyarray(py), solution.sub_profiles, solution.sweeps))
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(solve_many, m)?)?;
    m.add_function(wrap_pyfunction!(influence_coefficients, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_spectrum, m)?)?;
    m.add_function(wrap_pyfunction!(westergaard_element_pressure, m)?)?;
    m.add_function(wrap_pyfunction!(westergaard_contact_half_width, m)?)?;
    m.add_function(wrap_pyfunction!(flat_punch_element_pressure, m)?)?;
    m.add_function(wrap_pyfunction!(self_affine_profile, m)?)?;
    m.add_function(wrap_pyfunction!(von_meier, m)?)?;
    m.add_function(wrap_pyfunction!(clapp, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
