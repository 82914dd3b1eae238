//! Inputs of the roadtex fuzz targets and what is done with them.
//!
//! Three targets (`fuzz/fuzz_targets/`):
//! - `contact_raw`: every number is an arbitrary f64 bit pattern (NaN, inf, subnormals, 1e308,
//!   -0.0, ...) and every option arbitrary; only small N.
//! - `contact_shaped`: physically shaped profiles built from blocks (spikes, plateaus, steps,
//!   slopes, pores, waves) at scales from 1e-10 m to 1e3 m per unit, with an offset, on N from 8
//!   to 8192, E, P, dx and tol over many decades: the inputs a survey archive can produce.
//! - `envelopes`: the von Meier envelope and Clapp's model on raw and shaped inputs.
//!
//! Errors are fine. A panic, a hang (libFuzzer's -timeout) or a broken promise of
//! [`check::check_solution`] is a finding.

use arbitrary::Arbitrary;
use roadtex::clapp::{clapp, ClappOptions};
use roadtex::solver::{Material, Method, SolverOptions};
use roadtex::{ContactError, KernelKind};

pub mod check;

use check::Problem;

/// Largest N of the raw target and of the shaped target's checked sizes.
pub const MAX_CHECKED_N: usize = check::DENSE_CHECK_MAX;
/// Largest N of the shaped target (above MAX_CHECKED_N without the dense check).
pub const MAX_N: usize = 8192;
/// Largest N given to the dense direct solver here (its cost grows as N^3).
pub const MAX_DIRECT_N: usize = 256;
/// Largest max_iterations (keeps every input well inside libFuzzer's timeout).
pub const MAX_ITERATIONS: usize = 3000;

#[derive(Arbitrary, Debug, Clone)]
pub struct RawInput {
    pub dx: f64,
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub mean_pressure: f64,
    pub tol: f64,
    pub max_iterations: u16,
    pub periodic: bool,
    pub spectral: bool,
    pub direct: bool,
    pub heights: Vec<f64>,
}

impl RawInput {
    pub fn problem(&self) -> Problem {
        let direct = self.direct;
        let cap = if direct { MAX_DIRECT_N } else { MAX_CHECKED_N };
        let heights: Vec<f64> = self.heights.iter().copied().take(cap).collect();
        Problem {
            heights,
            dx: self.dx,
            youngs_modulus: self.youngs_modulus,
            poisson: self.poisson,
            mean_pressure: self.mean_pressure,
            options: SolverOptions {
                periodic: self.periodic,
                kernel: if self.spectral { KernelKind::Spectral } else { KernelKind::Element },
                method: if direct { Method::Direct } else { Method::ConjugateGradient },
                tol: self.tol,
                max_iterations: (self.max_iterations as usize).min(MAX_ITERATIONS),
            },
        }
    }
}

/// One building block of a shaped profile; `value` is in units of the input's height scale.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Block {
    /// One point at `value`, then back to the current level.
    Spike(i16),
    /// `1 + len % 64` points at the current level.
    Plateau(u8),
    /// The level jumps to `value`.
    Step(i16),
    /// `1 + |value| % 32` points climbing (or falling) by one unit each.
    Slope(i16),
    /// One point `|value|` units below the level: a pore or a drop-out filled with a low value.
    Pore(i16),
    /// Sixteen points of a sine of amplitude `value` about the level.
    Wave(i16),
}

#[derive(Arbitrary, Debug, Clone)]
pub struct ShapedHeights {
    pub n: u16,
    pub blocks: Vec<Block>,
    pub height_exp: u8,
    pub offset_exp: u8,
    pub offset_sign: i8,
}

