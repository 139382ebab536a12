#!/usr/bin/env bash
# Install scdp into the current Python, CPU-only and lean.
#   bash scripts/install.sh          # the library
#   bash scripts/install.sh test     # ... plus the test tools
# torch is installed first, pinned to the 2.13.0 CPU build, but only when no torch is
# present: a plain `torch` requirement would pull several GB of CUDA packages, and an
# existing (e.g. GPU) torch is kept as it is.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if ! "$PY" -c "import torch" >/dev/null 2>&1; then
  "$PY" -m pip install --quiet "torch==2.13.0"
fi
extra=""
[ "${1:-}" = "test" ] && extra="[test]"
"$PY" -m pip install --quiet -e ".${extra}"
