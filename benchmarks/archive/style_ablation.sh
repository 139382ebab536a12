#!/usr/bin/env bash
# The style ablation of results/cpu/ablation.md: what makes SCDP's two styles move paths apart
# while every method still reaches its goal. Model sets are trained with the project's CLI, one
# factor changed at a time, and each gets one row from benchmarks/style_ablation.py on the same
# 30 ambiguous + 30 clear *validation* scenes (seed 2; the evaluation uses seed 1).
#   bash benchmarks/style_ablation.sh [navigation] [block_reach]   # ~5 min a row on 2 cores; ~90 min in all
# Every setting is pinned with --set, so rows do not move when the cpu preset does. Training
# minutes of each part are in its checkpoint's config.json (train_seconds).
set -euo pipefail
cd "$(dirname "$0")/.."
A=runs/ablation
OUT=results/cpu/ablation.json
tasks=("$@")
[ ${#tasks[@]} -eq 0 ] && tasks=(navigation block_reach)
scdp() { python3 -m scdp "$@"; }

# bases: the cpu preset before this ablation (200 demos, 1680 steps), and two on all 1000 demos
SMALL_BASE=(--set data.base_demos=200 --set base.train.epochs=20 --set base.train.min_steps=1680)
MID_BASE=(--set data.base_demos=1000 --set base.train.epochs=1 --set base.train.min_steps=3360)
BIG_BASE=(--set data.base_demos=1000 --set base.train.epochs=20 --set base.train.min_steps=3360)
# the predictors as the paper builds them (bottleneck film at every denoising step, plain ε-MSE), on
# the scene frame and the first 15 % of each style demo's windows, 80 epochs
STYLE=(--set style.model.film_blocks=bottleneck --set style.model.noise_window=1.0 --set style.x0_weight_cap=1.0
       --set style.early_windows=0.15 --set style.train.epochs=80 --set style.arbitration=probabilistic)

base() {  # base TASK NAME BASE_ARGS...: demos, encoder and a base under $A/TASK/NAME
  local task=$1 name=$2; shift 2
  local dir=$A/$task/$name
  [ -f "$A/$task/demos.zarr/.zattrs" ] || scdp generate --task "$task" --num-demos 1000 --seed 0 --out "$A/$task/demos.zarr" --force
  [ -f "$A/$task/encoder/config.json" ] || scdp train encoder --task "$task" --out "$A/$task/encoder" --force
  scdp train base --task "$task" --data "$A/$task/demos.zarr" --out "$dir/base" --force "$@"
}

row() {  # row TASK BASE_NAME SET LABEL STYLE_ARGS...: both predictors on that base, then the row
  local task=$1 base=$2 set=$3 label=$4; shift 4
  local ck=$A/$task/$set
  mkdir -p "$ck"; rm -rf "$ck/base" "$ck/encoder"
  cp -r "$A/$task/$base/base" "$A/$task/encoder" "$ck/"
  for st in legible efficient; do
    scdp train style --task "$task" --data "$A/$task/demos.zarr" --out "$ck/style_$st" --style "$st" --force "${STYLE[@]}" "$@"
  done
  python3 benchmarks/style_ablation.py --task "$task" --checkpoints "$ck" --label "$label" --arbitration probabilistic --out "$OUT"
}

W=style.model.noise_window
for task in "${tasks[@]}"; do
  base "$task" small "${SMALL_BASE[@]}"
  row "$task" small paper "small base; paper's film (bottleneck, every step)"
  row "$task" small w05 "small base; noise window 0.5" --set $W=0.5
  row "$task" small w07fa "small base; film on every block, noise window 0.7" --set $W=0.7 --set style.model.film_blocks=all
  if [ "$task" = navigation ]; then
    row "$task" small c10 "small base; x0-weighted loss (cap 10)" --set style.x0_weight_cap=10
    row "$task" small w03 "small base; noise window 0.3" --set $W=0.3
    row "$task" small w06 "small base; noise window 0.6" --set $W=0.6
    row "$task" small w07 "small base; noise window 0.7" --set $W=0.7
    row "$task" small c10w05 "small base; noise window 0.5, x0-weighted loss (cap 10)" --set $W=0.5 --set style.x0_weight_cap=10
    row "$task" small w05all "small base; noise window 0.5, every window (12 epochs)" --set $W=0.5 --set style.early_windows=1.0 --set style.train.epochs=12
    row "$task" small w05e30 "small base; noise window 0.5, first 30 % of windows (40 epochs)" --set $W=0.5 --set style.early_windows=0.3 --set style.train.epochs=40
    row "$task" small w07e10 "small base; noise window 0.7, first 10 % of windows (120 epochs)" --set $W=0.7 --set style.early_windows=0.1 --set style.train.epochs=120
    row "$task" small w05fa "small base; film on every block, noise window 0.5" --set $W=0.5 --set style.model.film_blocks=all
    base "$task" big "${BIG_BASE[@]}"
    row "$task" big big_w06 "big base (1000 demos, 9240 steps); noise window 0.6" --set $W=0.6
  fi
  row "$task" small w09fa "small base; film on every block, noise window 0.9" --set $W=0.9 --set style.model.film_blocks=all
  base "$task" mid "${MID_BASE[@]}"
  row "$task" mid mid_w07fa "mid base (1000 demos, 3360 steps); film on every block, noise window 0.7" --set $W=0.7 --set style.model.film_blocks=all
done

# Block Reach, clear scenes: can the efficient predictor's subset carry SCDP to Dataset + 0.10? On the
# committed cpu run's checkpoints (results/cpu), 100 + 100 validation scenes, with the Dataset's T.
# Only the efficient predictor is retrained; the subsets' own ceiling is benchmarks/subset_ceiling.py.
if [[ " ${tasks[*]} " == *" block_reach "* ]]; then
  CK=results/cpu/block_reach/checkpoints
  [ -f "$CK/style_efficient/config.json" ] || { echo "run scdp reproduce --task block_reach --preset cpu --out results/cpu first" >&2; exit 2; }
  python3 benchmarks/style_ablation.py --task block_reach --checkpoints "$CK" --scenes 100 --arbitration probabilistic \
    --label "cpu preset (efficient subset by Ê, the paper's)" --out "$OUT"
  for variant in "T20 0.2 80 cpu preset, efficient subset ranked by T" \
                 "T10 0.1 160 cpu preset, efficient subset = top 10 % by T (160 epochs)"; do
    read -r name fraction epochs label <<< "$variant"
    ck=$A/block_reach/$name
    mkdir -p "$ck"; rm -rf "$ck/base" "$ck/encoder" "$ck/style_legible"
    cp -r "$CK/base" "$CK/encoder" "$CK/style_legible" "$ck/"
    scdp train style --task block_reach --data results/cpu/block_reach/demos.zarr --out "$ck/style_efficient" --style efficient \
      --force --set 'style.efficient_score="transparency"' --set data.style_fraction="$fraction" --set style.train.epochs="$epochs"
    python3 benchmarks/style_ablation.py --task block_reach --checkpoints "$ck" --scenes 100 --arbitration probabilistic \
      --label "$label" --out "$OUT"
  done
fi