impl ShapedHeights {
    /// Profile heights (m): the blocks written one after another (repeated when they run out),
    /// times 10^(height_exp % 14 - 10) m, plus an offset of 0 or +-10^(offset_exp % 8 - 4) m.
    pub fn heights(&self, max_n: usize) -> Vec<f64> {
        let n = 8 + self.n as usize % (max_n - 7);
        let mut units = Vec::with_capacity(n);
        let mut level = 0.0_f64;
        if self.blocks.is_empty() {
            units.resize(n, 0.0);
        }
        'fill: while units.len() < n {
            for block in &self.blocks {
                match *block {
                    Block::Spike(v) => units.push(v as f64),
                    Block::Plateau(len) => units.extend(std::iter::repeat_n(level, 1 + len as usize % 64)),
                    Block::Step(v) => {
                        level = v as f64;
                        units.push(level);
                    }
                    Block::Slope(v) => {
                        for _ in 0..=(v.unsigned_abs() % 32) {
                            level += v.signum() as f64;
                            units.push(level);
                        }
                    }
                    Block::Pore(v) => units.push(level - (v as f64).abs()),
                    Block::Wave(v) => {
                        for k in 0..16 {
                            units.push(level + v as f64 * (std::f64::consts::PI * k as f64 / 8.0).sin());
                        }
                    }
                }
                if units.len() >= n {
                    break 'fill;
                }
            }
        }
        units.truncate(n);
        let scale = 10f64.powi(self.height_exp as i32 % 14 - 10);
        let offset = match self.offset_sign {
            0 => 0.0,
            s => s.signum() as f64 * 10f64.powi(self.offset_exp as i32 % 8 - 4),
        };
        units.iter().map(|u| u * scale + offset).collect()
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub struct ShapedInput {
    pub profile: ShapedHeights,
    pub dx_exp: u8,
    pub e_exp: u8,
    pub p_exp: u8,
    pub tol_exp: u8,
    pub poisson: u8,
    pub max_iterations: u16,
    pub flags: u8,
}

impl ShapedInput {
    pub fn problem(&self) -> Problem {
        let large = self.flags & 0x18 == 0x18;
        let direct = self.flags & 4 != 0;
        let max_n = if direct {
            MAX_DIRECT_N
        } else if large {
            MAX_N
        } else {
            MAX_CHECKED_N
        };
        let periodic = self.flags & 1 == 0;
        Problem {
            heights: self.profile.heights(max_n),
            dx: 10f64.powi(self.dx_exp as i32 % 10 - 8),            // 1e-8 .. 10 m
            youngs_modulus: 10f64.powi(self.e_exp as i32 % 13 + 2), // 1e2 .. 1e14 Pa
            poisson: -0.99 + 1.49 * self.poisson as f64 / 255.0,    // -0.99 .. 0.5
            mean_pressure: 10f64.powi(self.p_exp as i32 % 13),      // 1 .. 1e12 Pa
            options: SolverOptions {
                periodic,
                kernel: if periodic && self.flags & 2 != 0 { KernelKind::Spectral } else { KernelKind::Element },
                method: if direct { Method::Direct } else { Method::ConjugateGradient },
                tol: 10f64.powi(-(self.tol_exp as i32 % 13) - 1), // 1e-1 .. 1e-13
                max_iterations: 1 + self.max_iterations as usize % MAX_ITERATIONS,
            },
        }
    }
}

#[derive(Arbitrary, Debug, Clone)]
pub enum EnvelopeInput {
    VonMeierRaw { heights: Vec<f64>, dx: f64, d_star: f64 },
    VonMeierShaped { profile: ShapedHeights, dx_exp: u8, d_star: u16 },
    Clapp { input: ShapedInput, sub_profile: u8, overlap: u8, wrap: bool },
}

/// Runs one contact input and panics (a fuzz finding) on a broken promise.
///
/// With `ROADTEX_FUZZ_SHOW=1` in the environment it prints each problem, its outcome and its
/// time (to read an artifact: `ROADTEX_FUZZ_SHOW=1 cargo fuzz run <target> <artifact>`).
pub fn run_contact(problem: &Problem) {
    let show = std::env::var_os("ROADTEX_FUZZ_SHOW").is_some();
    if show {
        eprintln!("problem: {problem:?}");
    }
    let started = std::time::Instant::now();
    let outcome = check::solve_and_check(problem);
    if show {
        match &outcome {
            Ok(Some(s)) => eprintln!(
                "solved in {:.3} s: converged {}, residual {:e}, iterations {}, contact fraction {}",
                started.elapsed().as_secs_f64(),
                s.converged,
                s.residual,
                s.iterations,
                s.pressure.iter().filter(|&&p| p > 0.0).count() as f64 / s.pressure.len() as f64
            ),
            Ok(None) => eprintln!("rejected in {:.3} s", started.elapsed().as_secs_f64()),
            Err(_) => {}
        }
    }
    if let Err(broken) = outcome {
        panic!("{broken}\nproblem: {problem:?}");
    }
}

pub fn run_envelope(input: &EnvelopeInput) {
    match input {
        EnvelopeInput::VonMeierRaw { heights, dx, d_star } => {
            let heights: Vec<f64> = heights.iter().copied().take(1 << 16).collect();
            if let Err(broken) = check::check_von_meier(&heights, *dx, *d_star) {
                panic!("{broken}\nheights {heights:?} dx {dx:e} d_star {d_star:e}");
            }
        }
        EnvelopeInput::VonMeierShaped { profile, dx_exp, d_star } => {
            let heights = profile.heights(1 << 16);
            let dx = 10f64.powi(*dx_exp as i32 % 10 - 8);
            let d_star = *d_star as f64 / 8.0;
            if let Err(broken) = check::check_von_meier(&heights, dx, d_star) {
                panic!("{broken}\nheights {heights:?} dx {dx:e} d_star {d_star:e}");
            }
        }
        EnvelopeInput::Clapp { input, sub_profile, overlap, wrap } => {
            let mut problem = input.problem();
            problem.heights.truncate(MAX_DIRECT_N);
            let options = ClappOptions { sub_profile: *sub_profile as usize, overlap: *overlap as usize, wrap: *wrap };
            let Ok(material) = Material::new(problem.youngs_modulus, problem.poisson) else { return };
            match clapp(&problem.heights, problem.dx, material, problem.mean_pressure, options) {
                Ok(s) => {
                    let n = problem.heights.len();
                    assert_eq!(s.pressure.len(), n);
                    assert!(s.pressure.iter().all(|p| p.is_finite() && *p >= 0.0), "clapp pressure {:?}", s.pressure);
                    let balance = s.pressure.iter().sum::<f64>() / (n as f64 * problem.mean_pressure) - 1.0;
                    assert!(balance.abs() <= 1e-9, "clapp load balance {balance:e}");
                    for i in 0..n {
                        assert!(s.envelope[i] >= problem.heights[i], "clapp envelope below the profile at {i}");
                    }
                }
                Err(ContactError::InvalidInput(m)) => assert!(!m.trim().is_empty()),
                // Clapp's windows can fail to settle; it says so. Not a panic.
                Err(ContactError::ClappFailed(m)) => assert!(!m.trim().is_empty()),
                Err(other @ ContactError::DirectSolverFailed(_)) => panic!("clapp reported a direct-solver error: {other}"),
            }
        }
    }
}
