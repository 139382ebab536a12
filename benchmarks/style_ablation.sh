#!/usr/bin/env bash
# One factor of the style predictors changed, everything else the committed cpu run's (issue 76).
#
# Regenerates: `results/authority/every_window.md`, `results/authority/every_window.json`
#
#   bash benchmarks/style_ablation.sh NAME SECTION.FIELD=VALUE [...]
#   bash benchmarks/style_ablation.sh every_window style.early_windows=1.0
#
# Copies results/cpu's base and encoder of both tasks into runs/ablation/NAME, trains the legible and efficient
# predictors there with the cpu preset and the given --set overrides (demos: results/cpu/<task>/demos.zarr),
# then measures style authority along the motion into results/authority/NAME.md (benchmarks/style_authority.py,
# the protocol of results/authority/PROTOCOL.md). Prints each training's minutes; run it alone.
set -euo pipefail
name=$1; shift
sets=(); for s in "$@"; do sets+=(--set "$s"); done
run=runs/ablation/$name
for task in navigation block_reach; do
  mkdir -p "$run/$task/checkpoints"
  cp -r "results/cpu/$task/checkpoints/base" "results/cpu/$task/checkpoints/encoder" "$run/$task/checkpoints/"
  for style in legible efficient; do
    start=$(date +%s)
    scdp train style --task "$task" --style "$style" --preset cpu "${sets[@]}" --data "results/cpu/$task/demos.zarr" \
      --out "$run/$task/checkpoints/style_$style" --force
    echo "$task style_$style: $(( ($(date +%s) - start) / 60 )) min"
  done
done
python benchmarks/style_authority.py --run "$run" --out "results/authority/$name.md"
