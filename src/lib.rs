//! roadtex: how a tyre's rubber envelops a measured road texture profile.
//!
//! The numerical core (no Python here): influence coefficients of the elastic half-space
//! ([`kernel`], [`compliance`]), the contact solvers ([`solver`]), the batch layer over many
//! segments ([`batch`]), areal contact on 3-D surfaces ([`surface`]) and closed-form reference
//! solutions ([`reference`]). The pyo3 binding lives in `python` behind the `python` feature.
//!
//! ```
//! use roadtex::solver::{solve, Material, SolverOptions};
//! let heights: Vec<f64> = (0..256).map(|i| 1e-4 * (i as f64 * 0.1).sin()).collect();
//! let rubber = Material::new(2.5e6, 0.5).unwrap();
//! let sol = solve(&heights, 1e-3, rubber, 2e5, SolverOptions::default()).unwrap();
//! assert!(sol.converged);
//! ```

pub mod batch;
pub mod clapp;
pub mod coarse_start;
pub mod compliance;
pub mod continuation;
pub mod envelope;
pub mod error;
pub mod kernel;
pub mod reference;
pub mod solver;
pub mod special;
pub mod surface;
pub mod synthetic;

#[cfg(feature = "python")]
mod python;

pub use error::{ContactError, Result};
pub use kernel::KernelKind;
pub use solver::{ContactSolution, ContactSolver, Material, Method, SolverOptions};
