#!/usr/bin/env bash
# The frozen confirmation of results/cpu/confirmation_observers/PROTOCOL.md: three training seeds, each
# with its own demonstrations, on the untouched evaluation seed 23, then the scene-clustered pooling of
# issue 36's observer targets. The code is the commit that added the protocol, checked out on its own
# (runs/confirm_observers/code), whatever the working copy holds. Resumable: re-run after a kill.
#   bash benchmarks/confirm_observers.sh     (about 2 compute-hours on 2 cores: seeds 1 and 2 train)
# Regenerates: `results/cpu/confirmation_observers/pooled.json`, `results/cpu/confirmation_observers/VERDICTS.md`
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
SCENES=23
RUNS=runs/confirm_observers
PROTOCOL=results/cpu/confirmation_observers/PROTOCOL.md
COMMIT=$(git log -1 --format=%H -- "$PROTOCOL")
if [ -z "$COMMIT" ]; then echo "confirm_observers: $PROTOCOL is not committed yet" >&2; exit 2; fi
mkdir -p "$RUNS"
[ -d "$RUNS/code" ] || git worktree add --detach "$RUNS/code" "$COMMIT"
export PYTHONPATH="$ROOT/$RUNS/code/src"  # ahead of the editable install: the protocol's code
python3 -c "import scdp, sys; sys.exit(0 if scdp.__file__.startswith('$ROOT/$RUNS/code/') else 'not the protocol code: ' + scdp.__file__)"
if [ ! -d "$RUNS/seed_0/navigation" ]; then  # seed 0: the committed models and demos at that commit, evaluated only
  mkdir -p "$RUNS/seed_0"
  for task in navigation block_reach; do
    # the commit's own files; reproduce judges them by content (scdp.pipeline.fingerprints), not by time
    cp -r "$RUNS/code/results/cpu/$task" "$RUNS/seed_0/"
    rm -f "$RUNS/seed_0/$task/trajectories.json"
  done
fi
for seed in 0 1 2; do
  demos=()
  [ "$seed" = 0 ] || demos=(--set "data.seed=$seed")  # each seed its own demonstrations (seed 0: the preset's)
  (cd "$RUNS/code" && python3 -m scdp reproduce --task all --preset cpu --seed "$seed" "${demos[@]}" \
     --set "evaluation.seed=$SCENES" --out "$ROOT/$RUNS/seed_$seed") > "$RUNS/seed_$seed.log" 2>&1
done
(cd "$RUNS/code" && python3 benchmarks/pool_seeds.py --runs "$ROOT/$RUNS/seed_0" "$ROOT/$RUNS/seed_1" "$ROOT/$RUNS/seed_2" \
   --seeds 0 1 2 --targets observers --keep-paths --commit "$COMMIT" --out "$ROOT/results/cpu/confirmation_observers" \
   --title "Observer confirmation on untouched scenes (evaluation seed $SCENES), training seeds 0-2, each with its own demos")
mkdir -p results/cpu/confirmation_observers/logs
for seed in 0 1 2; do
  cp "$RUNS/seed_$seed/report.md" "results/cpu/confirmation_observers/logs/report_seed_$seed.md"
  cp "$RUNS/seed_$seed/stage_times.json" "results/cpu/confirmation_observers/logs/stage_times_seed_$seed.json"
done
