//! Vectors of 2^17 points or more are reduced in parallel blocks fixed by N (`solver::reduce`):
//! a solve there must give the same bits on one thread and on several, for profiles and surfaces,
//! and still agree with the closed-form solution it must reach (Westergaard's wavy surface).

use roadtex::batch::{solve_many, Segments};
use roadtex::reference::Westergaard;
use roadtex::surface::synthetic::self_affine_surface;
use roadtex::surface::{solve_surfaces, Grid};
use roadtex::synthetic::self_affine;
use roadtex::{Material, SolverOptions};

#[test]
fn long_profiles_give_the_same_bits_on_one_and_two_threads() {
    let (n, dx) = (1 << 17, 1e-5);
    let heights: Vec<f64> = [5u64, 9].iter().flat_map(|&seed| self_affine(n, n as f64 * dx, 0.8, 0.2, 0.25, seed)).collect();
    let segments = Segments { heights: &heights, len: n };
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    let moduli = [1e6, 1e7];
    let one = solve_many(segments, dx, &moduli, 0.5, 2e5, options, Some(1), true, None).unwrap();
    let two = solve_many(segments, dx, &moduli, 0.5, 2e5, options, Some(2), true, None).unwrap();
    assert_eq!(one, two);
    for solution in &one {
        assert!(solution.converged && solution.residual <= 1e-8);
        // load control: the mean pressure is P to rounding
        let mean = solution.pressure.iter().sum::<f64>() / n as f64;
        assert!((mean / 2e5 - 1.0).abs() < 1e-9, "{mean}");
    }
}

#[test]
fn a_long_wavy_profile_reaches_westergaards_pressure_on_one_and_two_threads() {
    // 2^17 points over 16 wavelengths of 2 cm (8,192 elements per wavelength), half the pressure
    // of complete contact: the parallel passes must leave the element-mean closed form intact.
    let (n, waves, wavelength, amplitude) = (1usize << 17, 16, 0.02, 1e-4);
    let dx = waves as f64 * wavelength / n as f64;
    let rubber = Material::new(2.5e6, 0.5).unwrap();
    let base = Westergaard { amplitude, wavelength, plane_strain_modulus: rubber.plane_strain_modulus(), mean_pressure: 1.0 };
    let exact = Westergaard { mean_pressure: 0.5 * base.full_contact_pressure(), ..base };
    let x: Vec<f64> = (0..n).map(|i| i as f64 * dx).collect();
    let heights: Vec<f64> = x.iter().map(|&x| amplitude * (2.0 * std::f64::consts::PI * x / wavelength).cos()).collect();
    let segments = Segments { heights: &heights, len: n };
    let options = SolverOptions { tol: 1e-10, ..Default::default() };
    let one = solve_many(segments, dx, &[2.5e6], 0.5, exact.mean_pressure, options, Some(1), false, None).unwrap();
    let two = solve_many(segments, dx, &[2.5e6], 0.5, exact.mean_pressure, options, Some(2), false, None).unwrap();
    assert_eq!(one, two);
    assert!(one[0].converged);
    let exact_p: Vec<f64> = x.iter().map(|&x| exact.element_pressure(x, dx)).collect();
    let l1 = one[0].pressure.iter().zip(&exact_p).map(|(p, q)| (p - q).abs()).sum::<f64>() / exact_p.iter().sum::<f64>();
    assert!(l1 < 1e-5, "L1 pressure error {l1:e} against Westergaard");
}

#[test]
fn large_surfaces_give_the_same_bits_on_one_and_two_threads() {
    let side = 384; // 147,456 points: above the parallel threshold
    let grid = Grid { ny: side, nx: side, dx: 1.0 / side as f64, dy: 1.0 / side as f64 };
    let tiles = self_affine_surface(side, 1.0, 0.8, 0.1, 4);
    let options = SolverOptions { tol: 1e-8, ..Default::default() };
    let one = solve_surfaces(&tiles, grid, &[0.75], 0.5, 0.01, options, Some(1), false).unwrap();
    let two = solve_surfaces(&tiles, grid, &[0.75], 0.5, 0.01, options, Some(2), false).unwrap();
    assert_eq!(one, two);
    assert!(one[0].converged && one[0].residual <= 1e-8);
    let fraction = one[0].pressure.iter().filter(|&&p| p > 0.0).count() as f64 / grid.len() as f64;
    assert!((0.1..0.35).contains(&fraction), "{fraction}");
}
