#!/usr/bin/env bash
# Is Block Reach's per-layout DP failing for lack of training steps? Retrain the base
# of some Block Reach layouts with the cpu preset's main base schedule (1680 steps
# instead of the per-layout 500) on the same 100 demos, and roll out DP on that
# layout (20 rollouts, the two targets in turn).
#   bash benchmarks/per_layout_budget_probe.sh [k ...]   # default: 4 6
# needs results/cpu/block_reach/per_layout from
#   scdp reproduce --task all --preset cpu --protocol both --out results/cpu
# writes results/cpu/per_layout_budget_probe.txt; checkpoints go to runs/budget_probe (ignored)
set -euo pipefail
cd "$(dirname "$0")/.."
layouts=("$@")
[ ${#layouts[@]} -eq 0 ] && layouts=(4 6)
root=results/cpu/block_reach/per_layout
for k in "${layouts[@]}"; do
  ck="runs/budget_probe/layout_$k"
  python3 -m scdp train base --task block_reach --preset cpu --data "$root/layout_$k/demos.zarr" --out "$ck/base" --force \
    >/dev/null 2>&1
  for steps in 500 1680; do
    if [ "$steps" = 500 ]; then dir="$root/layout_$k/checkpoints"; else dir="$ck"; fi
    echo "layout_$k base trained for $steps steps"
    python3 -m scdp evaluate --task block_reach --checkpoints "$dir" --methods dp --layout "$k" --scenes 20 --seed 1 2>/dev/null
  done
done | tee results/cpu/per_layout_budget_probe.txt
