#!/usr/bin/env bash
# Parameter counts of every part, as printed by `scdp train <part> --dry-run`.
#   bash benchmarks/parameter_counts.sh      # writes results/parameter_counts.md
# Regenerates: `results/parameter_counts.md`
set -euo pipefail
cd "$(dirname "$0")/.."
out=results/parameter_counts.md
{
  echo "# Parameter counts"
  echo
  echo "Command: \`bash benchmarks/parameter_counts.sh\` (each row is the last line of \`scdp train <part> --task <task> --preset <preset> --dry-run\`)"
  echo
  echo "| preset | task | part | output |"
  echo "|---|---|---|---|"
  for preset in paper cpu; do
    for task in navigation block_reach; do
      for part in base encoder style ld; do
        line=$(python3 -m scdp train "$part" --task "$task" --preset "$preset" --dry-run | tail -n 1)
        echo "| $preset | $task | $part | \`$line\` |"
      done
    done
  done
} > "$out.tmp" && mv "$out.tmp" "$out"
cat "$out"
