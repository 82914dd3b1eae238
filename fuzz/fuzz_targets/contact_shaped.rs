//! Road-like and pathological profiles (spikes, plateaus, steps, pores) over many decades of
//! scale, E, P, dx and tol; N from 8 to 8192.
#![no_main]
use libfuzzer_sys::fuzz_target;
use roadtex_fuzz::{run_contact, ShapedInput};

fuzz_target!(|input: ShapedInput| run_contact(&input.problem()));
