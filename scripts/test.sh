#!/usr/bin/env bash
# Every test: hygiene (rustfmt, clippy, ruff, stubtest), the Rust core (cargo test) and the Python
# package (pytest).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
# The MPD peer (captif-slp) lives in its own venv; the MPD tests run it live on the CAPTIF files.
bash scripts/peer-captif-slp.sh install >&2
echo "roadtex: hygiene (cargo fmt --check, cargo clippy -D warnings, ruff, stubtest)" >&2
cargo fmt --check
cargo clippy --release --all-targets -- -D warnings
cargo clippy --release --all-targets --features python -- -D warnings
.venv/bin/ruff check python tests/python benches
.venv/bin/python -m mypy.stubtest roadtex._core
cargo test --release
.venv/bin/python -m pytest -q tests/python "$@"
