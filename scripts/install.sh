#!/usr/bin/env bash
# Install scdp into the current Python, CPU-only and lean.
#   bash scripts/install.sh          # the library
#   bash scripts/install.sh test     # ... plus the test tools and Debian's chromium (the study's browser test),
#                                    # then a check that MuJoCo can render (EGL)
# torch is installed first, pinned to the 2.13.0 CPU build, but only when no torch is
# present: a plain `torch` requirement would pull several GB of CUDA packages, and an
# existing (e.g. GPU) torch is kept as it is. Everything else is installed at the versions the
# tests and the committed results ran with (constraints.txt; pyproject.toml holds the ranges).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if ! "$PY" -c "import torch" >/dev/null 2>&1; then
  "$PY" -m pip install --quiet "torch==2.13.0"
fi
extra=""
[ "${1:-}" = "test" ] && extra="[test]"
"$PY" -m pip install --quiet -c constraints.txt -e ".${extra}"

if [ "${1:-}" = "test" ]; then
  # the study's browser test drives Debian's chromium through Playwright (never Playwright's own download)
  if ! command -v chromium >/dev/null 2>&1; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
      apt-get install -y -qq --no-install-recommends chromium >/dev/null || { apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends chromium >/dev/null; }
    fi
    if ! command -v chromium >/dev/null 2>&1; then
      echo "scdp install: error: chromium: not found; install Debian's chromium package (the study's browser test needs it)" >&2
      exit 2
    fi
  fi
  # the perception and deploy tests render with MuJoCo off-screen; without a display scdp renders with
  # EGL (OSMesa where EGL is missing): this checks EGL, or OSMesa when MUJOCO_GL=osmesa is set. One
  # line naming what is missing, instead of failing tests.
  gl=${MUJOCO_GL:-egl}
  if [ -z "${DISPLAY:-}" ] && [ "$gl" = egl ] && ! ldconfig -p 2>/dev/null | grep -q 'libEGL\.so\.1'; then
    echo "scdp install: error: EGL: libEGL.so.1 not found; install Debian's libegl1 and libgl1-mesa-dri (or set MUJOCO_GL=osmesa with libosmesa6)" >&2
    exit 2
  fi
  if ! MUJOCO_GL=$gl "$PY" -c "import scdp, mujoco; c = mujoco.GLContext(8, 8); c.make_current(); c.free()" >/dev/null 2>&1; then
    echo "scdp install: error: MUJOCO_GL=$gl: MuJoCo cannot open an off-screen OpenGL context; install Debian's libgl1-mesa-dri (EGL's Mesa driver), or libosmesa6 and set MUJOCO_GL=osmesa" >&2
    exit 2
  fi
fi
