#!/usr/bin/env bash
# The few-step student on the committed cpu reproduction (issue 79): train it for both tasks beside the
# committed parts, export its ONNX graph, then measure whether it keeps the styles.
#
# Regenerates: `results/benchmarks/style_fidelity.md`, `results/cpu/navigation/checkpoints/student/config.json`, `results/cpu/block_reach/checkpoints/student/config.json`
#
#   bash benchmarks/student.sh            # about 35 compute-minutes on 2 cores; alone on the machine
#
# Writes results/cpu/<task>/checkpoints/student/ (weights, config.json with its train_seconds, model.onnx)
# and results/benchmarks/style_fidelity.{md,json} (every candidate, the student among them). A student
# already trained is kept (delete its folder to retrain it).
set -euo pipefail
RUN=${RUN:-results/cpu}
for task in navigation block_reach; do
  ckpt="$RUN/$task/checkpoints"
  if [ ! -f "$ckpt/student/model.safetensors" ]; then
    python -m scdp train student --task "$task" --data "$RUN/$task/demos.zarr" --out "$ckpt/student" --preset cpu
  fi
  if [ ! -f "$ckpt/student/model.onnx" ]; then
    python -m scdp export --task "$task" "$ckpt" --parts student
  fi
done
python benchmarks/style_fidelity.py --run "$RUN" --scenes 100 --out results/benchmarks/style_fidelity
