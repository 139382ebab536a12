#!/usr/bin/env bash
# Is Block Reach's per-configuration DP failing for lack of training steps? Retrain the base
# of some Block Reach configurations with the cpu preset's main base schedule (1680 steps
# instead of the per-configuration 500) on the same 100 demos, and roll out DP on that
# configuration (20 rollouts, the two targets in turn).
#   bash benchmarks/per_config_budget_probe.sh [k ...]   # default: 4 6
# needs results/cpu/block_reach/per_config from
#   scdp reproduce --task all --preset cpu --protocol both --out results/cpu
# writes results/cpu/per_config_budget_probe.txt; checkpoints go to runs/budget_probe (ignored)
set -euo pipefail
cd "$(dirname "$0")/.."
configs=("$@")
[ ${#configs[@]} -eq 0 ] && configs=(4 6)
root=results/cpu/block_reach/per_config
for k in "${configs[@]}"; do
  ck="runs/budget_probe/config_$k"
  python3 -m scdp train base --task block_reach --preset cpu --data "$root/config_$k/demos.zarr" --out "$ck/base" --force \
    >/dev/null 2>&1
  for steps in 500 1680; do
    if [ "$steps" = 500 ]; then dir="$root/config_$k/checkpoints"; else dir="$ck"; fi
    echo "config_$k base trained for $steps steps"
    python3 -m scdp evaluate --task block_reach --checkpoints "$dir" --methods dp --config "$k" --scenes 20 --seed 1 2>/dev/null
  done
done | tee results/cpu/per_config_budget_probe.txt
