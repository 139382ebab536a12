#!/usr/bin/env bash
# The changing-scene confirmation (issue 65; round 2, issue 76), as results/dynamic/PROTOCOL.md fixes it: every event family (appear, vanish,
# move) on both tasks from the committed cpu models, on untouched scenes (evaluation stream, seed 83,
# each family its own sub-stream), then the report and the figures. Run alone on the machine.
#   bash benchmarks/dynamic.sh [OUT]        (default OUT: results/dynamic)
# Regenerates: `results/dynamic/report.md`, `results/dynamic/navigation_appear.json`
set -euo pipefail
OUT=${1:-results/dynamic}
mkdir -p "$OUT"
for task in navigation block_reach; do
  for family in appear vanish move; do
    python3 -m scdp evaluate --task "$task" --checkpoints "results/cpu/$task/checkpoints" \
      --methods dp ld scdp scdp_legible scdp_efficient scdp_paper \
      --events "$family" --scenes 40 --seed 83 --out "$OUT/${task}_${family}.json" --force
  done
done
python3 benchmarks/dynamic_report.py --dir "$OUT"
