#!/usr/bin/env bash
# Every test: the Rust core (cargo test) and the Python package (pytest).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
cargo test --release
.venv/bin/python -m pytest -q tests/python "$@"
