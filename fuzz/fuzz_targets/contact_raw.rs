//! Arbitrary f64 bit patterns for every number of one contact problem (small N).
#![no_main]
use libfuzzer_sys::fuzz_target;
use roadtex_fuzz::{run_contact, RawInput};

fuzz_target!(|input: RawInput| run_contact(&input.problem()));
