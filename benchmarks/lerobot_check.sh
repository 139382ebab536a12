#!/usr/bin/env bash
# Issue 77: scdp's LeRobot export read, normalised, trained on, edited and appended to by the real lerobot, and a
# dataset lerobot wrote taken through scdp and back (benchmarks/lerobot_check.py says what each check is).
#
# Regenerates: `results/lerobot/check.txt`
#
#   LEROBOT_PYTHON=/tmp/lerobot311/bin/python bash benchmarks/lerobot_check.sh
#
# LEROBOT_PYTHON is a Python with lerobot installed, in a venv of its own (the recipe: docs/data.md); scdp runs from
# this environment. Offline: HF_HUB_OFFLINE=1, HF_DATASETS_OFFLINE=1. Scratch files go to runs/lerobot_check/.
set -euo pipefail
py=${LEROBOT_PYTHON:?"set LEROBOT_PYTHON to the python of a venv with lerobot (docs/data.md)"}
work=runs/lerobot_check
out=results/lerobot/check.txt
mkdir -p "$work" "$(dirname "$out")"
export HF_HUB_OFFLINE=1 HF_DATASETS_OFFLINE=1
step() { echo "\$ $*"; "$@" 2>&1 | grep -v -E "torchcodec|torchvision's _C.so|it/s\]|%\|" || true; }
{
  echo "lerobot $("$py" -c 'import importlib.metadata as m; print(m.version("lerobot"))'), torch $("$py" -c 'import importlib.metadata as m; print(m.version("torch"))'), numpy $("$py" -c 'import numpy; print(numpy.__version__)')"
  step scdp generate --task navigation --num-demos 12 --seed 1 --out "$work/demos.zarr" --force
  step scdp export-demos "$work/demos.zarr" --out "$work/export" --force
  step "$py" benchmarks/lerobot_check.py check "$work/export"
  step "$py" benchmarks/lerobot_check.py write "$work/written" --force
  step scdp import-lerobot "$work/written" --task navigation --out "$work/in.zarr" --force
  step scdp export-demos "$work/in.zarr" --out "$work/back" --force
  step "$py" benchmarks/lerobot_check.py compare "$work/written" "$work/back"
} | tee "$out.tmp"
mv "$out.tmp" "$out"
