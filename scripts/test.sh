#!/usr/bin/env bash
# Every test: the Rust core (cargo test) and the Python package (pytest).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
# The MPD peer (captif-slp) lives in its own venv; the MPD tests run it live on the CAPTIF files.
bash scripts/peer-captif-slp.sh install >&2
cargo test --release
.venv/bin/python -m pytest -q tests/python "$@"
