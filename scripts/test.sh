#!/usr/bin/env bash
# Every test: hygiene (rustfmt, clippy, ruff, stubtest), the Rust core (cargo test), the Python
# package (pytest) and the documentation site (mkdocs --strict: every example executed, every link
# and reference resolved).
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
echo "roadtex: docs (mkdocs build --strict, examples executed)" >&2
# Not --quiet: with it mkdocs does not count warnings, and a broken link would pass strict mode.
NO_MKDOCS_2_WARNING=1 .venv/bin/mkdocs build --strict --site-dir "$root/site"
.venv/bin/python -m pytest -q tests/python "$@"
