//! Helpers shared by the integration tests (`mod common;` in each test file that uses them).

use roadtex::compliance::Compliance;

/// The residual of `pressure` (Pa) on heights `z` (m) recomputed here with the operator's
/// double-precision product, as the solver defines it: the gap with the rigid approach that makes
/// it zero-mean on the contact set, worst |gap| on the set and worst penetration off it, over the
/// peak-to-valley height. Independent of the solver's own check (and of any product it took in
/// single precision).
pub fn recomputed_residual<Op: Compliance>(op: &Op, z: &[f64], pressure: &[f64], e_star: f64) -> f64 {
    let p: Vec<f64> = pressure.iter().map(|&x| x / e_star).collect();
    let mut u = vec![0.0; p.len()];
    op.displacement(&p, &mut u, &mut op.scratch());
    let contact: Vec<usize> = (0..p.len()).filter(|&i| p[i] > 0.0).collect();
    let approach = -contact.iter().map(|&i| u[i] - z[i]).sum::<f64>() / contact.len() as f64;
    let gap = |i: usize| u[i] - z[i] + approach;
    let worst = (0..p.len()).map(|i| if p[i] > 0.0 { gap(i).abs() } else { (-gap(i)).max(0.0) }).fold(0.0, f64::max);
    let (lo, hi) = z.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    worst / (hi - lo)
}
