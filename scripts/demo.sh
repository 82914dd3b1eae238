#!/usr/bin/env bash
# The main job on the built-in default data set. Extra arguments go to `roadtex demo`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/bootstrap.sh"
exec "$root/.venv/bin/roadtex" demo "$@"
