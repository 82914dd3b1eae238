#!/usr/bin/env bash
# Makes .venv (Python deps from PyPI) and builds the Rust extension into it in release mode.
# Sourced by scripts/demo.sh and scripts/test.sh; safe to run again (quick when nothing changed).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
python="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "roadtex: creating .venv with $("$python" --version)" >&2
  "$python" -m venv .venv
fi
stamp=.venv/.requirements-installed
if [ ! -f "$stamp" ] || [ scripts/requirements-dev.txt -nt "$stamp" ]; then
  .venv/bin/python -m pip install --quiet --upgrade pip
  .venv/bin/python -m pip install --quiet -r scripts/requirements-dev.txt
  touch "$stamp"
fi
echo "roadtex: building the Rust extension (release)" >&2
VIRTUAL_ENV="$root/.venv" PATH="$root/.venv/bin:$PATH" .venv/bin/maturin develop --release --quiet >&2
