#!/usr/bin/env bash
# The peer for mean profile depth: captif-slp 0.22 (PyPI), in its own virtual environment
# (.venv-peers), because it pins pandas < 2.2 and so numpy < 2, which the main .venv cannot hold.
#
#   bash scripts/peer-captif-slp.sh install            # create .venv-peers (about a minute)
#   bash scripts/peer-captif-slp.sh mpd [--alpha A] FILE...
#       prints one JSON line per CAPTIF file: {"file", "mpd_mm", "valid_segments", "segments",
#       "start_mm", "end_mm"}, computed as captif-slp's own process_files does
#       (0.5 mm resampling, 100 mm segments, reference plates detected, alpha 6 by default).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/.venv-peers"
command="${1:-install}"
shift || true

install() {
    if [[ ! -x "$venv/bin/python" ]]; then
        python3 -m venv "$venv"
    fi
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "captif-slp==0.22"
}

case "$command" in
    install)
        install
        "$venv/bin/python" -c "import captif_slp; print('captif-slp', captif_slp.__version__, 'ready in', '$venv')"
        ;;
    mpd)
        if [[ ! -x "$venv/bin/python" ]]; then
            echo "no $venv: run 'bash scripts/peer-captif-slp.sh install' first" >&2
            exit 2
        fi
        alpha=6
        if [[ "${1:-}" == "--alpha" ]]; then
            alpha="$2"
            shift 2
        fi
        "$venv/bin/python" - "$alpha" "$@" <<'PY'
import json
import sys

from captif_slp import Reading

alpha = float(sys.argv[1])
for path in sys.argv[2:]:
    reading = Reading.from_file(path, alpha=alpha, detect_plates=True, parallel=False,
                                segment_length_mm=100, target_sample_spacing_mm=0.5)
    result = reading.mpd()
    print(json.dumps({
        "file": path,
        "mpd_mm": float(result["mpd"]),
        "valid_segments": int(result["valid_segments"]),
        "segments": [{"segment": int(s["segment_no"]), "msd_mm": float(s["msd"]), "valid": bool(s["valid"])}
                     for s in reading.msd()],
        "start_mm": reading.start_mm,
        "end_mm": reading.end_mm,
    }), flush=True)
PY
        ;;
    *)
        echo "usage: $0 install | mpd [--alpha A] FILE..." >&2
        exit 2
        ;;
esac
