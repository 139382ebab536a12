#!/usr/bin/env bash
# The frozen confirmation of results/cpu/confirmation/PROTOCOL.md: three training seeds on the
# untouched evaluation seed 11, then the scene-clustered pooling. Resumable: re-run after a kill.
#   bash benchmarks/confirm.sh [--executor ray ...]   (about 80 compute-min on 2 cores: seeds 1 and 2 train;
#   the executor's options pass through to scdp reproduce, docs/cluster.md)
# Regenerates: `results/cpu/confirmation/pooled.md`, `results/cpu/confirmation/VERDICTS.md`
set -euo pipefail
cd "$(dirname "$0")/.."
SCENES=11
mkdir -p runs/confirm
if [ ! -d runs/confirm/seed_0/navigation ]; then  # seed 0: the committed models, evaluated only
  mkdir -p runs/confirm/seed_0
  for task in navigation block_reach; do
    cp -a "results/cpu/$task" runs/confirm/seed_0/
    rm -f "runs/confirm/seed_0/$task/trajectories.json"
  done
fi
# the three seeds' units side by side under an executor: bash benchmarks/confirm.sh --executor ray [--ray-address auto]
python3 -m scdp reproduce --task all --preset cpu --seeds 0 1 2 --set "evaluation.seed=$SCENES" \
  --out runs/confirm "$@" > runs/confirm.log 2>&1
python3 benchmarks/pool_seeds.py --runs runs/confirm/seed_0 runs/confirm/seed_1 runs/confirm/seed_2 --seeds 0 1 2 \
  --out results/cpu/confirmation --title "Confirmation on untouched scenes (evaluation seed $SCENES), training seeds 0-2"
