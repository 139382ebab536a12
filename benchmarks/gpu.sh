#!/usr/bin/env bash
# scdp on a GPU (issue 49): the GPU tests, then the speed table (benchmarks/gpu.py) -> OUT/gpu.md, gpu.json.
#   bash benchmarks/gpu.sh [OUT]        (default OUT: results/benchmarks)
# Runs as is wherever scdp is importable beside a CUDA build of torch (python3 -m scdp works); installs
# nothing. About 4-8 minutes on one H200. Without a CUDA GPU it says so and stops (exit 0): CI has none.
# Regenerates: `results/benchmarks/gpu_tests.log`, `results/benchmarks/gpu.md`
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-results/benchmarks}
if ! python3 -c "import sys, torch; sys.exit(0 if torch.cuda.is_available() else 1)"; then
  echo "benchmarks/gpu.sh: torch sees no CUDA GPU here: nothing to measure (the GPU tests skip without one)"
  exit 0
fi
mkdir -p "$OUT"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null || true
python3 -m pytest -q -m gpu -p no:cacheprovider tests/test_gpu.py tests/test_devices.py 2>&1 | tee "$OUT/gpu_tests.log"
tests=$(grep -E "passed|failed|error" "$OUT/gpu_tests.log" | tail -1)
python3 benchmarks/gpu.py --out "$OUT" --tests "${tests:-no summary line}"
