#!/usr/bin/env bash
# Issue 76: the style-authority candidates of results/authority/PROTOCOL.md, one factor added at a time,
# each measured by benchmarks/style_authority.py on validation scenes.
#
# Regenerates: `results/authority/every_window.md`, `results/authority/rest_windows.md`, `results/authority/turning_demos.md`,
# `results/authority/turning_point.md`, `results/authority/turning_all.md`, `results/authority/films_every_step.md`
#
#   bash benchmarks/style_ablation.sh every_window   # A: predictors on every window (~11 compute-min)
#   bash benchmarks/style_ablation.sh rest_windows   # C: A + windows ranked by the path that remains (~12)
#   bash benchmarks/style_ablation.sh turning_demos  # B: C on demos half of which turn, base retrained (~35)
#   bash benchmarks/style_ablation.sh turning_point  # B': B with each turn's second course from the turn (~35)
#   bash benchmarks/style_ablation.sh turning_all    # D: B' with every demo turning (~33)
#   bash benchmarks/style_ablation.sh films_every_step  # E: B' with films on every denoising step (its committed
#       table was made from B''s demos and base, which this would regenerate the same: seeded, one machine)
#
# Runs go to runs/<candidate>/<task>/checkpoints (not committed); base and encoder come from results/cpu unless the
# candidate retrains them. Run one at a time, alone, for honest minutes (each step's seconds are printed). Never edit
# this file while it runs: bash reads it as it goes.
set -euo pipefail
candidate=${1:?"which candidate: every_window, rest_windows or turning_demos"}
sets=(--set style.early_windows=1.0 --set style.train.epochs=12)
case "$candidate" in
  every_window) ;;
  rest_windows) sets+=(--set 'style.windows="rest"') ;;
  turning_demos) sets+=(--set 'style.windows="rest"' --set data.turning=0.5); turn_from=start ;;
  turning_point) sets+=(--set 'style.windows="rest"' --set data.turning=0.5 --set 'data.turn_from="point"'); turn_from=point ;;
  turning_all) sets+=(--set 'style.windows="rest"' --set data.turning=1.0 --set 'data.turn_from="point"'); turn_from=point
               turning=1.0 ;;  # candidate D
  films_every_step) sets+=(--set 'style.windows="rest"' --set data.turning=0.5 --set 'data.turn_from="point"'
                           --set style.model.noise_window=1.0); turn_from=point ;;  # candidate E
  *) echo "scdp: error: candidate: one of every_window, rest_windows, turning_demos, turning_point, turning_all," \
          "films_every_step, got '$candidate'" >&2
     exit 2 ;;
esac
run=runs/$candidate
timed() { local start=$SECONDS; "$@"; echo "[$candidate] $((SECONDS - start)) s: ${*:1:6}"; }
for task in navigation block_reach; do
  ckpt=$run/$task/checkpoints
  mkdir -p "$ckpt"
  rm -rf "$ckpt/encoder" && cp -r "results/cpu/$task/checkpoints/encoder" "$ckpt/"
  demos=results/cpu/$task/demos.zarr
  if [ -n "${turn_from:-}" ]; then
    demos=$run/$task/demos.zarr
    timed scdp generate --task "$task" --num-demos 1000 --seed 0 --turning "${turning:-0.5}" --turn-from "$turn_from" \
      --out "$demos" --force
    timed scdp train base --task "$task" --preset cpu --data "$demos" --out "$ckpt/base" --force
  else
    rm -rf "$ckpt/base" && cp -r "results/cpu/$task/checkpoints/base" "$ckpt/"
  fi
  for style in legible efficient; do
    timed scdp train style --task "$task" --style "$style" --preset cpu "${sets[@]}" --data "$demos" \
      --out "$ckpt/style_$style" --force
  done
done
timed python benchmarks/style_authority.py --run "$run" --methods scdp --out "results/authority/$candidate.md"
