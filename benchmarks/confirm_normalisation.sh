#!/usr/bin/env bash
# The frozen confirmation of results/cpu/confirmation_normalisation/PROTOCOL.md: the committed cpu models
# on the untouched evaluation seed 59, every verdict under both normalisations of D̂, Ê and ĵ. The code is
# the commit that added the protocol, checked out on its own (runs/confirm_normalisation/code), whatever
# the working copy holds. Resumable: re-run after a kill.
#   bash benchmarks/confirm_normalisation.sh     (about 20 compute-minutes on 2 cores: rollouts only)
# Regenerates: `results/cpu/confirmation_normalisation/VERDICTS.md`
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
SCENES=59
RUNS=runs/confirm_normalisation
PROTOCOL=results/cpu/confirmation_normalisation/PROTOCOL.md
COMMIT=$(git log -1 --format=%H -- "$PROTOCOL")
if [ -z "$COMMIT" ]; then echo "confirm_normalisation: $PROTOCOL is not committed yet" >&2; exit 2; fi
mkdir -p "$RUNS"
[ -d "$RUNS/code" ] || git worktree add --detach "$RUNS/code" "$COMMIT"
export PYTHONPATH="$ROOT/$RUNS/code/src"  # ahead of the editable install: the protocol's code
python3 -c "import scdp, sys; sys.exit(0 if scdp.__file__.startswith('$ROOT/$RUNS/code/') else 'not the protocol code: ' + scdp.__file__)"
if [ ! -d "$RUNS/run/navigation" ]; then  # the committed models and demos at that commit, evaluated only
  mkdir -p "$RUNS/run"
  for task in navigation block_reach; do
    cp -r "$RUNS/code/results/cpu/$task" "$RUNS/run/"  # judged by content (scdp.pipeline.fingerprints), not time
    rm -f "$RUNS/run/$task/trajectories.json"
  done
fi
(cd "$RUNS/code" && python3 -m scdp reproduce --task all --preset cpu --set "evaluation.seed=$SCENES" \
   --out "$ROOT/$RUNS/run") > "$RUNS/run.log" 2>&1
(cd "$RUNS/code" && python3 benchmarks/confirm_normalisation.py --run "$ROOT/$RUNS/run" --commit "$COMMIT" \
   --out "$ROOT/results/cpu/confirmation_normalisation")
