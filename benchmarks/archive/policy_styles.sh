#!/usr/bin/env bash
# Issue-3 check of the trained cpu checkpoints: DP success and the two fixed styles of SCDP
# on 50 random scenes per task.
#   bash benchmarks/policy_styles.sh [task ...]   # default: navigation block_reach
# needs results/cpu/<task>/checkpoints from `scdp reproduce --task all --preset cpu --out results/cpu`
# writes results/cpu/policy_styles_<task>.json and .txt
set -euo pipefail
cd "$(dirname "$0")/.."
tasks=("$@")
[ ${#tasks[@]} -eq 0 ] && tasks=(navigation block_reach)
for task in "${tasks[@]}"; do
  python3 -m scdp evaluate --task "$task" --checkpoints "results/cpu/$task/checkpoints" \
    --methods dp scdp:legible scdp:efficient --scenes 50 --seed 1 \
    --out "results/cpu/policy_styles_$task.json" 2>/dev/null | tee "results/cpu/policy_styles_$task.txt"
done
