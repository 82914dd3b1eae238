//! The von Meier envelope (raw and shaped inputs) and Clapp's model.
#![no_main]
use libfuzzer_sys::fuzz_target;
use roadtex_fuzz::{run_envelope, EnvelopeInput};

fuzz_target!(|input: EnvelopeInput| run_envelope(&input));
