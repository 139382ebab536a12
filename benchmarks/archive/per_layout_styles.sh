#!/usr/bin/env bash
# Do the per-layout style predictors change the paths? For each per-layout
# model set: DP, SCDP forced legible and SCDP forced efficient on its own layout
# (20 rollouts, the two targets in turn).
#   bash benchmarks/per_layout_styles.sh [task ...]   # default: navigation block_reach
# needs results/cpu/<task>/per_layout from
#   scdp reproduce --task all --preset cpu --protocol both --out results/cpu
# writes results/cpu/per_layout_styles_<task>.txt and per_layout/styles_layout_<k>.json
set -euo pipefail
cd "$(dirname "$0")/.."
tasks=("$@")
[ ${#tasks[@]} -eq 0 ] && tasks=(navigation block_reach)
for task in "${tasks[@]}"; do
  root="results/cpu/$task"
  for k in 1 2 3 4 5 6; do
    echo "layout_$k"
    python3 -m scdp evaluate --task "$task" --checkpoints "$root/per_layout/layout_$k/checkpoints" \
      --encoder "$root/checkpoints/encoder" --layout "$k" --scenes 20 --seed 1 \
      --methods dp scdp:legible scdp:efficient --out "$root/per_layout/styles_layout_$k.json" 2>/dev/null
  done | tee "results/cpu/per_layout_styles_$task.txt"
done
