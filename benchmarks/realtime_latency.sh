#!/usr/bin/env bash
# Issue 39's batch-1 latency, run alone on the machine: the committed cpu checkpoints copied and
# exported (scdp export), then SCDP's default (DDPM-20, cold) and the fast planner (DDPM-8, warm
# start at 4) under torch and ONNX Runtime, interleaved scene by scene, with the matmul rate.
#   bash benchmarks/realtime_latency.sh      (about 18 minutes on 2 cores)
# Regenerates: `results/benchmarks/realtime_latency.md`, `results/benchmarks/realtime_paper.md`, `results/benchmarks/serve_load_default.md`, `results/benchmarks/serve_load_fast.md`
set -euo pipefail
cd "$(dirname "$0")/.."
RUN=runs/realtime
for task in navigation block_reach; do
  if [ ! -f "$RUN/$task/checkpoints/base/model.onnx" ]; then
    rm -rf "$RUN/$task" && mkdir -p "$RUN/$task"
    cp -r "results/cpu/$task/checkpoints" "$RUN/$task/checkpoints"
    python3 -m scdp export --task "$task" "$RUN/$task/checkpoints"
  fi
done
python3 benchmarks/realtime.py --run "$RUN" --scenes 0 --latency-scenes 20 --out results/benchmarks/realtime_latency
# the paper's network size (freshly initialised weights), default DDPM-100 against the fast planner
python3 benchmarks/realtime.py --scenes 0 --latency-scenes 0 --paper-trajectories 2 --out results/benchmarks/realtime_paper
# /v1/act seen by clients: the defaults, then the fast planner with clients sending the last answer back
python3 benchmarks/serve_load.py --checkpoints "$RUN/navigation/checkpoints" --task navigation --out results/benchmarks/serve_load_default
python3 benchmarks/serve_load.py --checkpoints "$RUN/navigation/checkpoints" --task navigation \
  --serve-args "--runtime onnx --steps 8 --warm-skip 4" --out results/benchmarks/serve_load_fast
