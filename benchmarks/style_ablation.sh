#!/usr/bin/env bash
# The style ablation of results/cpu/ablation.md: Navigation model sets trained with the
# project's CLI on the cpu preset, one factor changed at a time, then one row per set (and
# per film scale or arbitration rule) from benchmarks/style_ablation.py on validation scenes.
#   bash benchmarks/style_ablation.sh       # about 55 min on 2 cores; writes results/cpu/ablation.{json,md}
set -euo pipefail
cd "$(dirname "$0")/.."
A=runs/abl
scdp() { python3 -m scdp "$@"; }
style() {  # style SET DEMOS [--set ...]: both predictors of a set on a shared base and encoder
  local set=$1 demos=$2; shift 2
  for st in legible efficient; do
    scdp train style --task navigation --data "$demos" --out "$A/$set/ck/style_$st" --style "$st" \
      --base "$A/$set/ck/base" --encoder "$A/nav200/ck/encoder" --force "$@"
  done
}
# the cpu preset as it is: 200 demos, base 1680 steps, predictors 30 epochs on every window
scdp generate --task navigation --num-demos 200 --seed 0 --out $A/nav200/demos.zarr --force
scdp generate --task navigation --num-demos 1000 --seed 0 --out $A/demos1000.zarr --force
scdp train encoder --task navigation --out $A/nav200/ck/encoder --force
scdp train base --task navigation --data $A/nav200/demos.zarr --out $A/nav200/ck/base --force
style nav200 $A/nav200/demos.zarr
# predictors on the first 25 % of each episode's windows (where the side of the path is decided)
mkdir -p $A/early25/ck && cp -r $A/nav200/ck/{base,encoder} $A/early25/ck/
style early25 $A/nav200/demos.zarr --set style.early_windows=0.25 --set style.train.epochs=120
# ... on the top 20 % of 1000 demos
mkdir -p $A/d1000_early25/ck && cp -r $A/nav200/ck/{base,encoder} $A/d1000_early25/ck/
style d1000_early25 $A/demos1000.zarr --set style.early_windows=0.25 --set style.train.epochs=40
# ... reading the distractors in the robot -> g* frame as well
mkdir -p $A/frame_early25/ck && cp -r $A/nav200/ck/{base,encoder} $A/frame_early25/ck/
style frame_early25 $A/nav200/demos.zarr --set style.model.scene_frame=true --set style.early_windows=0.25 --set style.train.epochs=120
mkdir -p $A/d1000_frame_early25/ck && cp -r $A/nav200/ck/{base,encoder} $A/d1000_frame_early25/ck/
style d1000_frame_early25 $A/demos1000.zarr --set style.model.scene_frame=true --set style.early_windows=0.25 --set style.train.epochs=40
mkdir -p $A/d1000_frame_early15/ck && cp -r $A/nav200/ck/{base,encoder} $A/d1000_frame_early15/ck/
style d1000_frame_early15 $A/demos1000.zarr --set style.model.scene_frame=true --set style.early_windows=0.15 --set style.train.epochs=80
# ... the same with the style film on every residual block (film_blocks=all, not in the paper)
mkdir -p $A/d1000_frame_early15_all/ck && cp -r $A/nav200/ck/{base,encoder} $A/d1000_frame_early15_all/ck/
style d1000_frame_early15_all $A/demos1000.zarr --set style.model.scene_frame=true --set style.early_windows=0.15 --set style.train.epochs=80 --set style.model.film_blocks=all
# a base with absolute action chunks and without the g* - p(s) feature (the paper's design)
mkdir -p $A/abs/ck && cp -r $A/nav200/ck/encoder $A/abs/ck/
scdp train base --task navigation --data $A/nav200/demos.zarr --out $A/abs/ck/base --force \
  --set base.model.relative_actions=false --set base.model.goal_offset=false
style abs $A/nav200/demos.zarr --set style.early_windows=0.25 --set style.train.epochs=120

# one row per variant, on the same 30 + 30 validation scenes (seed 2)
row() { python3 benchmarks/style_ablation.py --task navigation --out results/cpu/ablation.json "$@"; }
row --checkpoints $A/nav200/ck --label "cpu preset (200 demos)" --film-scales 1 2
row --checkpoints $A/early25/ck --label "styles on the first 25 % of windows, 120 epochs" --film-scales 1 2
row --checkpoints $A/d1000_early25/ck --label "styles on top 20 % of 1000 demos, first 25 % of windows" --film-scales 1 2
row --checkpoints $A/frame_early25/ck --label "scene frame + first 25 % of windows"
row --checkpoints $A/d1000_frame_early25/ck --label "1000 demos, scene frame, first 25 % of windows"
row --checkpoints $A/d1000_frame_early25/ck --label "1000 demos, scene frame, first 25 % of windows" --arbitration probabilistic
row --checkpoints $A/abs/ck --label "absolute actions, no g*-p(s), first 25 % of windows"
row --checkpoints $A/d1000_frame_early15/ck --label "1000 demos, scene frame, first 15 % of windows, 80 epochs" --arbitration probabilistic --style-guidance 0 0.3 1
row --checkpoints $A/d1000_frame_early15_all/ck --label "1000 demos, scene frame, first 15 % of windows, 80 epochs, film on every block" --arbitration probabilistic
