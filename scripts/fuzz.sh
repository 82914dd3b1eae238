#!/usr/bin/env bash
# Fuzzes the Rust core for a bounded time (not part of scripts/test.sh).
#
#   bash scripts/fuzz.sh [seconds per target] [target ...]
#
# Targets (fuzz/fuzz_targets/): contact_raw (arbitrary f64 bit patterns for every input),
# contact_shaped (road-like and pathological profiles over many decades), envelopes (von Meier,
# Clapp). Default: 60 s each, all three. A target "fails" when the core panics, hangs (over
# FUZZ_TIMEOUT s for one input) or breaks a promise checked by fuzz/src/check.rs (NaN, p < 0,
# load not carried, a wrong answer flagged converged).
#
# Toolchain: cargo-fuzz builds with libFuzzer's coverage instrumentation. It is run with
# +nightly when a nightly toolchain is installed; otherwise on stable with RUSTC_BOOTSTRAP=1
# (which lets stable accept the few unstable flags cargo-fuzz may pass). The sanitizer is off
# by default (FUZZ_SANITIZER=none): the core is safe Rust, and AddressSanitizer would cost half
# the speed; set FUZZ_SANITIZER=address to hunt memory errors in the dependencies.
# cargo-fuzz is installed (cargo install) if missing.
#
# Corpus (fuzz/corpus/<target>) and findings (fuzz/artifacts/<target>) stay out of git.
# To turn a finding into a regression test:
#   1. print its input:  ROADTEX_FUZZ_SHOW=1 cargo +nightly fuzz run -s none <target> <artifact>
#      (prints the Problem as Rust, its outcome and its time);
#   2. fix the bug, and add a test that calls must_hold(&problem) to tests/fuzz_regressions.rs
#      (findings are fixed, not listed as known: the checker has no list of exceptions);
#   3. cargo test --release --test fuzz_regressions.
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

seconds="${1:-60}"
shift $(( $# > 0 ? 1 : 0 ))
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(contact_raw contact_shaped envelopes)
fi
sanitizer="${FUZZ_SANITIZER:-none}"
timeout_s="${FUZZ_TIMEOUT:-300}"

if ! command -v cargo-fuzz >/dev/null 2>&1; then
    echo "fuzz.sh: installing cargo-fuzz (once)" >&2
    cargo install cargo-fuzz --locked || exit 2
fi
toolchain=()
if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
    toolchain=(+nightly)
else
    echo "fuzz.sh: no nightly toolchain: stable with RUSTC_BOOTSTRAP=1" >&2
    export RUSTC_BOOTSTRAP=1
fi

status=0
for target in "${targets[@]}"; do
    mkdir -p "fuzz/corpus/$target"
    echo "== fuzzing $target for ${seconds} s (sanitizer $sanitizer) ==" >&2
    log="$(mktemp)"
    # -len_control=0: full-size inputs from the start (structured inputs need a few hundred bytes).
    if cargo "${toolchain[@]}" fuzz run -s "$sanitizer" "$target" -- \
        -max_total_time="$seconds" -timeout="$timeout_s" -max_len=4096 -len_control=0 \
        -rss_limit_mb=3072 -print_final_stats=1 >"$log" 2>&1; then
        grep -E "^stat::number_of_executed_units|^stat::new_units_added|^#[0-9]+ *DONE" "$log" >&2
        echo "== $target: no finding ==" >&2
    else
        status=1
        grep -aE "panicked at|^problem:|Test unit written|ERROR: libFuzzer|SUMMARY" "$log" | head -20 >&2
        echo "== $target: FINDING (full log: $log); see the steps at the top of scripts/fuzz.sh ==" >&2
        continue
    fi
    rm -f "$log"
done
exit $status
